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
inside the ball of radius δ_max in continuous time; an Euler step could overshoot it). The
default method's switch ``P_BOUND`` adds two data-consistency bounds: while a contact torque
is confirmed, a flank no further out than the largest (smallest) Δθ ever seen; and the *flank
recovery* — a confirmed contact torque that the model does not show for ``P_RESET_T``, once
the gap was crossed twice, puts the flank at the current Δθ (the law has no gradient inside
its modelled gap, so an overshoot past the Δθ the motion reaches in contact would stay).

A sample is :func:`_observe` (Δθ, the STSMO, the motor-side observer, the filtered shaft
torque: nothing that depends on δ̂) followed by :func:`_law`; :func:`deadzone_run2_into` runs
two laws that observe alike (the chosen law and the δ1 check) over one observation.

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

from drivelash.errors import DataError, ParameterError
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
#: shaft-torque source (0: load observer J_l φ̂; 1: motor side −N J_m φ̂_m from the recorded
#: motor torque, when the samples carry it), motor-side parameters and observer gains
P_TSRC, P_J_M, P_T_CM, P_BETA_M, P_K1M, P_K2M, P_INV_JM = 43, 44, 45, 46, 47, 48, 49
#: torque-offset learning inside the gap: rate [1/s] (0 = off), speed threshold [rad/s]
#: (load side), margin as a fraction of the modelled gap
P_LAM_G, P_OMEGA_G, P_GAP_M = 50, 51, 52
#: first sample index of the verdict accumulators; time constant of the torque filter [s]
P_K0, P_TAU_Q = 53, 54
#: contact-consistency bound on δ̂ (and δ̂1) on/off
P_BOUND = 55
N_PARAMS = 56

# -- state array layout (followed by the σ ring buffer of W samples) -----------------
S_OMEGA_HAT, S_Z, S_DELTA, S_P, S_XHAT, S_INIT, S_EF, S_GF = 0, 1, 2, 3, 4, 5, 6, 7
S_TQF, S_SIDE, S_TRAV, S_SIGSUM, S_RING_IDX, S_COUNT = 8, 9, 10, 11, 12, 13
#: motor-side observer [ω̂_m, z_m]
S_OMEGA_M_HAT, S_Z_M = 14, 15
#: extended least squares (default method): θ = [δ, κ, δ1, -] at S_TH, filtered regressors at
#: S_HF, 4×4 gain matrix (row-major) at S_PM
NTH = 4
S_TH, S_HF, S_PM, S_PH, S_RESET = 16, 20, 24, 40, 44
#: gap-learnt torque offsets for positive / negative speed [N·m] and the time spent in the gap [s]
S_FP, S_FN, S_GAPT = 45, 46, 47
#: Δθ where the current contact side was entered, and the range of Δθ seen [rad]
S_DSIDE, S_DTH_MIN, S_DTH_MAX = 48, 49, 50
#: accumulators from sample P_K0 on: count, Σ e_f², Σ (δ̂ − δ̂_K0), Σ (δ̂ − δ̂_K0)², δ̂_K0
S_ACC_N, S_ACC_E2, S_ACC_D, S_ACC_D2, S_ACC_REF = 51, 52, 53, 54, 55
#: contact samples from P_K0 on: count, Σ T², Σ |T|
S_CON_N, S_CON_T2, S_CON_T = 56, 57, 58
#: motor vs load shaft torque (moving load, from P_K0 on): n, Σd, Σd·s, Σs, Σs², Σd², with
#: d = T_motor − J_l φ̂ (filtered) and s = sgn ω_l; filtered load torque
S_DIS_N, S_DIS_D, S_DIS_DS, S_DIS_S, S_DIS_SS, S_DIS_DD, S_TQF_L = 59, 60, 61, 62, 63, 64, 65
#: torque-sign changes beyond ±T_thr regardless of Δθ (count, side), peak |filtered torque|
S_RAW_TRAV, S_RAW_SIDE, S_PEAK_TQ = 66, 67, 68
#: filtered residual in lower / upper contact from P_K0 on: Σ e_f², count (each side)
S_E2_LO, S_N_LO, S_E2_HI, S_N_HI = 69, 70, 71, 72
#: time [s] for which a confirmed contact torque has been measured where the model sees none
#: (signed: > 0 upper contact, < 0 lower contact) and the model torque κ T_l filtered as the
#: measured one (the flank-recovery bound)
S_NOCON_T, S_TQM = 73, 74
N_STATE = 75

# -- output columns -----------------------------------------------------------------
O_DELTA, O_PHI, O_OMEGA_HAT, O_SIGMA_WIN, O_DTHETA, O_TORQUE_HAT, O_TORQUE_MEAS, O_TRAV, O_DELTA1 = range(9)
N_OUT = 9

# -- input columns ------------------------------------------------------------------
I_THETA_M, I_OMEGA_M, I_THETA_L, I_OMEGA_L, I_TORQUE_M = 0, 1, 2, 3, 4
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
def deadzone_step(state, theta_m, omega_m, theta_l, omega_l, u, p, out, i_out):
    """One sample of the estimator, in place on ``state``; writes row ``i_out`` of ``out`` (n, N_OUT).

    ``u`` is the recorded motor torque [N·m] (NaN when the recording has none; the shaft
    torque then comes from the load observer). ``p`` must come from
    :func:`~drivelash.estimation.estimator.build_params` (derived entries filled).
    The sample is :func:`_observe` (what does not depend on δ̂) followed by :func:`_law`.
    """
    obs = _observe(state, theta_m, omega_m, theta_l, omega_l, u, p)
    _law(state, obs, omega_l, p, out, i_out)


#: Entries of the parameter array that :func:`_observe` reads: two laws whose arrays agree on
#: them observe a recording identically (:func:`deadzone_run2_into` observes it once for both).
OBSERVE_PARAMS = (
    P_J_L, P_N, P_T_CL, P_BETA_L, P_K1, P_K2, P_TS, P_METHOD, P_OMEGA_C, P_OMEGA_EPS, P_TSRC,
    P_T_CM, P_BETA_M, P_K1M, P_K2M, P_C_POS, P_A_Q, P_INV_N, P_INV_J, P_INV_JM,
)  # fmt: skip
#: State entries that :func:`_observe` alone writes (copied to the second law's state after
#: :func:`deadzone_run2_into`).
OBSERVE_STATE = (
    S_XHAT, S_INIT, S_DTH_MIN, S_DTH_MAX, S_OMEGA_HAT, S_Z, S_OMEGA_M_HAT, S_Z_M, S_TQF,
)  # fmt: skip


@njit(cache=True, error_model="numpy", inline="always")
def _observe(state, theta_m, omega_m, theta_l, omega_l, u, p):
    """The part of a sample that does not depend on δ̂ (nor on the law's other parameters):
    Δθ (reconstructed in the default method) and its range, the STSMO on ω_l, the motor-side
    observer and the filtered shaft torque; updates the :data:`OBSERVE_STATE` entries.

    Returns (Δθ, Δω, φ̂, ω̂_l before the update, J_l φ̂, shaft torque of the chosen source,
    speed on that side, motor source used, filtered shaft torque, smallest and largest Δθ).
    """
    J_l = p[P_J_L]
    T_s = p[P_TS]
    default = p[P_METHOD] > 0.5

    # relative coordinates (8)–(9), load side
    inv_N = p[P_INV_N]
    dtheta_meas = theta_m * inv_N - theta_l
    domega = omega_m * inv_N - omega_l
    if state[S_INIT] < 0.5:
        state[S_XHAT] = dtheta_meas
        state[S_INIT] = 1.0
        state[S_DTH_MIN] = dtheta_meas
        state[S_DTH_MAX] = dtheta_meas
    if default and p[P_OMEGA_C] > 0.0:
        xhat = state[S_XHAT]
        xhat = xhat + p[P_C_POS] * (dtheta_meas - xhat)
        dtheta = xhat
        state[S_XHAT] = xhat + T_s * domega  # prediction for the next sample
    else:
        dtheta = dtheta_meas
        state[S_XHAT] = dtheta_meas
    if dtheta < state[S_DTH_MIN]:
        state[S_DTH_MIN] = dtheta
    if dtheta > state[S_DTH_MAX]:
        state[S_DTH_MAX] = dtheta

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
    T_load = J_l * phi

    # shaft torque from the motor side: the same observer on ω_m with the recorded torque,
    # J_m ω̇_m = u − T_F,m(ω_m) − T_l/N, so that −N J_m φ̂_m estimates T_l without the
    # load-side parameters (J_l, T_C,l, β_l) and with any external load torque included
    motor = default and p[P_TSRC] > 0.5 and u == u
    if motor:
        a_m = (u - p[P_T_CM] * sgn(omega_m) - p[P_BETA_M] * omega_m) * p[P_INV_JM]
        wm_hat = state[S_OMEGA_M_HAT]
        err_m = omega_m - wm_hat
        s_m = sgn(err_m)
        phi_m = p[P_K1M] * math.sqrt(abs(err_m)) * s_m + state[S_Z_M]
        state[S_OMEGA_M_HAT] = wm_hat + T_s * (a_m + phi_m)
        state[S_Z_M] = state[S_Z_M] + T_s * p[P_K2M] * s_m
        T_raw = -p[P_N] * phi_m / p[P_INV_JM]
        v_side = omega_m * inv_N
    else:
        T_raw = T_load
        v_side = omega_l

    # filtered shaft torque of the chosen source (excitation monitor, κ gate, offsets)
    tq_raw = state[S_TQF] + p[P_A_Q] * (T_raw - state[S_TQF])
    state[S_TQF] = tq_raw
    return (
        dtheta, domega, phi, w_hat, T_load, T_raw, v_side, motor, tq_raw,
        state[S_DTH_MIN], state[S_DTH_MAX],
    )  # fmt: skip


@njit(cache=True, error_model="numpy", inline="always")
def _law(state, obs, omega_l, p, out, i_out):
    """The part of a sample that depends on δ̂: model torque, adaptive law, bounds, excitation
    monitor and verdict accumulators, from :func:`_observe`'s ``obs``; writes row ``i_out``."""
    dtheta, domega, phi, w_hat, T_load, T_raw, v_side, motor, tq_raw, dth_min, dth_max = obs
    delta1 = p[P_DELTA1]
    alpha = p[P_ALPHA]
    T_s = p[P_TS]
    default = p[P_METHOD] > 0.5
    delta_max = p[P_DELTA_MAX]
    thr = p[P_T_THR]
    k_idx = state[S_COUNT]
    acc = k_idx >= p[P_K0]

    est_d1 = default and p[P_EST_D1] > 0.5
    if est_d1:
        delta1 = state[S_TH + 2]

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

    lo = -delta1
    hi = delta - delta1
    # torque offset learnt in the gap, where the shaft carries no torque: what the source
    # shows there is the error of its friction model (or a constant load such as gravity on
    # the load observer), per direction of motion
    fhat = 0.0
    if default and p[P_LAM_G] > 0.0:
        m = p[P_GAP_M] * (hi - lo)
        if m < 3.0 * p[P_THETA_DEF]:
            m = 3.0 * p[P_THETA_DEF]
        if dtheta > lo + m and dtheta < hi - m:
            state[S_GAPT] += T_s
        else:
            state[S_GAPT] = 0.0
        if state[S_GAPT] > 3.0 * p[P_TAU_F]:
            ag = p[P_LAM_G] * T_s
            if v_side > p[P_OMEGA_G]:
                state[S_FP] += ag * (tq_raw - state[S_FP])
            elif v_side < -p[P_OMEGA_G]:
                state[S_FN] += ag * (tq_raw - state[S_FN])
        sp = 0.5 * (1.0 + math.tanh(v_side / p[P_OMEGA_G]))
        fhat = sp * state[S_FP] + (1.0 - sp) * state[S_FN]
    T_meas = T_raw - fhat
    tq = tq_raw - fhat

    if default:
        kappa = state[S_TH + 1]
        # κ learns only from confirmed contact (measured and model torque agree in sign, exceed
        # the threshold and lie within a factor 2)
        gate_k = 0.0
        if tq * T_hat > 0.0 and abs(tq) > thr and abs(T_hat) > thr:
            r = tq / (kappa * T_hat)
            if 0.5 < r < 2.0:
                gate_k = p[P_EST_K]
        h0 = kappa * g
        h1 = (T_hat * inv_K) * gate_k
        h2 = 0.0
        if est_d1:  # κ ∂T_l/∂δ1 / K_S = κ [B + arg α (1/(1+z²) − 1/(1+w²))] / π
            h2 = kappa * (bracket + arg * (alpha / (1.0 + z * z) - alpha / (1.0 + w * w))) * (1.0 / math.pi)
        y_hat = kappa * T_hat * inv_K
        e = T_meas * inv_K - y_hat
        a_f = p[P_A_F]
        ef = state[S_EF] + a_f * (e - state[S_EF])
        f0 = state[S_HF] + a_f * (h0 - state[S_HF])
        f1 = state[S_HF + 1] + a_f * (h1 - state[S_HF + 1])
        f2 = state[S_HF + 2] + a_f * (h2 - state[S_HF + 2])
        state[S_EF] = ef
        state[S_HF] = f0
        state[S_HF + 1] = f1
        state[S_HF + 2] = f2
        # gain reset: a residual beyond P_RESET_E·θ_def that persists for P_RESET_T in
        # informative samples means δ (or κ) has changed — restart from P0 (wear, a swap)
        q = S_PM
        if p[P_RESET_E] > 0.0:
            if abs(ef) > p[P_RESET_E] * p[P_THETA_DEF] and f0 * f0 > 0.25:
                state[S_RESET] += T_s
            else:
                state[S_RESET] = 0.0
            if state[S_RESET] > p[P_RESET_T]:
                state[S_RESET] = 0.0
                for i in range(NTH):
                    for j in range(NTH):
                        state[q + NTH * i + j] = p[P_P0 + i] if i == j else 0.0
        # P h_f (P symmetric, row-major at S_PM; the 3rd row/column only with the offset,
        # slot 3 unused). Normalised (Sherman–Morrison) least-squares step: the information
        # T_s h hᵀ of one sample is added exactly, so P stays positive definite and the step
        # bounded however large h gets (the damping term of (12) makes χ2 spike when a
        # wrong contact point is crossed at speed).
        ph0 = state[q] * f0 + state[q + 1] * f1
        ph1 = state[q + 4] * f0 + state[q + 5] * f1
        ph2 = 0.0
        if est_d1:
            ph0 += state[q + 2] * f2
            ph1 += state[q + 6] * f2
            ph2 = state[q + 8] * f0 + state[q + 9] * f1 + state[q + 10] * f2
        inv_den = 1.0 / (1.0 + T_s * (f0 * ph0 + f1 * ph1 + f2 * ph2))
        rate = _projection_fast(delta, ph0 * ef * inv_den, p[P_PROJ_C1], p[P_PROJ_C0])
        if ef == ef and inv_den == inv_den:
            kappa = kappa + T_s * ph1 * ef * inv_den
            kappa = min(max(kappa, 0.25), 4.0)
            state[S_TH + 1] = kappa
            if est_d1:
                d1 = state[S_TH + 2] + T_s * ph2 * ef * inv_den
                state[S_TH + 2] = min(max(d1, -delta_max), delta_max)
            # dP/dt = λ (P0 − P) − P h hᵀ P / (1 + T_s hᵀ P h)  (leakage keeps P bounded and alive)
            lam_ts = p[P_LAMBDA] * T_s
            c = T_s * inv_den
            v00 = state[q] + lam_ts * (p[P_P0] - state[q]) - c * ph0 * ph0
            v01 = state[q + 1] - lam_ts * state[q + 1] - c * ph0 * ph1
            v11 = state[q + 5] + lam_ts * (p[P_P0 + 1] - state[q + 5]) - c * ph1 * ph1
            state[q] = v00
            state[q + 1] = v01
            state[q + 4] = v01
            state[q + 5] = v11
            if est_d1:
                v02 = state[q + 2] - lam_ts * state[q + 2] - c * ph0 * ph2
                v12 = state[q + 6] - lam_ts * state[q + 6] - c * ph1 * ph2
                v22 = state[q + 10] + lam_ts * (p[P_P0 + 2] - state[q + 10]) - c * ph2 * ph2
                state[q + 2] = v02
                state[q + 8] = v02
                state[q + 6] = v12
                state[q + 9] = v12
                state[q + 10] = v22
        if acc:
            state[S_ACC_E2] += ef * ef
            if tq < -thr:
                state[S_E2_LO] += ef * ef
                state[S_N_LO] += 1.0
            elif tq > thr:
                state[S_E2_HI] += ef * ef
                state[S_N_HI] += 1.0
    else:
        e = (T_meas - T_hat) * inv_K
        rate = _projection_fast(delta, p[P_GAMMA] * g * e, p[P_PROJ_C1], p[P_PROJ_C0])
        if acc:
            state[S_ACC_E2] += e * e
    if rate == rate:  # skip a NaN update (keeps δ̂ finite)
        delta = delta + T_s * rate
    if default and p[P_BOUND] > 0.5:
        # data consistency: while a contact torque is confirmed, the contact point of that
        # side cannot lie beyond every Δθ seen so far (the upper one δ − δ1 above the largest
        # Δθ, the lower one −δ1 below the smallest). Without this bound an estimate that
        # overshot the data range receives no gradient (the model sees no contact anywhere)
        # and stays there; inside the range it never acts.
        if tq > 2.0 * thr and delta - delta1 > dth_max:
            delta = dth_max + delta1
        if est_d1 and tq < -2.0 * thr and -delta1 < dth_min:
            state[S_TH + 2] = -dth_min
        # flank recovery: a confirmed contact torque on the far side of the modelled gap's
        # centre that the model does not show (κ T_l, filtered as the measured torque, below
        # T_thr: the modelled flank lies beyond the current Δθ) for longer than P_RESET_T
        # places the flank too far out. The law receives no gradient there (∂T_l/∂δ = 0
        # inside the modelled gap), so an estimate that overshot past the Δθ the motion
        # reaches in contact stays there, whatever the largest Δθ ever seen (a start-up
        # transient) allows. The flank is then put at the current Δθ, which a contact torque
        # shows to lie at or beyond the true flank; the law refines it from there.
        tqm = state[S_TQM] + p[P_A_Q] * (state[S_TH + 1] * T_hat - state[S_TQM])
        state[S_TQM] = tqm
        mid_m = 0.5 * (delta - 2.0 * delta1)
        if state[S_TRAV] < 2.0:
            state[S_NOCON_T] = 0.0
        elif tq > 2.0 * thr and dtheta > mid_m and tqm < thr:
            if state[S_NOCON_T] < 0.0:
                state[S_NOCON_T] = 0.0
            state[S_NOCON_T] += T_s
            if state[S_NOCON_T] > p[P_RESET_T] and delta - delta1 > dtheta:
                delta = dtheta + delta1
                state[S_NOCON_T] = 0.0
        elif est_d1 and tq < -2.0 * thr and dtheta < mid_m and tqm > -thr:
            if state[S_NOCON_T] > 0.0:
                state[S_NOCON_T] = 0.0
            state[S_NOCON_T] -= T_s
            if state[S_NOCON_T] < -p[P_RESET_T] and -delta1 < dtheta:
                state[S_TH + 2] = -dtheta
                state[S_NOCON_T] = 0.0
        else:
            state[S_NOCON_T] = 0.0
    if delta < 0.0:
        delta = 0.0
    if delta > delta_max:
        delta = delta_max
    state[S_DELTA] = delta

    # excitation monitor: a contact side is a filtered shaft torque beyond ±T_thr on the
    # matching side of the modelled gap's centre; a traversal is a change of contact side
    # after Δθ moved by at least half the estimated gap from the outermost point of the other
    # side (the gap was crossed, not merely the torque reversed while one flank kept the load)
    mid = 0.5 * (lo + hi)
    side = state[S_SIDE]
    # S_DSIDE: the outermost Δθ reached on the current side (robust to a side entered early)
    if side > 0.5 and dtheta > state[S_DSIDE]:
        state[S_DSIDE] = dtheta
    elif side < -0.5 and dtheta < state[S_DSIDE]:
        state[S_DSIDE] = dtheta
    if tq > thr and side < 0.5 and dtheta > mid:
        if side < -0.5 and dtheta - state[S_DSIDE] >= 0.5 * (hi - lo):
            state[S_TRAV] += 1.0
        state[S_SIDE] = 1.0
        state[S_DSIDE] = dtheta
    elif tq < -thr and side > -0.5 and dtheta < mid:
        if side > 0.5 and state[S_DSIDE] - dtheta >= 0.5 * (hi - lo):
            state[S_TRAV] += 1.0
        state[S_SIDE] = -1.0
        state[S_DSIDE] = dtheta
    raw = state[S_RAW_SIDE]
    if tq > thr and raw < 0.5:
        if raw < -0.5:
            state[S_RAW_TRAV] += 1.0
        state[S_RAW_SIDE] = 1.0
    elif tq < -thr and raw > -0.5:
        if raw > 0.5:
            state[S_RAW_TRAV] += 1.0
        state[S_RAW_SIDE] = -1.0
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

    # verdict accumulators (from sample P_K0 on; sequential sums, so chunking cannot change them)
    if acc:
        if state[S_ACC_N] == 0.0:
            state[S_ACC_REF] = delta
        state[S_ACC_N] += 1.0
        dd = delta - state[S_ACC_REF]
        state[S_ACC_D] += dd
        state[S_ACC_D2] += dd * dd
        if abs(tq) > thr:
            state[S_CON_N] += 1.0
            state[S_CON_T2] += tq * tq
            state[S_CON_T] += abs(tq)
        if abs(tq) > state[S_PEAK_TQ]:
            state[S_PEAK_TQ] = abs(tq)
        if motor:
            tl = state[S_TQF_L] + p[P_A_Q] * (T_load - state[S_TQF_L])
            state[S_TQF_L] = tl
            if abs(omega_l) > p[P_OMEGA_G]:
                d = tq - tl
                sl = 1.0 if omega_l > 0.0 else -1.0
                state[S_DIS_N] += 1.0
                state[S_DIS_D] += d
                state[S_DIS_DS] += d * sl
                state[S_DIS_S] += sl
                state[S_DIS_SS] += 1.0
                state[S_DIS_DD] += d * d
    elif motor:
        state[S_TQF_L] += p[P_A_Q] * (T_load - state[S_TQF_L])
    state[S_COUNT] = k_idx + 1.0

    out[i_out, O_DELTA] = delta
    out[i_out, O_PHI] = phi
    out[i_out, O_OMEGA_HAT] = w_hat
    out[i_out, O_SIGMA_WIN] = state[S_SIGSUM] * T_s
    out[i_out, O_DTHETA] = dtheta
    out[i_out, O_TORQUE_HAT] = T_hat
    out[i_out, O_TORQUE_MEAS] = T_meas
    out[i_out, O_TRAV] = state[S_TRAV]
    out[i_out, O_DELTA1] = delta1


def _describe(a: object) -> str:
    """``float64 array of shape (3,)`` / ``list``: what was given, for a message."""
    if isinstance(a, np.ndarray):
        layout = "" if a.flags.c_contiguous else "non-contiguous "
        return f"{layout}{a.dtype} array of shape {a.shape}"
    return type(a).__name__


def state_length(params: np.ndarray) -> int:
    """Length of the state of ``params``: :data:`N_STATE` + the σ window (as :func:`initial_state`)."""
    return N_STATE + int(params[P_WINDOW])


def _float_vector(x: object, n: int, owner: str, name: str, what: str = "") -> np.ndarray:
    """``x`` if it is a C-contiguous float64 array of shape (n,), else a one-line ParameterError."""
    if not (isinstance(x, np.ndarray) and x.dtype == np.float64 and x.shape == (n,) and x.flags.c_contiguous):
        raise ParameterError(
            owner, name, f"expected a C-contiguous float64 array of shape ({n},){what}, got {_describe(x)}"
        )
    return x


def check_params(params: object, owner: str = "deadzone_run") -> np.ndarray:
    """``params`` if it is a C-contiguous float64 array of shape (:data:`N_PARAMS`,), else a one-line
    :class:`~drivelash.errors.ParameterError` (O(1))."""
    return _float_vector(params, N_PARAMS, owner, "params")


def check_state(state: object, params: np.ndarray, owner: str = "deadzone_run") -> np.ndarray:
    """``state`` if it is a C-contiguous float64 array of the exact length of ``params``' state
    (:func:`state_length`: the σ window depends on T_s), else a one-line
    :class:`~drivelash.errors.ParameterError` naming the expected and the given shape (O(1))."""
    n = state_length(params)
    what = f" (initial_state of these parameters: {N_STATE} + σ window {n - N_STATE})"
    return _float_vector(state, n, owner, "state", what)


#: input column names, in the kernel's order (:data:`I_THETA_M` …)
INPUT_COLUMNS = ("theta_m", "omega_m", "theta_l", "omega_l", "torque_m")


def check_samples(samples: object, name: str = "samples") -> np.ndarray:
    """``samples`` if it is a C-contiguous float64 array of shape (n, 4) or (n, 5) — columns
    θ_m, ω_m, θ_l, ω_l[, torque_m] — else a one-line :class:`~drivelash.errors.DataError`
    naming the argument, the expected and the given shape (O(1)).

    A transposed block (4, n) or (5, n) is refused unless n is itself 4 or 5 (indistinguishable).
    """
    if not (
        isinstance(samples, np.ndarray)
        and samples.dtype == np.float64
        and samples.ndim == 2
        and samples.shape[1] in (N_IN, N_IN + 1)
        and samples.flags.c_contiguous
    ):
        raise DataError(
            f"{name}: expected a C-contiguous float64 array of shape (n, 4) or (n, 5) with columns "
            f"θ_m, ω_m, θ_l, ω_l[, torque_m], got {_describe(samples)}"
        )
    return samples


def nonfinite_message(
    value: float, i: int, inputs: str = "θ_m, ω_m, θ_l and ω_l", owner: str = "estimator"
) -> str:
    """The message of a non-finite input at 0-based sample ``i`` of a call to a stateful
    ``owner`` (the deadzone estimator; the super-twisting observer names its own inputs)."""
    return (
        f"sample {i} (0-based in this call) is {value}: {inputs} must be finite "
        f"(a NaN would stay in the {owner} state); nothing was run, the state is unchanged"
    )


def check_finite(samples: np.ndarray) -> np.ndarray:
    """``samples`` (checked by :func:`check_samples`) if θ_m, ω_m, θ_l and ω_l are finite in
    every row, else a one-line :class:`~drivelash.errors.DataError` naming the column and the
    0-based sample (row) of the first non-finite value. One vectorised pass; the torque column
    may hold NaN (the kernel then takes the shaft torque from the load observer)."""
    pv = samples[:, :N_IN]
    finite = np.isfinite(pv)
    if not finite.all():
        flat = int(np.argmin(finite))  # row-major: the first bad sample, its first bad column
        i, c = divmod(flat, N_IN)
        raise DataError(nonfinite_message(float(pv[i, c]), i), column=INPUT_COLUMNS[c])
    return samples


@njit(cache=True)
def deadzone_run_kernel(state, samples, params):
    """:func:`deadzone_run` without the argument checks (the caller guarantees the shapes)."""
    out = np.empty((samples.shape[0], N_OUT))
    st = deadzone_run_into(state, samples, params, out)
    return st, out


def deadzone_run(state: np.ndarray, samples: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Run the estimator over a block: ``run(state, samples, params) -> (state, outputs)``.

    Parameters
    ----------
    state : numpy.ndarray
        Estimator state (see :func:`initial_state`): C-contiguous float64 of the exact length
        :func:`state_length` of ``params``; not modified.
    samples : numpy.ndarray
        Shape (n, 4) or (n, 5), C-contiguous float64: θ_m [rad], ω_m [rad/s], θ_l [rad],
        ω_l [rad/s] and, optionally, the recorded motor torque u [N·m], at the sample time T_s.
    params : numpy.ndarray
        Parameter array (see :class:`~drivelash.estimation.estimator.EstimatorConfig`).

    Raises
    ------
    DataError
        ``samples`` of another shape, dtype or layout (:func:`check_samples`), or a non-finite
        θ_m, ω_m, θ_l or ω_l (:func:`check_finite`: one line naming the column and the 0-based
        sample; a NaN there would stay in the state and freeze δ̂). A NaN torque is allowed:
        that sample's shaft torque comes from the load observer.
    ParameterError
        ``state`` or ``params`` of another length, dtype or layout (the njit kernel would read
        and write out of bounds).

    Returns
    -------
    state : numpy.ndarray
        State after the last sample (new array).
    outputs : numpy.ndarray
        Shape (n, 9): δ̂ [rad], φ̂ [rad/s²], ω̂_l [rad/s], σ-window integral [s], Δθ used [rad],
        T_l(x, δ̂) [N·m], shaft torque seen by the law [N·m], traversal count [-], δ1 used [rad].
    """
    check_params(params)
    check_state(state, params)
    check_samples(samples)
    check_finite(samples)
    return deadzone_run_kernel(state, samples, params)


@njit(cache=True, error_model="numpy")
def deadzone_run_into(state, samples, params, out):
    """As :func:`deadzone_run`, writing into a caller-provided ``out`` (n, N_OUT); returns the new state.

    For streaming use: a reused output buffer avoids allocating (and page-faulting) fresh
    memory for every block.
    """
    st = state.copy()
    n = samples.shape[0]
    has_u = samples.shape[1] > 4
    for i in range(n):
        u = samples[i, 4] if has_u else math.nan
        deadzone_step(st, samples[i, 0], samples[i, 1], samples[i, 2], samples[i, 3], u, params, out, i)
    return st


@njit(cache=True, error_model="numpy")
def deadzone_run2_into(state_a, state_b, samples, params_a, params_b, out_a, out_b):
    """Two laws over the same block, observed once: ``(state_a, state_b)`` after the block.

    Each sample is :func:`_observe`-d once (on law a's state) and both laws' :func:`_law` run
    on the result; the :data:`OBSERVE_STATE` entries are then copied to law b's state. The
    two laws must agree on :data:`OBSERVE_PARAMS` and their observer states must be equal
    (:func:`observe_shared`); the results are then bit-identical to two
    :func:`deadzone_run_into` calls. Outputs as :func:`deadzone_run_into`, one buffer per law.
    """
    sa = state_a.copy()
    sb = state_b.copy()
    n = samples.shape[0]
    has_u = samples.shape[1] > 4
    for i in range(n):
        u = samples[i, 4] if has_u else math.nan
        w_l = samples[i, 3]
        obs = _observe(sa, samples[i, 0], samples[i, 1], samples[i, 2], w_l, u, params_a)
        _law(sa, obs, w_l, params_a, out_a, i)
        _law(sb, obs, w_l, params_b, out_b, i)
    for k in OBSERVE_STATE:
        sb[k] = sa[k]
    return sa, sb


def observe_shared(
    state_a: np.ndarray, state_b: np.ndarray, params_a: np.ndarray, params_b: np.ndarray
) -> bool:
    """Whether two laws observe a recording identically (:func:`deadzone_run2_into` applies):
    equal :data:`OBSERVE_PARAMS` entries and equal observer states (bitwise)."""
    ip, ist = list(OBSERVE_PARAMS), list(OBSERVE_STATE)
    return bool(
        np.array_equal(params_a[ip].view(np.int64), params_b[ip].view(np.int64))
        and np.array_equal(state_a[ist].view(np.int64), state_b[ist].view(np.int64))
    )


def derive_params(p: np.ndarray) -> np.ndarray:
    """Fill the derived entries of a parameter array in place (and return it).

    P_C_POS = 1 − exp(−ω_c T_s) (complementary filter), P_A_F = 1 − exp(−T_s/τ_f) (residual
    filter), P_A_Q = 1 − exp(−T_s/max(τ_f, 2 ms)) (torque filter of the excitation monitor),
    P_P0 … P_P0+3 = diagonal of P0: [P_max, q P_max/θ_def², q_δ1 P_max, 0].
    """
    T_s = p[P_TS]
    p[P_C_POS] = 1.0 - math.exp(-p[P_OMEGA_C] * T_s) if p[P_OMEGA_C] > 0 else 1.0
    p[P_A_F] = 1.0 - math.exp(-T_s / p[P_TAU_F]) if p[P_TAU_F] > 0 else 1.0
    p[P_A_Q] = 1.0 - math.exp(-T_s / max(p[P_TAU_F], 2e-3)) if p[P_TAU_F] > 0 else 1.0
    p[P_TAU_Q] = max(p[P_TAU_F], 2e-3) if p[P_TAU_F] > 0 else T_s
    p[P_INV_N] = 1.0 / p[P_N]
    p[P_INV_J] = 1.0 / p[P_J_L]
    p[P_INV_JM] = 1.0 / p[P_J_M] if p[P_J_M] > 0 else 0.0
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


# -- helpers of the streaming session (estimator._Track, estimator._block_samples) ------
@njit(cache=True)
def block_minmax(out, row0, Bh, dmin, dmax):
    """Fold column ``O_DELTA`` of an output block into per-history-block min/max, in place.

    Row ``i`` of ``out`` is global sample ``row0 + i`` and belongs to history block
    ``(row0 + i) // Bh`` of ``dmin``/``dmax``; a NaN stays NaN (as ``np.minimum``/``np.maximum``).
    """
    n = out.shape[0]
    i = 0
    while i < n:
        b = (row0 + i) // Bh
        end = min(n, (b + 1) * Bh - row0)
        lo = dmin[b]
        hi = dmax[b]
        for k in range(i, end):
            v = out[k, O_DELTA]
            if (v < lo or v != v) and lo == lo:
                lo = v
            if (v > hi or v != v) and hi == hi:
                hi = v
        dmin[b] = lo
        dmax[b] = hi
        i = end


@njit(cache=True)
def stack_finite(cols, data):
    """``data[i, j] = cols[j][i]`` row by row; returns the first (row, column) in row-major
    order whose value is not finite, or (−1, −1)."""
    bad_i = -1
    bad_j = -1
    m = len(cols)
    for i in range(data.shape[0]):
        for j in range(m):
            v = cols[j][i]
            data[i, j] = v
            if bad_i < 0 and not np.isfinite(v):
                bad_i = i
                bad_j = j
    return bad_i, bad_j
