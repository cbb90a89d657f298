"""Parameter-mismatch sweep of the online estimator (issue 11 item 3): the table of figures.

Each drive is estimated with its parameters stated as in :data:`MISMATCH` (each of K_S, J_l,
D_S, T_Cl ×0.5 / ×2, friction ×3, singly and combined), with the default and the paper law.
A row fails the acceptance rule when δ̂ is off by more than 2 mrad *and* claimed converged,
or the default law is converged and worse than the paper law by more than 1 mrad.

Sources of drives:

* ``bench``: bench-0A/0B/0C of the project's simulator (60 s, 8 kHz);
* ``random SEED``: the 12 random drives of ``test_generalisation.py`` for that seed (project
  simulator, 40 s, 8 kHz);
* ``independent SEED``: 12 random drives drawn the same way but simulated by the independent
  simulator (tests/estimation/independent.py; 20 s at 2 kHz).

Regenerate (from the repository root; each source is a separate process)::

    .venv/bin/python tests/estimation/mismatch_sweep.py bench > sweep_bench.md
    .venv/bin/python tests/estimation/mismatch_sweep.py independent 0 > sweep_ind0.md
    .venv/bin/python tests/estimation/mismatch_sweep.py random 0 > sweep_rnd0.md
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

if __package__ in (None, ""):  # run as a script
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from estimation.independent import IndependentDrive, draw_plant, simulate_independent  # type: ignore[no-redef]
    from estimation.test_generalisation import random_drive  # type: ignore[no-redef]
    from estimation.test_robustness import MISMATCH  # type: ignore[no-redef]
else:
    from .independent import IndependentDrive, draw_plant, simulate_independent
    from .test_generalisation import random_drive
    from .test_robustness import MISMATCH

from drivelash.estimation.estimator import DeadzoneEstimator
from drivelash.params import DrivetrainParams


@dataclass
class Row:
    drive: str
    case: str
    err: float
    std: float
    converged: bool
    flag: str
    err_paper: float
    converged_paper: bool

    @property
    def confidently_wrong(self) -> bool:
        return self.converged and abs(self.err) > 2e-3

    @property
    def worse_than_paper(self) -> bool:
        return self.converged and abs(self.err) > abs(self.err_paper) + 1e-3

    @property
    def paper_confidently_wrong(self) -> bool:
        return self.converged_paper and abs(self.err_paper) > 2e-3


def _scaled(d: DrivetrainParams, scale: dict[str, float]) -> DrivetrainParams:
    return replace(d, **{k: getattr(d, k) * v for k, v in scale.items()})


def independent_drives(
    seed: int, n: int = 12
) -> Iterator[tuple[str, DrivetrainParams, float, float, object]]:
    """Random drives as in the generalisation test, simulated by the independent simulator."""
    rng = np.random.default_rng(1000 + seed)
    for case in range(n):
        N, J_l, J_m, wn, K_S, T_Cl = draw_plant(rng)
        delta = 10 ** rng.uniform(-2, np.log10(0.5))
        drive = IndependentDrive(
            J_m=J_m, J_l=J_l, N=N, K_S=K_S, D_S=2 * 0.02 * np.sqrt(K_S * J_l) * rng.uniform(0.5, 3),
            T_Cm=0.02 * J_m / 8e-4, T_Cl=T_Cl, beta_m=0.001, beta_l=T_Cl * 0.05,
            delta=delta, delta1=delta * rng.uniform(0.1, 0.9),
        )  # fmt: skip
        f = float(rng.uniform(0.3, 2.0))
        amp = max(3 * delta, rng.uniform(0.3, 2.0))
        counts = int(rng.choice([0, 1024, 2048, 8192, 65536]))
        tr = simulate_independent(
            drive, duration=20.0, T_s=5e-4, amplitude=amp, frequency=f,
            bandwidth=float(min(0.5 * wn, 300.0)), torque_limit=max(0.5 * K_S, 1.0),
            counts=counts, sigma_omega=float(rng.choice([0.0, 0.01, 0.03])), seed=case,
        )  # fmt: skip
        yield f"ind{seed}.{case}", drive.drivetrain(), drive.delta, drive.delta1, tr


def project_random_drives(seed: int) -> Iterator[tuple[str, DrivetrainParams, float, float, object]]:
    rng = np.random.default_rng(seed)
    for case in range(12):
        dt, bl, tr = random_drive(rng, case)
        yield f"rnd{seed}.{case}", dt, bl.delta, bl.delta1, tr


def bench_drives() -> Iterator[tuple[str, DrivetrainParams, float, float, object]]:
    from drivelash.sim.scenarios import get_scenario

    for name in ("bench-0A", "bench-0B", "bench-0C"):
        sc = get_scenario(name)
        yield name, sc.estimator_drivetrain, sc.plant_backlash.delta, sc.plant_backlash.delta1, sc.simulate()


def sweep(drives) -> list[Row]:  # noqa: ANN001
    rows = []
    for name, dt, delta, delta1, tr in drives:
        for case, scale in MISMATCH.items():
            d = _scaled(dt, scale)
            r = DeadzoneEstimator(d, delta1, tr.T_s).run(tr)
            rp = DeadzoneEstimator(d, delta1, tr.T_s, method="paper").run(tr)
            if not r.excitation_ok:
                flag = "unexcited"
            else:
                flag = "; ".join(w.split(":")[0][:40] for w in r.warnings if not w.startswith("note:"))
            rows.append(
                Row(
                    name,
                    case,
                    r.delta - delta,
                    r.delta_std,
                    r.converged,
                    flag,
                    rp.delta - delta,
                    rp.converged,
                )
            )
    return rows


def markdown(rows: list[Row]) -> str:
    head = (
        "| drive | stated | default δ̂−δ [mrad] | ±95 % | converged | flag | paper δ̂−δ [mrad] | converged |\n"
        "|---|---|---:|---:|---|---|---:|---|\n"
    )
    body = "".join(
        f"| {r.drive} | {r.case} | {1e3 * r.err:+.2f} | {1e3 * 1.96 * r.std:.2f} | {r.converged} | {r.flag} "
        f"| {1e3 * r.err_paper:+.2f} | {r.converged_paper} |\n"
        for r in rows
    )
    conv = [r for r in rows if r.converged]
    tail = (
        f"\n{len(rows)} runs; default law converged in {len(conv)}, worst |δ̂−δ| among them "
        f"{1e3 * max((abs(r.err) for r in conv), default=float('nan')):.2f} mrad; "
        f"confidently wrong (> 2 mrad and converged): {sum(r.confidently_wrong for r in rows)}; "
        f"converged and worse than the paper law by > 1 mrad: {sum(r.worse_than_paper for r in rows)}; "
        f"paper law confidently wrong: {sum(r.paper_confidently_wrong for r in rows)}.\n"
    )
    return head + body + tail


def main(argv: list[str]) -> None:
    which = argv[0]
    if which == "bench":
        drives = bench_drives()
    elif which == "random":
        drives = project_random_drives(int(argv[1]))
    else:
        drives = independent_drives(int(argv[1]))
    print(markdown(sweep(drives)))


if __name__ == "__main__":
    main(sys.argv[1:])
