"""Scene S5: steady-state horizontal kinetic energy E_x(f) = <vx^2/2>.

Averaged over whole driving periods after the transient and over the reference
ensemble (docs/model.md §3), error bars one standard error over particles.
Reads the scan shared with S3 and S4.
"""

from __future__ import annotations

import numpy as np

from bbdyn.scans.frequency import P_FLAG
from bbdyn.scenes import figure_axes
from bbdyn.scenes.frequency_scene import DEVICES, FULL, QUICK, FrequencyScanScene, scan_scene

TITLE = "Steady-state horizontal kinetic energy E_x(f)"
__all__ = ["TITLE", "QUICK", "FULL", "DEVICES", "compute", "draw"]


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> FrequencyScanScene:
    """The shared scan of ``settings`` with S5's key numbers."""
    scene = scan_scene(settings, seed, out_dir, progress)
    f, ex, err = scene["f"], scene["E_x"], scene["E_x_err"]
    i = int(np.argmax(ex))
    scene.meta["key_numbers"] = {
        "E_x max (kg mm^2/s^2)": f"{ex[i]:.4g} +- {err[i]:.2g} at f = {f[i]:.2f} Hz",
        "E_x / E (median)": f"{np.median(ex / scene['E']):.3g}",
    }
    return scene


def draw(result: FrequencyScanScene, ax=None):
    """E_x(f) with error bars, non-stationary energies marked; returns the Figure."""
    fig, ax = figure_axes(ax, figsize=(11, 4.4), layout="constrained")
    result.mark_tongues(ax)
    result.plot(ax, key="E_x")
    result.mark_points(ax, "E_x", result["energy_stationary"] == 0,
                       f"energy not stationary (drift, p < {P_FLAG:g})", marker="s", ms=6,
                       mfc="none", mec="r")  # fmt: skip
    ax.set_ylabel(r"$E_x = \langle v_x^2/2 \rangle$ (kg mm$^2$/s$^2$)")
    ax.set_title(result.run_title("Steady-state horizontal kinetic energy E_x(f)")
                 + "; bars: 1 standard error", pad=14)  # fmt: skip
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return fig
