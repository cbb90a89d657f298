"""Offline drive identification: inverse dynamic model, least squares (IDIM-LS).

Rigid axis (motor side, or a prismatic axis like EMPS)::

    τ = M q̈ + F_v q̇ + F_c sign(q̇) + offset

with τ the measured motor torque [N·m] (force [N]), q the position [rad] ([m]).
Practice of Gautier and Janot for IDIM-LS (and of the EMPS benchmark):

1. the position is low-passed with a zero-phase Butterworth filter
   (``scipy.signal.butter`` + ``filtfilt``), then differentiated twice by central
   differences — no phase lag between q̇, q̈ and τ;
2. ``n_border`` samples are dropped at each end against filter edge effects;
3. "parallel filtering": every column of the observation matrix W and the
   torque τ are decimated by the same factor with the same low-pass
   (``scipy.signal.decimate``: order-8 Chebyshev I, zero phase — as MATLAB's
   ``decimate``). This removes the high-frequency torque ripple the rigid
   model does not explain, identically on both sides of the equation;
4. ordinary least squares θ̂ = argmin ‖y − Wθ‖; σ̂² = ‖y − Wθ̂‖²/(r − p); relative error
   ‖y − Wθ̂‖/‖y‖; cov(θ̂) (motor side) the Newey–West sandwich (WᵀW)⁻¹ S (WᵀW)⁻¹ of the scores
   w_t e_t, Bartlett kernel, Andrews' lag (the rows are autocorrelated: σ̂² (WᵀW)⁻¹, kept as
   ``std_ols``, is 2–4.5× too narrow on EMPS).

Load side of a two-mass drive (J_l ω̇_l = T_l − T_F,l(ω_l), spec 01 eq 3): the
shaft torque is estimated from the motor side with known motor parameters,
T̂_l = N (u − J_m ω̇_m − β_m ω_m − T_Cm sign ω_m) (eq 1), and
T̂_l = J_l ω̇_l + β_l ω_l + T_Cl sign ω_l + offset is solved the same way, without the rows
where the load rests: with backlash the load stands still while the motor crosses the gap
(18 % of bench-0B), the shaft torque is 0 there and so is the friction, not T_Cl sign ω̂_l.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import signal

from drivelash.errors import DataError, ParameterError
from drivelash.io.trace import Trace

RIGID_NAMES = ("M", "F_v", "F_c", "offset")
#: Load side: a row of the decimated system is left out when more than this share of its
#: anti-alias filter weight falls on samples where the load rests (:func:`identify_load`).
REST_WEIGHT_MAX = 0.05
#: Relative torque error above which the rigid model is said not to describe the drive [-]
#: (EMPS, a rigid axis: 0.040, cross-test 0.060; bench-0A, backlash 1.027 rad: 0.60 with
#: J_m 6.7× low; docs/assumptions.md).
RIGID_POOR_FIT = 0.2
#: A decimated row counts as moving forward (backward) when its decimated sign(q̇) column is
#: above this level (below its negative): most of the row's anti-alias window moves that way;
#: encoder jitter at standstill averages out and counts as neither [-].
REVERSAL_SIGN_LEVEL = 0.5
#: Fewer decimated rows than this moving in either direction: Coulomb friction F_c sign(q̇) and
#: the offset are (nearly) the same column, not separable; only their sum for the direction moved
#: is fitted (docs/assumptions.md, "Identification (IDIM-LS)"). EMPS 0.5–3.0 s (forward only):
#: 0 rows backward, cond(W) 3.8e16, F_c = 3.6e15 N before this rule.
REVERSAL_MIN_ROWS = 20
LOAD_NAMES = ("J_l", "beta_l", "T_Cl", "offset")
#: Cross-test: a least-squares scale of the prediction beyond this factor (or below its inverse)
#: is named a unit slip [-] — a wrong gain or unit is a factor of 10^k (mm read as m: 1e-3, EMPS
#: 79 142 %); the model error of a right reading leaves the scale near 1 (EMPS → EMPS_PULSES:
#: docs/assumptions.md).
CROSS_UNIT_FACTOR = 10.0


@dataclass(frozen=True)
class IdentificationResult:
    """IDIM-LS estimates and their statistics.

    Attributes
    ----------
    names : tuple of str
        Parameter names, in column order of W.
    theta : numpy.ndarray
        Estimates (units: M [kg·m²] or [kg], F_v [N·m·s/rad] or [N·s/m],
        F_c and offset [N·m] or [N]).
    std : numpy.ndarray
        Standard deviations, same units as ``theta``: motor side the Newey–West (HAC) sandwich
        (:func:`hac_sandwich`; the decimated rows are autocorrelated), load side σ̂ √diag((WᵀW)⁻¹).
    relative_error : float
        ‖y − Wθ̂‖ / ‖y‖ on the (decimated) identification data [-].
    sigma : float
        Residual standard deviation σ̂ [N·m] or [N].
    condition : float
        Condition number of the decimated W [-].
    n_rows : int
        Rows of the decimated system.
    options : dict
        Filter cut-off [Hz], order, decimation factor, border, sample time [s].
    t, y, y_hat : numpy.ndarray
        Decimated time [s], measured and predicted torque (for plots).
    q_dot, q_ddot : numpy.ndarray
        Decimated velocity and acceleration used in W.
    axis : str
        ``"rotary"`` or ``"prismatic"`` (units of the numbers above).
    side : str
        ``"motor"`` or ``"load"``.
    cov : numpy.ndarray, optional
        Covariance of ``theta`` (of which ``std`` is the root of the diagonal).
    not_determined : dict of str to str
        Parameters the recording cannot determine, with the reason (e.g. ``F_c`` and ``offset``
        when the axis moved one way only). Their ``theta`` entries are what the fit used for the
        prediction (``F_c`` = 0, ``offset`` = the constant force of the direction moved), their
        ``std`` NaN; they are never written as drive parameters.
    std_ols : numpy.ndarray, optional
        The white-residual std σ̂ √diag((WᵀW)⁻¹) (motor side; what the published EMPS figures
        state): 2–4.5× below ``std`` on EMPS — not an uncertainty of these rows.
    """

    names: tuple[str, ...]
    theta: np.ndarray
    std: np.ndarray
    relative_error: float
    sigma: float
    condition: float
    n_rows: int
    options: dict[str, Any]
    t: np.ndarray = field(repr=False)
    y: np.ndarray = field(repr=False)
    y_hat: np.ndarray = field(repr=False)
    q_dot: np.ndarray = field(repr=False)
    q_ddot: np.ndarray = field(repr=False)
    axis: str = "rotary"
    side: str = "motor"
    cov: np.ndarray | None = field(default=None, repr=False)
    not_determined: dict[str, str] = field(default_factory=dict)
    std_ols: np.ndarray | None = field(default=None, repr=False)

    def __getitem__(self, name: str) -> float:
        return float(self.theta[self.names.index(name)])

    def std_of(self, name: str) -> float:
        """Standard deviation of parameter ``name``."""
        return float(self.std[self.names.index(name)])

    @property
    def notes(self) -> list[str]:
        """Warnings about the fit itself: parameters the recording cannot determine, and the rigid
        model leaving much of the torque unexplained."""
        out = [
            f"{' and '.join(n for n, w in self.not_determined.items() if w == why)} not determined: {why}"
            for why in dict.fromkeys(self.not_determined.values())
        ]
        if not self.relative_error > RIGID_POOR_FIT:
            return out
        return out + [
            f"the rigid model leaves {100 * self.relative_error:.0f} % of the torque unexplained "
            f"(relative error above {100 * RIGID_POOR_FIT:.0f} %): these are not the drive's values — "
            "a drive with backlash or a compliant shaft needs --model two-mass"
        ]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (no arrays)."""
        return {
            "notes": self.notes,
            "side": self.side,
            "axis": self.axis,
            "parameters": {
                n: (
                    {
                        "value": None,
                        "std": None,
                        "rel_std_percent": None,
                        "not_determined": self.not_determined[n],
                    }
                    if n in self.not_determined
                    else {
                        "value": float(v),
                        "std": float(s),
                        "rel_std_percent": float(100 * s / abs(v)) if v else None,
                    }
                )
                for n, v, s in zip(self.names, self.theta, self.std, strict=True)
            },
            "std_method": (
                "Newey–West (HAC) sandwich, Bartlett kernel, Andrews lag"
                if self.std_ols is not None
                else "σ̂²(WᵀW)⁻¹ (white residuals)"
            ),
            "relative_error": self.relative_error,
            "residual_std": self.sigma,
            "condition_number": self.condition,
            "n_rows": self.n_rows,
            "options": self.options,
        }

    def drivetrain_values(self) -> dict[str, float]:
        """The identified values under their ``[drivetrain]`` names.

        Motor side: J_m ← M, beta_m ← F_v, T_Cm ← F_c. Load side: J_l, beta_l, T_Cl.
        A negative friction estimate is clipped to 0 (params require ≥ 0); a parameter in
        :attr:`not_determined` is left out.
        """
        if self.side == "motor":
            out = {"J_m": self["M"], "beta_m": max(self["F_v"], 0.0), "T_Cm": max(self["F_c"], 0.0)}
            names = dict(zip(("M", "F_v", "F_c"), out, strict=True))
        else:
            out = {"J_l": self["J_l"], "beta_l": max(self["beta_l"], 0.0), "T_Cl": max(self["T_Cl"], 0.0)}
            names = {k: k for k in out}
        return {k: v for n, k in names.items() for v in [out[k]] if n not in self.not_determined}


def central_difference(x: np.ndarray, T_s: float) -> np.ndarray:
    """Central difference (x[k+1] − x[k−1]) / 2dt; one-sided at the two ends.

    Parameters
    ----------
    x : numpy.ndarray
        Samples at constant period.
    T_s : float
        Sample period [s].
    """
    return np.gradient(x, T_s, edge_order=1)


def lowpass_zero_phase(x: np.ndarray, cutoff_hz: float, fs: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass (``butter`` + ``filtfilt``).

    Parameters
    ----------
    x : numpy.ndarray
        Signal.
    cutoff_hz : float
        −3 dB frequency of the single-pass filter [Hz]; must be below fs/2.
    fs : float
        Sample rate [Hz].
    order : int
        Butterworth order (the forward-backward pass doubles the attenuation).
    """
    if not 0 < cutoff_hz < fs / 2:
        raise ParameterError("identification", "cutoff_hz", f"must lie in (0, fs/2 = {fs / 2:g}) Hz")
    b, a = signal.butter(order, cutoff_hz / (fs / 2))
    return signal.filtfilt(b, a, x)


def decimation_stages(q: int) -> list[int]:
    """Factors of the staged decimation by ``q``: stages of at most 10, as scipy recommends
    for IIR decimation (a prime factor above 10 is one stage)."""
    stages = []
    while q > 1:
        step = next(s for s in range(min(q, 10), 0, -1) if q % s == 0)
        if step == 1:  # prime factor > 10: one stage (scipy warns only for q > 13)
            step = q
        stages.append(step)
        q //= step
    return stages


def _decimate(x: np.ndarray, q: int) -> np.ndarray:
    if q == 1:
        return x.copy()
    out = x
    for step in decimation_stages(q):
        out = signal.decimate(out, step, ftype="iir", zero_phase=True)
    return out


def _prepare(
    q: np.ndarray, T_s: float, cutoff_hz: float, order: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    qf = lowpass_zero_phase(q, cutoff_hz, 1.0 / T_s, order)
    dq = central_difference(qf, T_s)
    ddq = central_difference(dq, T_s)
    return qf, dq, ddq


#: Rows of the decimated system per QR step of :class:`ChunkedLSQ` (fixed, so the result does
#: not depend on how the rows arrive).
LSQ_BLOCK = 8192


class ChunkedLSQ:
    """Ordinary least squares y ≈ Wθ by a chunked (TSQR) QR of ``[W | y]``, bounded memory.

    Rows are buffered and factorised in fixed blocks of :data:`LSQ_BLOCK` rows,
    ``R ← qr([R; block])``; from the final triangular factor, θ̂ = R_w⁻¹ r_wy, the residual
    norm ‖y − Wθ̂‖ = |r_yy|, cov(θ̂) = σ̂² (R_wᵀR_w)⁻¹ and cond(W) = cond(R_w). QR is
    backward stable: no squaring of the condition number as with normal equations.
    """

    def __init__(self, names: tuple[str, ...]) -> None:
        self.names = names
        self.p = len(names)
        self.R: np.ndarray | None = None
        self.rows = 0
        self.col_sq = np.zeros(self.p)
        self.yy = 0.0
        self._buf: list[np.ndarray] = []
        self._have = 0

    def add(self, W: np.ndarray, y: np.ndarray) -> None:
        """Append rows of W (``(m, p)``) and y (``(m,)``)."""
        if len(y) == 0:
            return
        self._buf.append(np.column_stack([W, y]))
        self._have += len(y)
        if self._have >= LSQ_BLOCK:
            a = np.concatenate(self._buf)
            k = (len(a) // LSQ_BLOCK) * LSQ_BLOCK
            for j in range(0, k, LSQ_BLOCK):
                self._factor(a[j : j + LSQ_BLOCK])
            rest = a[k:]
            self._buf, self._have = ([rest] if len(rest) else []), len(rest)

    def _factor(self, A: np.ndarray) -> None:
        self.rows += len(A)
        self.col_sq += np.einsum("ij,ij->j", A[:, : self.p], A[:, : self.p])
        self.yy += float(A[:, self.p] @ A[:, self.p])
        stacked = A if self.R is None else np.vstack([self.R, A])
        self.R = np.linalg.qr(stacked, mode="r")

    def solve(
        self, drop: tuple[int, ...] = ()
    ) -> tuple[np.ndarray, np.ndarray, float, float, float, np.ndarray]:
        """(θ̂, std, relative error, σ̂, cond(W), cov).

        ``drop``: indices of columns left out of the fit (the returned arrays cover the others,
        in order): the triangular factor of ``[W | y]`` without them is the QR of the factor's
        remaining columns (WᵀW = RᵀR), so no second pass over the rows is needed.
        """
        from scipy.linalg import solve_triangular

        if self._buf:
            self._factor(np.concatenate(self._buf))
            self._buf, self._have = [], 0
        r, p = self.rows, self.p
        cols = [j for j in range(p) if j not in drop]
        if r <= len(cols):
            raise DataError(f"only {r} rows after decimation for {len(cols)} parameters; record longer")
        zero = [j for j in cols if self.col_sq[j] == 0]
        if zero:
            bad = self.names[zero[0]]
            raise DataError(f"the recording does not excite parameter {bad} (its regressor column is zero)")
        assert self.R is not None
        R = self.R if not drop else np.linalg.qr(self.R[:, [*cols, p]], mode="r")
        p = len(cols)
        Rw, rwy, ryy = R[:p, :p], R[:p, p], float(R[p, p])
        theta = solve_triangular(Rw, rwy)
        e2 = ryy * ryy
        sigma2 = e2 / (r - p)
        Rinv = solve_triangular(Rw, np.eye(p))
        #: (WᵀW)⁻¹ of the columns solved for (the bread of :func:`hac_sandwich`)
        self.inv_gram = Rinv @ Rinv.T
        cov = sigma2 * self.inv_gram
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
        rel = float(np.sqrt(e2) / np.sqrt(self.yy)) if self.yy > 0 else float("inf")
        return theta, std, rel, float(np.sqrt(sigma2)), float(np.linalg.cond(Rw)), cov


def _solve(
    W: np.ndarray, y: np.ndarray, names: tuple[str, ...]
) -> tuple[np.ndarray, np.ndarray, float, float, float, np.ndarray]:
    lsq = ChunkedLSQ(names)
    lsq.add(W, y)
    return lsq.solve()


def _regressors(
    trace: Trace, side: str, cutoff_hz: float, filter_order: int, n_border: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Undecimated (t, q̇, q̈, τ-or-shaft-torque, sign source) after border removal."""
    T_s = trace.T_s
    col = "theta_m" if side == "motor" else "theta_l"
    for need in (col, "torque_m"):
        if need not in trace:
            raise DataError("identification needs this column", column=need, path=trace.meta.get("source"))
    _, dq, ddq = _prepare(trace[col], T_s, cutoff_hz, filter_order)
    y = trace["torque_m"].copy()
    t = trace["t"]
    n = len(trace)
    if 2 * n_border + 20 >= n:
        raise DataError(f"recording too short ({n} samples) for n_border = {n_border}", column="t")
    sl = slice(n_border, n - n_border)
    return t[sl], dq[sl], ddq[sl], y[sl], dq[sl]


def identify_rigid(
    trace: Trace,
    *,
    cutoff_hz: float = 100.0,
    filter_order: int = 4,
    decimate: int = 10,
    n_border: int = 50,
) -> IdentificationResult:
    """IDIM-LS of τ = M q̈ + F_v q̇ + F_c sign(q̇) + offset on the motor side.

    The same computation as the streamed ``drivelash identify`` (:func:`identify_rigid_stream`),
    on the whole trace in memory.

    Parameters
    ----------
    trace : Trace
        Needs ``theta_m`` [rad] or [m] and ``torque_m`` [N·m] or [N].
    cutoff_hz : float
        Butterworth cut-off on position [Hz].
    filter_order : int
        Butterworth order.
    decimate : int
        Decimation factor of W and τ (parallel filtering).
    n_border : int
        Samples dropped at each end.

    Returns
    -------
    IdentificationResult
        Names ``M``, ``F_v``, ``F_c``, ``offset``.
    """
    return identify_rigid_stream(
        *_whole(trace),
        cutoff_hz=cutoff_hz,
        filter_order=filter_order,
        decimate=decimate,
        n_border=n_border,
        keep=1,
        spill=_ArraySpill,
        axis=str(trace.meta.get("axis", "rotary")),
        source=trace.meta.get("source"),
    )


def _downsampled(spill: Any, m: int, step: int, rows: int) -> Iterator[np.ndarray]:
    """Rows 0, step, 2·step, … of ``spill`` (``m`` rows), read ``rows`` at a time."""
    rows = max(step, (rows // step) * step)
    for a in range(0, m, rows):
        yield spill.read(a, min(m, a + rows))[::step]


def identify_rigid_stream(
    chunks: Callable[[], Iterable[Any]],
    n: int,
    T_s: float,
    names: list[str],
    *,
    cutoff_hz: float = 100.0,
    filter_order: int = 4,
    decimate: int = 10,
    n_border: int = 50,
    keep: int | None = 1,
    plot_rows: int | None = None,
    spill: Callable[..., Any] | None = None,
    spill_dir: Any = None,
    back_rows: int = 1 << 18,
    axis: str = "rotary",
    source: Any = None,
) -> IdentificationResult:
    """IDIM-LS on a recording given in chunks, in bounded memory (``drivelash identify``).

    Each step equals the whole-array computation bit for bit: the zero-phase low-pass of the
    position (:func:`~drivelash.estimation.zero_phase.filtfilt_to_spill`), the central
    differences (:func:`~drivelash.estimation.zero_phase.gradient_rows`), the border cut,
    the staged parallel decimation of W and τ (the anti-alias filter of
    ``scipy.signal.decimate``, streamed the same way); the decimated rows go into
    :class:`ChunkedLSQ`. Spill files hold the filtered position (8 B per sample) and the
    undecimated system (40 B per sample), one at a time on disk, never in memory.

    Parameters
    ----------
    chunks : callable
        ``chunks()`` yields the recording in order (chunks with ``t``, ``theta_m``,
        ``torque_m``); called twice.
    n, T_s, names
        Samples, sample period [s], the chunks' columns.
    keep : int or None
        Keep every ``keep``-th decimated row for the result's ``t``/``y``/``y_hat``/``q_dot``/
        ``q_ddot`` (1: all); ``plot_rows`` instead chooses it so that about that many remain.
    Other parameters as :func:`identify_rigid`.
    """
    from drivelash.estimation.zero_phase import ZeroPhase, filtfilt_to_spill, gradient_rows
    from drivelash.io.spill import Spill

    for need in ("theta_m", "torque_m"):
        if need not in names:
            raise DataError("identification needs this column", column=need, path=source)
    if decimate < 1:
        raise ParameterError("identification", "decimate", "must be >= 1")
    if 2 * n_border + 20 >= n:
        raise DataError(f"recording too short ({n} samples) for n_border = {n_border}", column="t")
    make = spill or Spill
    filt = ZeroPhase.butter(filter_order, cutoff_hz, 1.0 / T_s)
    lo, hi = n_border, n - n_border
    m = hi - lo
    stages = decimation_stages(decimate)
    m_dec = m
    for step in stages:
        m_dec = -(-m_dec // step)
    if plot_rows is not None:
        keep = max(1, m_dec // plot_rows)
    t_dec: list[np.ndarray] = []
    t_step = decimate * (keep or 1)
    with make(n, 1, spill_dir) as qf:
        filtfilt_to_spill(filt, (ch["theta_m"] for ch in chunks()), n, qf, back_rows=back_rows)

        def read(a: int, b: int) -> np.ndarray:
            return qf.read(a, b)[:, 0]

        def system() -> Iterator[np.ndarray]:
            """Rows [q̈, q̇, sign q̇, 1, τ] of the border-cut recording, in order."""
            row = 0
            for ch in chunks():
                r0, r1 = row, row + len(ch["t"])
                row = r1
                a, b = max(r0, lo), min(r1, hi)
                if a >= b:
                    continue
                _, dq, ddq = gradient_rows(read, n, a, b, T_s, 2)
                if keep is not None:  # time of every keep-th decimated row
                    s = (-(a - lo)) % t_step
                    t_dec.append(ch["t"][a - r0 : b - r0][s::t_step].copy())
                tau = ch["torque_m"][a - r0 : b - r0]
                yield np.column_stack([ddq, dq, np.sign(dq), np.ones_like(dq), tau])

        source_rows: Iterable[np.ndarray] = system()
        held: Any = None
        size = m
        try:
            for step in stages:
                nxt = make(size, 5, spill_dir)
                try:
                    filtfilt_to_spill(ZeroPhase.decimator(step), source_rows, size, nxt, back_rows=back_rows)
                except BaseException:
                    nxt.close()
                    raise
                if held is not None:
                    held.close()
                held = nxt
                source_rows = _downsampled(held, size, step, back_rows)
                size = -(-size // step)
            lsq = ChunkedLSQ(RIGID_NAMES)
            kept: list[np.ndarray] = []
            row = 0
            n_fwd = n_bwd = 0
            dec = make(size, 5, spill_dir)  # the decimated system, read again for the HAC covariance
            for block in source_rows:
                dec.write(row, block)
                lsq.add(block[:, :4], block[:, 4])
                n_fwd += int(np.count_nonzero(block[:, 2] > REVERSAL_SIGN_LEVEL))
                n_bwd += int(np.count_nonzero(block[:, 2] < -REVERSAL_SIGN_LEVEL))
                if keep is not None:
                    kept.append(block[(-row) % keep :: keep].copy() if keep > 1 else block)
                row += len(block)
            if held is not None:
                held.close()
                held = None
            held = dec
            if min(n_fwd, n_bwd) >= REVERSAL_MIN_ROWS:
                solution = lsq.solve()
                not_determined: dict[str, str] = {}
            else:
                solution, not_determined = _one_way(lsq, n_fwd, n_bwd, axis)
            cols = [0, 1, 3] if min(n_fwd, n_bwd) == 0 else [0, 1, 2, 3]
            cov, lags = hac_sandwich(
                lambda: (dec.read(a, min(row, a + back_rows)) for a in range(0, row, back_rows)),
                solution[0],
                cols,
                lsq.inv_gram,
            )
            std_ols = solution[1]
            solution = _with_hac(solution, cov, cols, not_determined)
        finally:
            if held is not None:
                held.close()
    Wk = np.concatenate(kept) if kept else np.empty((0, 5))
    td = np.concatenate(t_dec)[: len(Wk)] if t_dec else np.empty(0)
    options = {
        "cutoff_hz": cutoff_hz,
        "filter_order": filter_order,
        "decimate": decimate,
        "n_border": n_border,
        "rows_forward": n_fwd,
        "rows_backward": n_bwd,
        "hac_lags": lags,
    }
    res = _result(
        RIGID_NAMES, solution, lsq.rows, {**options, "T_s": T_s}, td, Wk[:, :4], Wk[:, 4], axis, "motor"
    )
    return replace(res, not_determined=not_determined, std_ols=std_ols)


def andrews_lag(n: int, v: np.ndarray, c: np.ndarray) -> int:
    """Andrews (1991) AR(1) plug-in bandwidth of the Bartlett kernel from the scores' moments —
    the one implementation of the rule, computable over a stream (the two-mass fit's
    :func:`~drivelash.estimation.identify_two_mass.andrews_bandwidth` calls it on its series).

    Parameters
    ----------
    n : int
        Rows of the score series.
    v, c : numpy.ndarray
        Per column: Σ x_t² and Σ x_t x_{t−1} of the demeaned scores x.
    """
    num = den = 0.0
    for vj, cj in zip(v, c, strict=True):
        if vj <= 0:
            continue
        rho = min(max(float(cj) / float(vj), -0.97), 0.97)
        s2 = float(vj) / n * (1 - rho * rho)
        num += 4 * rho * rho * s2 * s2 / ((1 - rho) ** 6 * (1 + rho) ** 2)
        den += s2 * s2 / (1 - rho) ** 4
    if den <= 0:
        return 0
    return int(min(max(math.floor(1.1447 * (num / den * n) ** (1.0 / 3.0)), 0), n // 4))


def hac_sandwich(
    blocks: Callable[[], Iterable[np.ndarray]], theta: np.ndarray, cols: list[int], inv_gram: np.ndarray
) -> tuple[np.ndarray, int]:
    """Newey–West (HAC) covariance (WᵀW)⁻¹ S (WᵀW)⁻¹ of least-squares estimates, over a stream.

    S is the Bartlett-weighted long-run covariance of the scores g_t = w_t e_t (as
    ``statsmodels.stats.sandwich_covariance.S_hac_simple``), with the lag of :func:`andrews_lag`.
    The decimated IDIM-LS rows are autocorrelated (EMPS residuals: lag-1 0.68), so the OLS
    σ̂²(WᵀW)⁻¹ understated the std 2–4.5× (session 31, tester C, C1).

    Parameters
    ----------
    blocks : callable
        ``blocks()`` yields the rows ``[W | y]`` in order (called twice).
    theta : numpy.ndarray
        Estimates in the layout of W's columns (the columns not in ``cols`` do not enter).
    cols : list of int
        Columns of W that were solved for.
    inv_gram : numpy.ndarray
        (WᵀW)⁻¹ of those columns.

    Returns
    -------
    cov : numpy.ndarray
        Covariance of the estimates of ``cols``.
    lags : int
        Bartlett lag used (rows).
    """
    k = len(cols)
    th = np.asarray(theta, dtype=np.float64)

    def scores() -> Iterator[np.ndarray]:
        for b in blocks():
            e = b[:, -1] - b[:, :-1] @ th
            yield b[:, cols] * e[:, None]

    n = 0
    s1, s2, c1 = np.zeros(k), np.zeros(k), np.zeros(k)
    head, prev = None, None
    for g in scores():
        if len(g) == 0:
            continue
        if head is None:
            head = g[0].copy()
        n += len(g)
        s1 += g.sum(0)
        s2 += np.einsum("ij,ij->j", g, g)
        c1 += np.einsum("ij,ij->j", g[1:], g[:-1]) + (prev * g[0] if prev is not None else 0.0)
        prev = g[-1].copy()
    if n == 0 or head is None or prev is None:
        return np.full((k, k), np.nan), 0
    m = s1 / n
    v = s2 - n * m * m
    # Σ (x_t − m)(x_{t−1} − m) over t = 1 … n−1
    c = c1 - m * ((s1 - head) + (s1 - prev)) + (n - 1) * m * m
    lags = andrews_lag(n, v, c)
    weights = 1.0 - np.arange(lags + 1) / (lags + 1.0)
    S = np.zeros((k, k))
    carry = np.empty((0, k))
    for g in scores():
        X = np.vstack([carry, g])
        off = len(carry)
        S += g.T @ g
        for lag in range(1, lags + 1):
            a = max(off, lag)
            if a >= len(X):
                break
            G = X[a:].T @ X[a - lag : len(X) - lag]
            S += weights[lag] * (G + G.T)
        carry = X[-lags:] if lags else carry
    return inv_gram @ S @ inv_gram, lags


def _with_hac(
    solution: tuple[np.ndarray, np.ndarray, float, float, float, np.ndarray],
    cov_cols: np.ndarray,
    cols: list[int],
    not_determined: dict[str, str],
) -> tuple[np.ndarray, np.ndarray, float, float, float, np.ndarray]:
    """``solution`` with the HAC covariance of ``cols`` in place of the OLS one (the estimates
    unchanged); a parameter in ``not_determined`` keeps its NaN std and covariance."""
    theta, _, rel, sigma, cond, _ = solution
    p = len(theta)
    cov = np.full((p, p), np.nan)
    cov[np.ix_(cols, cols)] = cov_cols
    nd = [RIGID_NAMES.index(n) for n in not_determined]
    cov[nd, :] = np.nan
    cov[:, nd] = np.nan
    std = np.sqrt(np.clip(np.diag(cov), 0, None))
    return theta, std, rel, sigma, cond, cov


def _one_way(
    lsq: ChunkedLSQ, n_fwd: int, n_bwd: int, axis: str
) -> tuple[tuple[np.ndarray, np.ndarray, float, float, float, np.ndarray], dict[str, str]]:
    """The rigid fit of a recording that moved one way only (fewer than :data:`REVERSAL_MIN_ROWS`
    decimated rows in one direction): sign(q̇) is (nearly) the offset's column, F_c and the offset
    are not separable. With no row the other way the two columns are one (± 1): M, F_v and one
    constant c are fitted and returned in the four-parameter layout (F_c = 0, offset = c); with a
    few rows the other way the four-parameter fit is kept for the prediction. Either way the std
    and covariance of F_c and offset are NaN, and the reason (with the sum F_c + offset the data
    do determine, or offset − F_c backward) is given for both."""
    if min(n_fwd, n_bwd) == 0:
        theta3, std3, rel, sigma, cond, cov3 = lsq.solve(drop=(2,))
        theta = np.zeros(4)
        theta[[0, 1, 3]] = theta3
        std = np.full(4, np.nan)
        std[[0, 1]] = std3[:2]
        cov = np.full((4, 4), np.nan)
        cov[np.ix_([0, 1], [0, 1])] = cov3[:2, :2]
    else:
        theta, std, rel, sigma, cond, cov = lsq.solve()
        std, cov = std.copy(), cov.copy()
        std[[2, 3]] = np.nan
        cov[[2, 3], :] = np.nan
        cov[:, [2, 3]] = np.nan
    unit = "N" if axis == "prismatic" else "N·m"
    forward = n_fwd >= n_bwd
    moved = "forward" if forward else "backward"
    total, c = ("F_c + offset", theta[2] + theta[3]) if forward else ("offset − F_c", theta[3] - theta[2])
    why = (
        f"the axis moved in one direction only ({moved}; {min(n_fwd, n_bwd)} of {lsq.rows} decimated rows "
        f"the other way, fewer than {REVERSAL_MIN_ROWS}): Coulomb friction and offset are not separable "
        f"(their sum {total} is {c:.4g} {unit}) — record a motion in both directions"
    )
    return (theta, std, rel, sigma, cond, cov), {"F_c": why, "offset": why}


def _result(
    names: tuple[str, ...],
    solution: tuple[np.ndarray, np.ndarray, float, float, float, np.ndarray],
    n_rows: int,
    options: dict[str, Any],
    t: np.ndarray,
    Wd: np.ndarray,
    yd: np.ndarray,
    axis: str,
    side: str,
) -> IdentificationResult:
    """The :class:`IdentificationResult` of a solved system (``solution`` from :class:`ChunkedLSQ`);
    ``t``, ``Wd``, ``yd``: the decimated rows kept for plots."""
    theta, std, rel, sigma, cond, cov = solution
    return IdentificationResult(
        names=names,
        theta=theta,
        std=std,
        relative_error=rel,
        sigma=sigma,
        condition=cond,
        n_rows=int(n_rows),
        options=options,
        t=t,
        y=yd,
        y_hat=Wd @ theta,
        q_dot=Wd[:, 1].copy(),
        q_ddot=Wd[:, 0].copy(),
        axis=axis,
        side=side,
        cov=cov,
    )


def _finish(
    trace: Trace,
    t: np.ndarray,
    W: np.ndarray,
    y: np.ndarray,
    names: tuple[str, ...],
    side: str,
    cutoff_hz: float,
    filter_order: int,
    decimate: int,
    n_border: int,
    rest: np.ndarray | None = None,
) -> IdentificationResult:
    """Decimate W and y, leave out the rows ``rest`` contaminates, solve.

    ``rest`` (boolean, one per row of W): samples whose equation the model does not describe.
    It is decimated with the same filter as W and y, and a decimated row that takes more than
    :data:`REST_WEIGHT_MAX` of its weight from such samples is left out (their count is
    ``options["rows_at_rest"]``).
    """
    if decimate < 1:
        raise ParameterError("identification", "decimate", "must be >= 1")
    Wd = np.column_stack([_decimate(W[:, j], decimate) for j in range(W.shape[1])])
    yd = _decimate(y, decimate)
    td = t[::decimate][: yd.size]
    options: dict[str, Any] = {
        "cutoff_hz": cutoff_hz,
        "filter_order": filter_order,
        "decimate": decimate,
        "n_border": n_border,
    }
    if rest is not None:
        keep = np.abs(_decimate(rest.astype(np.float64), decimate)) <= REST_WEIGHT_MAX
        options["rows_at_rest"] = int(keep.size - np.count_nonzero(keep))
        Wd, yd, td = Wd[keep], yd[keep], td[keep]
    axis = str(trace.meta.get("axis", "rotary"))
    return _result(
        names, _solve(Wd, yd, names), yd.size, {**options, "T_s": trace.T_s}, td, Wd, yd, axis, side
    )


def shaft_torque_estimate(
    trace: Trace, J_m: float, beta_m: float, T_Cm: float, N: float, **kw: Any
) -> np.ndarray:
    """Shaft torque from the motor side, eq (1): T̂_l = N (u − J_m ω̇_m − β_m ω_m − T_Cm sign ω_m).

    Parameters
    ----------
    trace : Trace
        Needs ``theta_m`` [rad] and ``torque_m`` [N·m].
    J_m, beta_m, T_Cm, N : float
        Motor inertia [kg·m²], viscous [N·m·s/rad], Coulomb [N·m], gear ratio [-].
    **kw
        ``cutoff_hz``, ``filter_order`` of the position filter.

    Returns
    -------
    numpy.ndarray
        T̂_l [N·m] at every sample.
    """
    T_s = trace.T_s
    _, dq, ddq = _prepare(trace["theta_m"], T_s, kw.get("cutoff_hz", 100.0), kw.get("filter_order", 4))
    return N * (trace["torque_m"] - J_m * ddq - beta_m * dq - T_Cm * np.sign(dq))


def identify_load(
    trace: Trace,
    *,
    J_m: float,
    beta_m: float,
    T_Cm: float,
    N: float,
    cutoff_hz: float = 100.0,
    filter_order: int = 4,
    decimate: int = 10,
    n_border: int = 50,
) -> IdentificationResult:
    """IDIM-LS of the load side T̂_l = J_l ω̇_l + β_l ω_l + T_Cl sign ω_l + offset.

    The shaft torque comes from :func:`shaft_torque_estimate` with the given
    motor parameters; the load encoder ``theta_l`` gives ω_l and ω̇_l. Samples where the
    load rests (|ω̂_l| at most ``STANDSTILL_FRACTION`` of its 99th-percentile speed, the rule
    of the two-mass fit) are not in the model; the decimated rows they contaminate are left out
    (:func:`_finish`, ``options["rows_at_rest"]``).

    Returns
    -------
    IdentificationResult
        Names ``J_l``, ``beta_l``, ``T_Cl``, ``offset`` (side ``"load"``).
    """
    if "theta_l" not in trace:
        raise DataError(
            "load-side identification needs a load encoder column",
            column="theta_l",
            path=trace.meta.get("source"),
        )
    from drivelash.estimation.identify_two_mass import STANDSTILL_FRACTION

    T_l = shaft_torque_estimate(trace, J_m, beta_m, T_Cm, N, cutoff_hz=cutoff_hz, filter_order=filter_order)
    T_s = trace.T_s
    _, dq, ddq = _prepare(trace["theta_l"], T_s, cutoff_hz, filter_order)
    n = len(trace)
    sl = slice(n_border, n - n_border)
    W = np.column_stack([ddq[sl], dq[sl], np.sign(dq[sl]), np.ones(n)[sl]])
    # the load at rest (in the gap, or held by static friction): T_l = T_F,l = 0 there, which
    # the Coulomb term T_Cl sign ω̂_l of a filtered near-zero velocity contradicts — included,
    # they gave β_l +330 % and T_Cl −60 % on noise-free bench-0B. Same rule as the two-mass fit.
    speed = np.abs(dq[sl])
    rest = speed <= STANDSTILL_FRACTION * float(np.percentile(speed, 99))
    return _finish(
        trace,
        trace["t"][sl],
        W,
        T_l[sl],
        LOAD_NAMES,
        "load",
        cutoff_hz,
        filter_order,
        decimate,
        n_border,
        rest=rest,
    )


@dataclass(frozen=True)
class CrossTest:
    """Inverse model of one recording applied to another (cross-test).

    Attributes
    ----------
    relative_error : float
        ‖y − Wθ̂‖ / ‖y‖ on the decimated validation data [-].
    t, y, y_hat : numpy.ndarray
        Decimated time [s], measured and predicted torque/force.
    """

    relative_error: float
    t: np.ndarray = field(repr=False)
    y: np.ndarray = field(repr=False)
    y_hat: np.ndarray = field(repr=False)

    @property
    def scale(self) -> float:
        """Least-squares factor a of y ≈ a ŷ [-]: 1 when the validation recording is read like the
        estimation one, ≈ −1 with a sign flipped, a power of ten with a unit slip."""
        d = float(self.y_hat @ self.y_hat)
        return float(self.y_hat @ self.y) / d if d > 0 else float("nan")

    @property
    def notes(self) -> list[str]:
        """One warning when the cross-test error is above :data:`RIGID_POOR_FIT` (the fit's own
        limit), naming a flipped sign (a < 0) or a unit (|a| beyond :data:`CROSS_UNIT_FACTOR`)
        where the best scale of the prediction shows one."""
        if not self.relative_error > RIGID_POOR_FIT:
            return []
        head = (
            f"the cross-test leaves {100 * self.relative_error:.0f} % of the validation force/torque "
            f"unexplained (above {100 * RIGID_POOR_FIT:.0f} %): "
        )
        a = self.scale
        if a < 0:
            return [
                head + f"the measured force/torque runs against the prediction (best scale {a:.3g}) — the "
                "validation file's force/torque sign (or its position's) is likely flipped; check its "
                "scale in [columns]"
            ]
        if not 1.0 / CROSS_UNIT_FACTOR <= a <= CROSS_UNIT_FACTOR:
            return [
                head
                + f"the prediction is off by a factor {1.0 / a:.3g} (best scale {a:.3g}) — a unit of the "
                "validation file (position, force/torque or time) likely differs from the estimation file's"
            ]
        return [
            head + "the identified model does not describe the validation recording — check it is the "
            "same axis, read with the same [columns]"
        ]


def cross_test(result: IdentificationResult, trace: Trace) -> CrossTest:
    """Evaluate an identified rigid model on another recording, same preprocessing.

    Parameters
    ----------
    result : IdentificationResult
        From :func:`identify_rigid` (motor side).
    trace : Trace
        Validation recording.
    """
    o = result.options
    t, dq, ddq, y, _ = _regressors(trace, "motor", o["cutoff_hz"], o["filter_order"], o["n_border"])
    W = np.column_stack([ddq, dq, np.sign(dq), np.ones_like(dq)])
    q = int(o["decimate"])
    Wd = np.column_stack([_decimate(W[:, j], q) for j in range(W.shape[1])])
    yd = _decimate(y, q)
    y_hat = Wd @ result.theta
    rel = float(np.linalg.norm(yd - y_hat) / np.linalg.norm(yd))
    return CrossTest(rel, t[::q][: yd.size], yd, y_hat)


def identify(trace: Trace, options: Any = None, drivetrain: Any = None) -> IdentificationResult:
    """Identify by an ``[identification]`` table (side motor or load).

    Parameters
    ----------
    trace : Trace
    options : IdentificationSection, optional
        Filter/decimation options; defaults when None.
    drivetrain : DrivetrainSection, optional
        Known motor parameters (J_m, beta_m, T_Cm, N), needed for ``side = "load"``.
    """
    from drivelash.io.config import IdentificationSection

    o = options or IdentificationSection()
    kw = {
        "cutoff_hz": o.cutoff_hz,
        "filter_order": o.filter_order,
        "decimate": o.decimate,
        "n_border": o.n_border,
    }
    if o.side == "motor":
        return identify_rigid(trace, **kw)
    if drivetrain is None:
        from drivelash.errors import ConfigError

        raise ConfigError("side = 'load' needs the motor parameters in [drivetrain] (J_m, beta_m, T_Cm, N)")
    return identify_load(
        trace, J_m=drivetrain.J_m, beta_m=drivetrain.beta_m, T_Cm=drivetrain.T_Cm, N=drivetrain.N, **kw
    )


# --------------------------------------------------------------------------- observer on an identified axis
#: Default bound ρ on |dφ/dt| for the STSMO gains when [estimator] gives no k1, k2
#: (Levant's rule via STSMOParams.from_rho: k2 = 1.1 ρ, k1 = 1.5 √ρ).
DEFAULT_RHO = 20.0

#: Speed [m/s] at which the default ρ is :data:`DEFAULT_RHO`: the max |q̇| of the EMPS
#: recordings ρ = 20 was chosen on (0.128 m/s DATA_EMPS, 0.137 m/s DATA_EMPS_PULSES).
#: :func:`default_rho` scales ρ with the recording's max |q̇| in whole decades.
RHO_REF_SPEED = 0.13


#: ``observe`` warns when the mean disturbance forward lies below the backward one by more than
#: this fraction of the larger of the two: d̂_fwd − d̂_bwd = 2 F_c would be negative (friction
#: pushing along the motion). EMPS: +41.2 N (17.00 − (−24.19)); with the force, position or
#: velocity sign flipped −117 N (−55.3 / +61.7), i.e. −1.9 × 61.7. A fraction, not 0, so that a
#: nearly frictionless axis (both means ≈ its offset) is not flagged on noise.
NEGATIVE_FRICTION_FRACTION = 0.5


def negative_friction_warning(d_forward: float, d_backward: float) -> str | None:
    """One-line warning when the constant-velocity means imply negative Coulomb friction.

    Parameters
    ----------
    d_forward, d_backward : float
        Mean d̂ on the forward / backward constant-velocity stretches [N·m] or [N].

    Returns
    -------
    str or None
        The warning, or None when d̂_fwd − d̂_bwd ≥ −:data:`NEGATIVE_FRICTION_FRACTION` ·
        max(|d̂_fwd|, |d̂_bwd|) (or a mean is not finite).
    """
    if not (math.isfinite(d_forward) and math.isfinite(d_backward)):
        return None
    if d_forward - d_backward >= -NEGATIVE_FRICTION_FRACTION * max(abs(d_forward), abs(d_backward)):
        return None
    return (
        f"the disturbance pushes along the motion (mean {d_forward:.4g} forward, {d_backward:.4g}"
        f" backward: Coulomb friction {(d_forward - d_backward) / 2:.4g} < 0) — is the sign of the"
        " torque/force, the position or the velocity column wrong? (scale = -1 in [columns])"
    )


def default_rho(v_max: float) -> float:
    """Default STSMO bound ρ for a recording whose max |q̇| is ``v_max``.

    ρ = :data:`DEFAULT_RHO` · 10^round(log10(v_max / :data:`RHO_REF_SPEED`)): the perturbation
    φ = d/J and its rate scale with the unit of q (positions × s: J ÷ s, φ × s), so ρ follows
    the recording's speed. In whole decades, so that a unit change by 10^k (m → mm, metres of a
    ball screw → ~10³ motor rad) scales the observer exactly (the same d̂ in N) and the EMPS
    recordings in m keep ρ = 20 bit for bit; within a decade the effective ρ stays in
    20/√10 … 20·√10 of the axis's scale, inside the 5 … 100 where the EMPS means move < 0.1 N.

    Parameters
    ----------
    v_max : float
        Max |q̇| of the observed velocity [rad/s] or [m/s].

    Returns
    -------
    float
        ρ [rad/s³] or [m/s³]; :data:`DEFAULT_RHO` when ``v_max`` is not finite and > 0.
    """
    if not (math.isfinite(v_max) and v_max > 0):
        return DEFAULT_RHO
    return DEFAULT_RHO * 10.0 ** round(math.log10(v_max / RHO_REF_SPEED))


@dataclass(frozen=True)
class DisturbanceEstimate:
    """Output of :func:`observe_disturbance`.

    Attributes
    ----------
    t : numpy.ndarray
        Time [s].
    velocity : numpy.ndarray
        Velocity fed to the observer [rad/s] or [m/s].
    disturbance : numpy.ndarray
        d̂ = −J φ̂: torque [N·m] (force [N]) not explained by J q̈ + β q̇, i.e.
        Coulomb friction + offset + external load.
    constant_velocity : numpy.ndarray
        Boolean mask of the constant-velocity stretches used for the summary.
    mean_positive, mean_negative : float
        Mean of d̂ on constant-velocity stretches moving forward / backward.
    J, beta : float
        Inertia and viscous coefficient the observer assumed.
    k1, k2 : float
        STSMO gains used.
    n_constant_velocity : int, optional
        Samples on constant-velocity stretches (when the mask above is thinned or empty).
    warnings : tuple of str
        One line each: a result that implies negative Coulomb friction
        (:func:`negative_friction_warning`).
    """

    t: np.ndarray = field(repr=False)
    velocity: np.ndarray = field(repr=False)
    disturbance: np.ndarray = field(repr=False)
    constant_velocity: np.ndarray = field(repr=False)
    mean_positive: float
    mean_negative: float
    J: float
    beta: float
    k1: float
    k2: float
    n_constant_velocity: int | None = None
    warnings: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``warnings`` only when there are any)."""
        return {
            **({"warnings": list(self.warnings)} if self.warnings else {}),
            "J": self.J,
            "beta": self.beta,
            "k1": self.k1,
            "k2": self.k2,
            "mean_disturbance_forward": self.mean_positive,
            "mean_disturbance_backward": self.mean_negative,
            "constant_velocity_samples": int(
                self.constant_velocity.sum() if self.n_constant_velocity is None else self.n_constant_velocity
            ),
        }


def constant_velocity_mask(
    velocity: np.ndarray,
    T_s: float,
    *,
    accel_fraction: float = 0.05,
    speed_fraction: float = 0.2,
    skip: int = 0,
) -> np.ndarray:
    """Samples on constant-velocity stretches.

    |q̈| below ``accel_fraction``·max|q̈| and |q̇| above ``speed_fraction``·max|q̇|
    (away from reversals, where Coulomb friction switches); the first ``skip``
    samples (observer transient) are excluded.
    """
    acc = central_difference(velocity, T_s)
    m = (np.abs(acc) < accel_fraction * np.abs(acc).max()) & (
        np.abs(velocity) > speed_fraction * np.abs(velocity).max()
    )
    m[:skip] = False
    return m


#: Leaf size of numpy's pairwise summation (``PW_BLOCKSIZE`` in numpy's ``loops_utils``).
PAIRWISE_LEAF = 128


class PairwiseSum:
    """numpy's pairwise sum of ``n`` values that arrive in chunks, bit for bit.

    ``np.sum`` of a contiguous float64 array splits ``n`` values recursively at
    ``n2 = n // 2 − (n // 2) % 8`` down to leaves of at most 128 values, each summed by its
    unrolled loop. With ``n`` known up front the leaves are fixed: each leaf is summed by
    ``np.sum`` as soon as its values have arrived, and the leaf sums are added in the same
    tree at the end. ``mean()`` equals ``np.mean`` of the concatenated values exactly
    (``tests/estimation/test_zero_phase.py``); memory: one leaf sum per ≤ 128 values.
    """

    def __init__(self, n: int) -> None:
        self.n = int(n)
        self.count = 0
        sizes: list[int] = []
        stack = [self.n] if self.n > 0 else []
        while stack:  # leaves in order (depth first, left before right)
            m = stack.pop()
            if m <= PAIRWISE_LEAF:
                sizes.append(m)
            else:
                m2 = m // 2
                m2 -= m2 % 8
                stack += [m - m2, m2]
        self._sizes = sizes
        self._sums = np.empty(len(sizes))
        self._leaf = 0
        self._buf: list[np.ndarray] = []
        self._have = 0

    def add(self, x: np.ndarray) -> None:
        """Append values (any length; ``n`` in total)."""
        if x.size == 0:
            return
        self.count += x.size
        if self.count > self.n:
            raise ValueError(f"more than the announced {self.n} values")
        self._buf.append(np.asarray(x, dtype=np.float64))
        self._have += x.size
        if self._leaf < len(self._sizes) and self._have >= self._sizes[self._leaf]:
            a = np.concatenate(self._buf)
            pos = 0
            while self._leaf < len(self._sizes) and a.size - pos >= self._sizes[self._leaf]:
                k = self._sizes[self._leaf]
                self._sums[self._leaf] = np.sum(a[pos : pos + k])
                pos += k
                self._leaf += 1
            rest = a[pos:]
            self._buf, self._have = ([rest] if rest.size else []), rest.size

    def total(self) -> np.float64:
        """The sum (all ``n`` values must have arrived)."""
        if self.count != self.n:
            raise ValueError(f"{self.count} of {self.n} values arrived")
        it = iter(self._sums)

        def tree(m: int) -> np.float64:
            if m <= PAIRWISE_LEAF:
                return next(it)
            m2 = m // 2
            m2 -= m2 % 8
            left = tree(m2)
            return left + tree(m - m2)

        return tree(self.n) if self.n else np.float64(0.0)

    def mean(self) -> float:
        """``np.mean`` of the values (NaN when there are none)."""
        return float(self.total() / self.n) if self.n else float("nan")


class _ArraySpill:
    """In-memory stand-in of :class:`drivelash.io.spill.Spill` (a whole Trace in memory)."""

    def __init__(self, n: int, k: int, directory: Any = None) -> None:
        self.n, self.k = n, k
        self.a = np.empty((n, k))

    def write(self, start: int, rows: np.ndarray) -> None:
        rows = np.asarray(rows)
        self.a[start : start + len(rows)] = rows.reshape(len(rows), self.k)

    def read(self, start: int, stop: int) -> np.ndarray:
        return self.a[max(0, start) : min(self.n, stop)].copy()

    def close(self) -> None:
        self.a = np.empty((0, self.k))

    def __enter__(self) -> _ArraySpill:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def trace_chunks(trace: Trace, rows: int = 1 << 18) -> Any:
    """A re-iterable chunk source over an in-memory Trace (for the streamed pipelines)."""

    def chunks() -> Iterator[Trace]:
        for a in range(0, len(trace), rows):
            yield trace.slice(a, a + rows)

    return chunks


def _whole(trace: Trace) -> tuple[Any, int, float, list[str]]:
    """The arguments (chunks, n, T_s, names) of a streamed pipeline over a whole Trace."""
    return trace_chunks(trace), len(trace), trace.T_s, list(trace.names)


def observe_disturbance(
    trace: Trace,
    *,
    J: float,
    beta: float = 0.0,
    k1: float | None = None,
    k2: float | None = None,
    cutoff_hz: float = 100.0,
    filter_order: int = 4,
    side: str = "m",
) -> DisturbanceEstimate:
    """Super-twisting observer of the disturbance on one axis (spec 01 eq 16 on any axis).

    Model J q̈ = u − β q̇ − d with u = ``torque_m``; the STSMO
    (:class:`drivelash.estimation.stsmo.SuperTwistingObserver`) tracks the velocity
    with known acceleration (u − β q̇)/J and its perturbation φ̂ gives d̂ = −J φ̂.
    The same computation as the streamed ``drivelash observe``
    (:func:`observe_stream`), on the whole trace in memory.

    Parameters
    ----------
    trace : Trace
        Needs ``torque_m`` and ``omega_<side>`` or ``theta_<side>`` (then differentiated
        after a zero-phase low-pass at ``cutoff_hz``).
    J : float
        Inertia [kg·m²] (mass [kg] on a prismatic axis).
    beta : float
        Viscous coefficient [N·m·s/rad] ([N·s/m]).
    k1, k2 : float, optional
        STSMO gains; default from ρ = :func:`default_rho` of the recording's max |q̇|
        (:data:`DEFAULT_RHO` = 20 on EMPS in m) by Levant's rule.
    cutoff_hz : float
        Cut-off of the zero-phase Butterworth low-pass applied to ``theta_<side>`` before
        differentiating it [Hz] (unused when ``omega_<side>`` is recorded).
    filter_order : int
        Order of that low-pass [-].
    side : {"m", "l"}
        The axis observed: the column suffix, ``"m"`` (motor: ``omega_m``/``theta_m``) or
        ``"l"`` (load).

    Raises
    ------
    ParameterError
        ``J`` is not finite and > 0, or ``beta`` not finite and >= 0.
    DataError
        The trace has neither ``omega_<side>`` nor ``theta_<side>``, or no ``torque_m``.
    """
    return observe_stream(
        *_whole(trace),
        J=J,
        beta=beta,
        k1=k1,
        k2=k2,
        cutoff_hz=cutoff_hz,
        filter_order=filter_order,
        side=side,
        keep=1,
        spill=_ArraySpill,
    )


def observe_stream(
    chunks: Callable[[], Iterable[Any]],
    n: int,
    T_s: float,
    names: list[str],
    *,
    J: float,
    beta: float = 0.0,
    k1: float | None = None,
    k2: float | None = None,
    cutoff_hz: float = 100.0,
    filter_order: int = 4,
    side: str = "m",
    keep: int | None = 1,
    sink: Callable[[np.ndarray, np.ndarray, np.ndarray], None] | None = None,
    spill: Callable[..., Any] | None = None,
    spill_dir: Any = None,
    back_rows: int = 1 << 18,
) -> DisturbanceEstimate:
    """The disturbance observer over a recording given in chunks, in bounded memory.

    Steps (each bit-identical to the whole-array computation of :func:`observe_disturbance`):
    the velocity column, or the position through the zero-phase low-pass
    (:func:`~drivelash.estimation.zero_phase.filtfilt_to_spill`) and a central difference;
    a pass over the velocity for max |q̇| and max |q̈| (the constant-velocity thresholds);
    then the STSMO over the chunks with its state carried, the constant-velocity means
    summed by :class:`PairwiseSum` (the samples on them are counted first, from the velocity).

    Parameters
    ----------
    chunks : callable
        ``chunks()`` yields the recording in order (Trace-like chunks with ``t``,
        ``torque_m`` and ``omega_<side>`` or ``theta_<side>``); called twice.
    n, T_s : int, float
        Samples and sample period [s].
    names : list of str
        Columns the chunks carry.
    keep : int or None
        Keep every ``keep``-th sample of t, velocity, d̂ and the mask in the result
        (1: all; None: none, the arrays are empty).
    sink : callable, optional
        ``sink(t, velocity, disturbance)`` receives every chunk of the output, in order.
    spill : callable, optional
        Factory of the velocity store ``(n, 1)`` (default :class:`drivelash.io.spill.Spill`
        in ``spill_dir``).
    Other parameters as :func:`observe_disturbance`.
    """
    from drivelash.estimation.stsmo import STSMOParams, SuperTwistingObserver
    from drivelash.estimation.zero_phase import ZeroPhase, filtfilt_to_spill, gradient_rows
    from drivelash.io.spill import Spill

    if not (math.isfinite(J) and J > 0):
        raise ParameterError("observer", "J", f"must be finite and > 0, got {J!r}")
    if not (math.isfinite(beta) and beta >= 0):
        raise ParameterError("observer", "beta", f"must be finite and >= 0, got {beta!r}")
    if f"omega_{side}" in names:
        vcol, filt = f"omega_{side}", None
    elif f"theta_{side}" in names:
        vcol, filt = f"theta_{side}", ZeroPhase.butter(filter_order, cutoff_hz, 1 / T_s)
    else:
        raise DataError("the observer needs a velocity or position column", column=f"omega_{side}")
    if "torque_m" not in names:
        raise DataError("the observer needs the motor torque/force", column="torque_m")
    store = (spill or Spill)(n, 1, spill_dir)
    with store:
        if filt is not None:
            filtfilt_to_spill(filt, (ch[vcol] for ch in chunks()), n, store, back_rows=back_rows)
            order = 2  # position → velocity → acceleration
        else:
            row = 0
            for ch in chunks():
                store.write(row, ch[vcol])
                row += len(ch[vcol])
            order = 1

        def read(a: int, b: int) -> np.ndarray:
            return store.read(a, b)[:, 0]

        def vel_acc(a: int, b: int) -> tuple[np.ndarray, np.ndarray]:
            g = gradient_rows(read, n, a, b, T_s, order)
            if filt is None:
                return g[0], g[1]
            return g[1], g[2]

        # thresholds of the constant-velocity mask need max |q̇| and max |q̈| of the whole run
        vmax = amax = 0.0
        v0 = None
        for a in range(0, n, back_rows):
            v, acc = vel_acc(a, min(n, a + back_rows))
            if v0 is None:
                v0 = float(v[0])
            vmax, amax = max(vmax, float(np.abs(v).max())), max(amax, float(np.abs(acc).max()))
        skip = min(n // 10, int(round(0.5 / T_s)))
        if k1 is None or k2 is None:  # ρ follows the recording's speed (units): default_rho
            p = STSMOParams.from_rho(default_rho(vmax), T_s)
            k1 = p.k1 if k1 is None else k1
            k2 = p.k2 if k2 is None else k2
        params = STSMOParams(k1=k1, k2=k2, T_s=T_s)

        def mask(a: int, v: np.ndarray, acc: np.ndarray) -> np.ndarray:
            cv = (np.abs(acc) < 0.05 * amax) & (np.abs(v) > 0.2 * vmax)
            if a < skip:
                cv[: skip - a] = False
            return cv

        # samples on the constant-velocity stretches, forward / backward (numpy's pairwise
        # sum, reproduced in PairwiseSum, needs the count up front)
        n_pos = n_neg = 0
        for a in range(0, n, back_rows):
            v, acc = vel_acc(a, min(n, a + back_rows))
            cv = mask(a, v, acc)
            n_pos += int(np.count_nonzero(cv & (v > 0)))
            n_neg += int(np.count_nonzero(cv & (v < 0)))
        obs = SuperTwistingObserver(params, omega0=float(v0))
        pos_sum, neg_sum = PairwiseSum(n_pos), PairwiseSum(n_neg)
        kept: dict[str, list[np.ndarray]] = {"t": [], "v": [], "d": [], "cv": []}
        row = 0
        for ch in chunks():
            m = len(ch["t"])
            v, acc = vel_acc(row, row + m)
            _, phi = obs.run(v, (ch["torque_m"] - beta * v) / J)
            d = -J * phi
            cv = mask(row, v, acc)
            pos_sum.add(d[cv & (v > 0)])
            neg_sum.add(d[cv & (v < 0)])
            if sink is not None:
                sink(ch["t"], v, d)
            if keep is not None:
                s = (-row) % keep
                for key, arr in (("t", ch["t"]), ("v", v), ("d", d), ("cv", cv)):
                    kept[key].append(arr[s::keep].copy() if keep > 1 else arr)
            row += m

    def cat(key: str, dtype: Any = np.float64) -> np.ndarray:
        return np.concatenate(kept[key]) if kept[key] else np.empty(0, dtype)

    both = pos_sum.count and neg_sum.count  # both directions on constant-velocity stretches
    neg = negative_friction_warning(pos_sum.mean(), neg_sum.mean()) if both else None
    return DisturbanceEstimate(
        warnings=(neg,) if neg else (),
        t=cat("t"),
        velocity=cat("v"),
        disturbance=cat("d"),
        constant_velocity=cat("cv", bool),
        mean_positive=pos_sum.mean(),
        mean_negative=neg_sum.mean(),
        J=float(J),
        beta=float(beta),
        k1=float(k1),
        k2=float(k2),
        n_constant_velocity=pos_sum.count + neg_sum.count,  # |q̇| > 0.2 max|q̇|: never 0
    )
