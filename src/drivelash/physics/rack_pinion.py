"""Rack-and-pinion test bench and its *true* transmission error, spec 02 §1.

Public interface (used by the TE learning and compensation code)::

    from drivelash.physics.rack_pinion import (
        RackPinionBench, TEGeneratorParams, TransmissionErrorModel,
    )
    bench = RackPinionBench()                       # the bench of spec 02 §1
    te_model = TransmissionErrorModel.generate(bench, seed=1)
    te_model.te(x_T, F, direction)                  # true TE [m], vectorised
    te_model.geometric(x_T, direction)              # TE_geo (no load) [m]
    te_model.deformation(x_T, F, direction)         # TE_def = TE − TE_geo [m]
    te_model.backlash(x_T)                          # b = TE_geo(−) − TE_geo(+) ≥ 0 [m]
    te_model.with_local_defect(x_center, width, amplitude)   # new model (wear)
    te_model.component_amplitudes(direction, F)     # configured spectral amplitudes [m]
    bench.x_M(theta_M); bench.te_from_measurement(x_T, theta_M)   # kinematics (1)

Conventions
-----------
* TE = x_T − x_M with x_M = θ_M d_p / (2 i_PG), eq (1).
* ``direction`` is the direction of travel, +1 or −1 (scalar or array). Moving in +x
  the motor pushes the table on the *positive* flank, the table lags the motor and
  the TE curve lies *below* the curve of the negative direction (paper Fig. 2);
  the gap TE_geo(x, −1) − TE_geo(x, +1) is the backlash b(x) > 0.
* ``F`` is the magnitude [N, ≥ 0] of the force transmitted by the mesh against the
  direction of travel (process load + table friction + inertia). At constant
  velocity in the simulator it is F_load + F_fric,T(v).

Structure of the generator (every component of spec §1, each seeded):

    TE(x, F, d) = drift(x) + R_d(x) + M_d(x) · A(F)/A(0) − (d/2) b_0(x) + Σ defects
                  − d · F · c_d(x)

1. ``drift``: rack-segment pitch (slope) errors joined smoothly at the rack joints,
   a global slope and a long-wave component (manufacturing and assembly);
2. ``R_d``: pinion/gearbox runout with the pinion circumference as period,
   amplitude ≈ 25 µm, plus a small second harmonic; slightly different per flank;
3. ``M_d``: tooth-meshing error with the tooth pitch as period, amplitude 5–7 µm (paper: 4–8 µm),
   three harmonics, tooth-to-tooth variation (a factor per pinion tooth — periodic
   with the circumference — times a factor per rack tooth); A(F) = 1/(1 + F/F_h)
   makes it shrink with load (flank deformation with profile modifications);
4. elastic deformation −d F c_d(x): compliance c_d(x) with a meshing-dependent
   part (varying number of teeth in contact) and a small pinion-period part;
5. distinct curves per direction: per-flank runout and mesh parameters and the
   backlash b(x) = b_0(x) + (R_− − R_+) + (M_− − M_+), with b_0 a slowly varying
   gap (incl. a centre-distance term with the pinion period); b(x) is guaranteed
   to stay inside the configured range [b_min, b_max].

For the simulator, :meth:`TransmissionErrorModel.tables` samples the components on
a fine position grid (linear interpolation in the ``@njit`` engine).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

import numpy as np

from drivelash.errors import ParameterError
from drivelash.params import require_finite, require_non_negative, require_positive

ArrayLike = float | np.ndarray


@dataclass(frozen=True)
class RackGeometry:
    """Geometry of a rack-and-pinion axis: gearing, gearbox and travel (the ``[geometry]`` table).

    Parameters
    ----------
    m_n : float
        Normal module [m] (4 mm).
    n_t : int
        Number of pinion teeth [-] (20).
    helix_angle : float
        Helix angle β [rad]; the default acos(80/84.882) = 19.527° gives d_p = 84.882 mm.
    alpha_n : float
        Normal pressure angle [rad] (20°, standard).
    face_width : float
        Face width b of the mesh [m] (enters the overlap ratio ε_β).
    i_PG : float
        Gearbox ratio, motor turns per pinion turn [-] (16).
    travel : float
        Usable travel [m]; any length of at least two tooth pitches.
    contact_ratio : float or None
        Total contact ratio ε [-] when known (e.g. from the gear data sheet, profile
        shift or tip relief); None derives it from the tooth geometry (:attr:`epsilon`).

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    m_n: float = 4e-3
    n_t: int = 20
    helix_angle: float = math.acos(80.0 / 84.882)
    alpha_n: float = math.radians(20.0)
    face_width: float = 40e-3
    i_PG: float = 16.0
    travel: float = 2.2
    contact_ratio: float | None = None

    def __post_init__(self) -> None:
        self._check_geometry()

    def _check_geometry(self) -> None:
        require_finite(self)
        require_positive(self, "m_n", "n_t", "face_width", "i_PG", "travel")
        require_non_negative(self, "helix_angle")
        if int(self.n_t) != self.n_t or self.n_t < 8:
            raise ParameterError(type(self).__name__, "n_t", f"must be a whole number >= 8, got {self.n_t!r}")
        if not 0 < self.alpha_n < math.pi / 4:
            raise ParameterError(type(self).__name__, "alpha_n", "must lie in (0, 45°)")
        if self.helix_angle >= math.pi / 3:
            raise ParameterError(type(self).__name__, "helix_angle", "must be < 60°")
        if self.travel < 2.0 * self.tooth_pitch:
            raise ParameterError(
                type(self).__name__,
                "travel",
                f"must cover at least two tooth pitches ({2e3 * self.tooth_pitch:.1f} mm),"
                f" got {self.travel!r}",
            )
        if self.contact_ratio is not None and not (
            math.isfinite(self.contact_ratio) and 1.0 <= self.contact_ratio <= 0.5 * self.n_t
        ):
            raise ParameterError(
                type(self).__name__,
                "contact_ratio",
                f"must lie in [1, n_t/2] = [1, {0.5 * self.n_t:g}], got {self.contact_ratio!r}",
            )

    # -- geometry -------------------------------------------------------------
    @property
    def d_p(self) -> float:
        """Pitch diameter d_p = m_n n_t / cos β [m]."""
        return self.m_n * self.n_t / math.cos(self.helix_angle)

    @property
    def tooth_pitch(self) -> float:
        """Transverse tooth pitch = travel per tooth, π d_p / n_t [m] (≈ 13.333 mm)."""
        return math.pi * self.d_p / self.n_t

    @property
    def circumference(self) -> float:
        """Pinion circumference = travel per pinion revolution, π d_p [m] (≈ 266.67 mm)."""
        return math.pi * self.d_p

    @property
    def r_eff(self) -> float:
        """Kinematic ratio x_M / θ_M = d_p / (2 i_PG) [m/rad], eq (1)."""
        return self.d_p / (2.0 * self.i_PG)

    @property
    def alpha_t(self) -> float:
        """Transverse pressure angle, tan α_t = tan α_n / cos β [rad]."""
        return math.atan(math.tan(self.alpha_n) / math.cos(self.helix_angle))

    @property
    def epsilon_alpha(self) -> float:
        """Transverse contact ratio of pinion and rack [-].

        ε_α = [√(r_a² − r_b²) − r sin α_t + h_a / sin α_t] / (π m_t cos α_t), with
        pitch radius r = d_p/2, tip radius r_a = r + m_n (addendum 1·m_n), base radius
        r_b = r cos α_t, rack addendum h_a = m_n and transverse module m_t = m_n/cos β:
        the pinion part plus the rack part of the path of contact over the transverse
        base pitch (standard spur/helical rack geometry, no profile shift).
        """
        r = self.d_p / 2.0
        r_a = r + self.m_n
        a_t = self.alpha_t
        r_b = r * math.cos(a_t)
        g_alpha = math.sqrt(r_a**2 - r_b**2) - r * math.sin(a_t) + self.m_n / math.sin(a_t)
        m_t = self.m_n / math.cos(self.helix_angle)
        return g_alpha / (math.pi * m_t * math.cos(a_t))

    @property
    def epsilon_beta(self) -> float:
        """Overlap (face) contact ratio ε_β = b sin β / (π m_n) [-]."""
        return self.face_width * math.sin(self.helix_angle) / (math.pi * self.m_n)

    @property
    def epsilon(self) -> float:
        """Total contact ratio ε [-] (≈ 2.68): the number of tooth pitches a pinion tooth
        stays in mesh; the width of the bump features (4)–(5). :attr:`contact_ratio` when
        given, else ε_α + ε_β from the tooth geometry."""
        if self.contact_ratio is not None:
            return float(self.contact_ratio)
        return self.epsilon_alpha + self.epsilon_beta

    # -- kinematics ----------------------------------------------------------------
    def x_M(self, theta_M: ArrayLike) -> ArrayLike:
        """Linear motor position x_M = θ_M d_p / (2 i_PG) [m] from the motor angle [rad].

        Parameters
        ----------
        theta_M : array_like
            Motor angle [rad].
        """
        return np.asarray(theta_M, dtype=np.float64) * self.r_eff

    def te_from_measurement(self, x_T: ArrayLike, theta_M: ArrayLike) -> np.ndarray:
        """Measured transmission error (1): TE = x_T − θ_M d_p / (2 i_PG) [m].

        Parameters
        ----------
        x_T : array_like
            Table position from the linear scale [m].
        theta_M : array_like
            Motor angle [rad].
        """
        return np.asarray(x_T, dtype=np.float64) - self.x_M(theta_M)


@dataclass(frozen=True)
class RackDrive:
    """Masses, inertias and friction of a rack-and-pinion drive train (the ``[drive]`` table).

    Parameters
    ----------
    m_T : float
        Table mass [kg] (400).
    J_motor : float
        Motor rotor inertia [kg·m²] (1FT7-class servo motor, frame 80).
    J_gearbox : float
        Gearbox inertia referred to its input (motor) shaft [kg·m²].
    J_pinion : float
        Pinion inertia about its own axis [kg·m²] (steel disc d_p × face width).
    T_Cm : float
        Coulomb friction torque of motor + gearbox, motor side [N·m].
    beta_m : float
        Viscous friction of motor + gearbox, motor side [N·m·s/rad].
    F_CT : float
        Coulomb friction force of the table guides [N].
    beta_T : float
        Viscous friction of the table guides [N·s/m].
    zeta_mesh : float
        Damping ratio of the drive-train (mesh + gearbox) mode [-]; converted to a
        damping coefficient in :attr:`RackPinionBench.d_mesh`.

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    m_T: float = 400.0
    J_motor: float = 2.5e-3
    J_gearbox: float = 0.6e-3
    J_pinion: float = 1.6e-3
    T_Cm: float = 0.5
    beta_m: float = 2e-4
    F_CT: float = 150.0
    beta_T: float = 1000.0
    zeta_mesh: float = 2.0

    def __post_init__(self) -> None:
        self._check_drive()

    def _check_drive(self) -> None:
        require_finite(self)
        require_positive(self, "m_T", "J_motor", "zeta_mesh")
        require_non_negative(self, "J_gearbox", "J_pinion", "T_Cm", "beta_m", "F_CT", "beta_T")


@dataclass(frozen=True)
class RackPinionBench(RackGeometry, RackDrive):
    """A rack-and-pinion axis: :class:`RackGeometry` and :class:`RackDrive` together.

    The defaults are the test bench of spec 02 §1 (paper §II): m_n = 4 mm, 20 teeth,
    β = 19.53°, i_PG = 16, a 400 kg table on 2.2 m of travel. Build one from its parts
    with :meth:`from_parts`; :attr:`geometry` and :attr:`drive` give them back.

    Parameters
    ----------
    m_T, J_motor, J_gearbox, J_pinion, T_Cm, beta_m, F_CT, beta_T, zeta_mesh
        As :class:`RackDrive`: table mass [kg], inertias [kg·m²], motor-side friction
        [N·m], [N·m·s/rad], guide friction [N], [N·s/m], damping ratio [-].
    m_n, n_t, helix_angle, alpha_n, face_width, i_PG, travel, contact_ratio
        As :class:`RackGeometry`: module [m], teeth [-], angles [rad], face width [m],
        gearbox ratio [-], travel [m], contact ratio [-] or None.

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    def __post_init__(self) -> None:
        self._check_geometry()
        self._check_drive()

    @classmethod
    def from_parts(cls, geometry: RackGeometry, drive: RackDrive) -> RackPinionBench:
        """The axis of ``geometry`` and ``drive``.

        Parameters
        ----------
        geometry : RackGeometry
            Gearing, gearbox and travel.
        drive : RackDrive
            Masses, inertias and friction.
        """
        return cls(**asdict(geometry), **asdict(drive))

    @property
    def geometry(self) -> RackGeometry:
        """The geometry part."""
        return RackGeometry(**{f.name: getattr(self, f.name) for f in fields(RackGeometry)})

    @property
    def drive(self) -> RackDrive:
        """The drive-train part."""
        return RackDrive(**{f.name: getattr(self, f.name) for f in fields(RackDrive)})

    # -- inertia ---------------------------------------------------------------
    @property
    def J_T_reflected(self) -> float:
        """Table mass reflected to the motor, m_T r_eff² [kg·m²] (≈ 2.81e-3)."""
        return self.m_T * self.r_eff**2

    @property
    def J_M(self) -> float:
        """Rotating inertia on the motor side: motor + gearbox + pinion/i_PG² [kg·m²]."""
        return self.J_motor + self.J_gearbox + self.J_pinion / self.i_PG**2

    @property
    def J_s(self) -> float:
        """Combined inertia of eqs (2)–(3), J_M + m_T r_eff² [kg·m²]."""
        return self.J_M + self.J_T_reflected

    def table_friction(self, v_T: ArrayLike) -> np.ndarray:
        """Friction force of the table guides at velocity ``v_T`` [N] (magnitude, ≥ 0):
        F_CT + β_T |v_T|. At constant velocity the mesh transmits F_load + this.

        Parameters
        ----------
        v_T : array_like
            Table velocity [m/s].
        """
        return self.F_CT + self.beta_T * np.abs(np.asarray(v_T, dtype=np.float64))

    def d_mesh(self, c_mesh: float) -> float:
        """Drive-train damping coefficient [N·s/m] for compliance ``c_mesh`` [m/N].

        Chosen so the two-mass mode (table m_T against J_M / r_eff²) has damping
        ratio :attr:`zeta_mesh`: d = 2 ζ √(k m_eff), m_eff = 1/(1/m_T + r_eff²/J_M).

        Parameters
        ----------
        c_mesh : float
            Drive-train compliance at the table [m/N].
        """
        k = 1.0 / c_mesh
        m_eff = 1.0 / (1.0 / self.m_T + self.r_eff**2 / self.J_M)
        return 2.0 * self.zeta_mesh * math.sqrt(k * m_eff)

    def to_dict(self) -> dict[str, float | None]:
        """The fields as a JSON-serialisable dict (``contact_ratio`` None when derived)."""
        return {k: (None if v is None else float(v)) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RackPinionBench:
        """Inverse of :meth:`to_dict`.

        Parameters
        ----------
        d : dict
            The fields (:meth:`to_dict`), SI units.
        """
        kw = dict(d)
        if "n_t" in kw:
            kw["n_t"] = int(kw["n_t"])
        return cls(**kw)


@dataclass(frozen=True)
class TEGeneratorParams:
    """Distribution parameters of the seeded TE generator (units SI; see module doc).

    Parameters
    ----------
    A_runout : float
        Mean runout amplitude, pinion-circumference period [m] (25 µm, paper §II).
    runout_spread : float
        Relative drive-to-drive spread (uniform ±) of the runout amplitude [-].
    runout_flank_spread : float
        Relative amplitude difference between the flanks (uniform ±) [-].
    runout_flank_phase : float
        Phase difference between the flanks (uniform ±) [rad].
    runout_h2 : float
        Second runout harmonic relative to the first [-] (gearbox).
    A_mesh_min, A_mesh_max : float
        No-load tooth-meshing amplitude per flank, uniform in [min, max] [m] (5–7 µm, inside
        the paper's 4–8 µm: the band leaves room for the tooth-to-tooth variation).
    mesh_harmonics : tuple of float
        Amplitudes of mesh harmonics 2, 3, … relative to the fundamental [-].
    mesh_flank_phase : float
        Std of the phase difference of each mesh harmonic between the flanks [rad].
    sigma_pinion_tooth, sigma_rack_tooth : float
        Std of the per-tooth amplitude factors (pinion teeth, rack teeth) [-].
    F_h : float
        Load at which the mesh amplitude has halved, A(F) = A(0)/(1 + F/F_h) [N].
    c0 : float
        Mean drive-train compliance at the table [m/N] (gearbox torsion + mesh).
    c_flank_spread : float
        Relative compliance difference between the flanks (uniform ±) [-].
    kappa_mesh : float
        Relative meshing-dependent compliance variation (tooth-pitch period) [-].
    kappa_pinion : float
        Relative pinion-period compliance variation [-].
    slope_sigma : float
        Std of the global drift slope [m/m].
    segment_length : float
        Length of one rack element [m].
    segment_slope_sigma : float
        Std of the pitch-error slope of each rack element [m/m].
    joint_width : float
        Width over which the slope changes at a rack joint [m].
    A_longwave : float
        Amplitude of the long-wave drift component (uniform in [0.5, 1] ×) [m].
    b_min, b_max : float
        Configured range of the backlash along the travel [m].
    b_pinion : float
        Amplitude of the centre-distance (pinion-period) part of the backlash [m].

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    A_runout: float = 25e-6
    runout_spread: float = 0.06
    runout_flank_spread: float = 0.03
    runout_flank_phase: float = 0.05
    runout_h2: float = 0.12
    A_mesh_min: float = 5e-6
    A_mesh_max: float = 7e-6
    mesh_harmonics: tuple[float, ...] = (0.3, 0.1)
    mesh_flank_phase: float = 0.25
    sigma_pinion_tooth: float = 0.08
    sigma_rack_tooth: float = 0.04
    F_h: float = 3000.0
    c0: float = 4e-9
    c_flank_spread: float = 0.05
    kappa_mesh: float = 0.05
    kappa_pinion: float = 0.03
    slope_sigma: float = 5e-6
    segment_length: float = 1.0
    segment_slope_sigma: float = 8e-6
    joint_width: float = 0.02
    A_longwave: float = 8e-6
    b_min: float = 20e-6
    b_max: float = 60e-6
    b_pinion: float = 2e-6

    def __post_init__(self) -> None:
        require_finite(self)
        require_positive(self, "A_runout", "A_mesh_min", "F_h", "c0", "segment_length", "joint_width")
        require_non_negative(
            self,
            "runout_spread",
            "runout_flank_spread",
            "runout_flank_phase",
            "runout_h2",
            "mesh_flank_phase",
            "sigma_pinion_tooth",
            "sigma_rack_tooth",
            "c_flank_spread",
            "kappa_mesh",
            "kappa_pinion",
            "slope_sigma",
            "segment_slope_sigma",
            "A_longwave",
            "b_min",
            "b_pinion",
        )
        if self.A_mesh_max < self.A_mesh_min:
            raise ParameterError(type(self).__name__, "A_mesh_max", "must be >= A_mesh_min")
        if self.b_max <= self.b_min:
            raise ParameterError(type(self).__name__, "b_max", "must be > b_min")
        if self.kappa_mesh + self.kappa_pinion >= 0.5:
            raise ParameterError(type(self).__name__, "kappa_mesh", "kappa_mesh + kappa_pinion must be < 0.5")

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dict (tuples become lists)."""
        d = asdict(self)
        d["mesh_harmonics"] = list(self.mesh_harmonics)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TEGeneratorParams:
        """Inverse of :meth:`to_dict`.

        Parameters
        ----------
        d : dict
            The fields (:meth:`to_dict`), SI units.
        """
        kw = dict(d)
        if "mesh_harmonics" in kw:
            kw["mesh_harmonics"] = tuple(float(v) for v in kw["mesh_harmonics"])
        return cls(**kw)


@dataclass(frozen=True)
class LocalDefect:
    """A local rack deviation (e.g. wear): amplitude · exp(−½((x − x_center)/width)²).

    Parameters
    ----------
    x_center : float
        Position of the defect [m].
    width : float
        Standard deviation of the Gaussian bump [m].
    amplitude : float
        Peak TE change [m] (positive: table ahead of the motor).
    direction : int
        0: both flanks; +1 / −1: only that direction's curve (changes the backlash).

    Raises
    ------
    ParameterError
        A field outside its valid range (one line naming the class and the field).
    """

    x_center: float
    width: float
    amplitude: float
    direction: int = 0

    def __post_init__(self) -> None:
        require_finite(self)
        require_positive(self, "width")
        if self.direction not in (-1, 0, 1):
            raise ParameterError(type(self).__name__, "direction", "must be -1, 0 or +1")


def _dir_index(direction: ArrayLike) -> np.ndarray:
    d = np.asarray(direction)
    if not np.all((d == 1) | (d == -1)):
        raise ParameterError("TransmissionErrorModel", "direction", "must be +1 or -1")
    return d


@dataclass(frozen=True, eq=False)
class TransmissionErrorModel:
    """The true, seeded transmission error of one drive (spec 02 §1).

    Build with :meth:`generate` (random drive) or :meth:`ideal` (TE ≡ 0, no backlash,
    compliance only). All evaluation methods are vectorised and broadcast over
    ``x_T`` [m], ``F`` [N] and ``direction`` (±1). Immutable: :meth:`with_local_defect`
    returns a new model.

    The attributes are drawn by the generator; arrays of shape (2, …) are indexed by flank,
    0 ⇔ direction +1, 1 ⇔ −1.

    Attributes
    ----------
    bench : RackPinionBench
        The axis (tooth pitch, circumference, travel).
    params : TEGeneratorParams
        The distribution the model was drawn from.
    seed : int or None
        The seed; None for :meth:`ideal`.
    A_r, phi_r : numpy.ndarray
        Runout amplitude [m] and phase [rad] per flank, shape (2,).
    A_r2, phi_r2 : numpy.ndarray
        Second runout harmonic: amplitude [m] and phase [rad] per flank, shape (2,).
    A_m : numpy.ndarray
        No-load mesh amplitude per flank [m], shape (2,).
    mesh_amp, mesh_phase : numpy.ndarray
        Relative amplitudes [-] and phases [rad] of the mesh harmonics 1 … H, shape (2, H).
    tooth_factor : numpy.ndarray
        Amplitude factor of each rack tooth (pinion-tooth × rack-tooth factor, mean 1 over
        the travel) [-]; index floor(x/p_t) − k0.
    k0 : int
        Rack-tooth index of ``tooth_factor[0]``.
    c : numpy.ndarray
        Mean drive-train compliance per flank [m/N], shape (2,).
    psi_c : numpy.ndarray
        Phase of the meshing compliance variation per flank [rad], shape (2,).
    psi_cp : float
        Phase of the pinion-period compliance variation [rad].
    slope : float
        Global drift slope [m/m].
    joints, joint_dslope : numpy.ndarray
        Rack-joint positions [m] and the slope change at each [m/m].
    lw_amp, lw_wavelength, lw_phase : numpy.ndarray
        Long-wave drift components: amplitude [m], wavelength [m], phase [rad].
    b_mean, b_var : float
        Mean of the slow gap b_0 and the amplitude of its variation [m].
    b_wave_amp, b_wavelength, b_wave_phase : numpy.ndarray
        Components of that variation: relative weight [-], wavelength [m], phase [rad].
    b_pin_amp, b_pin_phase : float
        Centre-distance (pinion-period) part of the gap: amplitude [m], phase [rad].
    defects : tuple of LocalDefect
        Local rack deviations added by :meth:`with_local_defect`.
    """

    bench: RackPinionBench
    params: TEGeneratorParams
    seed: int | None
    A_r: np.ndarray
    phi_r: np.ndarray
    A_r2: np.ndarray
    phi_r2: np.ndarray
    A_m: np.ndarray
    mesh_amp: np.ndarray
    mesh_phase: np.ndarray
    tooth_factor: np.ndarray
    k0: int
    c: np.ndarray
    psi_c: np.ndarray
    psi_cp: float
    slope: float
    joints: np.ndarray
    joint_dslope: np.ndarray
    lw_amp: np.ndarray
    lw_wavelength: np.ndarray
    lw_phase: np.ndarray
    b_mean: float
    b_var: float
    b_wave_amp: np.ndarray
    b_wavelength: np.ndarray
    b_wave_phase: np.ndarray
    b_pin_amp: float
    b_pin_phase: float
    defects: tuple[LocalDefect, ...] = field(default_factory=tuple)

    # -- construction ------------------------------------------------------------
    @classmethod
    def generate(
        cls, bench: RackPinionBench, seed: int, params: TEGeneratorParams | None = None
    ) -> TransmissionErrorModel:
        """Draw a random drive.

        Parameters
        ----------
        bench : RackPinionBench
            Geometry (tooth pitch, circumference, travel).
        seed : int
            Seed of :func:`numpy.random.default_rng`; same seed ⇒ identical model.
        params : TEGeneratorParams, optional
            Distribution parameters (defaults documented in docs/assumptions.md).

        Returns
        -------
        TransmissionErrorModel

        Raises
        ------
        ParameterError
            [b_min, b_max] too narrow for the drawn flank differences.
        """
        p = params if params is not None else TEGeneratorParams()
        rng = np.random.default_rng(seed)
        H = 1 + len(p.mesh_harmonics)
        # runout (pinion circumference period)
        A_r0 = p.A_runout * (1.0 + rng.uniform(-p.runout_spread, p.runout_spread))
        dA = rng.uniform(-p.runout_flank_spread, p.runout_flank_spread)
        A_r = A_r0 * np.array([1.0 + dA / 2, 1.0 - dA / 2])
        phi0 = rng.uniform(0, 2 * np.pi)
        dphi = rng.uniform(-p.runout_flank_phase, p.runout_flank_phase)
        phi_r = np.array([phi0 + dphi / 2, phi0 - dphi / 2])
        A_r2 = p.runout_h2 * A_r
        phi2 = rng.uniform(0, 2 * np.pi)
        phi_r2 = np.array([phi2, phi2 + rng.normal(0, p.runout_flank_phase)])
        # tooth meshing (tooth pitch period)
        A_m = rng.uniform(p.A_mesh_min, p.A_mesh_max, size=2)
        mesh_amp = np.tile(np.array((1.0, *p.mesh_harmonics)), (2, 1))
        base_phase = rng.uniform(0, 2 * np.pi, size=H)
        mesh_phase = np.vstack(
            [
                base_phase + rng.normal(0, p.mesh_flank_phase, H),
                base_phase + rng.normal(0, p.mesh_flank_phase, H),
            ]
        )
        # tooth-to-tooth variation: pinion tooth factor × rack tooth factor, mean 1
        pt = bench.tooth_pitch
        k0 = int(math.floor(-0.5 / pt))
        n_rack = int(math.ceil((bench.travel + 0.5) / pt)) - k0 + 2
        pin = 1.0 + rng.normal(0, p.sigma_pinion_tooth, bench.n_t)
        pin /= pin.mean()
        rack = 1.0 + rng.normal(0, p.sigma_rack_tooth, n_rack)
        ks = np.arange(k0, k0 + n_rack)
        tooth = np.clip(pin[np.mod(ks, bench.n_t)] * rack, 0.2, None)
        inside = (ks >= 0) & (ks * pt <= bench.travel)
        tooth /= tooth[inside].mean()
        # compliance
        dc = rng.uniform(-p.c_flank_spread, p.c_flank_spread)
        c = p.c0 * np.array([1.0 + dc / 2, 1.0 - dc / 2])
        psi_c = rng.uniform(0, 2 * np.pi) + rng.normal(0, 0.2, 2)
        psi_cp = float(rng.uniform(0, 2 * np.pi))
        # drift: global slope, rack-element slopes joined smoothly, one long wave
        slope = float(rng.normal(0, p.slope_sigma))
        joints = np.arange(p.segment_length, bench.travel, p.segment_length)
        joint_dslope = rng.normal(0, p.segment_slope_sigma * math.sqrt(2.0), joints.size)
        lw_amp = np.array([p.A_longwave * rng.uniform(0.5, 1.0)])
        lw_wavelength = np.array([rng.uniform(1.0, 3.0) * bench.travel])
        lw_phase = np.array([rng.uniform(0, 2 * np.pi)])
        # backlash: slow gap b_0 + pinion-period centre-distance term, bounded
        b_wave_amp = rng.uniform(0.3, 1.0, 3)
        b_wavelength = rng.uniform(0.4, 2.5, 3)
        b_wave_phase = rng.uniform(0, 2 * np.pi, 3)
        b_pin_phase = float(rng.uniform(0, 2 * np.pi))
        model = cls(
            bench=bench,
            params=p,
            seed=int(seed),
            A_r=A_r,
            phi_r=phi_r,
            A_r2=A_r2,
            phi_r2=phi_r2,
            A_m=A_m,
            mesh_amp=mesh_amp,
            mesh_phase=mesh_phase,
            tooth_factor=tooth,
            k0=k0,
            c=c,
            psi_c=psi_c,
            psi_cp=psi_cp,
            slope=slope,
            joints=joints,
            joint_dslope=joint_dslope,
            lw_amp=lw_amp,
            lw_wavelength=lw_wavelength,
            lw_phase=lw_phase,
            b_mean=0.5 * (p.b_min + p.b_max),
            b_var=0.0,
            b_wave_amp=b_wave_amp,
            b_wavelength=b_wavelength,
            b_wave_phase=b_wave_phase,
            b_pin_amp=p.b_pinion,
            b_pin_phase=b_pin_phase,
        )
        # the flank differences (R_− − R_+) + (M_− − M_+) are bounded analytically;
        # the slow gap takes what is left of the configured half-range.
        half = 0.5 * (p.b_max - p.b_min)
        b_var = half - model._flank_difference_bound() - p.b_pinion
        if b_var <= 0.0:
            raise ParameterError(
                "TEGeneratorParams", "b_max", "backlash range too narrow for the flank differences"
            )
        return replace(model, b_var=0.95 * b_var)

    @classmethod
    def ideal(cls, bench: RackPinionBench, c0: float = 4e-9) -> TransmissionErrorModel:
        """A drive without geometric errors and backlash: TE = −d F c0 only [m].

        Parameters
        ----------
        bench : RackPinionBench
            The axis.
        c0 : float
            Drive-train compliance at the table [m/N], both flanks.
        """
        p = TEGeneratorParams(c0=c0, kappa_mesh=0.0, kappa_pinion=0.0)
        z2 = np.zeros(2)
        pt = bench.tooth_pitch
        k0 = int(math.floor(-0.5 / pt))
        n_rack = int(math.ceil((bench.travel + 0.5) / pt)) - k0 + 2
        return cls(
            bench=bench,
            params=p,
            seed=None,
            A_r=z2,
            phi_r=z2,
            A_r2=z2,
            phi_r2=z2,
            A_m=z2,
            mesh_amp=np.zeros((2, 1)),
            mesh_phase=np.zeros((2, 1)),
            tooth_factor=np.ones(n_rack),
            k0=k0,
            c=np.full(2, c0),
            psi_c=z2,
            psi_cp=0.0,
            slope=0.0,
            joints=np.zeros(0),
            joint_dslope=np.zeros(0),
            lw_amp=np.zeros(0),
            lw_wavelength=np.ones(0),
            lw_phase=np.zeros(0),
            b_mean=0.0,
            b_var=0.0,
            b_wave_amp=np.zeros(0),
            b_wavelength=np.ones(0),
            b_wave_phase=np.zeros(0),
            b_pin_amp=0.0,
            b_pin_phase=0.0,
        )

    def with_local_defect(
        self, x_center: float, width: float, amplitude: float, direction: int = 0
    ) -> TransmissionErrorModel:
        """A copy with an added local rack deviation (wear), see :class:`LocalDefect`.

        Parameters
        ----------
        x_center : float
            Centre of the defect [m].
        width : float
            Gaussian standard deviation [m] (e.g. 0.02 for a worn region of ~3 teeth).
        amplitude : float
            Peak TE change [m].
        direction : int
            0 (default): both curves; ±1: only that direction's curve.
        """
        return replace(self, defects=(*self.defects, LocalDefect(x_center, width, amplitude, direction)))

    # -- components ----------------------------------------------------------------
    def drift(self, x_T: ArrayLike) -> np.ndarray:
        """Rack drift over the travel (common to both flanks) [m].

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        """
        x = np.asarray(x_T, dtype=np.float64)
        L = self.bench.travel
        out = self.slope * (x - 0.5 * L)
        w = self.params.joint_width
        for xj, ds in zip(self.joints, self.joint_dslope, strict=True):
            u = (x - xj) / w
            # ∫ ½(1 + tanh u) dx = ½ (x − x_j + w log cosh u); offset so the mid-travel value is 0
            logcosh = np.logaddexp(u, -u) - math.log(2.0)
            out = out + 0.5 * ds * (x - xj + w * logcosh)
        for a, lam, ph in zip(self.lw_amp, self.lw_wavelength, self.lw_phase, strict=True):
            out = out + a * np.sin(2 * np.pi * x / lam + ph)
        return out

    def runout(self, x_T: ArrayLike, direction: ArrayLike) -> np.ndarray:
        """Pinion/gearbox runout R_d(x), pinion-circumference period [m].

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        direction : array_like
            Direction of travel (the flank in contact), +1 or −1.
        """
        x = np.asarray(x_T, dtype=np.float64)
        i = (1 - _dir_index(direction)) // 2
        ph = 2 * np.pi * x / self.bench.circumference
        return self.A_r[i] * np.sin(ph + self.phi_r[i]) + self.A_r2[i] * np.sin(2 * ph + self.phi_r2[i])

    def tooth_variation(self, x_T: ArrayLike) -> np.ndarray:
        """Tooth-to-tooth amplitude factor g(x) [-]: per-tooth factors, raised-cosine
        interpolated between tooth centres (a partition of unity, so g ≡ 1 if all
        factors are 1 and g adds no content at the mesh frequency and its harmonics).

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        """
        s = np.asarray(x_T, dtype=np.float64) / self.bench.tooth_pitch
        k = np.floor(s)
        frac = s - k
        idx = np.clip(k.astype(np.int64) - self.k0, 0, self.tooth_factor.size - 2)
        w = 0.5 * (1.0 - np.cos(np.pi * frac))
        return (1.0 - w) * self.tooth_factor[idx] + w * self.tooth_factor[idx + 1]

    def mesh(self, x_T: ArrayLike, direction: ArrayLike, F: ArrayLike = 0.0) -> np.ndarray:
        """Tooth-meshing error M_d(x) A(F)/A(0), tooth-pitch period [m].

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        direction : array_like
            Direction of travel (the flank in contact), +1 or −1.
        F : array_like
            Magnitude of the force the mesh transmits [N] (0: the no-load error).
        """
        x = np.asarray(x_T, dtype=np.float64)
        i = (1 - _dir_index(direction)) // 2
        ph = 2 * np.pi * x / self.bench.tooth_pitch
        out = np.zeros(np.broadcast(x, i).shape)
        for h in range(self.mesh_amp.shape[1]):
            out = out + self.mesh_amp[i, h] * np.sin((h + 1) * ph + self.mesh_phase[i, h])
        return self.A_m[i] * self.tooth_variation(x) * out * self.load_factor(F)

    def load_factor(self, F: ArrayLike) -> np.ndarray:
        """Mesh-amplitude factor A(F)/A(0) = 1 / (1 + |F|/F_h) [-].

        Parameters
        ----------
        F : array_like
            Magnitude of the force the mesh transmits [N].
        """
        return 1.0 / (1.0 + np.abs(np.asarray(F, dtype=np.float64)) / self.params.F_h)

    def compliance(self, x_T: ArrayLike, direction: ArrayLike) -> np.ndarray:
        """Drive-train compliance c_d(x) at the table [m/N] (mesh-dependent part included).

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        direction : array_like
            Direction of travel (the flank in contact), +1 or −1.
        """
        x = np.asarray(x_T, dtype=np.float64)
        i = (1 - _dir_index(direction)) // 2
        p = self.params
        ph = 2 * np.pi * x / self.bench.tooth_pitch
        php = 2 * np.pi * x / self.bench.circumference
        return self.c[i] * (
            1.0 + p.kappa_mesh * np.cos(ph + self.psi_c[i]) + p.kappa_pinion * np.sin(php + self.psi_cp)
        )

    def gap(self, x_T: ArrayLike) -> np.ndarray:
        """Slow part of the backlash b_0(x) (incl. the pinion-period centre-distance term) [m].

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        """
        x = np.asarray(x_T, dtype=np.float64)
        out = np.full(x.shape, self.b_mean)
        if self.b_wave_amp.size:
            norm = float(np.sum(self.b_wave_amp))
            for a, lam, ph in zip(self.b_wave_amp, self.b_wavelength, self.b_wave_phase, strict=True):
                out = out + self.b_var * (a / norm) * np.sin(2 * np.pi * x / lam + ph)
        if self.b_pin_amp:
            out = out + self.b_pin_amp * np.sin(2 * np.pi * x / self.bench.circumference + self.b_pin_phase)
        return out

    def defect(self, x_T: ArrayLike, direction: ArrayLike) -> np.ndarray:
        """Sum of the local defects for the given direction [m].

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        direction : array_like
            Direction of travel (the flank in contact), +1 or −1.
        """
        x = np.asarray(x_T, dtype=np.float64)
        d = np.asarray(direction)
        out = np.zeros(np.broadcast(x, d).shape)
        for df in self.defects:
            bump = df.amplitude * np.exp(-0.5 * ((x - df.x_center) / df.width) ** 2)
            if df.direction == 0:
                out = out + bump
            else:
                out = out + np.where(d == df.direction, bump, 0.0)
        return out

    # -- the error -------------------------------------------------------------------
    def geometric(self, x_T: ArrayLike, direction: ArrayLike) -> np.ndarray:
        """Geometric error TE_geo(x, d) (no load, no friction) [m].

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        direction : array_like
            Direction of travel (the flank in contact), +1 or −1.
        """
        x = np.asarray(x_T, dtype=np.float64)
        d = _dir_index(direction)
        return self.drift(x) + self.runout(x, d) + self.mesh(x, d) - 0.5 * d * self.gap(x) + self.defect(x, d)

    def deformation(self, x_T: ArrayLike, F: ArrayLike, direction: ArrayLike) -> np.ndarray:
        """Load-dependent part TE_def(x, F, d) = TE − TE_geo [m].

        Mesh amplitude reduction (A(F)/A(0) − 1) M_d(x) plus the elastic deflection
        −d |F| c_d(x) (the table lags the motor in the direction of travel).

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        F : array_like
            Magnitude of the force the mesh transmits [N].
        direction : array_like
            Direction of travel (the flank in contact), +1 or −1.
        """
        x = np.asarray(x_T, dtype=np.float64)
        d = _dir_index(direction)
        Fa = np.abs(np.asarray(F, dtype=np.float64))
        return self.mesh(x, d) * (self.load_factor(Fa) - 1.0) - d * Fa * self.compliance(x, d)

    def te(self, x_T: ArrayLike, F: ArrayLike, direction: ArrayLike) -> np.ndarray:
        """True transmission error TE(x_T, F, direction) = x_T − x_M [m].

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        F : array_like
            Magnitude of the force transmitted by the mesh against the motion [N].
        direction : array_like
            Direction of travel, +1 or −1.
        """
        return self.geometric(x_T, direction) + self.deformation(x_T, F, direction)

    def backlash(self, x_T: ArrayLike) -> np.ndarray:
        """Backlash b(x) = TE_geo(x, −1) − TE_geo(x, +1) [m] (> 0).

        Parameters
        ----------
        x_T : array_like
            Table position [m].
        """
        return self.geometric(x_T, -1) - self.geometric(x_T, 1)

    def _flank_difference_bound(self) -> float:
        """Upper bound of |(R_− − R_+) + (M_− − M_+)| over all x [m]."""
        bound = abs(self.A_r[1] * np.exp(1j * self.phi_r[1]) - self.A_r[0] * np.exp(1j * self.phi_r[0]))
        bound += abs(self.A_r2[1] * np.exp(1j * self.phi_r2[1]) - self.A_r2[0] * np.exp(1j * self.phi_r2[0]))
        gmax = float(self.tooth_factor.max())
        for h in range(self.mesh_amp.shape[1]):
            a1 = self.A_m[1] * self.mesh_amp[1, h] * np.exp(1j * self.mesh_phase[1, h])
            a0 = self.A_m[0] * self.mesh_amp[0, h] * np.exp(1j * self.mesh_phase[0, h])
            bound += gmax * abs(a1 - a0)
        return float(bound)

    def component_amplitudes(self, direction: int, F: float = 0.0) -> dict[str, float]:
        """Configured spectral amplitudes of one direction's curve at load F [m].

        ``runout``: amplitude at the pinion-circumference period (runout fundamental
        combined with the pinion-period part of the gap, −d/2 · b_pin);
        ``mesh``: amplitude at the tooth-pitch period (mesh fundamental × A(F)/A(0)
        combined with the meshing part of the elastic deflection −d F c κ cos(…));
        ``runout2`` and ``mesh2``: second harmonics (no load part).

        Parameters
        ----------
        direction : int
            +1 or −1.
        F : float
            Magnitude of the force the mesh transmits [N].
        """
        d = int(direction)
        i = (1 - d) // 2
        run = self.A_r[i] * np.exp(1j * (self.phi_r[i] - np.pi / 2)) - 0.5 * d * self.b_pin_amp * np.exp(
            1j * (self.b_pin_phase - np.pi / 2)
        )
        lf = float(self.load_factor(F))
        mesh = self.A_m[i] * self.mesh_amp[i, 0] * lf * np.exp(1j * (self.mesh_phase[i, 0] - np.pi / 2))
        mesh = mesh - d * abs(F) * self.c[i] * self.params.kappa_mesh * np.exp(1j * self.psi_c[i])
        m2 = self.A_m[i] * self.mesh_amp[i, 1] * lf if self.mesh_amp.shape[1] > 1 else 0.0
        return {
            "runout": float(abs(run)),
            "mesh": float(abs(mesh)),
            "runout2": float(self.A_r2[i]),
            "mesh2": float(m2),
        }

    # -- for the simulator ------------------------------------------------------------
    def tables(self, dx: float = 10e-6, margin: float = 0.3) -> tuple[float, float, np.ndarray]:
        """Components sampled on a uniform grid for the ``@njit`` engine.

        Parameters
        ----------
        dx : float
            Grid step [m].
        margin : float
            Extent of the grid beyond each end of the travel [m].

        Returns
        -------
        x0 : float
            First grid position [m] (−margin).
        dx : float
            Grid step [m].
        table : numpy.ndarray, shape (6, n)
            Rows: S_+, M_+, c_+, S_−, M_−, c_− with TE(x, F, d) = S_d + M_d A(F)/A(0) − d F c_d,
            S_d = TE_geo − M_d [m], M_d no-load mesh error [m], c_d compliance [m/N].
            Beyond the grid the engine clamps to the end values.
        """
        x0 = -margin
        n = int(math.ceil((self.bench.travel + 2 * margin) / dx)) + 1
        x = x0 + dx * np.arange(n)
        rows = []
        for d in (1, -1):
            M = self.mesh(x, d)
            rows += [self.geometric(x, d) - M, M, self.compliance(x, d)]
        return x0, dx, np.ascontiguousarray(np.vstack(rows))

    def to_dict(self) -> dict[str, Any]:
        """Enough to regenerate the model: bench, generator parameters, seed, defects."""
        return {
            "bench": self.bench.to_dict(),
            "te_generator": self.params.to_dict(),
            "seed": self.seed,
            "defects": [asdict(d) for d in self.defects],
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TransmissionErrorModel:
        """Regenerate a model written by :meth:`to_dict` (``seed`` None ⇒ :meth:`ideal`).

        Parameters
        ----------
        d : dict
            What :meth:`to_dict` wrote (``bench``, ``te_generator``, ``seed``, ``defects``).
        """
        bench = RackPinionBench.from_dict(d["bench"])
        params = TEGeneratorParams.from_dict(d["te_generator"])
        if d.get("seed") is None:
            model = cls.ideal(bench, c0=params.c0)
        else:
            model = cls.generate(bench, int(d["seed"]), params)
        for df in d.get("defects", []):
            model = model.with_local_defect(
                df["x_center"], df["width"], df["amplitude"], int(df["direction"])
            )
        return model
