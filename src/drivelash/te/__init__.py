"""Rack-and-pinion transmission errors (spec 02), by layer.

* :mod:`drivelash.te.learn` — preprocessing, tooth-meshing features, the stacked
  model (network + bagged trees), fitting a campaign, baselines (training side:
  scikit-learn, and PyTorch inside the training calls);
* :mod:`drivelash.te.runtime` — the loaded model (NumPy/numba predictor, never
  torch), its safe persistence, the runtime table, the compensator kernel, exports;
* :mod:`drivelash.te.protocol` — campaigns read back, the validation protocol on
  the virtual bench, monitoring.

The virtual bench itself (the closed-loop axis and the simulated campaign) is in
:mod:`drivelash.sim`; the true-TE generator in :mod:`drivelash.physics.rack_pinion`;
every figure in :mod:`drivelash.report.te_figures`.
"""

__all__ = ["learn", "protocol", "runtime"]
