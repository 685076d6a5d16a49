"""Scene S1: the k/1 Arnold tongues of the flat ball in the (Gamma, alpha) plane.

Closed-form tongues (docs/model.md, derived in ``derivations/flat_tongues.py``) with,
on top, the edges found numerically from the multipliers of the exact map's
k/1 orbits (``bbdyn.flat.tongues.gamma_lo_numeric`` / ``gamma_hi_numeric``).  The
dimensionless tongues do not depend on A or g.
"""

from __future__ import annotations

import time

import numpy as np

from bbdyn.flat.tongues import gamma_hi_numeric, gamma_lo_numeric, tongue_gamma_hi, tongue_gamma_lo
from bbdyn.results import Result, make_meta
from bbdyn.scenes import figure_axes

TITLE = "Arnold tongues k/1 of the flat ball: closed form and exact-map multipliers"
QUICK = {"kmax": 3, "n_curve": 201, "n_numeric": 6}
FULL = {"kmax": 3, "n_curve": 801, "n_numeric": 40}


class SceneS1Result(Result):
    """Arrays: ``alpha_curve`` (n,), ``gamma_lo_curve``/``gamma_hi_curve`` (kmax, n) closed
    form; ``alpha_points`` (p,), ``gamma_lo_numeric``/``gamma_hi_numeric`` (kmax, p)."""

    kind = "scene_s1"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def compute(settings: dict, seed: int = 0) -> SceneS1Result:
    """Closed-form tongues on a fine alpha grid, numeric edges on a coarse one (no randomness)."""
    start = time.perf_counter()
    ks = np.arange(1, int(settings["kmax"]) + 1)[:, None]
    alpha = np.linspace(0.0, 1.0, int(settings["n_curve"]))[None, :]
    points = np.linspace(0.05, 0.95, int(settings["n_numeric"]))
    lo_num = np.array([[gamma_lo_numeric(int(k), a) for a in points] for k in ks[:, 0]])
    hi_num = np.array([[gamma_hi_numeric(int(k), a) for a in points] for k in ks[:, 0]])
    arrays = {
        "k": ks[:, 0],
        "alpha_curve": alpha[0],
        "gamma_lo_curve": tongue_gamma_lo(ks, alpha, np),
        "gamma_hi_curve": tongue_gamma_hi(ks, alpha, np),
        "alpha_points": points,
        "gamma_lo_numeric": lo_num,
        "gamma_hi_numeric": hi_num,
    }
    rel = {
        "max_rel_dev_lo": float(np.max(np.abs(lo_num / tongue_gamma_lo(ks, points, np) - 1))),
        "max_rel_dev_hi": float(np.max(np.abs(hi_num / tongue_gamma_hi(ks, points, np) - 1))),
    }
    return SceneS1Result(arrays, make_meta(seed=seed, wall_s=time.perf_counter() - start, **rel))


def draw(result: Result, ax=None):
    """Tongues as shaded bands in (Gamma, alpha), numeric edges as markers named in the legend
    (outside the axes); returns the Figure."""
    fig, ax = figure_axes(ax, figsize=(8.5, 4.5), layout="constrained")
    a = result["alpha_curve"]
    for i, k in enumerate(result["k"]):
        lo, hi = result["gamma_lo_curve"][i], result["gamma_hi_curve"][i]
        ax.fill_betweenx(a, lo, hi, alpha=0.35, label=f"{k}/1 tongue (closed form)")
        ax.plot(lo, a, "k-", lw=0.6)
        ax.plot(hi, a, "k-", lw=0.6)
        first = i == 0
        ax.plot(result["gamma_lo_numeric"][i], result["alpha_points"], "kv", ms=4,
                label="lower edge, multiplier +1 (exact map)" if first else None)  # fmt: skip
        ax.plot(result["gamma_hi_numeric"][i], result["alpha_points"], "k^", ms=4,
                label="upper edge, multiplier -1 (exact map)" if first else None)  # fmt: skip
    ax.set(xlabel=r"$\Gamma = A\omega^2/g$ (1)", ylabel=r"$\alpha$ (1)", ylim=(0, 1),
           xlim=(0, None))  # fmt: skip
    ax.set_title(f"k/1 Arnold tongues of the flat ball, k = 1-{int(result['k'][-1])}: closed "
                 f"form and {result['alpha_points'].size} edges per side from the exact map",
                 fontsize=10)  # fmt: skip
    handles, labels = ax.get_legend_handles_labels()
    order = sorted(range(len(labels)), key=lambda j: "tongue" not in labels[j])  # bands first
    ax.legend([handles[j] for j in order], [labels[j] for j in order], loc="upper left",
              bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)  # fmt: skip
    return fig
