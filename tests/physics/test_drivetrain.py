"""Two-mass right-hand side (1)–(4), its fast/event forms and the linear model."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from drivelash.params import BacklashParams, DrivetrainParams
from drivelash.physics.drivetrain import (
    contact_mode_scalar,
    linear_state_space,
    plant_params_array,
    rhs,
    rhs_mode_scalar,
    rk4_event_step_scalar,
    rk4_step_scalar,
)
from drivelash.physics.friction import friction

RIG = DrivetrainParams(
    J_m=8.31e-4, J_l=8.31e-4, N=1.0, K_S=32.94, D_S=0.0548, T_Cm=0.0223, T_Cl=0.0232,
    beta_m=0.0016, beta_l=0.0016, T_Sm=0.044, T_Sl=0.044, omega_s=0.05,
)  # fmt: skip
GEARED = DrivetrainParams(
    J_m=2e-4, J_l=5e-3, N=3.0, K_S=50.0, D_S=0.1, T_Cm=0.01, T_Cl=0.05, beta_m=1e-3, beta_l=4e-3
)
BL = BacklashParams(delta=0.2, delta1=0.08, alpha=500.0)


@pytest.mark.parametrize("model", ["deadzone", "smooth"])
@pytest.mark.parametrize("plant", [RIG, GEARED])
def test_fast_rhs_equals_reference_rhs(model: str, plant: DrivetrainParams) -> None:
    """The engine's RHS (reciprocals, fixed contact mode) equals (1)–(4) via friction_scalar."""
    p = plant_params_array(plant, BL, model=model, omega_reg=0.02)
    rng = np.random.default_rng(3)
    for _ in range(500):
        x = rng.normal(0.0, [2.0, 1.0, 2.0, 1.0]) * rng.choice([1e-3, 1.0])
        u = rng.normal(0.0, 0.5)
        mode = contact_mode_scalar(x[1] / plant.N - x[3], BL.delta, BL.delta1)
        fast = np.array(rhs_mode_scalar(x[0], x[1], x[2], x[3], u, BL.delta, BL.delta1, p, mode))
        ref = rhs(x, u, BL.delta, BL.delta1, p)
        np.testing.assert_allclose(fast, ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))


def test_rhs_hand_computed_point() -> None:
    """One point of (1)–(4) by hand: upper flank engaged, both shafts moving forward."""
    p = plant_params_array(GEARED, BL, omega_reg=0.0)  # exact sign
    x = np.array([3.0, 0.9, 0.5, 0.1])  # Δθ = 0.3 − 0.1 = 0.2 > δ − δ1 = 0.12; Δω = 1 − 0.5
    T_l = 50.0 * (0.2 + 0.08 - 0.2) + 0.1 * 0.5  # 4.05 N·m
    d_wm = (1.0 - (0.01 + 1e-3 * 3.0) - T_l / 3.0) / 2e-4
    d_wl = (T_l - (0.05 + 4e-3 * 0.5)) / 5e-3
    np.testing.assert_allclose(rhs(x, 1.0, 0.2, 0.08, p), [d_wm, 3.0, d_wl, 0.5], rtol=1e-14)


def test_linear_state_space_matches_rhs() -> None:
    """With δ = 0 and no Coulomb friction the RHS is A x + B u."""
    lin = DrivetrainParams(J_m=2e-4, J_l=5e-3, N=3.0, K_S=50.0, D_S=0.1, beta_m=1e-3, beta_l=4e-3)
    A, B = linear_state_space(lin)
    p = plant_params_array(lin, BacklashParams(0.0, 0.0))
    rng = np.random.default_rng(5)
    for _ in range(50):
        x, u = rng.normal(size=4), rng.normal()
        np.testing.assert_allclose(rhs(x, u, 0.0, 0.0, p), A @ x + B[:, 0] * u, rtol=1e-12, atol=1e-9)


def test_friction_fast_paths_are_exact() -> None:
    """The tanh/exp shortcuts of friction_scalar change nothing: compare with the plain formula."""
    w = np.concatenate([np.linspace(-5, 5, 20001), [0.0, 1e-300, -1e-300, 0.4, -0.4]])
    T_C, beta, T_S, w_s, w_r = 0.0232, 0.0016, 0.044, 0.05, 0.02
    plain = (T_C + (T_S - T_C) * np.exp(-((w / w_s) ** 2))) * np.tanh(w / w_r) + beta * w
    np.testing.assert_allclose(friction(w, T_C, beta, T_S, w_s, w_r), plain, rtol=1e-15, atol=1e-17)


def test_event_step_resolves_contact() -> None:
    """One 125 µs step through a contact: the event step keeps RK4 accuracy, the plain step does not."""
    p = plant_params_array(RIG, BL, omega_reg=0.02)
    # motor just before the upper contact (Δθ = 0.12 − 20 µrad), closing at 1 rad/s
    x0 = np.array([1.5, 0.12 - 2e-5, 0.5, 0.0])
    h = 125e-6
    ref = solve_ivp(lambda t, y: rhs(y, 0.1, BL.delta, BL.delta1, p), (0, h), x0, rtol=1e-12, atol=1e-14)
    x_ref = ref.y[:, -1]
    ev = np.array(rk4_event_step_scalar(*x0, 0.1, BL.delta, BL.delta1, p, h))
    plain = np.array(rk4_step_scalar(*x0, 0.1, BL.delta, BL.delta1, p, h))
    err_ev = np.abs(ev - x_ref)
    err_plain = np.abs(plain - x_ref)
    assert err_ev[0] < 1e-9 and err_ev[2] < 1e-9  # velocities [rad/s]
    assert err_plain[0] > 100 * err_ev[0]  # D_S Δω jump: the plain step loses ~h·D_S·Δω/J/6
