"""Fill numba's on-disk cache before ``make test`` starts its workers (session 33).

On a clean clone every pytest worker — and every CLI process a test starts before a kernel is
cached — compiles the same ``@njit(cache=True)`` kernels: the two-law estimator kernel alone takes
≈ 19 s, the kernels of the fast suite ≈ 85 s of one core (measured with a ``numba:compile`` event
listener, docs/assumptions.md "Test-suite set-up and time"). Two processes here compile the two
largest groups once, side by side, through the same public entry points the tests call (so the
same type signatures), and every later process loads them from ``NUMBA_CACHE_DIR``.

Nothing is asserted: a failure here is printed and the tests run anyway (they compile what is
missing). Run as ``python tests/warm_numba_cache.py``.
"""

from __future__ import annotations

import sys
import tempfile
import time
import traceback
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _trace_file(d: str) -> Path:
    """1 s of bench-0C written as Parquet (the simulator's kernels on the way)."""
    from drivelash.sim import get_scenario

    pq = Path(d) / "run.parquet"
    get_scenario("bench-0C").simulate(duration=1.0, seed=1).to_parquet(pq)
    return pq


def _default_law() -> str:
    """The default (two-law) online estimator through the loader: its kernel alone ≈ 19 s cold."""
    import drivelash as dl

    with tempfile.TemporaryDirectory() as d:
        dl.estimate_backlash(_trace_file(d), str(REPO / "examples" / "drive_bench.toml"))
    return "default law"


def _the_rest() -> str:
    """The paper's law, the two-mass identification and the rack-and-pinion axis simulator."""
    import drivelash as dl
    from drivelash.physics.rack_pinion import RackPinionBench, TransmissionErrorModel
    from drivelash.sim.rack_axis import RackAxisSimulator, constant_velocity_pass

    with tempfile.TemporaryDirectory() as d:
        pq = _trace_file(d)
        dl.estimate_backlash(pq, str(REPO / "examples" / "drive_bench.toml"), method="paper")
        dl.identify_drive(pq, model="two-mass", N=1.0)
    bench = RackPinionBench()
    _, xd, vd = constant_velocity_pass(0.2, 0.25, 0.05)
    RackAxisSimulator(bench, TransmissionErrorModel.generate(bench, seed=1)).run(xd, vd, 1000.0)
    return "paper law, identification, rack axis"


def _guarded(fn) -> str:
    try:
        return fn()
    except Exception:  # a warm-up never fails the run: the tests compile what is missing
        return f"{fn.__name__} failed (the tests will compile it):\n{traceback.format_exc()}"


def main() -> int:
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        done = list(pool.map(_guarded, (_default_law, _the_rest)))
    print(f"numba cache warmed ({', '.join(done)}) in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
