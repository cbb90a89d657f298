"""Zero-phase filtering and differentiation of recordings larger than memory.

``scipy.signal.filtfilt`` (and ``sosfiltfilt``) with the default odd-extension padding is

1. ``ext = [2 x[0] − x[edge:0:-1], x, 2 x[-1] − x[-2:-edge-2:-1]]``;
2. a forward pass ``lfilter(b, a, ext, zi=zi·ext[0])``;
3. a backward pass over the reversed forward output with ``zi·y[-1]``; the pads are cut.

Each pass is a recursion with explicit state, so it runs chunk by chunk with the state
carried across chunks and gives the same floating-point operations in the same order as
the whole-array call: :func:`filtfilt_to_spill` is **bit-identical** to ``filtfilt`` /
``sosfiltfilt`` (``tests/estimation/test_zero_phase.py``). The forward output goes to a
:class:`~drivelash.io.spill.Spill` file, the backward pass reads it in reverse chunks and
writes the result back in place; memory holds one chunk, the state and the ``edge``
samples of each pad.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np
from scipy import signal

from drivelash.errors import DataError, ParameterError
from drivelash.io.spill import Spill

__all__ = ["ZeroPhase", "filtfilt_to_spill", "gradient_rows"]


@dataclass(frozen=True)
class ZeroPhase:
    """A forward–backward filter: transfer function (``b``, ``a``) or second-order sections.

    Attributes
    ----------
    b, a : numpy.ndarray or None
        Transfer-function coefficients (``filtfilt``).
    sos : numpy.ndarray or None
        Second-order sections (``sosfiltfilt``).
    """

    b: np.ndarray | None = None
    a: np.ndarray | None = None
    sos: np.ndarray | None = None

    @classmethod
    def butter(cls, order: int, cutoff_hz: float, fs: float) -> ZeroPhase:
        """The Butterworth low-pass of :func:`drivelash.estimation.identify.lowpass_zero_phase`."""
        if not 0 < cutoff_hz < fs / 2:
            raise ParameterError("identification", "cutoff_hz", f"must lie in (0, fs/2 = {fs / 2:g}) Hz")
        b, a = signal.butter(order, cutoff_hz / (fs / 2))
        return cls(b=b, a=a)

    @classmethod
    def decimator(cls, q: int) -> ZeroPhase:
        """The anti-alias filter of ``scipy.signal.decimate(x, q, ftype="iir", zero_phase=True)``
        (order-8 Chebyshev I, 0.05 dB ripple, edge 0.8/q, second-order sections)."""
        return cls(sos=signal.cheby1(8, 0.05, 0.8 / q, output="sos"))

    @property
    def edge(self) -> int:
        """Pad length of ``filtfilt``/``sosfiltfilt`` (their default ``padlen``) [samples]."""
        if self.sos is not None:
            sos = self.sos
            ntaps = 2 * len(sos) + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
            return 3 * ntaps
        assert self.a is not None and self.b is not None
        return 3 * max(len(self.a), len(self.b))

    def initial(self, x0: np.ndarray) -> np.ndarray:
        """State ``zi·x0`` for a first row ``x0`` of shape ``(k,)``."""
        if self.sos is not None:
            return signal.sosfilt_zi(self.sos)[:, :, None] * x0[None, None, :]
        assert self.a is not None and self.b is not None
        return signal.lfilter_zi(self.b, self.a)[:, None] * x0[None, :]

    def run(self, x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Filter rows ``x`` (``(m, k)``) from state ``z``; returns (output, new state)."""
        if self.sos is not None:
            return signal.sosfilt(self.sos, x, axis=0, zi=z)
        return signal.lfilter(self.b, self.a, x, axis=0, zi=z)


def _rows(chunks: Iterable[np.ndarray]) -> Iterator[np.ndarray]:
    for c in chunks:
        c = np.asarray(c, dtype=np.float64)
        yield c[:, None] if c.ndim == 1 else c


def filtfilt_to_spill(
    filt: ZeroPhase, chunks: Iterable[np.ndarray], n: int, spill: Spill, *, back_rows: int = 1 << 18
) -> Spill:
    """``filtfilt`` of the concatenated ``chunks`` (``n`` rows, ``spill.k`` columns) into ``spill``.

    Parameters
    ----------
    filt : ZeroPhase
        The filter.
    chunks : iterable of numpy.ndarray
        The signal in order, ``(m, k)`` or ``(m,)`` arrays of any sizes.
    n : int
        Total rows; must exceed :attr:`ZeroPhase.edge` (as for ``filtfilt``).
    spill : Spill
        ``(n, k)`` destination.
    back_rows : int
        Rows per step of the backward pass.

    Returns
    -------
    Spill
        ``spill``, holding the zero-phase output (bit-identical to ``filtfilt`` per column).
    """
    edge = filt.edge
    if n <= edge:
        raise DataError(f"only {n} samples: the zero-phase filter needs more than {edge}", column="t")
    head: list[np.ndarray] = []
    have = 0
    z: np.ndarray | None = None
    row = 0
    tail = np.empty((0, spill.k))

    def forward(x: np.ndarray) -> None:
        nonlocal z, row, tail
        assert z is not None
        y, z = filt.run(x, z)
        spill.write(row, y)
        row += len(x)
        tail = np.concatenate((tail, x))[-(edge + 1) :]

    for c in _rows(chunks):
        if z is None:
            head.append(c)
            have += len(c)
            if have <= edge:
                continue
            x = np.concatenate(head)
            head = []
            left = 2 * x[0] - x[edge:0:-1]
            z = filt.initial(left[0])
            _, z = filt.run(left, z)
            forward(x)
        else:
            forward(c)
    if z is None or row != n:
        raise DataError(f"the recording gave {row} rows, expected {n}", column="t")
    right = 2 * tail[-1] - tail[-2 : -(edge + 2) : -1]
    y_right, z = filt.run(right, z)
    z = filt.initial(y_right[-1])
    _, z = filt.run(y_right[::-1], z)
    stop = n
    while stop > 0:
        start = max(0, stop - back_rows)
        out, z = filt.run(spill.read(start, stop)[::-1], z)
        spill.write(start, out[::-1])
        stop = start
    return spill


def gradient_rows(read: Callable[[int, int], np.ndarray], n: int, start: int, stop: int, T_s: float,
                  order: int = 1) -> list[np.ndarray]:  # fmt: skip
    """``np.gradient`` (``edge_order=1``) of a long signal, ``order`` times, at rows ``start:stop``.

    ``read(a, b)`` returns rows ``a:b`` of the signal (``(m, k)`` or ``(m,)``). Rows are read
    with ``order + 1`` rows of context on each side, so every returned value is computed from
    the same operands as ``np.gradient`` of the whole signal: bit-identical.

    Returns
    -------
    list of numpy.ndarray
        ``[x, x', x'', …]`` (``order + 1`` arrays) at rows ``start:stop``.
    """
    h = order + 1
    a, b = max(0, start - h), min(n, stop + h)
    x = read(a, b)
    outs = [x]
    for _ in range(order):
        x = np.gradient(x, T_s, axis=0, edge_order=1)
        outs.append(x)
    return [o[start - a : stop - a] for o in outs]
