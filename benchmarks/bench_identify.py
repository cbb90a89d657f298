"""Speed of the two-mass identification on a 60 s, 8 kHz recording (issue 11: ≤ 10 s on one core).

Recording: 60 s of ``bench-0B`` (480 000 samples, 11-bit encoders, noisy velocities).

Compared in one run, on the same preprocessed window data and from the same start values:

* **ours**: :func:`~drivelash.estimation.identify_two_mass.fit_two_mass` — the deadzone
  window terms in an ``@njit`` kernel, analytic Jacobian, ``scipy.optimize.least_squares``
  (Levenberg–Marquardt), two weighted passes and the HAC covariance;
* **baseline** (what a competent user writes first): ``scipy.optimize.least_squares`` with its
  default trust-region method and finite-difference Jacobian on the same residual written in
  plain NumPy (``np.minimum``/``np.maximum`` on all samples, reshape-and-mean per window),
  same two weighted passes. It must reach the same solution: the parameters are compared.

The end-to-end time of :func:`identify_two_mass` (preprocessing, position fusion, contact
grid, fits, verdict) is printed as well — that is the figure the 10 s goal is about.
Times are CPU time of this process (``time.process_time``) with every library limited to one
thread; wall time and the load average are printed because other jobs may share the machine.

Run: ``make bench`` or ``.venv/bin/python benchmarks/bench_identify.py``.
"""

from __future__ import annotations

import os

for _v in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"

import importlib  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from drivelash.sim.scenarios import get_scenario  # noqa: E402

# the module, not the function of the same name that drivelash.estimation exports
itm = importlib.import_module("drivelash.estimation.identify_two_mass")

DURATION_S = 60.0
GOAL_S = 10.0


def baseline_fit(data: itm.WindowData, start: itm.GridStart) -> np.ndarray:
    """Plain NumPy residual, finite-difference Jacobian, default ``least_squares`` (trf)."""
    M, nw, N = data.M, data.n_win, data.N
    dth = data.dth
    dw_int = data.dw.reshape(nw, M)[:, 1:]
    im, il = np.flatnonzero(data.ok_m), np.flatnonzero(data.ok_l)

    def model(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        J_m, J_l, K_S, D_S, T_Cm, b_m, T_Cl, b_l, u0, c_lo, c_hi = p
        dz = np.minimum(dth - c_lo, 0.0) + np.maximum(dth - c_hi, 0.0)
        contact = (dz != 0.0).reshape(nw, M)[:, 1:]
        T = K_S * dz.reshape(nw, M).mean(axis=1) + D_S * (dw_int * contact).mean(axis=1)
        am = (data.U - u0 - b_m * data.WM - T_Cm * data.SM - T / N) / J_m
        al = (T - b_l * data.WL - T_Cl * data.SL) / J_l
        return am, al

    w = np.ones(2)

    def residuals(p: np.ndarray) -> np.ndarray:
        am, al = model(p)
        return np.concatenate([w[0] * (data.a_m - am)[im], w[1] * (data.a_l - al)[il]])

    x = np.array(start.x0[: itm.I_TAU], dtype=float)
    for _ in range(2):
        am, al = model(x)
        w[:] = 1.0 / np.std((data.a_m - am)[im]), 1.0 / np.std((data.a_l - al)[il])
        x = least_squares(residuals, x, x_scale="jac").x
    return x


def main() -> None:
    sc = get_scenario("bench-0B")
    trace = sc.simulate(duration=DURATION_S)
    n = len(trace)
    # warm-up (numba compilation / cache load) on a short slice
    itm.identify_two_mass(trace.slice(0, 80_000), 1.0)

    c0, w0 = time.process_time(), time.perf_counter()
    result = itm.identify_two_mass(trace, 1.0)
    cpu_total, wall_total = time.process_time() - c0, time.perf_counter() - w0

    data = itm.window_data(trace, 1.0)
    start = itm.grid_start(data)
    c0 = time.process_time()
    fit = itm.fit_two_mass(data, start=start)
    cpu_fit = time.process_time() - c0
    c0, w0 = time.process_time(), time.perf_counter()
    x_base = baseline_fit(data, start)
    cpu_base, wall_base = time.process_time() - c0, time.perf_counter() - w0

    ours = fit.p[: itm.I_TAU]
    rel = np.abs(x_base - ours) / np.maximum(np.abs(ours), 1e-12)
    names = itm.PARAM_NAMES[: itm.I_TAU]
    worst = int(np.argmax(rel))
    print(f"two-mass identification, {n} samples ({DURATION_S:.0f} s at {1 / trace.T_s:.0f} Hz), one thread")
    print(f"  load average: {os.getloadavg()[0]:.1f}")
    print(
        f"  identify_two_mass end to end: {cpu_total:.2f} s CPU ({wall_total:.2f} s wall); "
        f"goal ≤ {GOAL_S:.0f} s on one core: {'met' if cpu_total <= GOAL_S else 'MISSED'}"
    )
    print(f"  fit stage (ours, njit + analytic Jacobian): {cpu_fit:.2f} s CPU")
    print(
        "  baseline (least_squares, NumPy residual, 2-point Jacobian): "
        f"{cpu_base:.2f} s CPU ({wall_base:.2f} s wall)"
    )
    print(f"  ratio baseline / ours (fit stage, CPU): {cpu_base / cpu_fit:.1f}x")
    print(f"  same solution: largest relative difference {rel[worst]:.2e} ({names[worst]})")
    d = result["delta"]
    print(f"  δ = {1e3 * d.value:.4f} mrad, 95 % CI [{1e3 * d.low:.4f}, {1e3 * d.high:.4f}] (true 186.0)")


if __name__ == "__main__":
    main()
