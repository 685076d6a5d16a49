"""The result shared by scenes S3, S4 and S5: the scalars of one frequency scan per frequency.

S3 (D), S4 (E) and S5 (E_x) draw the same scan (``bbdyn.scans.cache.diffusion_scan``);
``FrequencyScanScene`` keeps the outputs the three figures need (``SCENE_KEYS``) with the
k/1 tongue intervals of the flat ball, which the figures shade.
"""

from __future__ import annotations

import math

import numpy as np

from bbdyn.flat.tongues import tongue_intervals
from bbdyn.params import Params
from bbdyn.results import Result, make_meta
from bbdyn.scans.cache import diffusion_scan
from bbdyn.schema import standard_key

__all__ = ["D_ZERO", "FULL", "QUICK", "SCENE_KEYS", "FrequencyScanScene", "scan_scene"]

#: ``|D|`` and ``D_err`` (mm^2/s) at or below this are zero to rounding: far above the rounding of
#: an MSD slope of frozen particles (eps x^2 / t ~ 1e-16 (100 mm)^2 / 100 s = 1e-14) and
#: far below the D of one particle of 1000 moving 1 mm in 200 s (1 / (2 1000 200) = 2.5e-6).
D_ZERO = 1e-9

#: Where the shared scan can run (``settings["device"]``, ``bbdyn.scans.frequency_scan``).
DEVICES = ("cpu", "cuda")
#: Settings of the shared scan, those of S3, S4 and S5: the grid (Hz), particles, time (s).
QUICK = {"f_start": 49.8, "f_stop": 95.0, "f_step": 1.0, "n": 100, "t": 20.0}
FULL = {"f_start": 49.8, "f_stop": 95.0, "f_step": 0.2, "n": 1000, "t": 200.0}

#: Outputs of a scan that the scenes keep (scalars per frequency).
SCENE_KEYS = (
    "gamma",
    "D",
    "D_err",
    "D_boot_lo",
    "D_boot_hi",
    "D_converged",
    "trapped",
    "E",
    "E_err",
    "E_x",
    "E_x_err",
    "E_y",
    "E_y_err",
    "E_pot",
    "E_pot_err",
    "E_reference",
    "energy_stationary",
    "stuck_fraction",
    "collision_rate",
    "events",
)


class FrequencyScanScene(Result):
    """Scalars of a frequency scan for scenes S3-S5 (arrays ``f`` and ``SCENE_KEYS``, each
    (n_f,)) with the k/1 tongue intervals ``tongues`` (m, 3): ``(k, f_lo, f_hi)`` in Hz."""

    kind = "frequency_scan_scene"

    @classmethod
    def from_scan(cls, scan, params: Params, **meta) -> FrequencyScanScene:
        """Keep the scenes' outputs of ``scan`` and add the tongue intervals."""
        f = scan.values
        # the scene keeps its array names; the scan's are the schema's (X_se for X_err)
        arrays = {"f": f} | {k: scan[standard_key(k)] for k in SCENE_KEYS}
        arrays["tongues"] = tongue_intervals(params, float(f.min()), float(f.max()))
        cpu = float(scan.point_cpu_s().sum())
        return cls(
            arrays,
            make_meta(
                params,
                scan_seed=scan.meta["seed"],
                scan_compute=scan.meta["compute"],
                scan_cpu_s=cpu,
                events_per_cpu_s=float(np.sum(scan["events"]) / cpu) if cpu else math.nan,
                **meta,
            ),
        )

    def plot(self, ax=None, key: str = "D"):
        """``key`` (``"D"``, ``"E"``, ``"E_x"``, ...) against f with error bars; the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots(figsize=(8, 4))
        ax.errorbar(self["f"], self[key], yerr=self[key + "_err"], fmt="o-", ms=2.5, lw=0.8,
                    capsize=1.5, elinewidth=0.8, label=key)  # fmt: skip
        ax.set_xlabel("f (Hz)")
        return ax

    def mark_tongues(self, ax) -> None:
        """Shade the k/1 tongue intervals, label them k/1 at the top of ``ax`` and name the
        shading once in the legend."""
        for i, (k, lo, hi) in enumerate(self["tongues"]):
            label = "k/1 tongue of the flat ball" if i == 0 else None
            ax.axvspan(lo, hi, color="tab:orange", alpha=0.15, lw=0, label=label)
            ax.text(0.5 * (lo + hi), 1.0, f"{int(k)}/1", transform=ax.get_xaxis_transform(),
                    ha="center", va="bottom", fontsize=8, color="tab:orange")  # fmt: skip

    def run_title(self, what: str) -> str:
        """``what`` with the f-range (Hz), number of frequencies, n and t (s) of the scan."""
        f = self["f"]
        run = self.meta["scan_compute"]["kwargs"]
        return (f"{what}\nf = {f.min():g}-{f.max():g} Hz ({f.size} frequencies), "
                f"n = {run['n']} particles, t = {run['t']:g} s")  # fmt: skip

    def mark_points(self, ax, key: str, where: np.ndarray, label: str, **style) -> None:
        """Mark ``key`` at the frequencies where ``where`` holds (a legend entry only if any)."""
        if np.any(where):
            ax.plot(self["f"][where], self[key][where], ls="none", label=label, **style)

    def D_zero_to_rounding(self) -> np.ndarray:
        """Frequencies whose D and D_err are both zero to rounding (``D_ZERO``, mm^2/s): every
        particle frozen over the D window, so D cannot be unconverged whatever the windows say."""
        return (np.abs(self["D"]) <= D_ZERO) & (self["D_err"] <= D_ZERO)

    def flagged(self) -> dict[str, list[float]]:
        """Frequencies whose convergence checks raised a flag (see the module docstring)."""
        f = self["f"]
        return {
            "D_windows_disagree": f[self["D_converged"] == 0].tolist(),
            "energy_not_stationary": f[self["energy_stationary"] == 0].tolist(),
        }


def scan_scene(settings: dict, seed: int, out_dir=None, progress=False) -> FrequencyScanScene:
    """The shared scan of an S3-S5 setting (``bbdyn.scans.cache.diffusion_scan``: loaded,
    computed or resumed) as the scenes' result, tongues at the default parameters."""
    scan = diffusion_scan(settings, seed, out_dir, progress)
    return FrequencyScanScene.from_scan(scan, Params(f=60.0))
