"""Online deadzone estimation: STSMO + adaptive law (49–50) with projection (App. B), spec 01 §2.

Two methods share one kernel, :func:`deadzone_run`:

``method="paper"`` — the paper's plain gradient law, explicit Euler at the sample time::

    φ̂        from the STSMO on ω_l with a_known = −T_F,l(ω_l)/J_l   (exact sgn, as the paper)
    g         = ∂T_l/∂δ(x, δ̂) / K_S                                 (50), dimensionless
    e         = (J_l φ̂ − T_l(x, δ̂)) / K_S                           [rad]
    δ̂_k+1   = δ̂_k + T_s Proj{δ̂, γ g e}                             (49)

  (γ (J_l/K_S²) ∂T_l/∂δ [φ̂ − T_l/J_l] = γ g e, so γ is a rate [1/s]), Δθ = θ_m/N − θ_l
  straight from the (quantised) encoders.

``method="default"`` — five improvements, each switchable by its parameter:

1. *Sub-count position reconstruction*: Δθ̂ from a complementary filter that fuses the
   quantised Δθ (low frequencies, cut-off ω_c) with the integral of the measured
   Δω = ω_m/N − ω_l (high frequencies): Δθ̂ ← Δθ̂ + c (Δθ_k − Δθ̂), then the prediction
   Δθ̂ ← Δθ̂ + T_s Δω_k for the next sample, c = 1 − exp(−ω_c T_s). Quantisation error of
   two encoders that keep moving is a fast, zero-mean signal and averages out below ω_c;
   velocity noise integrates to a random walk that the position pulls back.
2. *Filtered residual and regressor*: e and the regressor pass through the same first-order
   low-pass (time constant τ_f), which removes the STSMO chattering from the law without a
   lag mismatch between them (the "filtered regressor" construction).
3. *Time-varying (least-squares) gain with leakage*: θ̂ += T_s P h_f e_f (δ component
   projected), dP/dt = λ (P0 − P) − P h_f h_fᵀ P. P starts at P0 (fast first convergence),
   shrinks while the law receives information (low steady-state noise) and leaks back
   towards P0 at rate λ, so that a later change of δ (wear) is tracked and P stays bounded
   when nothing is learned.
4. *Joint stiffness scale*: the model torque is κ T_l(x, δ̂) with κ = K_S,true/K_S learned
   alongside δ (θ = [δ, κ], regressor h = [κ ∂T_l/∂δ, T_l]/K_S, ∂/∂κ gated to confirmed
   contact where measured and model torque agree in sign and within a factor 2, κ ∈ [¼, 4],
   gain q·P0). A wrong K_S otherwise biases δ̂ by about half the contact deflection times
   the relative error (3.6 mrad on bench-1A with the paper's law).
5. *Gain reset*: when the filtered residual exceeds P_RESET_E·θ_def in informative samples
   (g_f² > ¼) without interruption for P_RESET_T, δ (or κ) has changed and P restarts at
   P0 — the least-squares gain had shrunk to its low-noise steady level (wear step, first
   convergence from a far-off δ0).

Option ``estimate_offset`` (P_EST_D1): δ1 joins θ (regressor κ ∂T_l/∂δ1 / K_S, gain
q_δ1·P_max, δ̂1 ∈ [−δ_max, δ_max]), for recordings where δ1 — the position of the lower
contact in Δθ — is not known (encoder zeros). Less accurate when δ1 is known (a friction
error shifts both contact points and the joint law follows); see
:meth:`~drivelash.estimation.estimator.DeadzoneEstimator.run` for the automatic check.
Slot 3 of θ and P is unused (a friction-error regressor was tried and dropped).

Output row k: δ̂ after the update, the other
columns at the sample (φ̂_k, ω̂_l,k before its update, Δθ used, T_l(x_k, δ̂_k) with δ̂ before
the update).

Both methods end every step with the hard bounds 0 ≤ δ̂ ≤ δ_max (the projection keeps δ̂
inside the ball of radius δ_max in continuous time; an Euler step could overshoot it).

Excitation monitor (both methods): σ_k = g_k² — the paper's σ(x) (45) evaluated at the
current estimate (σ(x, Λ) = (χ1 + χ2)²/π² = (∂T_l/∂δ/K_S)²; with the paper's Λ > δ_max it
would vanish for every physically reachable Δθ) — is summed over a sliding window of W
samples: ``sigma_window`` = ∫σ dt over the last W T_s seconds [s]. A *contact* is a
filtered shaft torque J_l φ̂ beyond ±T_thr; a *traversal* is a change of contact side
(positive ↔ negative). Excitation is sufficient when at least two traversals have been seen
and the σ-window integral exceeds ε_σ = 1 % of the window length
(:data:`drivelash.estimation.estimator.SIGMA_FRACTION_MIN`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from drivelash.physics.backlash import sgn

# -- parameter array layout ---------------------------------------------------------
P_J_L, P_N, P_K_S, P_D_S, P_T_CL, P_BETA_L, P_DELTA1, P_ALPHA = 0, 1, 2, 3, 4, 5, 6, 7
P_K1, P_K2, P_GAMMA, P_DELTA_MAX, P_EPS_DELTA, P_TS, P_METHOD = 8, 9, 10, 11, 12, 13, 14
P_OMEGA_C, P_TAU_F, P_LAMBDA, P_P_MAX, P_OMEGA_EPS, P_T_THR, P_WINDOW = 15, 16, 17, 18, 19, 20, 21
P_EST_K, P_EST_D1, P_Q_D1, P_THETA_DEF, P_Q_AUX = 22, 23, 24, 25, 26
#: derived entries (filled by :func:`derive_params`): per-sample filter constants and the
#: diagonal P0 of the least-squares gain
P_C_POS, P_A_F, P_A_Q, P_P0 = 27, 28, 29, 30
P_INV_N, P_INV_J, P_D_OVER_K, P_K_OVER_PI, P_INV_K, P_PROJ_C1, P_PROJ_C0 = 34, 35, 36, 37, 38, 39, 40
#: gain reset on a persistent residual: threshold (multiple of θ_def; 0 = off) and duration [s]
P_RESET_E, P_RESET_T = 41, 42
N_PARAMS = 43

# -- state array layout (followed by the σ ring buffer of W samples) -----------------
S_OMEGA_HAT, S_Z, S_DELTA, S_P, S_XHAT, S_INIT, S_EF, S_GF = 0, 1, 2, 3, 4, 5, 6, 7
S_TQF, S_SIDE, S_TRAV, S_SIGSUM, S_RING_IDX, S_COUNT = 8, 9, 10, 11, 12, 13
#: extended least squares (default method): θ = [δ, κ, a, b] at S_TH, filtered regressors at
#: S_HF, 4×4 gain matrix (row-major) at S_PM
NTH = 4
S_TH, S_HF, S_PM, S_PH, S_RESET = 16, 20, 24, 40, 44
N_STATE = 45

# -- output columns -----------------------------------------------------------------
O_DELTA, O_PHI, O_OMEGA_HAT, O_SIGMA_WIN, O_DTHETA, O_TORQUE_HAT, O_TORQUE_MEAS, O_TRAV = range(8)
N_OUT = 8

# -- input columns ------------------------------------------------------------------
I_THETA_M, I_OMEGA_M, I_THETA_L, I_OMEGA_L = 0, 1, 2, 3
N_IN = 4


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


@njit(cache=True, inline="always")
def _projection_fast(delta, tau, c1, c0):
    """:func:`projection` with h = c1 δ² − c0, c1 = (ε_δ+1)/(ε_δ δ_max²), c0 = 1/ε_δ precomputed."""
    h = c1 * delta * delta - c0
    if h < 0.0:
        return tau
    if delta * tau <= 0.0:  # h'(δ) = 2 c1 δ has the sign of δ
        return tau
    return tau * (1.0 - h)


@njit(cache=True, inline="always")
def _atan_diff(z, w):
    """atan(z) − atan(w) for z ≤ w with a single atan (branch-corrected addition formula)."""
    den = 1.0 + z * w
    if den > 0.0:
        return math.atan((z - w) / den)
    if den < 0.0:
        return math.atan((z - w) / den) - math.pi
    return -0.5 * math.pi


@njit(cache=True, error_model="numpy")
def deadzone_step(state, theta_m, omega_m, theta_l, omega_l, p, out, i_out):
    """One sample of the estimator, in place on ``state``; writes row ``i_out`` of ``out`` (n, N_OUT).

    ``p`` must come from :func:`~drivelash.estimation.estimator.build_params` (its derived
    entries P_C_POS, P_A_F, P_A_Q hold the per-sample filter constants).
    """
    J_l = p[P_J_L]
    delta1 = p[P_DELTA1]
    alpha = p[P_ALPHA]
    T_s = p[P_TS]
    default = p[P_METHOD] > 0.5
    delta_max = p[P_DELTA_MAX]
    thr = p[P_T_THR]

    est_d1 = default and p[P_EST_D1] > 0.5
    if est_d1:
        delta1 = state[S_TH + 2]

    # relative coordinates (8)–(9), load side
    inv_N = p[P_INV_N]
    dtheta_meas = theta_m * inv_N - theta_l
    domega = omega_m * inv_N - omega_l
    if state[S_INIT] < 0.5:
        state[S_XHAT] = dtheta_meas
        state[S_INIT] = 1.0
    if default and p[P_OMEGA_C] > 0.0:
        xhat = state[S_XHAT]
        xhat = xhat + p[P_C_POS] * (dtheta_meas - xhat)
        dtheta = xhat
        state[S_XHAT] = xhat + T_s * domega  # prediction for the next sample
    else:
        dtheta = dtheta_meas
        state[S_XHAT] = dtheta_meas

    # STSMO on the load velocity (16)–(21)
    if default and p[P_OMEGA_EPS] > 0.0:
        sg = math.tanh(omega_l / p[P_OMEGA_EPS])
    else:
        sg = sgn(omega_l)
    a_known = -(p[P_T_CL] * sg + p[P_BETA_L] * omega_l) * p[P_INV_J]
    w_hat = state[S_OMEGA_HAT]
    err = omega_l - w_hat
    s = sgn(err)
    phi = p[P_K1] * math.sqrt(abs(err)) * s + state[S_Z]
    state[S_OMEGA_HAT] = w_hat + T_s * (a_known + phi)
    state[S_Z] = state[S_Z] + T_s * p[P_K2] * s

    # model torque (12) and sensitivity (46)–(50), sharing the bracket of (11):
    # B = π + atan(α(Δθ − δ + δ1)) − atan(α(Δθ + δ1)),  K_BL = K_S B / π,  χ1 = ½(1 + sgn Δθ) B
    delta = state[S_DELTA]
    inv_K = p[P_INV_K]
    z = alpha * (dtheta - delta + delta1)
    w = alpha * (dtheta + delta1)
    bracket = math.pi + _atan_diff(z, w)
    pos = 0.5 * (1.0 + sgn(dtheta))
    arg = dtheta + delta1 - delta * pos + p[P_D_OVER_K] * domega
    T_hat = arg * p[P_K_OVER_PI] * bracket
    chi1 = pos * bracket
    chi2 = arg * alpha / (1.0 + z * z)
    g = -(chi1 + chi2) * (1.0 / math.pi)  # ∂T_l/∂δ / K_S
    T_meas = J_l * phi
    if default:
        kappa = state[S_TH + 1]
        # κ learns only from confirmed contact (measured and model torque agree in sign, exceed
        # the threshold and lie within a factor 2)
        tqf = state[S_TQF]
        gate_k = 0.0
        if tqf * T_hat > 0.0 and abs(tqf) > thr and abs(T_hat) > thr:
            r = tqf / (kappa * T_hat)
            if 0.5 < r < 2.0:
                gate_k = p[P_EST_K]
        h0 = kappa * g
        h1 = (T_hat * inv_K) * gate_k
        h2 = 0.0
        if est_d1:  # κ ∂T_l/∂δ1 / K_S = κ [B + arg α (1/(1+z²) − 1/(1+w²))] / π
            h2 = kappa * (bracket + arg * (alpha / (1.0 + z * z) - alpha / (1.0 + w * w))) * (1.0 / math.pi)
        h3 = 0.0
        y_hat = kappa * T_hat * inv_K
        e = T_meas * inv_K - y_hat
        a_f = p[P_A_F]
        ef = state[S_EF] + a_f * (e - state[S_EF])
        f0 = state[S_HF] + a_f * (h0 - state[S_HF])
        f1 = state[S_HF + 1] + a_f * (h1 - state[S_HF + 1])
        f2 = state[S_HF + 2] + a_f * (h2 - state[S_HF + 2])
        f3 = state[S_HF + 3] + a_f * (h3 - state[S_HF + 3])
        state[S_EF] = ef
        state[S_HF] = f0
        state[S_HF + 1] = f1
        state[S_HF + 2] = f2
        state[S_HF + 3] = f3
        # P h_f (P symmetric 4×4, row-major at S_PM; slot 3 unused, h3 = 0). Without the
        # offset (P_EST_D1 = 0) h2 = 0 forever, the coupling entries stay 0 and the 2×2
        # block is exact.
        q = S_PM
        full = est_d1
        if full:
            ph0 = state[q] * f0 + state[q + 1] * f1 + state[q + 2] * f2 + state[q + 3] * f3
            ph1 = state[q + 4] * f0 + state[q + 5] * f1 + state[q + 6] * f2 + state[q + 7] * f3
            ph2 = state[q + 8] * f0 + state[q + 9] * f1 + state[q + 10] * f2 + state[q + 11] * f3
            ph3 = state[q + 12] * f0 + state[q + 13] * f1 + state[q + 14] * f2 + state[q + 15] * f3
        else:
            ph0 = state[q] * f0 + state[q + 1] * f1
            ph1 = state[q + 4] * f0 + state[q + 5] * f1
            ph2 = 0.0
            ph3 = 0.0
        # gain reset: a residual beyond P_RESET_E·θ_def that persists for P_RESET_T in
        # informative samples means δ (or κ) has changed — restart from P0 (wear, a swap)
        if p[P_RESET_E] > 0.0:
            if abs(ef) > p[P_RESET_E] * p[P_THETA_DEF] and f0 * f0 > 0.25:
                state[S_RESET] += T_s
            else:
                state[S_RESET] = 0.0
            if state[S_RESET] > p[P_RESET_T]:
                state[S_RESET] = 0.0
                for i in range(NTH):
                    for j in range(NTH):
                        state[S_PM + NTH * i + j] = p[P_P0 + i] if i == j else 0.0
                ph0 = state[q] * f0 + state[q + 1] * f1 + state[q + 2] * f2 + state[q + 3] * f3
                ph1 = state[q + 4] * f0 + state[q + 5] * f1 + state[q + 6] * f2 + state[q + 7] * f3
                ph2 = state[q + 8] * f0 + state[q + 9] * f1 + state[q + 10] * f2 + state[q + 11] * f3
                ph3 = 0.0
        rate = _projection_fast(delta, ph0 * ef, p[P_PROJ_C1], p[P_PROJ_C0])
        if ef == ef:
            kappa = kappa + T_s * ph1 * ef
            kappa = min(max(kappa, 0.25), 4.0)
            state[S_TH + 1] = kappa
            if full:
                d1 = state[S_TH + 2] + T_s * ph2 * ef
                state[S_TH + 2] = min(max(d1, -delta_max), delta_max)
        # dP/dt = λ (P0 − P) − P h hᵀ P  (leakage towards P0 keeps P bounded and alive)
        lam_ts = p[P_LAMBDA] * T_s
        if full:
            state[S_PH] = ph0
            state[S_PH + 1] = ph1
            state[S_PH + 2] = ph2
            state[S_PH + 3] = ph3
            for i in range(NTH):
                for j in range(NTH):
                    k = S_PM + NTH * i + j
                    p0 = p[P_P0 + i] if i == j else 0.0
                    v = state[k] + lam_ts * (p0 - state[k]) - T_s * state[S_PH + i] * state[S_PH + j]
                    if v == v:
                        state[k] = v
        else:
            v00 = state[q] + lam_ts * (p[P_P0] - state[q]) - T_s * ph0 * ph0
            v01 = state[q + 1] - lam_ts * state[q + 1] - T_s * ph0 * ph1
            v11 = state[q + 5] + lam_ts * (p[P_P0 + 1] - state[q + 5]) - T_s * ph1 * ph1
            if v00 == v00 and v01 == v01 and v11 == v11:
                state[q] = v00
                state[q + 1] = v01
                state[q + 4] = v01
                state[q + 5] = v11
    else:
        e = (T_meas - T_hat) * inv_K
        rate = _projection_fast(delta, p[P_GAMMA] * g * e, p[P_PROJ_C1], p[P_PROJ_C0])
    if rate == rate:  # skip a NaN update (keeps δ̂ finite)
        delta = delta + T_s * rate
    if delta < 0.0:
        delta = 0.0
    if delta > delta_max:
        delta = delta_max
    state[S_DELTA] = delta

    # excitation monitor
    tq = state[S_TQF] + p[P_A_Q] * (T_meas - state[S_TQF])
    state[S_TQF] = tq
    side = state[S_SIDE]
    if tq > thr and side < 0.5:
        if side < -0.5:
            state[S_TRAV] += 1.0
        state[S_SIDE] = 1.0
    elif tq < -thr and side > -0.5:
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

    out[i_out, O_DELTA] = delta
    out[i_out, O_PHI] = phi
    out[i_out, O_OMEGA_HAT] = w_hat
    out[i_out, O_SIGMA_WIN] = state[S_SIGSUM] * T_s
    out[i_out, O_DTHETA] = dtheta
    out[i_out, O_TORQUE_HAT] = T_hat
    out[i_out, O_TORQUE_MEAS] = T_meas
    out[i_out, O_TRAV] = state[S_TRAV]


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
    out = np.empty((samples.shape[0], N_OUT))
    st = deadzone_run_into(state, samples, params, out)
    return st, out


@njit(cache=True, error_model="numpy")
def deadzone_run_into(state, samples, params, out):
    """As :func:`deadzone_run`, writing into a caller-provided ``out`` (n, N_OUT); returns the new state.

    For streaming use: a reused output buffer avoids allocating (and page-faulting) fresh
    memory for every block.
    """
    st = state.copy()
    n = samples.shape[0]
    for i in range(n):
        deadzone_step(st, samples[i, 0], samples[i, 1], samples[i, 2], samples[i, 3], params, out, i)
    return st


def derive_params(p: np.ndarray) -> np.ndarray:
    """Fill the derived entries of a parameter array in place (and return it).

    P_C_POS = 1 − exp(−ω_c T_s) (complementary filter), P_A_F = 1 − exp(−T_s/τ_f) (residual
    filter), P_A_Q = 1 − exp(−T_s/max(τ_f, 2 ms)) (torque filter of the excitation monitor),
    P_P0 … P_P0+3 = diagonal of P0: [P_max, q P_max/θ_def², q P_max, q P_max].
    """
    T_s = p[P_TS]
    p[P_C_POS] = 1.0 - math.exp(-p[P_OMEGA_C] * T_s) if p[P_OMEGA_C] > 0 else 1.0
    p[P_A_F] = 1.0 - math.exp(-T_s / p[P_TAU_F]) if p[P_TAU_F] > 0 else 1.0
    p[P_A_Q] = 1.0 - math.exp(-T_s / max(p[P_TAU_F], 2e-3)) if p[P_TAU_F] > 0 else 1.0
    p[P_INV_N] = 1.0 / p[P_N]
    p[P_INV_J] = 1.0 / p[P_J_L]
    p[P_D_OVER_K] = p[P_D_S] / p[P_K_S]
    p[P_K_OVER_PI] = p[P_K_S] / math.pi
    p[P_INV_K] = 1.0 / p[P_K_S]
    eps, dmax = p[P_EPS_DELTA], p[P_DELTA_MAX]
    p[P_PROJ_C1] = (eps + 1.0) / (eps * dmax * dmax)
    p[P_PROJ_C0] = 1.0 / eps
    pm, q, td = p[P_P_MAX], p[P_Q_AUX], p[P_THETA_DEF]
    p[P_P0] = pm
    p[P_P0 + 1] = q * pm / (td * td)
    p[P_P0 + 2] = p[P_Q_D1] * pm
    p[P_P0 + 3] = 0.0
    return p


def initial_state(params: np.ndarray, delta0: float = 0.0) -> np.ndarray:
    """Fresh estimator state for ``params`` with δ̂(0) = ``delta0`` [rad]."""
    W = int(params[P_WINDOW])
    st = np.zeros(N_STATE + W, dtype=np.float64)
    st[S_DELTA] = min(max(delta0, 0.0), params[P_DELTA_MAX])
    st[S_P] = params[P_P_MAX] if params[P_METHOD] > 0.5 else 0.0
    st[S_TH + 1] = 1.0
    st[S_TH + 2] = params[P_DELTA1]
    for i in range(NTH):
        st[S_PM + NTH * i + i] = params[P_P0 + i]
    return st
