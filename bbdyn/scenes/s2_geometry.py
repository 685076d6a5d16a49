"""Scene S2: a sketch of the billiard (docs/model.md §2), vertical scale exaggerated.

Three tiles of the floor of circular arcs at its mean position and at its
extreme positions y_p = +-A, from the floor geometry of ``bbdyn.billiard``;
a particle leaving an arc point at arc length s with velocity (vx, vy);
gravity g and the drive y_p(t) = -A sin(w t).  No randomness.
"""

from __future__ import annotations

import time

import numpy as np

from bbdyn.billiard import floor_profile, xi_at_arc_length
from bbdyn.params import Params
from bbdyn.results import Result, make_meta
from bbdyn.scenes import figure_axes

TITLE = "The bouncing ball billiard: floor of arcs, drive, arc length and velocities"
QUICK = {"f": 58.0, "tiles": 3, "points": 121, "s_frac": 0.3}
FULL = {"f": 58.0, "tiles": 3, "points": 601, "s_frac": 0.3}


class SceneS2Result(Result):
    """Arrays: ``x`` (mm), ``b`` (floor height above the wedges at x, mm), ``s_x``/``s_b``
    (the arc from the left wedge of tile 1 to the marked point) and ``point`` (x, y, s)
    of the marked point."""

    kind = "scene_s2"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def compute(settings: dict, seed: int = 0) -> SceneS2Result:
    """Floor profile over ``tiles`` tiles and a marked arc point at ``s_frac * s_max`` on tile 1."""
    start = time.perf_counter()
    params = Params(f=float(settings["f"]))
    tiles, points = int(settings["tiles"]), int(settings["points"])
    xi = np.linspace(-0.5 * params.d, 0.5 * params.d, points)
    s_all, b = floor_profile(params, xi)
    x = np.concatenate([(tile + 0.5) * params.d + xi for tile in range(tiles)])
    s_mark = float(settings["s_frac"]) * params.s_max
    xi_mark = xi_at_arc_length(params, s_mark)
    on_arc = s_all <= s_mark
    _, (b_mark,) = floor_profile(params, [xi_mark])
    arrays = {
        "x": x,
        "b": np.tile(b, tiles),
        "s_x": 1.5 * params.d + xi[on_arc],
        "s_b": b[on_arc],
        "point": np.array([1.5 * params.d + xi_mark, b_mark, s_mark]),
    }
    meta = make_meta(
        params,
        seed=seed,
        wall_s=time.perf_counter() - start,
        key_numbers={"h_mm": params.h, "s_max_mm": params.s_max, "A_over_h": params.A / params.h},
    )
    return SceneS2Result(arrays, meta)


def draw(result: Result, ax=None):
    """The sketch; returns the Figure."""
    fig, ax = figure_axes(ax, figsize=(8, 4.5))
    p = result.meta["params"]
    A, d = p["A"], p["d"]
    x, b = result["x"], result["b"]
    ax.fill_between(x, -A + b, A + b, color="0.85", lw=0, label=r"floor range, $y_p = \pm A$")
    ax.plot(x, b, "k-", lw=1.5, label=r"floor at $y_p = 0$")
    ax.plot(x, b + A, "k:", lw=0.8)
    ax.plot(x, b - A, "k:", lw=0.8)
    wedges = np.arange(0, x.max() + d / 2, d)
    ax.plot(wedges, np.zeros_like(wedges), "kv", ms=5, label="wedges")
    # the arc length s, from the left wedge of the middle tile
    ax.plot(result["s_x"], result["s_b"], "-", color="C3", lw=4, alpha=0.7)
    px, py, s = result["point"]
    ax.annotate(
        f"s = {s:.2f} mm",
        (result["s_x"].mean(), result["s_b"].mean()),
        color="C3",
        xytext=(0, -28),
        textcoords="offset points",
        ha="center",
    )
    ax.plot([px], [py], "o", color="C0", ms=7, zorder=5)
    # velocity components drawn in data units of a 'display' velocity scale
    sx, sy = 0.45 * d, 0.09
    ax.annotate(
        "", (px + sx, py), (px, py), arrowprops={"arrowstyle": "->", "color": "C0", "lw": 2}
    )
    ax.annotate(
        "", (px, py + sy), (px, py), arrowprops={"arrowstyle": "->", "color": "C0", "lw": 2}
    )
    ax.annotate(
        "",
        (px + sx, py + sy),
        (px, py),
        arrowprops={"arrowstyle": "->", "color": "C0", "lw": 1, "ls": "--"},
    )
    ax.text(px + sx, py - 0.012, r"$v_x$", color="C0", ha="center", va="top")
    ax.text(px - 0.05, py + sy, r"$v_y$", color="C0", ha="right")
    # the drive and gravity
    xd = x.max() - 0.15 * d
    ax.annotate("", (xd, A), (xd, -A), arrowprops={"arrowstyle": "<->", "color": "k"})
    ax.text(xd - 0.05, 0.5 * A, r"$2A$", ha="right")
    ax.text(
        x.max() - 0.05 * d,
        -0.16,
        r"$y_p(t) = -A\sin\omega t$" + "\n" + r"$\omega = 2\pi f$",
        ha="right",
        va="bottom",
        fontsize=9,
    )
    xg = 0.2 * d
    ax.annotate("", (xg, 0.12), (xg, 0.2), arrowprops={"arrowstyle": "->", "color": "k", "lw": 2})
    ax.text(xg + 0.08, 0.16, "g", va="center")
    h = result.meta["key_numbers"]["h_mm"]
    ax.annotate("", (0.5 * d, h), (0.5 * d, 0), arrowprops={"arrowstyle": "<->", "color": "0.3"})
    ax.text(0.5 * d, h + 0.008, f"h = {h:.3f} mm", ha="center", fontsize=8, color="0.3")
    ax.set(xlim=(0, x.max()), ylim=(-0.17, 0.22), xlabel="x (mm)", ylabel="y (mm)")
    bbox = ax.get_window_extent()
    exaggeration = (bbox.height / 0.39) / (bbox.width / x.max())
    ax.set_title(
        f"Floor of arcs (R = {p['R']:g} mm, d = {d:g} mm, A = {A:g} mm); "
        f"vertical scale x{exaggeration:.0f}",
        fontsize=10,
    )
    ax.legend(loc="upper center", fontsize=8, ncol=3)
    return fig
