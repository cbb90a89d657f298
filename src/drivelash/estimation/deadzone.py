"""Online deadzone estimation: STSMO + adaptive law (49–50) with projection (App. B), spec 01 §2.

Two methods share one kernel, :func:`deadzone_run`:

``method="paper"`` — the paper's plain gradient law, explicit Euler at the sample time::

    φ̂        from the STSMO on ω_l with a_known = −T_F,l(ω_l)/J_l   (exact sgn, as the paper)
    g         = ∂T_l/∂δ(x, δ̂) / K_S                                 (50), dimensionless
    e         = (J_l φ̂ − T_l(x, δ̂)) / K_S                           [rad]
    δ̂_k+1   = δ̂_k + T_s Proj{δ̂, γ g e}                             (49)

  (γ (J_l/K_S²) ∂T_l/∂δ [φ̂ − T_l/J_l] = γ g e, so γ is a rate [1/s]), Δθ = θ_m/N − θ_l
  straight from the (quantised) encoders.

``method="default"`` — three improvements, each switchable by its parameter:

1. *Sub-count position reconstruction*: Δθ̂ from a complementary filter that fuses the
   quantised Δθ (low frequencies, cut-off ω_c) with the integral of the measured
   Δω = ω_m/N − ω_l (high frequencies): Δθ̂ ← Δθ̂ + T_s Δω_k, then Δθ̂ ← Δθ̂ + c (Δθ_k − Δθ̂),
   c = 1 − exp(−ω_c T_s). Quantisation error of two encoders that keep moving is a fast,
   zero-mean signal and averages out below ω_c; velocity noise integrates to a random walk
   that the position pulls back.
2. *Filtered residual and regressor*: e and g pass through the same first-order low-pass
   (time constant τ_f), which removes the STSMO chattering from the law without a lag
   mismatch between e and g (the "filtered regressor" construction).
3. *Time-varying (least-squares) gain with forgetting*: δ̂ += T_s P Proj{g_f e_f},
   P += T_s (λ P − P² g_f²), P ∈ [λ, P_max]. P starts at P_max (fast first convergence),
   shrinks while the law receives information (low steady-state noise) and, by the
   forgetting rate λ, comes back up so that a later change of δ (wear) is tracked.
   The load-friction sign is regularised, tanh(ω_l/ω_ε), so that velocity noise at
   standstill does not throw ±T_C,l into φ̂.

Both methods end every step with the hard bounds 0 ≤ δ̂ ≤ δ_max (the projection keeps δ̂
inside the ball of radius δ_max in continuous time; an Euler step could overshoot it).

Excitation monitor (both methods): σ_k = g_k² — the paper's σ(x) (45) evaluated at the
current estimate (σ(x, Λ) = (χ1 + χ2)²/π² = (∂T_l/∂δ/K_S)²; with the paper's Λ > δ_max it
would vanish for every physically reachable Δθ) — is summed over a sliding window of W
samples: ``sigma_window`` = ∫σ dt over the last W T_s seconds [s]. A *contact* is a
filtered shaft torque J_l φ̂ beyond ±T_thr; a *traversal* is a change of contact side
(positive ↔ negative). Excitation is sufficient when at least two traversals have been seen
and the σ-window integral exceeds ε_σ = 5 % of the window length.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from drivelash.physics.backlash import dtorque_ddelta_scalar, smooth_torque_scalar

# -- parameter array layout ---------------------------------------------------------
P_J_L, P_N, P_K_S, P_D_S, P_T_CL, P_BETA_L, P_DELTA1, P_ALPHA = 0, 1, 2, 3, 4, 5, 6, 7
P_K1, P_K2, P_GAMMA, P_DELTA_MAX, P_EPS_DELTA, P_TS, P_METHOD = 8, 9, 10, 11, 12, 13, 14
P_OMEGA_C, P_TAU_F, P_LAMBDA, P_P_MAX, P_OMEGA_EPS, P_T_THR, P_WINDOW = 15, 16, 17, 18, 19, 20, 21
P_EST_K, P_EST_F, P_OMEGA_REF, P_THETA_DEF, P_Q_AUX = 22, 23, 24, 25, 26
N_PARAMS = 27

# -- state array layout (followed by the σ ring buffer of W samples) -----------------
S_OMEGA_HAT, S_Z, S_DELTA, S_P, S_XHAT, S_INIT, S_EF, S_GF = 0, 1, 2, 3, 4, 5, 6, 7
S_TQF, S_SIDE, S_TRAV, S_SIGSUM, S_RING_IDX, S_COUNT = 8, 9, 10, 11, 12, 13
#: extended least squares (default method): θ = [δ, κ, a, b] at S_TH, filtered regressors at
#: S_HF, 4×4 gain matrix (row-major) at S_PM
NTH = 4
S_TH, S_HF, S_PM = 16, 20, 24
N_STATE = 40

# -- output columns -----------------------------------------------------------------
O_DELTA, O_PHI, O_OMEGA_HAT, O_SIGMA_WIN, O_DTHETA, O_TORQUE_HAT, O_TORQUE_MEAS, O_TRAV = range(8)
N_OUT = 8

# -- input columns ------------------------------------------------------------------
I_THETA_M, I_OMEGA_M, I_THETA_L, I_OMEGA_L = 0, 1, 2, 3
N_IN = 4


@njit(cache=True, inline="always")
def _sgn(x: float) -> float:
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return 0.0


@njit(cache=True)
def projection(delta, tau, delta_max, eps_delta):
    """Scalar projection operator of App. B (65) [rad/s].

    Parameters
    ----------
    delta : float
        Current estimate δ̂ [rad].
    tau : float
        Unprojected update rate [rad/s].
    delta_max : float
        Radius of the parameter ball [rad].
    eps_delta : float
        Width ε_δ > 0 of the boundary layer [-].
    """
    h = ((eps_delta + 1.0) * delta * delta - delta_max * delta_max) / (eps_delta * delta_max * delta_max)
    if h < 0.0:
        return tau
    dh = 2.0 * (eps_delta + 1.0) * delta / (eps_delta * delta_max * delta_max)
    if dh * tau <= 0.0:
        return tau
    return tau * (1.0 - h)


@njit(cache=True)
def deadzone_step(state, theta_m, omega_m, theta_l, omega_l, p, out):
    """One sample of the estimator, in place on ``state``; writes ``out`` (length N_OUT)."""
    J_l = p[P_J_L]
    K_S = p[P_K_S]
    D_S = p[P_D_S]
    delta1 = p[P_DELTA1]
    alpha = p[P_ALPHA]
    Ts = p[P_TS]
    default = p[P_METHOD] > 0.5
    delta_max = p[P_DELTA_MAX]

    # relative coordinates (8)–(9), load side
    dtheta_meas = theta_m / p[P_N] - theta_l
    domega = omega_m / p[P_N] - omega_l
    if state[S_INIT] < 0.5:
        state[S_XHAT] = dtheta_meas
        state[S_INIT] = 1.0
    if default and p[P_OMEGA_C] > 0.0:
        c = 1.0 - math.exp(-p[P_OMEGA_C] * Ts)
        xhat = state[S_XHAT]
        xhat = xhat + c * (dtheta_meas - xhat)
        dtheta = xhat
        state[S_XHAT] = xhat + Ts * domega  # prediction for the next sample
    else:
        dtheta = dtheta_meas
        state[S_XHAT] = dtheta_meas

    # STSMO on the load velocity (16)–(21)
    if default and p[P_OMEGA_EPS] > 0.0:
        sg = math.tanh(omega_l / p[P_OMEGA_EPS])
    else:
        sg = _sgn(omega_l)
    a_known = -(p[P_T_CL] * sg + p[P_BETA_L] * omega_l) / J_l
    w_hat = state[S_OMEGA_HAT]
    err = omega_l - w_hat
    s = _sgn(err)
    phi = p[P_K1] * math.sqrt(abs(err)) * s + state[S_Z]
    state[S_OMEGA_HAT] = w_hat + Ts * (a_known + phi)
    state[S_Z] = state[S_Z] + Ts * p[P_K2] * s

    # adaptive law (49)–(50)
    delta = state[S_DELTA]
    T_hat = smooth_torque_scalar(dtheta, domega, K_S, D_S, delta, delta1, alpha)
    g = dtorque_ddelta_scalar(dtheta, domega, K_S, D_S, delta, delta1, alpha) / K_S
    T_meas = J_l * phi
    if default:
        kappa = state[S_TH + 1]
        h = np.empty(NTH)
        h[0] = kappa * g
        # κ learns only from confirmed contact (measured and model torque agree in sign and
        # exceed the threshold); friction terms only where the model says "free" (|T̂| small)
        thr = p[P_T_THR]
        tqf = state[S_TQF]
        gate_k = 0.0
        if tqf * T_hat > 0.0 and abs(tqf) > thr and abs(T_hat) > thr:
            r = tqf / (kappa * T_hat)
            if 0.5 < r < 2.0:
                gate_k = 1.0
        gate_f = 1.0 if abs(T_hat) < 0.1 * thr else 0.0
        h[1] = (T_hat / K_S) * p[P_EST_K] * gate_k
        h[2] = sg * p[P_EST_F] * gate_f
        h[3] = (omega_l / p[P_OMEGA_REF]) * p[P_EST_F] * gate_f
        y_hat = kappa * T_hat / K_S + state[S_TH + 2] * sg + state[S_TH + 3] * omega_l / p[P_OMEGA_REF]
        e = T_meas / K_S - y_hat
        a_f = 1.0
        if p[P_TAU_F] > 0.0:
            a_f = 1.0 - math.exp(-Ts / p[P_TAU_F])
        state[S_EF] = state[S_EF] + a_f * (e - state[S_EF])
        for i in range(NTH):
            state[S_HF + i] = state[S_HF + i] + a_f * (h[i] - state[S_HF + i])
        ef = state[S_EF]
        # Ph = P h_f
        Ph = np.zeros(NTH)
        for i in range(NTH):
            acc = 0.0
            for j in range(NTH):
                acc += state[S_PM + NTH * i + j] * state[S_HF + j]
            Ph[i] = acc
        rate = projection(delta, Ph[0] * ef, delta_max, p[P_EPS_DELTA])
        if ef == ef:
            kappa = kappa + Ts * Ph[1] * ef
            kappa = min(max(kappa, 0.25), 4.0)
            state[S_TH + 1] = kappa
            lim = 20.0 * p[P_THETA_DEF]
            a_ = state[S_TH + 2] + Ts * Ph[2] * ef
            b_ = state[S_TH + 3] + Ts * Ph[3] * ef
            state[S_TH + 2] = min(max(a_, -lim), lim)
            state[S_TH + 3] = min(max(b_, -lim), lim)
        # dP/dt = λ (P0 − P) − P h hᵀ P  (leakage towards P0 keeps P bounded and alive)
        lam = p[P_LAMBDA]
        pm = p[P_P_MAX]
        td = p[P_THETA_DEF]
        for i in range(NTH):
            for j in range(NTH):
                k = S_PM + NTH * i + j
                p0 = 0.0
                if i == j:
                    p0 = pm * p[P_Q_AUX] / (td * td) if i == 1 else (pm if i == 0 else pm * p[P_Q_AUX])
                v = state[k] + Ts * (lam * (p0 - state[k]) - Ph[i] * Ph[j])
                if v == v:
                    state[k] = v
        tq_in = T_meas
    else:
        e = (T_meas - T_hat) / K_S
        rate = projection(delta, p[P_GAMMA] * g * e, delta_max, p[P_EPS_DELTA])
        tq_in = T_meas
    if rate == rate:  # skip a NaN update (keeps δ̂ finite)
        delta = delta + Ts * rate
    if delta < 0.0:
        delta = 0.0
    if delta > delta_max:
        delta = delta_max
    state[S_DELTA] = delta

    # excitation monitor
    a_q = 1.0
    if p[P_TAU_F] > 0.0:
        a_q = 1.0 - math.exp(-Ts / max(p[P_TAU_F], 2e-3))
    state[S_TQF] = state[S_TQF] + a_q * (tq_in - state[S_TQF])
    side = state[S_SIDE]
    if state[S_TQF] > p[P_T_THR] and side < 0.5:
        if side < -0.5:
            state[S_TRAV] += 1.0
        state[S_SIDE] = 1.0
    elif state[S_TQF] < -p[P_T_THR] and side > -0.5:
        if side > 0.5:
            state[S_TRAV] += 1.0
        state[S_SIDE] = -1.0
    W = int(p[P_WINDOW])
    sigma = g * g
    if not sigma == sigma:
        sigma = 0.0
    idx = int(state[S_RING_IDX])
    state[S_SIGSUM] += sigma - state[N_STATE + idx]
    state[N_STATE + idx] = sigma
    idx += 1
    if idx >= W:
        idx = 0
    state[S_RING_IDX] = idx
    state[S_COUNT] += 1.0

    out[O_DELTA] = delta
    out[O_PHI] = phi
    out[O_OMEGA_HAT] = w_hat
    out[O_SIGMA_WIN] = state[S_SIGSUM] * Ts
    out[O_DTHETA] = dtheta
    out[O_TORQUE_HAT] = T_hat
    out[O_TORQUE_MEAS] = T_meas
    out[O_TRAV] = state[S_TRAV]


@njit(cache=True)
def deadzone_run(state, samples, params):
    """Run the estimator over a block: ``run(state, samples, params) -> (state, outputs)``.

    Parameters
    ----------
    state : numpy.ndarray
        Estimator state (see :func:`initial_state`); not modified.
    samples : numpy.ndarray
        Shape (n, 4): θ_m [rad], ω_m [rad/s], θ_l [rad], ω_l [rad/s] at the sample time T_s.
    params : numpy.ndarray
        Parameter array (see :class:`~drivelash.estimation.estimator.EstimatorConfig`).

    Returns
    -------
    state : numpy.ndarray
        State after the last sample (new array).
    outputs : numpy.ndarray
        Shape (n, 8): δ̂ [rad], φ̂ [rad/s²], ω̂_l [rad/s], σ-window integral [s], Δθ used [rad],
        T_l(x, δ̂) [N·m], J_l φ̂ [N·m], traversal count [-].
    """
    st = state.copy()
    n = samples.shape[0]
    out = np.empty((n, N_OUT))
    row = np.empty(N_OUT)
    for i in range(n):
        deadzone_step(st, samples[i, 0], samples[i, 1], samples[i, 2], samples[i, 3], params, row)
        for j in range(N_OUT):
            out[i, j] = row[j]
    return st, out


def initial_state(params: np.ndarray, delta0: float = 0.0) -> np.ndarray:
    """Fresh estimator state for ``params`` with δ̂(0) = ``delta0`` [rad]."""
    W = int(params[P_WINDOW])
    st = np.zeros(N_STATE + W, dtype=np.float64)
    st[S_DELTA] = min(max(delta0, 0.0), params[P_DELTA_MAX])
    st[S_P] = params[P_P_MAX] if params[P_METHOD] > 0.5 else 0.0
    st[S_TH + 1] = 1.0
    td = params[P_THETA_DEF]
    for i in range(NTH):
        q = 1.0 if i == 0 else params[P_Q_AUX]
        st[S_PM + NTH * i + i] = q * params[P_P_MAX] / (td * td if i == 1 else 1.0)
    return st
