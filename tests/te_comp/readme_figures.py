"""The transmission-error figures README.md quotes, each with its tolerance and its test.

One table, read by two tests: ``test_readme_te_figures.py`` (fast) checks that README.md
quotes every figure exactly as written here, and ``test_readme_te_figures_slow.py``
(``make test-slow``) measures each one on the seed-0 run of the README's own commands
(``drivelash te campaign -o C --seed 0``, ``te fit C -o M``, ``te evaluate M C -o E``,
``te validate M -o V``; the :func:`te_seed0` fixture). A figure that moves fails the
slow test; a README edit that is not reflected here fails the fast one.

Tolerances: the figures are deterministic for given code and machine (seeded campaign,
seeded training on one torch thread per direction); the tolerance is half a unit of the
quoted figure's last digit plus the same again for floating-point differences between
machines (BLAS and torch summation order), unless stated otherwise.

The learning and constant-velocity figures were re-measured on 2026-11-23 (session 3,
af360fa, `pytest -m slow tests/te_comp/test_readme_te_figures_slow.py`): the README had
quoted an earlier model's figures (training 0.050, held-out 0.063, 3500–5000 N 0.31 µm,
network 95–96 %, 87.2 %, ≥ 89 % / ≥ 46 %) that the current code no longer gives
(0.0515, 0.0619, 0.341 µm, 93.9–95.2 %, 86.86 %, 88.8 % / 45.6 %). The issue's goals
(``tests/te_learn/test_campaign_acceptance.py``) are unchanged.

Correction (session 5, 2026-11-27): "the current code no longer gives" the earlier figures was a
misattribution. On a CPU with AVX-512 and AMX main's code gave the earlier figures again
(training 0.0499 µm, held-out 0.0634 µm, 3500–5000 N 0.313 µm, average 87.21 %).

Session 6 (2026-11-27) found the two causes and removed them (``tests/te_learn/test_numerics.py``,
docs/assumptions.md "Transmission-error learning"): Optuna's random default study name made
Hyperband prune other trials on every run (two identical ``te fit`` runs: −x 0.0456 and
0.0653 µm), and torch's kernels followed the CPU (AVX-512 against AVX2 chose lr 0.0121 against
0.0064 for +x). ``te fit`` now names its study and trains on torch's AVX2 kernels with oneMKL's
AVX2 branch on every CPU. The learning figures and the loop margins
(``test_loop_stability_slow.py``: gain margin 85, 197 up to 100 mm/s, slowest mode 1.3 %, K_v
0.8 %, raw motor torque 6.5) were re-measured on that path (session 6, worktree of 7512ffd:
``pytest -m slow tests/te_learn tests/te_comp tests/te_axis tests/te_bench``): training 0.0501 µm
(+x 0.0546, −x 0.0456), held-out 0.0582 µm (3.6 %), 3500–5000 N 0.369 µm (14.0 %); every
``te validate`` figure (86.9 %, ≥ 88 % / ≥ 77 % / ≥ 45 %, 19 → 2.1 µm, 0.16, 77 → 95 %) held within
its tolerance; two were re-quoted at their measured value: the average 86.98 % (now "87.0 %") and
the lowest beyond-range pass 44.2 % (quoted "≥ 45 %", now "≥ 44 %": 44.2 was inside the ±1 tolerance
but "≥ 45" was not true). Tolerances unchanged.

Valid-range fix (branch ``valid-range``): the model now stores, and ``te validate`` uses, the
positions where it was measured (the no-load runs' span ∩ the span the no-load curves hold
data: 55 … 2145 mm on the seed-0 campaign instead of the runs' 50.0107 … 2149.9893 mm, where
the curves were held flat over 5 mm at each end). Measured on one seed-0 model (``te campaign
-o C --seed 0``, ``te fit C -o M`` at main 23bab9b, then ``te validate M -o V`` with main's code
and with the branch's): average 86.98 → 87.24 % (quoted "87.0 %" → "87.2 %"), lowest in-range
pass 88.96 → 89.77 % ("≥ 88 %" → "≥ 89 %"), lowest in-range section 77.72 → 88.66 % ("≥ 77 %" →
"≥ 88 %": the first and last sections had run over the flat bands), lowest beyond-range pass
44.20 → 44.19 %, reversal 19.20 → 2.115/2.116 µm, hf ratio 0.1603/0.1603, monitoring defect
section 77.2 → 77.8 % and 95.2 → 95.4 % (all within their tolerances, quotes unchanged); the
monitoring defect moved with the sections from 1300.01 to 1305.00 mm (README "at 1.30 m" →
"at 1.305 m", same 0.1 mm tolerance). The goals (≥ 75 %, ≥ 60 %, ≥ 35 %) are unchanged and met.
Tolerances unchanged.
"""

from __future__ import annotations

from pathlib import Path

#: The CPU the README's learning figures were measured on (session 6, pinned AVX2 path).
REFERENCE_CPU_VENDOR = "GenuineIntel"

#: The same figures measured on a CPU that is not the reference's (session 27, AMD EPYC with
#: AVX2, ``te campaign -o C --seed 0`` → ``te fit`` → ``te evaluate`` → ``te validate`` on main
#: 3ffb92a; the campaign is bit-identical to the reference's and to session 21's code, and
#: session 21's code (5807576) fits the same network here, so the CPU is the cause, not a change):
#: oneMKL's conditional numerical reproducibility promises the AVX2 branch's results on Intel
#: CPUs only, and the training is chaotic in the last bit, so it ends in another network.
OTHER_CPU_MEASURED: dict[str, float] = {
    "train_mae_um": 0.0583,
    "heldout_mae_um": 0.0631,
    "heldout_ratio_pct": 3.89,
    "extrapolation_mae_um": 0.412,
    "extrapolation_ratio_pct": 15.6,
    "average_improvement_pct": 86.54,
    "min_in_range_pass_pct": 87.94,
    "min_in_range_section_pct": 86.54,
    "min_beyond_range_pass_pct": 43.58,
}


def _cpuinfo(field: str) -> str:
    """Value of ``field`` for the first CPU in /proc/cpuinfo ("" where there is none)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith(field):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return ""


def cpu_vendor() -> str:
    """``vendor_id`` of the first CPU in /proc/cpuinfo ("" where there is none)."""
    return _cpuinfo("vendor_id")


def cpu_model() -> str:
    """``model name`` of the first CPU in /proc/cpuinfo ("" where there is none)."""
    return _cpuinfo("model name")


#: The CPU model :data:`OTHER_CPU_MEASURED` was measured on (its ``model name`` starts so).
OTHER_CPU_MODEL = "AMD EPYC"


def on_reference_cpu() -> bool:
    """True on a CPU of the reference's vendor (the learning figures hold there)."""
    return cpu_vendor() == REFERENCE_CPU_VENDOR


def cpu_dependent(what: str, measured: str):  # noqa: ANN201 - a pytest mark
    """Strict known miss off the reference vendor's CPUs for a check of the fitted network.

    ``what`` names the figures (README's), ``measured`` what another CPU gave. Strict: should
    another vendor's CPU reproduce them, the marker has to go.
    """
    import pytest

    return pytest.mark.xfail(
        not on_reference_cpu(),
        strict=True,
        reason=f"known miss on this CPU ({cpu_vendor() or 'vendor unknown'}): {what} were measured on an"
        " Intel Xeon on the pinned AVX2 path (ATEN_CPU_CAPABILITY=avx2, MKL_CBWR=AVX2); oneMKL promises that"
        " path's results on Intel CPUs only, and training is chaotic in the last bit, so another network is"
        f" fitted. Measured on an AMD EPYC (session 27): {measured}",
    )


#: name → (value as quoted, tolerance, text README.md contains, unit of value)
FIGURES: dict[str, tuple[float, float, str]] = {
    # -- virtual bench (eq. (3) against the simulated path error, no-load passes, full travel)
    "eq3_mae_10mm_s_um": (0.0, 0.00001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    "eq3_mae_50mm_s_um": (0.0005, 0.0001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    "eq3_mae_100mm_s_um": (0.0035, 0.0001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    # -- learning (te evaluate: MAE of TE_def, pooled over directions and velocities)
    "train_mae_um": (0.050, 0.001, "training MAE 0.050 µm"),
    "heldout_mae_um": (0.058, 0.001, "held-out loads 0.058 µm (3.6 % of the"),
    "heldout_ratio_pct": (3.6, 0.1, "held-out loads 0.058 µm (3.6 % of the"),
    "extrapolation_mae_um": (0.37, 0.01, "3500–5000 N 0.37 µm (14.0 %)"),
    "extrapolation_ratio_pct": (14.0, 0.1, "3500–5000 N 0.37 µm (14.0 %)"),
    "stage1_share_min_pct": (94.0, 1.0, "the network carries 94–95 % of the output"),
    "stage1_share_max_pct": (95.0, 1.0, "the network carries 94–95 % of the output"),
    # -- compensation (te validate)
    "average_improvement_pct": (87.2, 0.1, "by 87.2 %\non average"),
    "min_in_range_pass_pct": (89.0, 1.0, "in the training range ≥ 89 % per pass"),
    "min_in_range_section_pct": (88.0, 1.0, "≥ 88 % per section"),
    "min_beyond_range_pass_pct": (44.0, 1.0, "beyond it ≥ 44 %"),
    "reversal_uncomp_um": (19.0, 1.0, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "reversal_comp_um": (2.1, 0.1, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "reversal_reduction_pct": (89.0, 1.0, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "hf_ratio": (0.16, 0.01, "no growth of the path error above 50 Hz (ratio 0.16)"),
    "monitor_defect_section_before_pct": (77.0, 1.0, "improvement from 77 % back to 95 %"),
    "monitor_defect_section_after_pct": (95.0, 1.0, "improvement from 77 % back to 95 %"),
}
