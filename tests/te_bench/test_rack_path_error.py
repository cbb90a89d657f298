"""Transfer functions (2)–(3) and the path-error prediction (spec 02 §2)."""

from __future__ import annotations

import numpy as np
import pytest

from drivelash.control.path_error import (
    g_d_cl,
    g_d_cl_closed_form,
    g_pc_ol,
    g_pc_ol_closed_form,
    predict_path_error,
)
from drivelash.errors import DataError
from drivelash.physics.rack_pinion import RackPinionBench
from drivelash.report.te_figures import bode_figure
from drivelash.sim.rack_axis import bench_gains

J_S = RackPinionBench().J_s
GAINS = bench_gains()
W = np.logspace(-2, 5, 400)  # rad/s


def test_python_control_equals_closed_forms():
    G2 = g_pc_ol(J_S, GAINS)(1j * W)
    G3 = g_d_cl(J_S, GAINS)(1j * W)
    np.testing.assert_allclose(G2, g_pc_ol_closed_form(1j * W, J_S, GAINS), rtol=1e-9)
    np.testing.assert_allclose(G3, g_d_cl_closed_form(1j * W, J_S, GAINS), rtol=1e-9)


def test_eq3_is_the_output_sensitivity_of_eq2():
    """TE is an output disturbance: G_d,CL = −1 / (1 + G_pc,OL)."""
    import control

    G3_from_2 = -control.feedback(1, g_pc_ol(J_S, GAINS))
    np.testing.assert_allclose(G3_from_2(1j * W), g_d_cl(J_S, GAINS)(1j * W), rtol=1e-9)
    assert np.all(np.real(control.poles(g_d_cl(J_S, GAINS))) < 0)


def test_high_pass_character():
    G = g_d_cl_closed_form(1j * W, J_S, GAINS)
    assert abs(G[0]) == pytest.approx(0.01 / GAINS.K_v, rel=1e-3)  # ≈ s/K_v at low frequency
    assert abs(G[-1]) == pytest.approx(1.0, rel=1e-2)  # passes high frequencies


def test_prediction_matches_python_control_forced_response():
    import control

    fs = 8000.0
    t = np.arange(0, 2.0, 1 / fs)
    te = 5e-6 * np.sin(2 * np.pi * 7.5 * t) + 20e-6 * np.sin(2 * np.pi * 0.375 * t) + 3e-6 * t
    e_hat = predict_path_error(te, t, J_S, GAINS)
    ref = control.forced_response(g_d_cl(J_S, GAINS), t, te - te[0]).outputs
    assert np.max(np.abs(e_hat - ref)) < 1e-3 * np.max(np.abs(ref))
    # a TE ramp (drift rate r) leaves the constant error −r/K_v
    e_ramp = predict_path_error(3e-6 * t, t, J_S, GAINS)
    assert e_ramp[-1] == pytest.approx(-3e-6 / GAINS.K_v, rel=1e-6)


def test_prediction_input_errors():
    t = np.array([0.0, 1.0, 3.0])
    with pytest.raises(DataError):
        predict_path_error(np.zeros(3), t, J_S, GAINS)
    with pytest.raises(DataError):
        predict_path_error(np.zeros(2), np.arange(3.0), J_S, GAINS)


def test_bode_figure(tmp_path):
    fig = bode_figure(J_S, GAINS)
    path = tmp_path / "bode.png"
    fig.savefig(path)
    assert path.stat().st_size > 1000
    mag = fig.axes[0].lines[1].get_ydata()
    assert mag[0] < -40 and abs(mag[-1]) < 1.0  # (3): strong suppression low, ≈ 0 dB high
