"""Scene S4: steady-state total energy E(f) with the reference line A^2 w^2 / 2.

E = (vx^2 + vy^2)/2 + g y averaged over whole driving periods after the transient
and over the reference ensemble (docs/model.md §3), error bars one standard
error over particles.  Reads the scan shared with S3 and S5.
"""

from __future__ import annotations

import numpy as np

from bbdyn.scans.frequency import P_FLAG
from bbdyn.scenes import figure_axes
from bbdyn.scenes.frequency_scene import DEVICES, FULL, QUICK, FrequencyScanScene, scan_scene

TITLE = "Steady-state energy E(f) and the line A^2 w^2 / 2"
__all__ = ["TITLE", "QUICK", "FULL", "DEVICES", "compute", "draw"]


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> FrequencyScanScene:
    """The shared scan of ``settings`` with S4's key numbers."""
    scene = scan_scene(settings, seed, out_dir, progress)
    ratio = scene["E"] / scene["E_reference"]
    moving = scene["trapped"] == 0
    scene.meta["key_numbers"] = {
        "E / (A^2 w^2/2), non-trapped frequencies": (
            f"{ratio[moving].min():.3g} to {ratio[moving].max():.3g}" if moving.any() else "none"
        ),
        "E_pot / E (median)": f"{np.median(scene['E_pot'] / scene['E']):.3g}",
        "energy not stationary at (Hz)": scene.flagged()["energy_not_stationary"],
    }
    return scene


def draw(result: FrequencyScanScene, ax=None):
    """E(f) with error bars and A^2 w^2 / 2, non-stationary energies marked; returns the
    Figure."""
    fig, ax = figure_axes(ax, figsize=(11, 4.4), layout="constrained")
    result.mark_tongues(ax)
    result.plot(ax, key="E")
    ax.plot(result["f"], result["E_reference"], "k--", lw=1, label=r"$A^2\omega^2/2$")
    result.mark_points(ax, "E", result["energy_stationary"] == 0,
                       f"energy not stationary (drift, p < {P_FLAG:g})", marker="s", ms=6,
                       mfc="none", mec="r")  # fmt: skip
    ax.set_ylabel(r"$E$ (kg mm$^2$/s$^2$)")
    ax.set_title(result.run_title("Steady-state energy E(f)") + "; bars: 1 standard error",
                 pad=14)  # fmt: skip
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return fig
