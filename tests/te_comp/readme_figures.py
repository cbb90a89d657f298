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
misattribution. On this session's machine (a CPU with AVX-512 and AMX) main's code gives the
earlier figures again — training 0.0499 µm (+x 0.0497, −x 0.0501), held-out 0.0634 µm, 3500–5000 N
0.313 µm (11.9 %), average 87.21 % — and the code at 2d96274 fits a model that predicts the same TE
to 2e-19 m. The seed-0 fit depends on the CPU's floating-point order (the Hyperband search picks
another trial), so on that CPU type the slow test fails four figures and the +x training-MAE
known miss passes (XPASS, strict). Measured with ``DRIVELASH_TE_SEED0=DIR .venv/bin/python -m
pytest -m slow -n 0 tests/te_comp/test_readme_te_figures_slow.py
tests/te_learn/test_campaign_acceptance.py`` on the four directories of the README's commands.
With that model the loop analysis (``test_loop_stability_slow.py``) gives a gain margin of 66.4
(quoted 76) and 5.10 with the raw motor torque (quoted 5.9); its stability requirements (margin ≥ 10,
modes ≤ 5 % slower) hold.
The figures and tolerances below are left as measured on the reference machine: making the fit
reproducible (a model selection that does not flip on such differences) is the fix, not a wider
tolerance.
"""

from __future__ import annotations

#: name → (value as quoted, tolerance, text README.md contains, unit of value)
FIGURES: dict[str, tuple[float, float, str]] = {
    # -- virtual bench (eq. (3) against the simulated path error, no-load passes, full travel)
    "eq3_mae_10mm_s_um": (0.0, 0.00001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    "eq3_mae_50mm_s_um": (0.0005, 0.0001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    "eq3_mae_100mm_s_um": (0.0035, 0.0001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    # -- learning (te evaluate: MAE of TE_def, pooled over directions and velocities)
    "train_mae_um": (0.052, 0.001, "training MAE 0.052 µm"),
    "heldout_mae_um": (0.062, 0.001, "held-out loads 0.062 µm (3.8 % of the"),
    "heldout_ratio_pct": (3.8, 0.1, "held-out loads 0.062 µm (3.8 % of the"),
    "extrapolation_mae_um": (0.34, 0.01, "3500–5000 N 0.34 µm (12.9 %)"),
    "extrapolation_ratio_pct": (12.9, 0.1, "3500–5000 N 0.34 µm (12.9 %)"),
    "stage1_share_min_pct": (94.0, 1.0, "the network carries 94–95 % of the output"),
    "stage1_share_max_pct": (95.0, 1.0, "the network carries 94–95 % of the output"),
    # -- compensation (te validate)
    "average_improvement_pct": (86.9, 0.1, "by 86.9 %\non average"),
    "min_in_range_pass_pct": (88.0, 1.0, "in the training range ≥ 88 % per pass"),
    "min_in_range_section_pct": (77.0, 1.0, "≥ 77 % per section"),
    "min_beyond_range_pass_pct": (45.0, 1.0, "beyond it ≥ 45 %"),
    "reversal_uncomp_um": (19.0, 1.0, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "reversal_comp_um": (2.1, 0.1, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "reversal_reduction_pct": (89.0, 1.0, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "hf_ratio": (0.16, 0.01, "no growth of the path error above 50 Hz (ratio 0.16)"),
    "monitor_defect_section_before_pct": (77.0, 1.0, "improvement from 77 % back to 95 %"),
    "monitor_defect_section_after_pct": (95.0, 1.0, "improvement from 77 % back to 95 %"),
}
