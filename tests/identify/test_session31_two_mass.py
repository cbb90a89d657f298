"""Session 31: two-mass ``identify`` findings C4, C9 (tester C) and H6 (session 30 tester A).

- C4: the motor and load channels swapped (θ_m↔θ_l, ω_m↔ω_l) on bench-0B: "the shaft never carried
  torque", J_m +70 %, β_m 5× written with intervals excluding the truth; the swap never named.
  Now refused before the fit with the online estimator's data test (torque–Δθ correlation).
"""

from __future__ import annotations

import pytest

from drivelash.errors import DataError
from drivelash.estimation.identify_two_mass import check_channel_swap, identify_two_mass
from drivelash.io.trace import Trace
from drivelash.sim.scenarios import get_scenario, list_scenarios

BENCH = [s.name for s in list_scenarios() if s.name.startswith("bench-")]


def _swapped(tr: Trace) -> Trace:
    """Motor and load channels exchanged (positions and velocities), torque kept."""
    return tr.with_columns(
        {
            "theta_m": tr["theta_l"],
            "theta_l": tr["theta_m"],
            "omega_m": tr["omega_l"],
            "omega_l": tr["omega_m"],
        }
    )


@pytest.fixture(scope="module")
def bench_0b() -> Trace:
    return get_scenario("bench-0B").simulate(duration=4.0, seed=1)


# ------------------------------------------------------------------------------------ C4
def test_swapped_motor_and_load_channels_are_refused(bench_0b):
    """C4: before, the fit ran and wrote J_m 1.41e-3 (truth 8.31e-4), β_m 0.0080 (0.0016) and "no
    contact"; now refused before the fit, naming the swap and the [columns] mapping."""
    swap = r"motor and load channels are swapped.*check the \[columns\] mapping"
    with pytest.raises(DataError, match=swap):
        identify_two_mass(_swapped(bench_0b), 1.0)


def test_swapped_channels_exit_2_and_write_nothing(tmp_path, bench_0b, capsys):
    """C4 through the command: exit 2, one line naming the swap, no drive table."""
    from cli_runner import run_in_process

    p, cfg, out = tmp_path / "sw.parquet", tmp_path / "n1.toml", tmp_path / "drive.toml"
    _swapped(bench_0b).to_parquet(p)
    cfg.write_text("[drivetrain]\nN = 1.0\n")
    r = run_in_process(["identify", str(p), "-c", str(cfg), "--model", "two-mass", "-o", str(out)], capsys)
    assert r.returncode == 2, r.stderr
    last = r.stderr.strip().splitlines()
    assert len(last) == 1 and "channels are swapped" in last[0], r.stderr
    assert not out.exists()


@pytest.mark.parametrize("name", BENCH)
def test_unswapped_bench_recordings_pass_the_swap_check(name):
    """Negative control: the 18 bench scenarios as recorded (correlation +0.47 … +0.85 over 60 s)
    pass; swapped, each is refused (−0.47 … −0.85)."""
    tr = get_scenario(name).simulate(duration=6.0, seed=2)
    check_channel_swap(tr, 1.0, tr["omega_m"])
    with pytest.raises(DataError, match="swapped"):
        check_channel_swap(_swapped(tr), 1.0, tr["omega_l"])


def test_torque_sign_error_is_left_to_the_fit(bench_0b):
    """A torque recorded with the wrong sign also turns the correlation around, but the motor then
    does negative work: it is not refused as a swap — the fit's J_m < 0 names the torque sign
    (tests/identify/test_identify_two_mass.py::test_negative_torque_gain_is_flagged)."""
    bad = bench_0b.with_columns({"torque_m": -bench_0b["torque_m"]})
    check_channel_swap(bad, 1.0, bad["omega_m"])
