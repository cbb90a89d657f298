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
"""

from __future__ import annotations

#: name → (value as quoted, tolerance, text README.md contains, unit of value)
FIGURES: dict[str, tuple[float, float, str]] = {
    # -- virtual bench (eq. (3) against the simulated path error, no-load passes, full travel)
    "eq3_mae_10mm_s_um": (0.0, 0.00001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    "eq3_mae_50mm_s_um": (0.0005, 0.0001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    "eq3_mae_100mm_s_um": (0.0035, 0.0001, "0.00000/0.0005/0.0035 µm MAE at 10/50/100 mm/s"),
    # -- learning (te evaluate: MAE of TE_def, pooled over directions and velocities)
    "train_mae_um": (0.050, 0.001, "training MAE 0.050 µm"),
    "heldout_mae_um": (0.063, 0.001, "held-out loads 0.063 µm (3.9 % of the"),
    "heldout_ratio_pct": (3.9, 0.1, "held-out loads 0.063 µm (3.9 % of the"),
    "extrapolation_mae_um": (0.31, 0.01, "3500–5000 N 0.31 µm (11.9 %)"),
    "extrapolation_ratio_pct": (11.9, 0.1, "3500–5000 N 0.31 µm (11.9 %)"),
    "stage1_share_min_pct": (95.0, 1.0, "the network carries 95–96 % of the output"),
    "stage1_share_max_pct": (96.0, 1.0, "the network carries 95–96 % of the output"),
    # -- compensation (te validate)
    "average_improvement_pct": (87.2, 0.1, "by 87.2 %\non average"),
    "min_in_range_pass_pct": (89.0, 1.0, "in the training range ≥ 89 % per pass"),
    "min_in_range_section_pct": (77.0, 1.0, "≥ 77 % per section"),
    "min_beyond_range_pass_pct": (46.0, 1.0, "beyond it ≥ 46 %"),
    "reversal_uncomp_um": (19.0, 1.0, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "reversal_comp_um": (2.1, 0.1, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "reversal_reduction_pct": (89.0, 1.0, "the reversal error falls from 19 µm to 2.1 µm (−89 %)"),
    "hf_ratio": (0.16, 0.01, "no growth of the path error above 50 Hz (ratio 0.16)"),
    "monitor_defect_section_before_pct": (77.0, 1.0, "improvement from 77 % back to 95 %"),
    "monitor_defect_section_after_pct": (95.0, 1.0, "improvement from 77 % back to 95 %"),
}
