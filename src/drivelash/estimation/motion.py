"""First pass over a recording: how it moves (pass 1 of the streaming estimator).

The online estimator is tuned from the excitation (motion-reversal) frequency f_r and scales
its contact threshold with the torque the recording actually carries. Both are read here,
in one cheap pass that keeps only:

* the motor position θ_m/N (and the motor torque, when recorded) at every B-th sample,
  B = max(1, ⌊1 ms / T_s⌋) — the reversal detector and the torque RMS run on these
  (≥ 1 kHz is plenty for motion reversals at a few Hz; a 1-hour 8 kHz recording keeps
  3.6 M samples of each, 29 MB);
* min / max of θ_m/N and θ_l (exact), the sample count, the first and last time stamp;
* min / max of Δθ = θ_m/N − θ_l (exact): the scale of the recording's relative motion, which
  the tuning rule's angle constants follow (:attr:`MotionSummary.dtheta_range`);
* the encoder count of θ_m and θ_l: the smallest non-zero step between consecutive samples
  (exact, every sample). A count-quantised signal gives its count, since the motion passes
  single counts at its reversals; an unquantised one only its slowest step (µrad at kHz
  rates, a negligible bound; 0 below 2π/2²⁴).

Decimating by the *global* sample index makes the summary independent of how the recording
is cut into blocks: a file read in chunks and the same data in memory give the same numbers
bit for bit (:class:`MotionScanner` with any chunking, :func:`scan_trace`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = ["REVERSAL_HYSTERESIS", "MotionScanner", "MotionSummary", "excitation_frequency", "scan_trace"]

#: Hysteresis of the reversal detector, as a fraction of the motor's total travel.
REVERSAL_HYSTERESIS = 0.1
#: Frequency returned when fewer than three reversals are found [Hz].
DEFAULT_F_EXC = 0.5
#: Decimation period of the pass-1 series [s].
DECIMATION_PERIOD = 1e-3
#: Steps between consecutive positions at or below this are "no change" (floating-point
#: round-off of a unit conversion), not an encoder count [rad].
STEP_FLOOR = 1e-12
#: Smallest step reported as an encoder count [rad]: 2π/2²⁴ (24 bit). Below it the signal is
#: unquantised or the encoder so fine that half a count (< 0.19 µrad) is far below anything
#: the estimator resolves; the count is then reported as 0.
COUNT_FLOOR = 2.0 * math.pi / 2**24


@njit(cache=True)
def _block_stats(x, prev, floor):
    """(min, max, smallest step |x_k − x_k−1| above ``floor``) of a block in one pass.

    ``prev`` is the sample before the block (NaN at the start of the recording: no step into
    the first sample). A NaN sample makes min and max NaN (as ``np.min``/``np.max``) and is no
    step (as the comparison ``d > floor`` of the array version); an empty block gives
    (inf, −inf, inf).
    """
    lo = np.inf
    hi = -np.inf
    step = np.inf
    nan = False
    p = prev
    for i in range(x.shape[0]):
        v = x[i]
        if v != v:
            nan = True
        else:
            if v < lo:
                lo = v
            if v > hi:
                hi = v
        d = abs(v - p)
        if d > floor and d < step:
            step = d
        p = v
    if nan:
        return np.nan, np.nan, step
    return lo, hi, step


@njit(cache=True)
def _reversals(x, h):
    """Schmitt-trigger reversal detector on a position signal.

    A reversal is counted when ``x`` retreats by more than ``h`` from its running extreme
    in the current direction. Returns (count, index of the first reversal's extreme,
    index of the last one's); −1 indices when there is none.
    """
    n = x.shape[0]
    if n == 0:
        return 0, -1, -1
    direction = 0  # +1 rising, −1 falling, 0 not yet known
    i_ext = 0
    x_ext = x[0]
    x_min = x[0]
    x_max = x[0]
    i_min = 0
    i_max = 0
    count = 0
    first = -1
    last = -1
    for i in range(1, n):
        v = x[i]
        if direction == 0:
            if v > x_max:
                x_max = v
                i_max = i
            if v < x_min:
                x_min = v
                i_min = i
            if x_max - x_min > h:
                if i_max > i_min:
                    direction = 1
                    x_ext = x_max
                    i_ext = i_max
                else:
                    direction = -1
                    x_ext = x_min
                    i_ext = i_min
            continue
        if direction > 0:
            if v > x_ext:
                x_ext = v
                i_ext = i
            elif x_ext - v > h:
                count += 1
                if first < 0:
                    first = i_ext
                last = i_ext
                direction = -1
                x_ext = v
                i_ext = i
        else:
            if v < x_ext:
                x_ext = v
                i_ext = i
            elif v - x_ext > h:
                count += 1
                if first < 0:
                    first = i_ext
                last = i_ext
                direction = 1
                x_ext = v
                i_ext = i
    return count, first, last


@dataclass(frozen=True)
class MotionSummary:
    """What pass 1 found out about a recording.

    Attributes
    ----------
    n : int
        Number of samples.
    T_s : float
        Sample period, (t_last − t_first)/(n − 1) [s].
    t0 : float
        First time stamp [s].
    f_exc : float
        Motion-reversal frequency [Hz] (:data:`DEFAULT_F_EXC` when fewer than three reversals).
    reversals : int
        Reversals of the motor position (hysteresis :data:`REVERSAL_HYSTERESIS` of its travel).
    motor_range : float
        Total travel of the motor, load side, θ_m/N [rad].
    load_range : float
        Total travel of the load θ_l [rad].
    torque_rms : float or None
        RMS of the recorded motor torque [N·m]; None without a ``torque_m`` column.
    t_last : float
        Last time stamp [s].
    count_m, count_l : float
        Encoder count of θ_m (motor side, as recorded) and of θ_l: the smallest non-zero step
        between consecutive samples [rad]; 0 when the signal never changes or the step is
        below :data:`COUNT_FLOOR` (unquantised).
    torque_deflection_corr : float or None
        Correlation coefficient of the motor torque with Δθ = θ_m/N − θ_l over every sample
        [-]; None without a torque column or when either is constant. Positive on a drive whose
        motor drives the load (in contact the shaft torque follows the deflection); negative
        when the motor and load channels are swapped (B2).
    velocity_noise : float
        Standard deviation of the white noise on Δω = ω_m/N − ω_l [rad/s, m/s on a linear axis]:
        the median absolute second difference of Δω over the recording, / (0.6745 √6) (a white
        noise's second difference has variance 6 σ²; the signal's own second difference, a jerk
        times T_s², is far below it at a drive's sample rates); NaN when the velocities were not
        scanned. Sets the Δθ reconstruction's cut-off (:meth:`~drivelash.params.EstimatorConfig.tuned`).
    dtheta_range : float
        max − min of the recorded Δθ = θ_m/N − θ_l over every sample [rad] (the gap plus the
        contact deflections and noise); NaN when not scanned. The tuning rule scales its angle
        constants with it when it is small (:func:`~drivelash.params.angle_scale_of`).
    """

    n: int
    T_s: float
    t0: float
    f_exc: float
    reversals: int
    motor_range: float
    load_range: float
    torque_rms: float | None
    t_last: float = math.nan
    count_m: float = 0.0
    count_l: float = 0.0
    torque_deflection_corr: float | None = None
    dtheta_range: float = math.nan
    velocity_noise: float = math.nan

    @property
    def duration(self) -> float:
        """n · T_s [s]."""
        return self.n * self.T_s

    @property
    def v_typ(self) -> float:
        """Typical load-side speed, the peak of a sine over the travel: π f_r · travel [rad/s]."""
        return math.pi * self.f_exc * self.motor_range

    @property
    def a_typ(self) -> float:
        """Typical load-side acceleration, the peak of a sine: (2π f_r)² · travel/2 [rad/s²]."""
        return (2.0 * math.pi * self.f_exc) ** 2 * 0.5 * self.motor_range


class MotionScanner:
    """Streaming pass 1: ``feed`` blocks in order, then :meth:`summary`.

    Parameters
    ----------
    N : float
        Gear ratio (θ_m is divided by it).
    """

    def __init__(self, N: float = 1.0) -> None:
        self.N = float(N)
        self.n = 0
        self.t_first = math.nan
        self.t_last = math.nan
        self.B = 0  # decimation factor, fixed by the first two time stamps
        self._th: list[np.ndarray] = []
        self._thl: list[np.ndarray] = []  # θ_l on the same samples (the gear-ratio check)
        self._u: list[np.ndarray] = []
        self._has_u: bool | None = None
        self.th_m_min = math.inf
        self.th_m_max = -math.inf
        self.th_l_min = math.inf
        self.th_l_max = -math.inf
        self.step_m = math.inf
        self.step_l = math.inf
        self.dth_min = math.inf
        self.dth_max = -math.inf
        self._last_m = math.nan
        self._last_l = math.nan
        # shifted sums of Δθ = θ_m/N − θ_l and the torque (by their first values), for their correlation
        self._c0: tuple[float, float] | None = None
        self._cs = np.zeros(6)  # n, Σx, Σu, Σx², Σu², Σxu
        # per block: median |second difference of Δω| and its sample count (velocity_noise)
        self._d2: list[tuple[float, int]] = []
        self._last_dw: np.ndarray = np.zeros(0)

    def feed(
        self,
        t: np.ndarray,
        theta_m: np.ndarray,
        theta_l: np.ndarray,
        torque_m: np.ndarray | None = None,
        omega_m: np.ndarray | None = None,
        omega_l: np.ndarray | None = None,
    ) -> None:
        """Add the next block (arrays of equal length, SI units; the velocities are optional and
        give :attr:`MotionSummary.velocity_noise`)."""
        k = int(t.size)
        if k == 0:
            return
        if omega_m is not None and omega_l is not None:
            dw = np.asarray(omega_m, dtype=np.float64) / self.N - np.asarray(omega_l, dtype=np.float64)
            # the last two samples of the previous block continue the differences across blocks
            dw = np.concatenate((self._last_dw, dw))
            if dw.size >= 3:
                d2 = dw[2:] - 2.0 * dw[1:-1] + dw[:-2]
                self._d2.append((float(np.median(np.abs(d2))), int(d2.size)))
            self._last_dw = dw[-2:].copy()
        if self.n == 0:
            self.t_first = float(t[0])
        if self.B == 0:
            if self.n + k >= 2:
                dt = float(t[1] - t[0]) if self.n == 0 else float(t[0] - self.t_last)
                self.B = max(1, int(DECIMATION_PERIOD / dt)) if dt > 0 else 1
        B = max(self.B, 1)
        # samples with global index i ≡ B − 1 (mod B)
        start = (B - 1 - self.n) % B
        th = np.asarray(theta_m[start::B], dtype=np.float64) / self.N
        self._th.append(th)
        # compact copies: a strided view of the chunk would keep the whole chunk alive, i.e. the
        # whole column over the recording (+190 MiB peak RSS on 1 h at 8 kHz, found by the slow
        # 1 GiB test)
        self._thl.append(np.ascontiguousarray(theta_l[start::B], dtype=np.float64))
        has_u = torque_m is not None
        if self._has_u is None:
            self._has_u = has_u
        if has_u and self._has_u:
            self._u.append(np.ascontiguousarray(torque_m[start::B], dtype=np.float64))
            uu = np.asarray(torque_m, dtype=np.float64)
            x = np.asarray(theta_m, dtype=np.float64) / self.N - np.asarray(theta_l, dtype=np.float64)
            if self._c0 is None:
                self._c0 = (float(x[0]), float(uu[0]))
            x = x - self._c0[0]
            uu = uu - self._c0[1]
            self._cs += (k, x.sum(), uu.sum(), x @ x, uu @ uu, x @ uu)
        else:
            self._has_u = False
        # min, max and smallest step of each position in one compiled pass
        f64 = np.float64
        lo_m, hi_m, st_m = _block_stats(np.ascontiguousarray(theta_m, dtype=f64), self._last_m, STEP_FLOOR)
        lo_l, hi_l, st_l = _block_stats(np.ascontiguousarray(theta_l, dtype=f64), self._last_l, STEP_FLOOR)
        self.th_m_min = min(self.th_m_min, float(lo_m) / self.N)
        self.th_m_max = max(self.th_m_max, float(hi_m) / self.N)
        self.th_l_min = min(self.th_l_min, float(lo_l))
        self.th_l_max = max(self.th_l_max, float(hi_l))
        # Δθ = θ_m/N − θ_l: its range is the recording's scale of relative motion
        dth = np.asarray(theta_m, dtype=f64) / self.N - np.asarray(theta_l, dtype=f64)
        lo_d, hi_d, _ = _block_stats(np.ascontiguousarray(dth), math.nan, STEP_FLOOR)
        self.dth_min = min(self.dth_min, float(lo_d))
        self.dth_max = max(self.dth_max, float(hi_d))
        self.step_m = min(self.step_m, float(st_m))
        self.step_l = min(self.step_l, float(st_l))
        self._last_m = float(theta_m[-1])
        self._last_l = float(theta_l[-1])
        self.t_last = float(t[-1])
        self.n += k

    def check_gear_ratio(self) -> None:
        """Refuse a configured N the recorded positions contradict (B6), on the pass-1 series
        (every B-th sample, ≥ 1 kHz): the rule and message of two-mass ``identify``
        (:func:`drivelash.estimation.identify_two_mass.check_gear_ratio`).

        Raises
        ------
        ParameterError
            ``[drivetrain] N`` contradicts the ratio the motor and load positions move in.
        """
        if not self._th:
            return
        from drivelash.estimation.identify_two_mass import check_gear_ratio

        check_gear_ratio(np.concatenate(self._th) * self.N, np.concatenate(self._thl), self.N)

    def summary(self) -> MotionSummary:
        """The :class:`MotionSummary` of everything fed so far."""
        n = self.n
        T_s = (self.t_last - self.t_first) / (n - 1) if n >= 2 else math.nan
        x = np.concatenate(self._th) if self._th else np.zeros(0)
        motor_range = self.th_m_max - self.th_m_min if n else 0.0
        load_range = self.th_l_max - self.th_l_min if n else 0.0
        f, count = DEFAULT_F_EXC, 0
        h = REVERSAL_HYSTERESIS * motor_range
        if x.size >= 3 and h > 0 and math.isfinite(T_s):
            count, first, last = _reversals(np.ascontiguousarray(x), h)
            count = int(count)
            if count >= 3 and last > first:
                f = float((count - 1) / (2.0 * (last - first) * self.B * T_s))
        u_rms = None
        if self._has_u and self._u:
            u = np.concatenate(self._u)
            u_rms = float(np.sqrt(np.mean(u * u))) if u.size else None
        corr = None
        if self._has_u and self._cs[0] >= 2:
            m, sx, su, sxx, suu, sxu = self._cs
            vx, vu = sxx - sx * sx / m, suu - su * su / m
            if vx > 0 and vu > 0:
                corr = float((sxu - sx * su / m) / math.sqrt(vx * vu))
        noise = math.nan
        if self._d2:  # the sample-weighted median of the block medians
            med = np.array([b[0] for b in self._d2])
            w = np.array([b[1] for b in self._d2], dtype=np.float64)
            o = np.argsort(med)
            cw = np.cumsum(w[o])
            noise = float(med[o][np.searchsorted(cw, 0.5 * cw[-1])]) / (0.6745 * math.sqrt(6.0))
        return MotionSummary(
            n=n,
            T_s=float(T_s),
            t0=self.t_first,
            f_exc=f,
            reversals=count,
            motor_range=float(motor_range),
            load_range=float(load_range),
            torque_rms=u_rms,
            t_last=self.t_last,
            count_m=self.step_m if COUNT_FLOOR <= self.step_m < math.inf else 0.0,
            count_l=self.step_l if COUNT_FLOOR <= self.step_l < math.inf else 0.0,
            torque_deflection_corr=corr,
            dtheta_range=float(self.dth_max - self.dth_min) if n else math.nan,
            velocity_noise=noise,
        )


def scan_trace(trace, N: float = 1.0, chunk: int = 1 << 16) -> MotionSummary:  # noqa: ANN001 - Trace
    """:class:`MotionSummary` of an in-memory :class:`~drivelash.io.trace.Trace` (same as streaming)."""
    sc = MotionScanner(N)
    n = len(trace)
    tq = trace["torque_m"] if "torque_m" in trace else None
    for a in range(0, n, chunk):
        b = a + chunk
        sc.feed(
            trace["t"][a:b],
            trace["theta_m"][a:b],
            trace["theta_l"][a:b] if "theta_l" in trace else trace["theta_m"][a:b],
            None if tq is None else tq[a:b],
            trace["omega_m"][a:b] if "omega_m" in trace else None,
            trace["omega_l"][a:b] if "omega_l" in trace else None,
        )
    return sc.summary()


def excitation_frequency(trace, default: float = DEFAULT_F_EXC, N: float = 1.0) -> float:  # noqa: ANN001
    """Motion-reversal frequency of a recording [Hz], from the motor position.

    Reversals of θ_m are detected with a hysteresis of :data:`REVERSAL_HYSTERESIS` of its
    total travel (position, not velocity: noise at standstill does not count) on the pass-1
    series (every B-th sample, ≥ 1 kHz), and the frequency is (reversals − 1) / (2 · time
    between the first and the last). ``default`` when fewer than three reversals are found.

    Parameters
    ----------
    trace : Trace
        Needs ``t`` and ``theta_m``.
    default : float
        Value returned for (nearly) unidirectional motion [Hz].
    N : float
        Gear ratio (the result does not depend on it).
    """
    if len(trace) < 3:
        return default
    s = scan_trace(trace, N)
    return s.f_exc if s.reversals >= 3 else default
