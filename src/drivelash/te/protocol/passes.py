"""One trajectory on the virtual bench with the compensator in the loop, and its scoring.

The compensator runs every t_s,c = 5 ms (40 control samples): it sees the set
positions x_d at the cycle start and one cycle ahead (look-ahead), and the mean motor
torque, the motor velocity and acceleration of the previous cycle; its v_c is held
for the cycle and subtracted from the velocity command (:mod:`drivelash.sim.rack_axis`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drivelash.errors import ParameterError
from drivelash.te.protocol.monitoring import section_mae
from drivelash.te.runtime.compensator import Compensator

__all__ = ["pass_range", "pass_trajectory", "run_pass", "score_pass"]


def run_pass(
    sim: Any,
    x_d: np.ndarray,
    v_d: np.ndarray,
    F_load: float,
    compensator: Compensator | None,
    decimate: int = 1,
) -> dict[str, np.ndarray]:
    """Simulate one trajectory on the axis, with the compensator every t_s,c (or without).

    Parameters
    ----------
    sim : RackAxisSimulator
        The virtual bench.
    x_d, v_d : numpy.ndarray
        Set position [m] and velocity [m/s] at the control rate.
    F_load : float
        Process load [N].
    compensator : Compensator or None
        None runs the uncompensated reference.
    decimate : int
        Keep every ``decimate``-th sample in the result.

    Returns
    -------
    dict of numpy.ndarray
        ``t, x_d, v_d, x_T, theta_m, omega_m, torque_m, e`` (= x_d − x_T), ``v_c``, ``v_te``,
        ``v_bl``, ``flank``, ``tq_model`` (the compensator's model torque) and ``outside``
        (1 where the compensator's set positions left its table and it held the edge value,
        :attr:`~drivelash.te.runtime.compensator.Compensator.cycles_outside`; else 0) per sample.

    Raises
    ------
    ParameterError
        The compensator's ``t_sc`` is not a whole number of control periods.
    """
    T_s = float(sim.T_s)
    t_sc = compensator.params.t_sc if compensator is not None else 5e-3
    nc = int(round(t_sc / T_s))
    if abs(nc * T_s - t_sc) > 1e-9 * t_sc:
        raise ParameterError("CompensatorParams", "t_sc", "must be a whole number of control periods")
    n = (x_d.size // nc) * nc
    nz = np.flatnonzero(np.abs(v_d) > 1e-9)
    d0 = int(np.sign(v_d[nz[0]])) if nz.size else 1
    state = sim.initial_state(float(x_d[0]), d0)  # at rest the load force is zero (tanh(v_d))
    if compensator is not None:
        compensator.reset(d0)
    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("t", "x_T", "theta_m", "omega_m", "torque_m")}
    vc_c = np.zeros(n // nc)
    vte_c = np.zeros(n // nc)
    vbl_c = np.zeros(n // nc)
    fl_c = np.zeros(n // nc)
    tqm_c = np.zeros(n // nc)
    out_c = np.zeros(n // nc)
    tq = om = al = 0.0
    # at rest on the starting flank before the pass: torque = friction-free holding torque
    for k in range(n // nc):
        a, b = k * nc, (k + 1) * nc
        vc = 0.0
        if compensator is not None:
            x_next = x_d[b] if b < x_d.size else x_d[-1]
            vc, vte_c[k], vbl_c[k] = compensator.step(x_d[a], x_next, tq, om, al)
            fl_c[k] = compensator.flank
            out_c[k] = compensator.cycles_outside
            tqm_c[k] = tq - compensator.params.J_model * al
        vc_c[k] = vc
        state, out = sim.step_chunk(state, x_d[a:b], v_d[a:b], F_load, vc)
        w = out["omega_m"]
        tq = float(np.mean(out["torque_m"]))
        om = float(w[-1])
        al = float((w[-1] - w[0]) / ((nc - 1) * T_s))
        for c in cols:
            cols[c].append(out[c])
    res = {c: np.concatenate(v) for c, v in cols.items()}
    res["x_d"] = np.asarray(x_d[:n], dtype=np.float64)
    res["v_d"] = np.asarray(v_d[:n], dtype=np.float64)
    res["e"] = res["x_d"] - res["x_T"]
    out_c = np.diff(out_c, prepend=0.0)  # the running count -> 1 for each cycle outside the table
    cycles = (("v_c", vc_c), ("v_te", vte_c), ("v_bl", vbl_c), ("flank", fl_c), ("tq_model", tqm_c),
              ("outside", out_c))  # fmt: skip
    for name, arr in cycles:
        res[name] = np.repeat(arr, nc)
    sl = slice(None, None, max(1, int(decimate)))
    return {k: v[sl] for k, v in res.items()}


def pass_range(sim: Any, cfg: Any) -> tuple[float, float]:
    """Travel range [m] of the passes: [margin, travel − margin] ∩ ``cfg.x_range``, cut to ``stroke``.

    ``cfg`` is a :class:`~drivelash.te.protocol.bench.ValidationConfig`.
    """
    from drivelash.te.protocol.bench import _pass_bounds

    return _pass_bounds(float(sim.bench.travel), cfg)


def pass_trajectory(sim: Any, lo: float, hi: float, v: float, direction: int, a_max: float = 0.5):
    """(t, x_d, v_d) of a constant-velocity pass over [lo, hi] in ``direction``."""
    from drivelash.sim.rack_axis import constant_velocity_pass

    a, b = (lo, hi) if direction > 0 else (hi, lo)
    return constant_velocity_pass(a, b, v, sim.T_s, a_max)


def score_pass(
    unc: dict[str, np.ndarray], comp: dict[str, np.ndarray], v: float, edges: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Path-error MAE per section [m] of the constant-velocity part, without and with compensation."""
    out = []
    for r in (unc, comp):
        m = np.abs(np.abs(r["v_d"]) - v) < 1e-9 * max(v, 1.0)
        out.append(section_mae(r["x_T"][m], r["e"][m], edges, min_count=10))
    return out[0], out[1]
