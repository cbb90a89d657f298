"""Figures of simulated drive-train traces (matplotlib, PNG)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["plot_backlash_trace"]


def plot_backlash_trace(trace: Any, path: Path, title: str = "") -> Path:
    """Figure: motor/load position over time, and the hysteresis Δθ = θ_m/N − θ_l vs θ_l.

    Parameters
    ----------
    trace : Trace
        Simulated or recorded trace (``delta_true``/``delta1_true`` drawn if present).
    path : Path
        PNG file to write.
    title : str
        Figure title.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = trace["t"]
    N = float(trace.meta.get("plant_drivetrain", {}).get("N", 1.0))
    dtheta = trace["theta_m"] / N - trace["theta_l"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.5), constrained_layout=True)
    show = t <= min(t[-1], 10.0)
    if "theta_ref" in trace:
        ax1.plot(t[show], trace["theta_ref"][show], "k:", lw=1.0, label=r"$\theta_r$")
    ax1.plot(t[show], trace["theta_m"][show], lw=1.2, label=r"$\theta_m$ (motor)")
    ax1.plot(t[show], trace["theta_l"][show], lw=1.2, label=r"$\theta_l$ (load)")
    ax1.set_xlabel("t [s]")
    ax1.set_ylabel("position [rad]")
    ax1.set_title("motor and load position (first 10 s)")
    ax1.grid(alpha=0.3)
    ax1.legend(loc="upper right", fontsize=8)
    ax2.plot(trace["theta_l"], dtheta, lw=0.6, color="C2", label=r"$\Delta\theta$ (measured)")
    if "delta_true" in trace and "delta1_true" in trace:
        d = float(trace["delta_true"][-1])
        d1 = float(trace["delta1_true"][-1])
        for y, lab in ((-d1, r"$-\delta_1$"), (d - d1, r"$\delta-\delta_1$")):
            ax2.axhline(y, color="k", ls="--", lw=0.8)
            ax2.annotate(lab, (ax2.get_xlim()[0], y), xytext=(4, 4), textcoords="offset points", fontsize=9)
    ax2.set_xlabel(r"load position $\theta_l$ [rad]")
    ax2.set_ylabel(r"$\Delta\theta = \theta_m/N - \theta_l$ [rad]")
    ax2.set_title("backlash hysteresis")
    ax2.grid(alpha=0.3)
    if title:
        fig.suptitle(title)
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
