"""Scene S10: truncated Green-Kubo D_n against the Einstein D on a fine grid (docs/model.md §4).

Per frequency in [84.6, 86.4] Hz (``bbdyn.scans.green_kubo.gk_point``): the Einstein D of the
reference ensemble and ``D_n = (1/tau)(<h_0^2>/2 + sum_{k=1..n} <h_0 h_k>)`` for
n = 0..nmax from the jumps of the same simulation, with bootstrap errors.  Drawn:
D and D_n for n in ``orders`` (0, 2, 4, 7 and nmax); key numbers: how close each
order comes to D over the grid.

The scan points are kept on disk (``bbdyn.scans.cache.scene_folder("gk", ...)``), so an interrupted
full run resumes where it stopped.
"""

from __future__ import annotations

import time

import numpy as np

from bbdyn import Params
from bbdyn.results import Result, make_meta
from bbdyn.scenes import figure_axes
from bbdyn.scenes.s9_random_walk import scan_points

TITLE = "Green-Kubo: Einstein D and truncated D_n (n = 0, 2, 4, 7, 10) on a fine f grid"
_GRID = {"f_start": 84.6, "f_stop": 86.4}
QUICK = {**_GRID, "f_step": 0.2, "n": 100, "t": 40.0, "nmax": 10, "orders": [0, 2, 4, 7, 10]}
FULL = {**_GRID, "f_step": 0.01, "n": 1000, "t": 200.0, "nmax": 10, "orders": [0, 2, 4, 7, 10]}

KEYS = ("D", "D_err", "D_n", "D_n_err", "tau", "p_f", "p_b")


class SceneS10Result(Result):
    """Arrays: ``f`` (Hz); ``D``, ``D_err`` (mm^2/s); ``D_n``, ``D_n_err`` (n_f, nmax + 1),
    mm^2/s; ``tau`` (s); ``p_f``, ``p_b``; ``orders`` (the drawn n)."""

    kind = "scene_s10"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> SceneS10Result:
    """Scan ``settings`` (grid in Hz, ``n``, ``t`` s, ``nmax``, ``orders``); the scan is kept
    in ``bbdyn.scans.cache.scene_folder("gk", settings, seed, out_dir)``, so a rerun resumes it."""
    start = time.perf_counter()
    nmax = int(settings["nmax"])
    orders = np.array(sorted(set(settings["orders"])), dtype=int)
    if orders[0] < 0 or orders[-1] > nmax:
        raise ValueError(f"orders must lie in [0, nmax = {nmax}], got {orders.tolist()}")
    arrays, scan_meta = scan_points(settings, seed, out_dir, keys=KEYS, progress=progress)
    arrays["orders"] = orders
    D, D_err = arrays["D"], arrays["D_err"]
    key = {"frequencies": f"{D.size} from {arrays['f'][0]:g} to {arrays['f'][-1]:g} Hz"}
    key["D range"] = f"{D.min():.3g} to {D.max():.3g} mm^2/s"
    for n in orders:
        d_n, err = arrays["D_n"][:, n], arrays["D_n_err"][:, n]
        pull = (d_n - D) / np.hypot(err, D_err)
        key[f"D_{n}"] = (
            f"mean D_{n}/D = {np.mean(d_n / D):.3f}; within 2 errors of D at "
            f"{int(np.sum(np.abs(pull) <= 2))} of {D.size} frequencies"
        )
    key["p_f"] = f"{np.nanmin(arrays['p_f']):.3f} to {np.nanmax(arrays['p_f']):.3f}"
    meta = make_meta(
        seed=seed,
        wall_s=time.perf_counter() - start,
        scan_manifest={k: scan_meta.get(k) for k in ("compute", "seed", "bbdyn_version")},
        key_numbers=key,
    )
    meta["params"] = {k: v for k, v in Params(f=85.0).to_dict().items() if k != "f"}
    return SceneS10Result(arrays, meta)


def draw(result: Result, ax=None):
    """D (band and points) and D_n for the chosen orders against f; returns the Figure."""
    fig, ax = figure_axes(ax, figsize=(7, 4.5), layout="constrained")
    f, D, D_err = result["f"], result["D"], result["D_err"]
    ax.fill_between(f, D - D_err, D + D_err, color="k", alpha=0.15, lw=0)
    ax.plot(f, D, "k.-", lw=1, label="Einstein $D$ (band: 1 err)")
    for i, n in enumerate(result["orders"]):
        ax.errorbar(f, result["D_n"][:, n], result["D_n_err"][:, n], fmt="o-", ms=2.5, lw=0.8,
                    capsize=1.5, color=f"C{i}", label=f"$D_{{{n}}}$")  # fmt: skip
    ax.set(xlabel="$f$ (Hz)", ylabel="$D$ (mm$^2$/s)")
    ax.set_title("S10: truncated Green-Kubo $D_n$ against the Einstein $D$")
    ax.legend(fontsize=8, frameon=False, ncol=2)
    return fig
