"""Scene S3: the diffusion coefficient D(f) with error bars, k/1 tongues marked on top.

D is the late-window Einstein slope of the reference ensemble (docs/model.md §3,
``bbdyn.scans.frequency.diffusion_point``), error bars one standard error over
particles.  S3, S4 and S5 read one shared scan (``bbdyn.scans.cache.diffusion_scan``),
computed once per setting and seed.  ``draw(result, regimes=b1)`` also draws the
regime bands of a regime map (scene B1) as a strip under D(f).
"""

from __future__ import annotations

import numpy as np

from bbdyn.scans.cache import grid_cpu_forecast
from bbdyn.scans.frequency import P_FLAG
from bbdyn.scenes import figure_axes
from bbdyn.scenes.b1_regime_map import draw_regime_strip
from bbdyn.scenes.frequency_scene import DEVICES, FULL, QUICK, FrequencyScanScene, scan_scene

TITLE = "Diffusion coefficient D(f) with standard errors and the k/1 tongues"
__all__ = ["TITLE", "QUICK", "FULL", "DEVICES", "compute", "cost", "draw", "key_numbers"]


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> FrequencyScanScene:
    """The shared scan of ``settings`` (computed or loaded) with S3's key numbers."""
    scene = scan_scene(settings, seed, out_dir, progress)
    scene.meta["key_numbers"] = key_numbers(scene)
    return scene


def cost(settings: dict) -> dict[str, float]:
    """Forecast of the CPU time (s) of the scan of ``settings`` (shared with S4, S5):
    ``bbdyn.scans.frequency.scan_cpu_forecast``."""
    return grid_cpu_forecast(settings)


def key_numbers(scene: FrequencyScanScene) -> dict:
    """Largest D and where, trapped and flagged frequencies, cost."""
    f, D, err = scene["f"], scene["D"], scene["D_err"]
    i = int(np.argmax(D))
    flags = scene.flagged()
    return {
        "frequencies": int(f.size),
        "D_max (mm^2/s)": f"{D[i]:.4g} +- {err[i]:.2g} at f = {f[i]:.2f} Hz",
        "trapped frequencies (D = 0 exactly)": int(np.sum(scene["trapped"])),
        "D windows disagree at (Hz)": flags["D_windows_disagree"],
        "energy not stationary at (Hz)": flags["energy_not_stationary"],
        "scan CPU time (s)": round(scene.meta["scan_cpu_s"], 1),
        "events per CPU second": f"{scene.meta['events_per_cpu_s']:.3g}",
    }


def draw(result: FrequencyScanScene, ax=None, regimes=None):
    """D(f) with error bars, the k/1 tongues and, with ``regimes`` (a B1 result), a strip of
    the regimes under it; returns the Figure.  Window-disagreement flags are drawn except
    where D and D_err are zero to rounding (nothing moves: D is exact)."""
    import matplotlib.pyplot as plt

    if regimes is not None and ax is None:
        fig, (ax, ax_reg) = plt.subplots(2, 1, figsize=(11, 4.8), sharex=True,
                                         height_ratios=(1, 0.07), layout="constrained")  # fmt: skip
        draw_regime_strip(ax_reg, regimes, loc="lower left", bbox_to_anchor=(1.01, -0.5))
    else:
        fig, ax = figure_axes(ax, figsize=(11, 4.4), layout="constrained")
    result.mark_tongues(ax)
    result.plot(ax, key="D")
    if regimes is not None and len(fig.axes) > 1:
        ax.set_xlabel("")  # on the regime strip below
        fig.axes[1].set_xlabel("f (Hz)")
    flag = (result["D_converged"] == 0) & ~result.D_zero_to_rounding()
    result.mark_points(ax, "D", flag, f"D windows disagree (p < {P_FLAG:g})",
                       marker="x", color="r", ms=6)  # fmt: skip
    ax.set_ylabel(r"$D$ (mm$^2$/s)")
    ax.set_title(result.run_title("Diffusion coefficient D(f), Einstein slope over [t/2, t]")
                 + "; bars: 1 standard error", pad=14)  # fmt: skip
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return fig
