"""Synthetic ISO 230-2 tests of an axis with known lost motion, pitch error and noise.

Two forms, both with the truth attached:

- :func:`synthetic_table` — the approaches directly:
  x_ij↑ = e(P_i) − δ/2 + ε_ij↑,  x_ij↓ = e(P_i) + δ/2 + ε_ij↓, ε ~ N(0, σ²), so the true
  reversal value is B_i = −δ at every target (the load lags the motor by half the gap
  in the direction of motion) and the true axis reversal value is δ.
- :func:`synthetic_recording` — a raw time series of the standard test cycle: trapezoid
  moves between the targets with an overshoot at each end of a run, a dwell at every
  target, a second-order servo response of the motor (settling), a play operator of
  width δ between motor and load, the pitch error of the load position, a per-approach
  stopping scatter, a slow drift of the reference and white measurement noise.

The pitch error e(x) is a linear (cumulative lead) error plus a periodic one, which
the standard's non-uniform target spacing is meant to sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = ["SyntheticAxis", "iso_targets", "synthetic_recording", "synthetic_table"]


@dataclass(frozen=True)
class SyntheticAxis:
    """A linear axis for synthetic tests (SI units).

    Parameters
    ----------
    travel : float
        Measured travel [m].
    delta : float
        Lost motion (deadzone at the load) [m].
    slope : float
        Cumulative lead error [m/m].
    pitch_amp : float
        Amplitude of the periodic pitch error [m].
    pitch_period : float
        Its period (e.g. the screw lead) [m].
    sigma : float
        Run-to-run scatter of the stopping position, per approach [m].
    """

    travel: float = 0.5
    delta: float = 12e-6
    slope: float = 20e-6
    pitch_amp: float = 3e-6
    pitch_period: float = 0.02
    sigma: float = 0.8e-6

    def pitch(self, x: np.ndarray) -> np.ndarray:
        """Positional error of the load at position ``x`` [m]."""
        return self.slope * x + self.pitch_amp * np.sin(2 * math.pi * x / self.pitch_period)


def iso_targets(travel: float, m: int, rng: np.random.Generator) -> np.ndarray:
    """Target positions P_i = (i−1)·p + r_i with p = travel/(m−1) and random r_i.

    ISO 230-2 spaces the targets non-uniformly so that periodic errors are sampled;
    r_i is drawn uniformly in ±p/5 for the inner targets, the end targets stay at
    0 and ``travel`` [m].
    """
    p = travel / (m - 1)
    P = np.arange(m) * p
    P[1:-1] += rng.uniform(-p / 5, p / 5, m - 2)
    return P


def synthetic_table(axis: SyntheticAxis, m: int = 11, n: int = 5, seed: int = 0) -> dict[str, np.ndarray]:
    """Approach table of an ISO test: columns P_target, run, direction, x_dev (SI).

    Parameters
    ----------
    axis : SyntheticAxis
    m : int
        Number of targets.
    n : int
        Runs per direction.
    seed : int
        Random seed (targets and scatter).
    """
    rng = np.random.default_rng(seed)
    P = iso_targets(axis.travel, m, rng)
    rows = []
    for j in range(1, n + 1):
        for sign in (1, -1):
            eps = rng.normal(0.0, axis.sigma, m)
            x = axis.pitch(P) - sign * axis.delta / 2 + eps
            for i in range(m):
                rows.append((P[i], j, sign, x[i]))
    a = np.array(rows)
    return {"P_target": a[:, 0], "run": a[:, 1], "direction": a[:, 2], "x_dev": a[:, 3]}


@njit(cache=True)
def _servo_play(
    u: np.ndarray, omega: float, T_s: float, h: float
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - numba
    """Motor and load positions for the command ``u`` (held over each sample).

    Motor: critically damped second-order response ẍ = ω²(u − x) − 2ωẋ, integrated exactly
    over a sample with Φ = e^{−ωT}[[1+ωT, T], [−ω²T, 1−ωT]] around the equilibrium (u, 0).
    Load: play (backlash) operator of half-width ``h``, dragged by the nearer flank.
    """
    e = np.exp(-omega * T_s)
    p11, p12 = e * (1 + omega * T_s), e * T_s
    p21, p22 = -e * omega * omega * T_s, e * (1 - omega * T_s)
    motor = np.empty_like(u)
    load = np.empty_like(u)
    x, v = u[0], 0.0
    y = x - h
    for k in range(u.size):
        motor[k] = x
        y = min(max(y, x - h), x + h)
        load[k] = y
        d = x - u[k]
        x, v = u[k] + p11 * d + p12 * v, p21 * d + p22 * v
    return motor, load


def _move(x0: float, x1: float, v: float, acc: float, T_s: float) -> np.ndarray:
    """Positions of a trapezoidal (or triangular) move from x0 to x1, sampled at T_s."""
    d = abs(x1 - x0)
    if d == 0:
        return np.empty(0)
    t_acc = v / acc
    if acc * t_acc**2 > d:  # triangular
        t_acc = math.sqrt(d / acc)
        v = acc * t_acc
    t_flat = (d - acc * t_acc**2) / v
    T = 2 * t_acc + t_flat
    t = np.arange(1, int(math.ceil(T / T_s)) + 1) * T_s
    t = np.minimum(t, T)
    s = np.where(
        t < t_acc,
        0.5 * acc * t**2,
        np.where(
            t < t_acc + t_flat,
            0.5 * acc * t_acc**2 + v * (t - t_acc),
            d - 0.5 * acc * np.maximum(T - t, 0.0) ** 2,
        ),
    )
    return x0 + math.copysign(1.0, x1 - x0) * s


def synthetic_recording(
    axis: SyntheticAxis,
    m: int = 21,
    n: int = 5,
    seed: int = 0,
    *,
    T_s: float = 1e-3,
    feed: float = 0.2,
    acc: float = 2.0,
    dwell: float = 1.0,
    overshoot: float = 0.005,
    omega_servo: float = 60.0,
    drift: float = 2e-8,
    noise: float = 0.3e-6,
    skip: tuple[tuple[int, int, int], ...] = (),
    overrun_dwell: bool = False,
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """A raw recording of the ISO 230-2 standard test cycle, and its truth.

    Parameters
    ----------
    axis : SyntheticAxis
    m, n : int
        Targets and runs per direction.
    seed : int
        Random seed.
    T_s : float
        Sample period [s].
    feed, acc : float
        Feed speed [m/s] and acceleration [m/s²] of the moves.
    dwell : float
        Dwell at each target [s].
    overshoot : float
        Overtravel beyond the end targets before each reversal [m].
    omega_servo : float
        Natural frequency of the motor's critically damped response to the command
        [rad/s]; its impulse response is positive, so the motor never overshoots a target
        (an overshoot would make the last approach come from the other side).
    drift : float
        Drift rate of the reference measurement (thermal) [m/s].
    noise : float
        White noise of the reference measurement per sample [m].
    skip : tuple of (target index, direction, run)
        Approaches whose dwell is left out (the axis passes through), for tests of
        refused recordings.
    overrun_dwell : bool
        Also dwell at each overrun (reversal) point beyond the end targets, as some CNC test
        programs do (not an approach: the evaluation must skip it).

    Returns
    -------
    columns : dict
        ``t``, ``P_cmd``, ``P_actual`` (reference), ``P_axis`` (motor encoder) [s, m].
    truth : dict
        Per approach: ``P_target``, ``direction``, ``run``, ``t_dwell`` (start of the
        dwell), ``x_dev`` (noise-free deviation of the load at the end of the dwell).
    """
    rng = np.random.default_rng(seed)
    P = iso_targets(axis.travel, m, rng)
    skip_set = set(skip)
    pieces: list[np.ndarray] = []
    offsets: list[np.ndarray] = []
    marks: list[tuple[int, int, int, int, int]] = []  # (start sample, length, i, direction, run)
    x = P[0] - overshoot
    rest = int(round(dwell / T_s))
    pieces.append(np.full(rest, x))  # start at rest below the first target
    offsets.append(np.zeros(rest))
    count = rest
    for j in range(1, n + 1):
        for sign, order in ((1, range(m)), (-1, range(m - 1, -1, -1))):
            start = P[0] - overshoot if sign > 0 else P[-1] + overshoot
            seg = _move(x, start, feed, acc, T_s)
            pieces.append(seg)
            offsets.append(np.zeros(seg.size))
            count += seg.size
            x = start
            if overrun_dwell:
                pieces.append(np.full(rest, x))
                offsets.append(np.zeros(rest))
                count += rest
            for i in order:
                seg = _move(x, P[i], feed, acc, T_s)
                eps = rng.normal(0.0, axis.sigma)
                pieces.append(seg)
                offsets.append(np.full(seg.size, eps))
                count += seg.size
                x = P[i]
                if (i, sign, j) in skip_set:
                    continue
                pieces.append(np.full(rest, x))
                offsets.append(np.full(rest, eps))
                marks.append((count, rest, i, sign, j))
                count += rest
    end = _move(x, P[0] - overshoot, feed, acc, T_s)
    pieces += [end, np.full(rest, P[0] - overshoot)]
    offsets += [np.zeros(end.size), np.zeros(rest)]
    P_cmd = np.concatenate(pieces)
    eps = np.concatenate(offsets)
    t = np.arange(P_cmd.size) * T_s
    # motor: servo response to the command plus the stopping scatter; load behind the play
    motor, load = _servo_play(P_cmd + eps, omega_servo, T_s, axis.delta / 2)
    err = axis.pitch(load)
    ref = load + err + drift * t + rng.normal(0.0, noise, t.size)
    truth_rows = []
    for s0, length, i, sign, j in marks:
        k = s0 + length - 1
        truth_rows.append((P[i], sign, j, t[s0], load[k] + err[k] + drift * t[k] - P[i]))
    tr = np.array(truth_rows)
    truth = {
        "P_target": tr[:, 0],
        "direction": tr[:, 1],
        "run": tr[:, 2],
        "t_dwell": tr[:, 3],
        "x_dev": tr[:, 4],
        "targets": P,
    }
    return {"t": t, "P_cmd": P_cmd, "P_actual": ref, "P_axis": motor}, truth
