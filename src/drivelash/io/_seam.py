"""The loader's position-continuity check: a position step no recorded velocity allows.

Two recordings joined end to end (a user's "more data"), or signals that restart while the
time runs on, leave one sample where the position jumps by far more than the recorded velocity
can move it in one sample period. The identification fits such a seam like any other window
(one bad window among thousands moved K_S by −43 %, tester finding B5); the loader names it.

A step ``Δθ_i = θ[i+1] − θ[i]`` between samples i and i+1 is a seam when all three hold
(thresholds and their reasons: docs/assumptions.md, "Position seams"):

1. ``|Δθ_i| > SEAM_VELOCITY_FACTOR · h_i · max |ω_j|`` over the samples j ∈ [i − 2, i + 3]
   (the recorded velocity, a lag of up to two samples and its noise allowed for);
2. ``|Δθ_i| > SEAM_ISOLATION_FACTOR · max |Δθ_j|`` over the other steps j within
   ±:data:`SEAM_CONTEXT` (a genuine fast move has neighbouring steps of similar size, also
   when the recorded velocity is filtered or lags by more than two samples);
3. ``|Δθ_i| > SEAM_COUNTS · q`` with q the travel-weighted median of the column's non-zero
   steps (the step size below which half the column's total travel |Δθ| lies, on a
   1/16-octave histogram, the lower edge of its bin): one encoder count for a quantised
   position moving slower than a count per sample — whose count steps pass conditions 1 and 2
   — and the typical step otherwise. Weighted by travel, not counted: one sample moved by an ulp,
   or a recording resampled by linear interpolation (every count step split into a count less
   ε and ε: half the non-zero steps a fraction of a count), would make a plain quantile tiny
   and every count step a seam; such slivers carry almost no travel.

:class:`SeamScan` is fed the whole column (``load_trace``) or its chunks in order
(``TraceStream``): the same steps are judged with the same context either way.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

__all__ = ["SEAM_CONTEXT", "SEAM_COUNTS", "SEAM_ISOLATION_FACTOR", "SEAM_VELOCITY_FACTOR", "SeamScan"]

#: A seam moves the position this many times further in one sample than the largest recorded
#: |ω| around it allows (docs/assumptions.md).
SEAM_VELOCITY_FACTOR = 10.0
#: … and this many times further than any other step within ±SEAM_CONTEXT samples.
SEAM_ISOLATION_FACTOR = 10.0
#: … and by more than this many of the column's smallest non-zero steps (encoder counts).
SEAM_COUNTS = 4.0
#: Share of the column's travel below the step size taken as q (condition 3): the weighted median.
SEAM_Q_QUANTILE = 0.5
#: Steps on each side compared with a candidate (condition 2) [samples].
SEAM_CONTEXT = 4
_VEL_BEFORE = 2  # velocity samples before step i's first sample (lag allowance)
_VEL_AFTER = 3  # … and after it (samples i+1 .. i+3)


_BINS_PER_OCTAVE = 16
_EXP_OFFSET = 1100  # frexp exponents of doubles lie in [−1073, 1024]
_N_BINS = (1024 + _EXP_OFFSET + 1) * _BINS_PER_OCTAVE


def _bin_of(x: np.ndarray) -> np.ndarray:
    """1/16-octave bin of each x > 0 (from the float's exponent and mantissa)."""
    mant, expo = np.frexp(x)
    return (expo + _EXP_OFFSET) * _BINS_PER_OCTAVE + np.floor((mant - 0.5) * 2 * _BINS_PER_OCTAVE).astype(
        np.int64
    )


def _window_max(x: np.ndarray, before: int, after: int) -> np.ndarray:
    """``out[k] = max(x[k − before : k + after + 1])`` clipped to ``x`` (``x`` ≥ 0)."""
    if x.size == 0:
        return x.copy()
    p = np.concatenate((np.zeros(before), x, np.zeros(after)))
    return sliding_window_view(p, before + after + 1).max(axis=1)


class SeamScan:
    """Position steps that no recorded velocity allows, found over one column fed in order.

    Parameters
    ----------
    column : str
        The source column of the position (for the message).
    """

    def __init__(self, column: str) -> None:
        self.column = column
        self._buf: dict[str, np.ndarray] | None = None
        self._row0 = 0  # global sample index of the buffer's first sample
        self._done = 0  # global index of the first step not yet judged
        self._hist = np.zeros(_N_BINS)  # travel Σ|Δθ| of the non-zero steps per 1/16-octave bin
        # steps meeting conditions 1 and 2, each larger than the one before: (step i, |Δθ|, h·max|ω|, t_i)
        self.candidates: list[tuple[int, float, float, float]] = []
        self._largest = 0.0

    def feed(
        self, t: np.ndarray, theta: np.ndarray, omega: np.ndarray, row0: int, final: bool = False
    ) -> None:
        """Add samples ``row0 …`` (time [s], position [rad or m], velocity [rad/s or m/s])."""
        new = {"t": np.asarray(t, float), "th": np.asarray(theta, float), "om": np.asarray(omega, float)}
        if self._buf is None:
            self._buf, self._row0 = new, row0
        else:
            self._buf = {k: np.concatenate((self._buf[k], new[k])) for k in new}
        self._judge(final)

    def finish(self) -> None:
        """Judge the last steps (no more samples follow)."""
        if self._buf is not None:
            self._judge(True)

    def _judge(self, final: bool) -> None:
        b = self._buf
        assert b is not None
        n = b["t"].size
        if n < 2:
            return
        d = np.abs(np.diff(b["th"]))
        h = np.diff(b["t"])
        C = SEAM_CONTEXT
        lo = self._done - self._row0  # first step of the buffer not judged yet
        hi = n - 1 if final else n - 1 - (C + 1)  # steps with their full right context
        if hi > lo:
            vmax = _window_max(np.abs(b["om"]), _VEL_BEFORE, _VEL_AFTER)[: n - 1]
            left = _window_max(np.concatenate(([0.0], d[:-1])), C - 1, 0)  # steps k−C … k−1
            right = _window_max(np.concatenate((d[1:], [0.0])), 0, C - 1)  # steps k+1 … k+C
            k = np.arange(lo, hi)
            dk = d[k]
            pos = dk[(dk > 0) & np.isfinite(dk)]
            if pos.size:
                self._hist += np.bincount(_bin_of(pos), weights=pos, minlength=_N_BINS)
            allowed = h[k] * vmax[k]
            hit = (dk > SEAM_VELOCITY_FACTOR * allowed) & (
                dk > SEAM_ISOLATION_FACTOR * np.maximum(left[k], right[k])
            )
            for j in np.flatnonzero(hit):
                # only a step larger than every earlier candidate can be the first seam (the
                # count threshold only falls as q does): the list stays short
                if dk[j] > self._largest:
                    kk = int(k[j])
                    self._largest = float(dk[j])
                    self.candidates.append(
                        (self._row0 + kk, float(dk[j]), float(allowed[j]), float(b["t"][kk]))
                    )
            self._done = self._row0 + hi
        # keep the context of the steps not yet judged
        cut = max(0, min(self._done - self._row0 - (C + 1), n - 1))
        if cut > 0:
            self._buf = {key: v[cut:] for key, v in b.items()}
            self._row0 += cut

    @property
    def q(self) -> float:
        """The position's resolution [SI]: the lower edge of the 1/16-octave bin holding the
        :data:`SEAM_Q_QUANTILE` quantile of the travel over the steps judged so far (inf: none)."""
        total = float(self._hist.sum())
        if not total > 0:
            return math.inf
        b = int(np.searchsorted(np.cumsum(self._hist), SEAM_Q_QUANTILE * total, side="left"))
        e, f = divmod(b, _BINS_PER_OCTAVE)
        return math.ldexp(0.5 + f / (2 * _BINS_PER_OCTAVE), e - _EXP_OFFSET)

    def first_seam(self) -> tuple[int, float, float, float] | None:
        """The first step that is a seam: (step i, |Δθ|, h·max|ω|, t_i), or None."""
        q = self.q
        for c in self.candidates:
            if c[1] > SEAM_COUNTS * q:
                return c
        return None


def seam_message(size: float, allowed: float, t_i: float, linear: bool) -> str:
    """The loader's one-line text for a seam (the file, column and row are added by DataError)."""
    f, u = (1e3, "mm") if linear else (1e3, "mrad")
    return (
        f"position jumps {size * f:.4g} {u} in one sample at t = {t_i:.6g} s where the recorded"
        f" velocity allows {allowed * f:.3g} {u}: concatenated recordings (or signals that restart)?"
        " — cut the recording at this row and use the parts separately; or a position counter that"
        " wraps (a 16-bit trace of a finer encoder)? — set wrap (its range, in the column's unit) in"
        " [columns]"
    )
