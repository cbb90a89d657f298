"""Session 31: two-mass ``identify`` findings C4, C9 (tester C) and H6 (session 30 tester A).

- C4: the motor and load channels swapped (θ_m↔θ_l, ω_m↔ω_l) on bench-0B: "the shaft never carried
  torque", J_m +70 %, β_m 5× written with intervals excluding the truth; the swap never named.
  Now refused before the fit with the online estimator's data test (torque–Δθ correlation).
- C9: EMPS (rigid axis, no backlash) with its reference position as θ_l: δ = 0.954 mm [0.738, 1.171]
  "both contacts seen" while J_l = 2.2e10 ± 4.5e18. The swap check now refuses it (the torque
  follows θ_l − θ_m: a set-point); behind it, a load equation that does not determine J_l by
  orders of magnitude withholds δ, δ1, K_S, D_S.
- H6: paper-sim (δ 200 → 210 mrad at 3 s) gave δ = 211.85 [210.89, 212.80] mrad, J_m +40 %, no
  warning; now δ refitted on each half differs by many standard errors: warned, δ/δ1 withheld.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import drivelash.estimation.identify_two_mass as itm
from drivelash.errors import DataError
from drivelash.estimation.identify_result import ParameterEstimate
from drivelash.estimation.identify_two_mass import check_channel_swap, identify_two_mass, load_not_driven
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


def _kuka_axis1(swapped: bool) -> tuple[str, object]:
    """KUKA rec_A axis 1 with examples/kuka/axis1.toml, the two encoders swapped if asked."""
    from identify.helpers import REPO, shared_data

    text = (REPO / "examples" / "kuka" / "axis1.toml").read_text(encoding="utf-8")
    if swapped:
        text = text.replace("act_pos_se_deg", "@").replace("act_pos_mot_deg", "act_pos_se_deg")
        text = text.replace("@", "act_pos_mot_deg")
    return text, shared_data("kuka-kr300", "rec_A.mat")


@pytest.mark.parametrize("swapped", [True, False])
def test_negative_encoder_delay_is_named_as_a_possible_swap(tmp_path, swapped):
    """C4 on KUKA rec_A axis 1 (one reversal: the data test does not judge it): with the encoders
    swapped the fit determines encoder_delay = −2.25 ms [−2.59, −1.91] (the link encoder lags by
    ~+3 ms) — now a warning names the possible swap; the config as shipped gets none."""
    import drivelash as dl

    text, mat = _kuka_axis1(swapped)
    cfg_path = tmp_path / "axis1.toml"
    cfg_path.write_text(text, encoding="utf-8")
    cfg = dl.load_config(cfg_path)
    r = dl.identify_drive(dl.load_trace(mat, cfg, required=["theta_m", "theta_l", "torque_m"]), cfg)
    named = [w for w in r.warnings if w.startswith("the fitted encoder delay is negative")]
    assert len(named) == int(swapped), r.warnings
    if swapped:
        assert "channels may be swapped" in named[0] and r["encoder_delay"].high < 0.0


# ------------------------------------------------------------------------------------ C9
def _emps_reference_as_load() -> Trace:
    """EMPS (DATA_EMPS.mat) with the reference position qg mapped as θ_l (and its derivative as ω_l)."""
    import scipy.io as sio

    from identify.helpers import emps_file

    d = sio.loadmat(emps_file("DATA_EMPS.mat"))
    t, qm, qg = d["t"].ravel(), d["qm"].ravel(), d["qg"].ravel()
    return Trace(
        {
            "t": t,
            "theta_m": qm,
            "omega_m": np.gradient(qm, t),
            "theta_l": qg,
            "omega_l": np.gradient(qg, t),
            "torque_m": float(d["gtau"].item()) * d["vir"].ravel(),
        },
        {"source": "emps_ref_as_load"},
    )


def test_reference_as_load_is_refused_naming_a_set_point():
    """C9: the position loop's torque follows qg − qm, so the torque falls as Δθ = qm − qg grows
    (correlation −0.71 over 7 reversals): refused, the message names a reference / set-point."""
    with pytest.raises(DataError, match="reference / set-point"):
        identify_two_mass(_emps_reference_as_load(), 1.0)


def test_load_not_driven_rule():
    """J_l's 95 % half-width over |J_l| above SPAN_LIMIT (C9: 2.0e8) marks the load as not driven;
    a determined J_l (bench ≤ 0.03) or the motor equation alone does not."""
    bad = {"J_l": ParameterEstimate.normal("J_l", 2.207e10, 4.49e18 / 1.96)}
    good = {"J_l": ParameterEstimate.normal("J_l", 8.36e-4, 1.2e-5)}
    assert load_not_driven(bad, "both") == pytest.approx(2.03e8, rel=0.01)
    assert load_not_driven(bad, "motor") is None
    assert load_not_driven(good, "both") is None


@pytest.mark.slow
def test_undetermined_load_equation_withholds_the_gap(monkeypatch):
    """C9 behind the swap check (a recording it lets through, e.g. one reversal): before, δ = 0.954 mm
    [0.738, 1.171], δ1, K_S = 14312 [11180, 17443] were reported with J_l = 2.2e10 ± 4.5e18; now
    withheld with the reason, and not written to the drive table."""
    monkeypatch.setattr(itm, "check_channel_swap", lambda *a, **k: None)
    r = identify_two_mass(_emps_reference_as_load(), 1.0)
    for n in ("delta", "delta1", "K_S", "D_S"):
        assert not r[n].identifiable and "does not follow the shaft torque" in r[n].reason, n
    assert not r.backlash_visible and r.reason.startswith("backlash not determined: θ_l does not follow")
    assert "delta" not in r.to_config().get("backlash", {})
    assert r["J_m"].identifiable  # the motor equation stands (EMPS: M = 95.1 kg)


# ------------------------------------------------------------------------------------ H6
@pytest.fixture(scope="module")
def paper_change() -> Trace:
    return get_scenario("paper-sim").simulate()


def test_gap_change_inside_the_recording_is_named(paper_change):
    """H6: δ 200 → 210 mrad at 3 s; before: δ = 211.85 [210.89, 212.80] mrad "both contacts seen",
    no warning. Now the halves give ≈ 202.7 and 212.6 mrad (z ≈ 117): warned, δ and δ1 withheld."""
    r = identify_two_mass(paper_change, 1.0)
    w = [x for x in r.warnings if x.startswith("the gap changed during the recording")]
    assert len(w) == 1, r.warnings
    h = r.fit["gap_halves"]
    assert h["z"] > itm.GAP_CHANGE_Z and h["delta"][1] - h["delta"][0] > 5e-3
    assert not r["delta"].identifiable and not r["delta1"].identifiable and not r.backlash_visible
    assert math.isnan(r["delta"].value)


def test_constant_gap_gives_no_gap_change_warning():
    """Negative control: paper-sim with a constant gap (the same drive, δ = 200 mrad throughout):
    halves 199.95 / 199.87 mrad (z ≈ 1.2), no warning, δ determined and accurate."""
    from dataclasses import replace

    from drivelash.sim.scenarios import DeadzoneProfile

    sc = get_scenario("paper-sim")
    r = identify_two_mass(replace(sc, deadzone_profile=DeadzoneProfile("constant")).simulate(), 1.0)
    assert not any("gap changed" in w for w in r.warnings), r.warnings
    assert r.fit["gap_halves"]["z"] < itm.GAP_CHANGE_Z
    assert r.backlash_visible and abs(r["delta"].value - 0.2) < 1e-3
