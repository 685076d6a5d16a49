"""Scene S3: the diffusion coefficient D(f) with error bars, k/1 tongues marked on top.

D is the late-window Einstein slope of the reference ensemble (docs/model.md §3,
``bbdyn.scans.frequency.diffusion_point``), error bars one standard error over
particles.  S3, S4 and S5 read one shared scan (``bbdyn.scans.cache.diffusion_scan``),
computed once per setting and seed.  ``draw(result, regimes=b1)`` also shades the
regime bands of a regime map (scene B1).
"""

from __future__ import annotations

import numpy as np

from bbdyn.scans.frequency import cpu_estimate, frequency_grid
from bbdyn.scenes import figure_axes
from bbdyn.scenes.frequency_scene import FrequencyScanScene, scan_scene

TITLE = "Diffusion coefficient D(f) with standard errors and the k/1 tongues"
QUICK = {"f_start": 49.8, "f_stop": 95.0, "f_step": 1.0, "n": 100, "t": 20.0}
FULL = {"f_start": 49.8, "f_stop": 95.0, "f_step": 0.2, "n": 1000, "t": 200.0}


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> FrequencyScanScene:
    """The shared scan of ``settings`` (computed or loaded) with S3's key numbers."""
    scene = scan_scene(settings, seed, out_dir, progress)
    scene.meta["key_numbers"] = key_numbers(scene)
    return scene


def cost(settings: dict) -> float:
    """Upper estimate of the CPU time (s) of the scan of ``settings`` (shared with S4, S5)."""
    grid = frequency_grid(settings["f_start"], settings["f_stop"], settings["f_step"])
    return cpu_estimate(grid.sum(), settings["n"], settings["t"])


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
    """D(f) with error bars, the k/1 tongues and, with ``regimes`` (a B1 result), the regime
    bands; returns the Figure."""
    fig, ax = figure_axes(ax, figsize=(9, 4.2))
    if regimes is not None:
        from bbdyn.scenes.b1_regime_map import regime_bands

        for lo, hi, label in regime_bands(regimes):
            ax.axvspan(lo, hi, color="0.9", lw=0)
            ax.text(0.5 * (lo + hi), 0.02, label, transform=ax.get_xaxis_transform(),
                    ha="center", fontsize=7, color="0.3")  # fmt: skip
    result.mark_tongues(ax)
    result.plot(ax, key="D")
    bad = result["D_converged"] == 0
    ax.plot(result["f"][bad], result["D"][bad], "rx", ms=6, label="D windows disagree")
    ax.set_ylabel(r"$D$ (mm$^2$/s)")
    n, t = result.meta["scan_compute"]["kwargs"]["n"], result.meta["scan_compute"]["kwargs"]["t"]
    ax.set_title(f"D(f): n = {n} particles, t = {t:g} s, bars: 1 standard error", pad=14)
    ax.legend(loc="upper left", fontsize=8)
    return fig
