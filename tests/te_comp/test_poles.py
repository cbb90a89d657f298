"""Feed-forward only: the closed-loop poles do not change with the compensator (spec 02 §5).

The cascade of spec 02 §2 is built block by block with python-control; its poles
are checked against the closed-form denominator of (3). The compensator enters as
a block whose gains are the numerical linearisation of the real kernel around an
operating point; with those gains the poles are identical, while a (hypothetical)
direct torque feed-through moves them — so the check can fail.
"""

from __future__ import annotations

import numpy as np
import pytest

import control as ct
from drivelash.te.runtime.compensator import Compensator, CompensatorParams
from drivelash.te.runtime.table import build_table

from .analytic import SineTE

K_V, K_P, T_N = 231.0, 12.4, 3.05e-3


def _loop(J_s: float, g_ff: float, g_T: float, g_omega: float) -> ct.InterconnectedSystem:
    """Linear cascade with TE as output disturbance and v_c subtracted from the velocity command."""
    blocks = [
        ct.tf(K_V, 1, inputs="e", outputs="vp", name="P"),
        ct.summing_junction(inputs=["vp", "vff", "-vc"], output="vcmd", name="sum_v"),
        ct.summing_junction(inputs=["vcmd", "-vm"], output="ev", name="sum_ev"),
        ct.tf([K_P * T_N, K_P], [T_N, 0], inputs="ev", outputs="T", name="PI"),
        ct.tf(1, [J_s, 0], inputs="T", outputs="vm", name="mech"),
        ct.tf(1, [1, 0], inputs="vm", outputs="xm", name="int"),
        ct.summing_junction(inputs=["xm", "TE"], output="xT", name="sum_x"),
        ct.summing_junction(inputs=["xd", "-xT"], output="e", name="sum_e"),
        # the compensator: gains from the planned velocity, the torque and the motor velocity
        ct.ss([], [], [], [[g_ff, g_T, g_omega]], inputs=["vff", "T", "vm"], outputs="vc", name="comp"),
    ]
    return ct.interconnect(blocks, inputs=["xd", "vff", "TE"], outputs=["e", "xT"])


def _kernel_gains(model, v=0.05, x=0.3, torque=4.0, omega=20.0, h=1e-3):
    """Central-difference linearisation of one compensation cycle of the real kernel."""
    tab = build_table(model, 0.0, 1.0, 0.05e-3, 10.0, 11)
    p = CompensatorParams(v_max=1.0, J_flank=1e-4, T_C=0.2, beta=1e-3, hysteresis=0.3, J_model=3e-3)

    def vc(vff=v, tq=torque, om=omega, al=0.0):
        c = Compensator(tab, p, flank=1)
        return c.step(x, x + vff * p.t_sc, tq, om, al)[0]

    g_ff = (vc(vff=v + h) - vc(vff=v - h)) / (2 * h)
    g_T = (vc(tq=torque + h) - vc(tq=torque - h)) / (2 * h)
    g_om = (vc(om=omega + h) - vc(om=omega - h)) / (2 * h)
    g_al = (vc(al=h) - vc(al=-h)) / (2 * h)
    return g_ff, g_T, g_om, g_al


@pytest.mark.parametrize("J_s", [3.5e-3, 8e-3])
def test_closed_loop_poles_equal_closed_form_of_3(J_s):
    sys0 = _loop(J_s, 0.0, 0.0, 0.0)
    den = [J_s * T_N / K_P, T_N, 1 + K_V * T_N, K_V]
    np.testing.assert_allclose(np.sort_complex(sys0.poles()), np.sort_complex(np.roots(den)), rtol=1e-9)
    # and the TE → e channel is (3) itself (frequency response, rel 1e-9)
    g3 = -ct.tf([J_s * T_N / K_P, T_N, 1, 0], den)
    w = np.logspace(0, 4, 50)
    h_sys = ct.ss2tf(sys0[0, 2])(1j * w)
    np.testing.assert_allclose(h_sys, g3(1j * w), rtol=1e-9)


@pytest.mark.parametrize("J_s", [3.5e-3, 8e-3])
def test_poles_identical_with_linearised_compensator(J_s):
    g_ff, g_T, g_om, g_al = _kernel_gains(SineTE())
    assert g_ff != 0.0  # the compensator does act on the planned trajectory
    # no feedback path from measured states (round-off of the difference quotients only)
    assert max(abs(g_T), abs(g_om), abs(g_al)) <= 1e-12 * abs(g_ff)
    p0 = np.sort_complex(_loop(J_s, 0.0, 0.0, 0.0).poles())
    p1 = np.sort_complex(_loop(J_s, g_ff, g_T, g_om).poles())
    np.testing.assert_allclose(p1, p0, rtol=1e-12)


def test_state_feed_through_would_move_the_poles():
    # negative control: feeding a measured state (here the motor velocity, 0.2 m/s per
    # m/s) through to v_c shifts the poles (a static torque gain would even close an
    # algebraic loop through the PI's direct term)
    J_s = 3.5e-3
    p0 = np.sort_complex(_loop(J_s, 0.0, 0.0, 0.0).poles())
    p1 = np.sort_complex(_loop(J_s, 0.0, 0.0, 0.2).poles())
    assert np.max(np.abs(p1 - p0) / np.abs(p0)) > 1e-3


def test_compensated_response_cancels_modelled_te():
    # the feed-forward cancels a TE ramp exactly when v_c = dTE/dt: TE = k x_d with v_c = k v_ff
    J_s = 3.5e-3
    k = 2e-4  # TE slope [m/m]
    sys_c = _loop(J_s, k, 0.0, 0.0)
    t = np.linspace(0, 0.2, 4001)
    v = 0.1
    xd = v * t
    u = np.vstack([xd, np.full_like(t, v), k * xd])
    e = ct.forced_response(sys_c, t, u).outputs[0]
    e_unc = ct.forced_response(_loop(J_s, 0.0, 0.0, 0.0), t, u).outputs[0]
    np.testing.assert_allclose(e_unc[-1], -k * v / K_V, rtol=1e-3)
    # after the start transient of the velocity step (no acceleration feed-forward)
    assert np.max(np.abs(e[-100:])) < 1e-12


def test_block_built_loop_matches_the_bench_transfer_functions():
    # cross-check of two implementations: the block-built cascade vs control.path_error (2)–(3)
    from drivelash.control.path_error import g_d_cl, g_pc_ol
    from drivelash.physics.rack_pinion import RackPinionBench
    from drivelash.sim.rack_axis import bench_gains

    J_s = RackPinionBench().J_s
    sys0 = _loop(J_s, 0.0, 0.0, 0.0)
    w = np.logspace(0, 4, 40)
    np.testing.assert_allclose(ct.ss2tf(sys0[0, 2])(1j * w), g_d_cl(J_s, bench_gains())(1j * w), rtol=1e-9)
    # (2) is the loop transfer function L = x_T / e: closed loop x_T/x_d = L/(1+L) without feed-forward
    L = g_pc_ol(J_s, bench_gains())
    cl = ct.feedback(L, 1)
    np.testing.assert_allclose(np.sort_complex(cl.poles()), np.sort_complex(sys0.poles()), rtol=1e-9)
