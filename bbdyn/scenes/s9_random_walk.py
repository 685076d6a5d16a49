"""Scene S9: Einstein D against the random-walk approximations D_rw and D_a (docs/model.md §4).

For f above 65.6 Hz, per frequency (``bbdyn.scans.green_kubo.gk_point``): the Einstein D of
the reference ensemble, ``D_rw = d^2 / (2 tau)`` with the escape time tau from the
same simulation, and the analytic ``D_a = (d/2) sqrt((A^2 w^2 - 2 g A) / (1 + r))``
with the energy ratio ``r = E_y / E_x`` measured there (drawn in a second panel).
``D_a`` does not exist for Gamma < 2 (f < 70.46 Hz at the defaults): the energy
balance leaves no kinetic energy; those frequencies are shaded and counted, not filled.

The scan points are kept on disk (``bbdyn.scans.cache.scene_folder("gk", ...)``), so an interrupted
full run resumes where it stopped.
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.results import Result, make_meta

TITLE = "Random walk: Einstein D, D_rw (tau from simulation) and D_a (measured r) against f"
QUICK = {"f_start": 66.0, "f_stop": 94.0, "f_step": 2.0, "n": 100, "t": 40.0}
FULL = {"f_start": 65.8, "f_stop": 95.0, "f_step": 0.2, "n": 1000, "t": 200.0}

#: Outputs of the scan kept by the scene.
KEYS = ("D", "D_err", "D_rw", "D_rw_err", "D_a", "D_a_err", "r", "r_err", "tau", "tau_err")


class SceneS9Result(Result):
    """Arrays: ``f`` (Hz), ``gamma``, and per f ``D, D_rw, D_a`` (mm^2/s), ``r``, ``tau`` (s),
    each with ``_err``; ``D_a`` is NaN where Gamma < 2."""

    kind = "scene_s9"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def scan_points(settings: dict, seed: int, out_dir, *, keys, progress=False):
    """The ``keys`` outputs of ``gk_scene_scan`` (computed or resumed), sorted by f."""
    from bbdyn.scans.cache import gk_scene_scan

    scan = gk_scene_scan(settings, seed, out_dir, progress)
    order = np.argsort(scan.values)
    arrays = {"f": scan.values[order]}
    arrays.update({k: scan[k][order] for k in keys})
    return arrays, scan.meta


def cost(settings: dict) -> float:
    """Upper estimate of the CPU time (s) of the scan of ``settings`` (shared with S10)."""
    from bbdyn.scans.frequency import cpu_estimate, frequency_grid

    grid = frequency_grid(settings["f_start"], settings["f_stop"], settings["f_step"])
    return cpu_estimate(grid.sum(), settings["n"], settings["t"])


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> SceneS9Result:
    """Scan the frequencies of ``settings`` (``f_start``, ``f_stop``, ``f_step`` in Hz, ``n``
    particles, ``t`` s) and collect D, D_rw, D_a, r; the scan is kept in
    ``bbdyn.scans.cache.scene_folder("gk", settings, seed, out_dir)``, so a rerun resumes it."""
    from bbdyn import Params

    start = time.perf_counter()
    arrays, scan_meta = scan_points(settings, seed, out_dir, keys=KEYS, progress=progress)
    f = arrays["f"]
    arrays["gamma"] = np.array([Params(f=v).gamma for v in f])
    p0 = Params(f=float(f[0]))
    f_gamma2 = math.sqrt(2 * p0.g / p0.A) / (2 * math.pi)  # A w^2 = 2 g
    no_da = ~np.isfinite(arrays["D_a"])
    diffusive = arrays["D"] > 3 * arrays["D_err"]
    key = {
        "frequencies": f"{f.size} from {f[0]:g} to {f[-1]:g} Hz",
        "D_a undefined (Gamma < 2)": (
            f"{int(no_da.sum())} of {f.size} frequencies, all below f = {f_gamma2:.2f} Hz"
            if np.all(f[no_da] < f_gamma2)
            else f"{int(no_da.sum())} frequencies (not only Gamma < 2: check)"
        ),
        "measured r = E_y/E_x": f"{np.nanmin(arrays['r']):.3g} to {np.nanmax(arrays['r']):.3g}",
        "median D_rw / D (D > 3 err)": _median_ratio(arrays["D_rw"], arrays["D"], diffusive),
        "median D_a / D (D > 3 err)": _median_ratio(arrays["D_a"], arrays["D"], diffusive & ~no_da),
        "max D": f"{np.max(arrays['D']):.3g} mm^2/s at {f[np.argmax(arrays['D'])]:g} Hz",
    }
    meta = make_meta(
        seed=seed,
        wall_s=time.perf_counter() - start,
        f_gamma2=f_gamma2,
        scan_manifest={k: scan_meta.get(k) for k in ("compute", "seed", "bbdyn_version")},
        key_numbers=key,
    )
    meta["params"] = {k: v for k, v in p0.to_dict().items() if k != "f"}
    return SceneS9Result(arrays, meta)


def _median_ratio(num: np.ndarray, den: np.ndarray, mask: np.ndarray) -> str:
    if not np.any(mask):
        return "no frequency with D > 3 err"
    return f"{np.median(num[mask] / den[mask]):.3g} over {int(mask.sum())} frequencies"


def draw(result: Result, ax=None):
    """D, D_rw, D_a against f (top) and the measured r (bottom); returns the Figure."""
    import matplotlib.pyplot as plt

    if ax is None:
        fig, (ax, ax_r) = plt.subplots(
            2, 1, figsize=(7, 6), sharex=True, height_ratios=(2.2, 1), layout="constrained"
        )
    else:
        fig, ax_r = ax.figure, None
    f = result["f"]
    f2 = result.meta["f_gamma2"]
    for a in (ax, ax_r):
        if a is not None and f[0] < f2:
            a.axvspan(f[0], f2, color="0.9", zorder=0)
    ax.errorbar(f, result["D"], result["D_err"], fmt="o", ms=3, capsize=2, label="Einstein $D$")
    ax.errorbar(f, result["D_rw"], result["D_rw_err"], fmt="s-", ms=3, lw=0.8,
                label=r"$D_{rw} = d^2 / 2\tau$")  # fmt: skip
    ax.errorbar(f, result["D_a"], result["D_a_err"], fmt="^-", ms=3, lw=0.8,
                label="$D_a$ (measured $r$)")  # fmt: skip
    if f[0] < f2:
        ax.text(0.5 * (f[0] + f2), 0.97, r"$\Gamma < 2$:" + "\n$D_a$\nundefined",
                transform=ax.get_xaxis_transform(), ha="center", va="top", fontsize=8)  # fmt: skip
    ax.set_ylabel("$D$ (mm$^2$/s)")
    ax.set_title("S9: Einstein $D$ and random-walk approximations")
    ax.legend(fontsize=8, frameon=False)
    if ax_r is not None:
        ax_r.errorbar(f, result["r"], result["r_err"], fmt="o-", ms=3, lw=0.8, color="C3")
        ax_r.set_ylabel("$r = E_y / E_x$")
        ax_r.set_xlabel("$f$ (Hz)")
    else:
        ax.set_xlabel("$f$ (Hz)")
    return fig
