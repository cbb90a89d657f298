"""NumPy/numba predictor of a loaded transmission-error model (never imports torch).

The loaded :class:`TEModel` packs each direction's arrays (geometric curve, network
weights with the standardisation folded into layer 1, bagged trees in a compact
depth-first layout) into two flat buffers that numba kernels evaluate.
Interface for the compensation (units!):

* ``TEModel.predict(x_T [m], torque [N·m], direction ±1) -> TE [m]`` (NumPy arrays,
  torque broadcast): TE = TE_geo(x_T) + [a + b·torque + TE_def(x_T, torque)]·1e-6, the
  absolute transmission error (1) of that flank, as ``x_T − θ_M d_p/(2 i_PG)``;
* ``TEModel.predict_def_um(...) -> TE_def [µm]`` — the offset-free learned deformation
  (stage 1 + stage 2), ``predict_stage1_um`` the network part alone;
* ``TEModel.predict_one(x_T, torque, direction) -> TE [m]`` (one point, float);
* ``TEModel.backlash(x_T, torque) -> TE_neg − TE_pos [m]`` (flank −1 at −|torque|, +1 at
  +|torque|, as ``TETable.backlash``);
* ``TEModel.kernel_arrays(direction) -> (fbuf float64, ibuf int64)`` — two flat arrays
  per direction that :func:`te_point` ``(x_T, torque, fbuf, ibuf) -> TE [m]`` and
  :func:`te_def_point` (µm) accept inside the caller's own ``@njit`` code.

``direction`` is the flank in contact: +1 moving in +x (positive torque), −1 in −x.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numba import njit, prange

from drivelash.errors import ParameterError
from drivelash.te.learn.preprocess import TEPipeline
from drivelash.te.runtime.table import check_direction

__all__ = ["SORT_MIN", "TEModel", "te_def_point", "te_point"]

_F_HDR = 8  # geo_x0, geo_step, d_p, eps, y_mean, y_scale, offset a [µm], offset b [µm/(N·m)]
_I_NAMES = (
    "n_t",
    "n_in",
    "hidden",
    "n_geo",
    "n_trees",
    "n_nodes",
    "o_geo",
    "o_xmean",
    "o_xscale",
    "o_W1",
    "o_b1",
    "o_W2",
    "o_b2",
    "o_W3",
    "o_b3",
    "o_nodes",
    "o_roots",
)
_I_HDR = len(_I_NAMES)
#: Batches at least this long are evaluated in position order (cache-friendly tree walks).
SORT_MIN = 4096


# ---------------------------------------------------------------------------
# numba kernels on the packed per-direction buffers
# ---------------------------------------------------------------------------
@njit(cache=True, inline="always")
def _child(k: int, w: int, xf: float, tf: float, fv: np.ndarray, o_nodes: int) -> int:  # pragma: no cover
    """Index of the child of node slot ``k`` (packed word ``w`` = 2·right + feature)."""
    v = xf if (w & 1) == 0 else tf
    return k + 2 if v <= fv[k] else o_nodes + 2 * (w >> 1)


@njit(cache=True)
def _def_um(
    x: float, torque: float, f: np.ndarray, ib: np.ndarray, z: np.ndarray, h1: np.ndarray, h2: np.ndarray
) -> float:  # pragma: no cover - njit
    n_t = ib[0]
    hid = ib[2]
    n_trees = ib[4]
    d_p = f[2]
    eps = f[3]
    # stage 1: layer 1 with the standardisation folded into W1/b1 at packing time
    # (W1s = W1/σ, b1s = b1 − Σ μ/σ·W1), so only torque and the ⌈ε⌉ teeth in mesh contribute
    o_W1 = ib[9]
    o_b1 = ib[10]
    for k in range(hid):
        h1[k] = f[o_b1 + k] + torque * f[o_W1 + k]
    u = x * n_t / (np.pi * d_p)
    fu = np.floor(u)
    for q in range(int(np.ceil(eps)) + 1):
        j1 = fu - q  # tooth number j (1-based) modulo n_t
        m = u - j1  # = mod(u − j, n_t) of eq (5), in [q, q + 1)
        eta = (2.0 / eps) * m - 1.0
        if -1.0 < eta < 1.0:
            e2 = eta * eta
            mj = np.exp(e2 / (e2 - 1.0))
            j0 = int(j1 - 1.0) % n_t  # 0-based tooth index
            row = o_W1 + (j0 + 1) * hid
            for k in range(hid):
                h1[k] += mj * f[row + k]
    for k in range(hid):
        v = h1[k]
        h1[k] = v if v > 0.0 else 0.0
    o_W2 = ib[11]
    o_b2 = ib[12]
    for k in range(hid):
        h2[k] = 0.0
    for i in range(hid):
        hi = h1[i]
        if hi == 0.0:
            continue
        row = o_W2 + i * hid
        for k in range(hid):
            h2[k] += hi * f[row + k]
    o_W3 = ib[13]
    acc = 0.0
    for k in range(hid):
        v = h2[k] + f[o_b2 + k]
        if v > 0.0:
            acc += v * f[o_W3 + k]
    y1 = (acc + f[ib[14]]) * f[5] + f[4]
    # stage 2: bagged trees on (x_T, torque); sklearn compares float32(X) <= threshold.
    # Compact depth-first layout, 16 bytes per node in ibuf: [threshold or leaf value (float64
    # bits), 2·right + feature (−1 for a leaf)]; the left child is the next node.
    o_nodes = ib[15]
    o_roots = ib[16]
    fv = ib.view(np.float64)
    xf = np.float64(np.float32(x))
    tf = np.float64(np.float32(torque))
    s = 0.0
    t = 0
    # four trees walked side by side: independent load chains overlap in the CPU
    while t + 4 <= n_trees:
        k0 = o_nodes + 2 * ib[o_roots + t]
        k1 = o_nodes + 2 * ib[o_roots + t + 1]
        k2 = o_nodes + 2 * ib[o_roots + t + 2]
        k3 = o_nodes + 2 * ib[o_roots + t + 3]
        w0 = ib[k0 + 1]
        w1 = ib[k1 + 1]
        w2 = ib[k2 + 1]
        w3 = ib[k3 + 1]
        while (w0 >= 0) or (w1 >= 0) or (w2 >= 0) or (w3 >= 0):
            if w0 >= 0:
                k0 = _child(k0, w0, xf, tf, fv, o_nodes)
                w0 = ib[k0 + 1]
            if w1 >= 0:
                k1 = _child(k1, w1, xf, tf, fv, o_nodes)
                w1 = ib[k1 + 1]
            if w2 >= 0:
                k2 = _child(k2, w2, xf, tf, fv, o_nodes)
                w2 = ib[k2 + 1]
            if w3 >= 0:
                k3 = _child(k3, w3, xf, tf, fv, o_nodes)
                w3 = ib[k3 + 1]
        s += fv[k0]
        s += fv[k1]
        s += fv[k2]
        s += fv[k3]
        t += 4
    while t < n_trees:
        k = o_nodes + 2 * ib[o_roots + t]
        w = ib[k + 1]
        while w >= 0:
            k = _child(k, w, xf, tf, fv, o_nodes)
            w = ib[k + 1]
        s += fv[k]
        t += 1
    if n_trees == 0:  # stage 1 only (see TEModel.predict_stage1_um)
        return y1
    return y1 + s / n_trees


@njit(cache=True)
def _geo(x: float, f: np.ndarray, ib: np.ndarray) -> float:  # pragma: no cover - njit
    n = ib[3]
    o = ib[6]
    x0 = f[0]
    step = f[1]
    u = (x - x0) / step
    if u <= 0.0:
        return f[o]
    if u >= n - 1:
        return f[o + n - 1]
    k = int(np.floor(u))
    if k >= n - 1:
        k = n - 2
    xk = x0 + step * k
    a = f[o + k]
    b = f[o + k + 1]
    return a + (b - a) / step * (x - xk)


@njit(cache=True)
def _geo_batch(x: np.ndarray, f: np.ndarray, ib: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    for k in range(x.size):
        out[k] = _geo(x[k], f, ib)


@njit(cache=True)
def te_def_point(x_T: float, torque: float, fbuf: np.ndarray, ibuf: np.ndarray) -> float:  # pragma: no cover
    """TE_def [µm] at one point (njit-callable; one direction).

    Parameters
    ----------
    x_T : float
        Table position [m].
    torque : float
        Motor torque [N·m].
    fbuf, ibuf : numpy.ndarray
        One direction's buffers (float64, int64) from :meth:`TEModel.kernel_arrays`.

    Returns
    -------
    float
        Offset-free learned deformation TE_def [µm] (stage 1 + stage 2).
    """
    n_in = ibuf[1]
    hid = ibuf[2]
    z = np.empty(n_in)
    h1 = np.empty(hid)
    h2 = np.empty(hid)
    return _def_um(x_T, torque, fbuf, ibuf, z, h1, h2)


@njit(cache=True)
def te_point(x_T: float, torque: float, fbuf: np.ndarray, ibuf: np.ndarray) -> float:  # pragma: no cover
    """Full TE [m] = TE_geo + offset(torque) + TE_def at one point (njit-callable; one direction).

    Parameters
    ----------
    x_T : float
        Table position [m].
    torque : float
        Motor torque [N·m].
    fbuf, ibuf : numpy.ndarray
        One direction's buffers (float64, int64) from :meth:`TEModel.kernel_arrays`.

    Returns
    -------
    float
        Transmission error [m]: TE_geo(x_T) + [a + b·torque + TE_def(x_T, torque)]·1e-6.
    """
    off = fbuf[6] + fbuf[7] * torque
    return _geo(x_T, fbuf, ibuf) + (off + te_def_point(x_T, torque, fbuf, ibuf)) / 1e6


@njit(cache=True, parallel=True)
def _batch(
    x: np.ndarray, tq: np.ndarray, f: np.ndarray, ib: np.ndarray, with_geo: bool, out: np.ndarray
) -> None:  # pragma: no cover - njit
    n = x.size
    n_in = ib[1]
    hid = ib[2]
    chunk = 4096
    n_chunks = (n + chunk - 1) // chunk
    for c in prange(n_chunks):
        z = np.empty(n_in)
        h1 = np.empty(hid)
        h2 = np.empty(hid)
        stop = min(n, (c + 1) * chunk)
        for i in range(c * chunk, stop):
            d = _def_um(x[i], tq[i], f, ib, z, h1, h2)
            if with_geo:
                out[i] = _geo(x[i], f, ib) + (f[6] + f[7] * tq[i] + d) / 1e6
            else:
                out[i] = d


# ---------------------------------------------------------------------------
# packing
# ---------------------------------------------------------------------------
def _pack(
    arrays: Mapping[str, np.ndarray],
    geo_x0: float,
    geo_step: float,
    geometry: Mapping[str, Any],
) -> tuple[np.ndarray, np.ndarray]:
    """Flatten one direction's arrays into the (fbuf, ibuf) layout of the kernels."""
    W1, b1, W2, b2, W3, b3 = (arrays[k] for k in ("W1", "b1", "W2", "b2", "W3", "b3"))
    n_in, hid = W1.shape
    mu, sd = arrays["x_mean"], arrays["x_scale"]
    W1 = W1 / sd[:, None]  # standardisation folded into layer 1
    b1 = b1 - (mu / sd) @ (W1 * sd[:, None])
    f_parts = [
        np.array(
            [
                geo_x0,
                geo_step,
                geometry["d_p"],
                geometry["eps"],
                float(arrays["y_mean"][0]),
                float(arrays["y_scale"][0]),
                float(arrays["offset"][0]),
                float(arrays["offset"][1]),
            ]
        ),
    ]
    offs: dict[str, int] = {}
    pos = _F_HDR
    for name, a in (
        ("o_geo", arrays["geo_te"]),
        ("o_xmean", arrays["x_mean"]),
        ("o_xscale", arrays["x_scale"]),
        ("o_W1", W1),
        ("o_b1", b1),
        ("o_W2", W2),
        ("o_b2", b2),
        ("o_W3", W3),
        ("o_b3", b3),
    ):
        offs[name] = pos
        flat = np.ascontiguousarray(a, dtype=np.float64).reshape(-1)
        f_parts.append(flat)
        pos += flat.size
    fbuf = np.concatenate(f_parts)
    n_nodes = arrays["threshold"].size
    i_parts: list[np.ndarray] = []
    ipos = _I_HDR
    for name, a in (
        ("o_nodes", _compact_nodes(arrays)),
        ("o_roots", arrays["roots"]),
    ):
        offs[name] = ipos
        flat = np.ascontiguousarray(a, dtype=np.int64).reshape(-1)
        i_parts.append(flat)
        ipos += flat.size
    hdr = {
        "n_t": int(geometry["n_t"]),
        "n_in": n_in,
        "hidden": hid,
        "n_geo": arrays["geo_te"].size,
        "n_trees": arrays["roots"].size,
        "n_nodes": n_nodes,
        **offs,
    }
    ibuf = np.concatenate([np.array([hdr[k] for k in _I_NAMES], dtype=np.int64), *i_parts])
    return fbuf, ibuf


def _compact_nodes(arrays: Mapping[str, np.ndarray]) -> np.ndarray:
    """Interleave the validated flat tree arrays into the kernel's 2-int64-per-node layout."""
    left = arrays["children_left"]
    leaf = left == -1
    nodes = np.empty(2 * left.size, dtype=np.int64)
    nodes[0::2] = np.where(leaf, arrays["value"], arrays["threshold"]).astype(np.float64).view(np.int64)
    nodes[1::2] = np.where(leaf, -1, 2 * arrays["children_right"] + arrays["feature"])
    return nodes


def _check_finite(x: np.ndarray, tq: np.ndarray) -> None:
    """Refuse NaN/inf positions or torques (one line naming the first; finding A12)."""
    for name, v in (("x_T", x), ("torque", tq)):
        bad = ~np.isfinite(v)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise ParameterError(
                "TEModel", name, f"value {k} is {float(v[k])!r}: positions and torques must be finite"
            )


# ---------------------------------------------------------------------------
# the loaded model
# ---------------------------------------------------------------------------
#: direction code of each per-direction key of ``model.json``
_SIGN = {"pos": 1, "neg": -1}


class TEModel:
    """A loaded transmission-error model: geometric curves + stacked deformation model per direction.

    Predicts with NumPy/numba only. Units: positions in metres, torque in N·m,
    ``predict``/``predict_one`` return TE in **metres**, ``predict_def_um`` returns
    TE_def in **micrometres**.

    Parameters
    ----------
    meta : dict
        Contents of ``model.json``.
    arrays : dict
        ``{"pos": {...}, "neg": {...}}`` of validated float64/int64 arrays.
    context : ModelContext, optional
        Axis, valid range, compensator settings and simulator of the model
        (:class:`drivelash.te.runtime.persist.ModelContext`), as loaded from ``model.json``.
    """

    def __init__(
        self, meta: dict[str, Any], arrays: dict[str, dict[str, np.ndarray]], context: Any = None
    ) -> None:
        self.meta = meta
        self.context = context
        self.pipeline = TEPipeline.from_dict(meta["pipeline"])
        self.directions = tuple(meta["directions"])
        self._buf: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for key in self.directions:
            dm = meta["models"][key]
            self._buf[key] = _pack(
                arrays[key], float(dm["geo_x0"]), float(dm["geo_step"]), meta["pipeline"]["geometry"]
            )
        #: the same buffers by direction code +1/−1 (what the methods are given)
        self._flank = {_SIGN[key]: buf for key, buf in self._buf.items()}
        #: no-load change of the te updates since the fit [m] on the geo grid (updated models only)
        self._noload_change = {
            _SIGN[key]: np.asarray(arrays[key]["noload_change"], dtype=np.float64)
            for key in self.directions
            if "noload_change" in arrays[key]
        }

    @property
    def info(self) -> dict[str, Any]:
        """The training record from ``model.json``."""
        return dict(self.meta.get("info", {}))

    def kernel_arrays(self, direction: int) -> tuple[np.ndarray, np.ndarray]:
        """``(fbuf float64, ibuf int64)`` of one direction for :func:`te_point` in njit code.

        Parameters
        ----------
        direction : int
            Flank in contact: +1 (moving in +x, positive torque) or −1; anything else is
            refused (:func:`~drivelash.te.runtime.table.check_direction`).

        Returns
        -------
        tuple of numpy.ndarray
            ``(fbuf, ibuf)``: the packed direction (positions in m, TE_geo in m, TE_def
            weights in µm), the model's own arrays — read them, do not write them.

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1, or the model has no such direction (one line).
        """
        d = check_direction(direction, "TEModel")
        buf = self._flank.get(d)
        if buf is None:
            have = " and ".join(f"{_SIGN[k]:+d}" for k in self.directions) or "none"
            raise ParameterError("TEModel", "direction", f"model has no direction {d:+d} (it has {have})")
        return buf

    def _run(self, x_T: Any, torque: Any, direction: int, with_geo: bool) -> np.ndarray:
        x = np.ascontiguousarray(np.asarray(x_T, dtype=np.float64).reshape(-1))
        tq = np.ascontiguousarray(np.broadcast_to(np.asarray(torque, dtype=np.float64), x.shape))
        f, ib = self.kernel_arrays(direction)
        _check_finite(x, tq)
        out = np.empty(x.size)
        if x.size >= SORT_MIN:
            # neighbouring positions walk the same tree paths: sorted, the nodes stay in cache
            order = np.argsort(x)
            tmp = np.empty(x.size)
            _batch(x[order], tq[order], f, ib, with_geo, tmp)
            out[order] = tmp
        else:
            _batch(x, tq, f, ib, with_geo, out)
        return out

    def predict(self, x_T: Any, torque: Any, direction: int, *, strict: bool = False) -> np.ndarray:
        """TE [m] = TE_geo(x_T) + TE_def(x_T, torque) for direction +1/−1 (torque broadcast to x_T).

        Parameters
        ----------
        x_T : array_like
            Table positions [m] (flattened).
        torque : array_like
            Motor torque [N·m], broadcast to ``x_T``.
        direction : int
            Flank in contact: +1 (moving in +x, positive torque) or −1; anything else is
            refused (:func:`~drivelash.te.runtime.table.check_direction`).
        strict : bool
            Also refuse positions outside the model's valid range (``context.valid_range``,
            :func:`~drivelash.te.runtime.table.measured_range`) and torques outside the flank's
            trained range (:func:`~drivelash.te.runtime.table.valid_torque_range`: flank +1
            [0, torque_max], flank −1 [−torque_max, 0], the range of the runtime table), where
            the model extrapolates (the runtime entry point; default False: evaluation code
            asks beyond the range on purpose).

        Returns
        -------
        numpy.ndarray
            Transmission error [m], 1-D, one per position: TE_geo + [a + b·torque + TE_def]·1e-6.

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1, or the model has no such direction; a position or
            torque that is NaN or infinite; with ``strict``, one outside the valid range (one
            line naming the first such value and the range).
        """
        if strict:
            self._check_valid(x_T, torque, direction)
        return self._run(x_T, torque, direction, True)

    def _check_valid(self, x_T: Any, torque: Any, direction: int) -> None:
        from drivelash.te.runtime.table import TORQUE_RTOL, measured_range, valid_torque_range

        x = np.asarray(x_T, dtype=np.float64).reshape(-1)
        tq = np.broadcast_to(np.asarray(torque, dtype=np.float64), x.shape)
        _check_finite(x, tq)
        lo, hi = measured_range(self)
        out = np.flatnonzero((x < lo - 1e-9) | (x > hi + 1e-9))
        if out.size:
            raise ParameterError(
                "TEModel.predict",
                "x_T",
                f"{x[out[0]]:.6g} m is outside the model's valid range [{lo:.6g}, {hi:.6g}] m"
                f" = [{lo * 1e3:.3f}, {hi * 1e3:.3f}] mm (x_T is in m)",
            )
        d = check_direction(direction, "TEModel")
        rng = valid_torque_range(self, d)
        if rng is not None:
            # per flank, as the runtime table spans it (flank_torques): +1 [0, T_max], −1 [−T_max, 0]
            t_lo, t_hi = rng
            slack = TORQUE_RTOL * max(abs(t_lo), abs(t_hi))
            bad = np.flatnonzero((tq < t_lo - slack) | (tq > t_hi + slack))
            if bad.size:
                o_lo, o_hi = valid_torque_range(self, -d) or rng
                raise ParameterError(
                    "TEModel.predict",
                    "torque",
                    f"{tq[bad[0]]:.6g} N·m is outside the model's valid torque range of flank {d:+d},"
                    f" [{t_lo:.6g}, {t_hi:.6g}] N·m (flank {-d:+d}: [{o_lo:.6g}, {o_hi:.6g}] N·m; its"
                    " training runs, the motor torque has the sign of the flank in contact): the model"
                    " would extrapolate",
                )

    def predict_def_um(self, x_T: Any, torque: Any, direction: int) -> np.ndarray:
        """Deformation TE_def [µm] (stage 1 + stage 2), without TE_geo and the offset line.

        Parameters
        ----------
        x_T : array_like
            Table positions [m] (flattened).
        torque : array_like
            Motor torque [N·m], broadcast to ``x_T``.
        direction : int
            Flank in contact: +1 (moving in +x, positive torque) or −1; anything else is
            refused (:func:`~drivelash.te.runtime.table.check_direction`).

        Returns
        -------
        numpy.ndarray
            Offset-free learned deformation TE_def [µm], 1-D, one per position.

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1, or the model has no such direction (one line).
        """
        return self._run(x_T, torque, direction, False)

    def predict_stage1_um(self, x_T: Any, torque: Any, direction: int) -> np.ndarray:
        """Stage-1 (network) part of TE_def [µm] alone.

        Parameters
        ----------
        x_T : array_like
            Table positions [m] (flattened).
        torque : array_like
            Motor torque [N·m], broadcast to ``x_T``.
        direction : int
            Flank in contact: +1 (moving in +x, positive torque) or −1; anything else is
            refused (:func:`~drivelash.te.runtime.table.check_direction`).

        Returns
        -------
        numpy.ndarray
            The network's TE_def [µm] (no trees), 1-D, one per position.

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1, or the model has no such direction (one line).
        """
        f, ib = self.kernel_arrays(direction)
        ib1 = ib.copy()
        ib1[4] = 0  # no trees
        x = np.ascontiguousarray(np.asarray(x_T, dtype=np.float64).reshape(-1))
        tq = np.ascontiguousarray(np.broadcast_to(np.asarray(torque, dtype=np.float64), x.shape))
        out = np.empty(x.size)
        _batch(x, tq, f, ib1, False, out)
        return out

    def predict_one(self, x_T: float, torque: float, direction: int) -> float:
        """TE [m] at one operating point (the per-cycle call: O(1) direction check).

        Parameters
        ----------
        x_T : float
            Table position [m].
        torque : float
            Motor torque [N·m].
        direction : int
            Flank in contact: +1 (moving in +x, positive torque) or −1; anything else is
            refused (:func:`~drivelash.te.runtime.table.check_direction`).

        Returns
        -------
        float
            Transmission error [m], as :meth:`predict` at that point.

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1, or the model has no such direction (one line).
        """
        # per-cycle call: a plain int ±1 takes one dict look-up, anything else the full check
        buf = self._flank.get(direction) if direction.__class__ is int else None
        f, ib = buf if buf is not None else self.kernel_arrays(direction)
        return te_point(float(x_T), float(torque), f, ib)

    def geometric(self, x_T: Any, direction: int) -> np.ndarray:
        """The geometric (no-load) error TE_geo [m] of a direction at ``x_T`` [m]: the lookup table
        of the no-load runs (linear interpolation, held at its edges; see :meth:`geometric_range`).

        Parameters
        ----------
        x_T : array_like
            Table positions [m] (flattened).
        direction : int
            Flank in contact: +1 (moving in +x, positive torque) or −1; anything else is
            refused (:func:`~drivelash.te.runtime.table.check_direction`).

        Returns
        -------
        numpy.ndarray
            TE_geo [m], 1-D, one per position.

        Raises
        ------
        ParameterError
            ``direction`` is not +1 or −1, or the model has no such direction (one line).
        """
        f, ib = self.kernel_arrays(direction)
        x = np.ascontiguousarray(np.asarray(x_T, dtype=np.float64).reshape(-1))
        out = np.empty(x.size)
        _geo_batch(x, f, ib, out)
        return out

    def noload_change(self, x_T: Any, direction: int) -> np.ndarray | None:
        """What ``te update`` changed in the no-load TE since the fit [m], or None (never updated).

        The change of the model's own prediction at the no-load torque (new minus parent,
        accumulated over the updates; zero outside the travel of the update passes), stored on
        the grid of the no-load curve and interpolated linearly like it.

        Parameters
        ----------
        x_T : array_like
            Table positions [m] (flattened).
        direction : int
            Flank in contact: +1 or −1.

        Returns
        -------
        numpy.ndarray or None
            Change [m], 1-D, one per position; None for a model that was never updated.
        """
        f, ib = self.kernel_arrays(direction)
        change = self._noload_change.get(check_direction(direction, "TEModel"))
        if change is None:
            return None
        x = np.asarray(x_T, dtype=np.float64).reshape(-1)
        grid = float(f[0]) + float(f[1]) * np.arange(change.size)
        return np.interp(x, grid, change)

    def noload(self, x_T: Any, direction: int) -> np.ndarray:
        """The no-load TE [m] the CNC tables hold: TE_geo plus the updates' change (:meth:`noload_change`).

        For a model that was never updated this is :meth:`geometric`, bit for bit.

        Parameters
        ----------
        x_T : array_like
            Table positions [m] (flattened).
        direction : int
            Flank in contact: +1 or −1.

        Returns
        -------
        numpy.ndarray
            No-load TE [m], 1-D, one per position.
        """
        geo = self.geometric(x_T, direction)
        change = self.noload_change(x_T, direction)
        return geo if change is None else geo + change

    def geometric_range(self) -> tuple[float, float]:
        """Positions [m] where every direction's no-load curve holds measured data (x_min, x_max).

        Returns
        -------
        tuple of float
            ``(x_min, x_max)`` [m]: the intersection of the directions' no-load curve spans.
        """
        lo, hi = -np.inf, np.inf
        for key in self.directions:
            f, ib = self._buf[key]
            lo = max(lo, float(f[0]))
            hi = min(hi, float(f[0] + f[1] * (ib[3] - 1)))
        return lo, hi

    def backlash(self, x_T: Any, torque: Any = 0.0) -> np.ndarray:
        """Gap between the direction curves TE_neg − TE_pos [m] at ``x_T``, at equal torque
        magnitude: each flank at the sign of torque it carries, as
        :meth:`~drivelash.te.runtime.table.TETable.backlash`.

        Parameters
        ----------
        x_T : array_like
            Table positions [m] (flattened).
        torque : array_like
            Motor torque magnitude [N·m], broadcast to ``x_T``: −|torque| on flank −1,
            +|torque| on flank +1 (the load acts against the motion, so the motor torque has
            the sign of the flank; a signed value is taken by its magnitude).

        Returns
        -------
        numpy.ndarray
            Backlash TE(−1, −|torque|) − TE(+1, +|torque|) [m], 1-D, one per position.
        """
        magnitude = np.abs(np.asarray(torque, dtype=np.float64))
        return self.predict(x_T, -magnitude, -1) - self.predict(x_T, magnitude, +1)
