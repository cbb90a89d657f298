"""A linear (prismatic) axis recording made cheaply from a simulated bench-0B run.

bench-0B, rewritten exactly in units s = 1e-3 (positions in m, velocities in m/s, force in N,
the drive's inertias, stiffness and damping divided by s): a 186 µm gap with δ1 = 93 µm
(tests/estimation/test_session31_scale.py for why the numbers carry over). ``lin.toml`` maps the
columns in m / m/s / N (a prismatic trace); ``ang.toml`` maps the same numbers as rad / rad/s / N·m
(the rotary negative control).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

POSITIONS = ("theta_m", "omega_m", "theta_l", "omega_l")
UNITS = {"theta_m": "m", "omega_m": "m/s", "theta_l": "m", "omega_l": "m/s", "torque_m": "N", "t": "s"}
ANGLE = {"m": "rad", "m/s": "rad/s", "N": "Nm", "s": "s"}
SCALE = 1e-3


def write_linear_bench(d: Path, duration: float = 6.0, seed: int = 1) -> Path:
    """``d``/lin.parquet, ``d``/lin.toml (prismatic) and ``d``/ang.toml (rotary); returns ``d``."""
    import pandas as pd

    from drivelash.sim.scenarios import get_scenario

    sc = get_scenario("bench-0B")
    tr = sc.simulate(duration=duration, seed=seed)
    s = SCALE
    dt0 = sc.estimator_drivetrain
    p = replace(dt0, **{f: getattr(dt0, f) / s for f in ("J_m", "J_l", "K_S", "D_S", "beta_m", "beta_l")})
    pd.DataFrame(
        {c: tr[c] * s if c in POSITIONS else tr[c] for c in ("t", *POSITIONS, "torque_m")}
    ).to_parquet(d / "lin.parquet")
    keys = ("J_m", "J_l", "N", "K_S", "D_S", "T_Cm", "T_Cl", "beta_m", "beta_l")
    dt = "".join(f"{k} = {getattr(p, k)!r}\n" for k in keys)
    head = f"[drivetrain]\n{dt}[backlash]\ndelta1 = {sc.estimator_backlash.delta1 * s!r}\n"
    for name, units in (("lin", UNITS), ("ang", {c: ANGLE[u] for c, u in UNITS.items()})):
        cols = "".join(f'[columns.{c}]\ncolumn = "{c}"\nunit = "{u}"\n' for c, u in units.items())
        (d / f"{name}.toml").write_text(head + cols, encoding="utf-8")
    return d
