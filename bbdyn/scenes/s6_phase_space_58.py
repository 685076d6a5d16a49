"""Scene S6: (s, vx+) at collisions on the attractor(s) at 58 Hz (inside the 1/1 tongue).

Particles of the reference ensemble are run for a transient and then continued
(``bbdyn.poincare.poincare``).  Collisions followed by a flight shorter than
``TINY_HOP_PERIODS`` are drawn apart: at 58 Hz most of the reference ensemble
ends on a chatter-stick-release attractor confined to its wedge, not on the
phase-locked one; ``key_numbers`` gives the fractions.
"""

from __future__ import annotations

import numpy as np

from bbdyn.params import Params
from bbdyn.poincare import PoincareResult, poincare
from bbdyn.scenes import figure_axes

TITLE = "Phase space (s, vx+) at collisions at 58 Hz"
QUICK = {"f": 58.0, "n": 200, "transient": 10.0, "particles": 200, "n_events": 150}
FULL = {"f": 58.0, "n": 1000, "transient": 40.0, "particles": 1000, "n_events": 500}

#: A particle making more than this many collisions per driving period over the
#: transient's late window is on a chattering attractor (the 1/1 orbit makes one).
CHATTER_RATE = 2.0


def compute(settings: dict, seed: int = 0) -> PoincareResult:
    """Collisions of ``particles`` ensemble particles after ``transient`` seconds."""
    res = poincare(
        Params(f=float(settings["f"])),
        n=int(settings["n"]),
        transient=float(settings["transient"]),
        particles=int(settings["particles"]),
        n_events=int(settings["n_events"]),
        seed=seed,
    )
    res.meta["key_numbers"] = key_numbers(res)
    return res


def key_numbers(res: PoincareResult) -> dict:
    """Counts of collisions drawn and the fractions on each kind of motion."""
    impacts, tiny = res.impacts(), res.tiny_hops()
    rate = res["rate"]
    return {
        "collisions_drawn": int(impacts.sum()),
        "tiny_hop_fraction": float(tiny.sum() / max(impacts.sum(), 1)),
        "ensemble_fraction_chattering": float(np.mean(rate > CHATTER_RATE)),
        "ensemble_median_rate": float(np.median(rate)),
        "vx_range_flights": _range(res["vx"][impacts & ~tiny]),
        "vx_range_tiny_hops": _range(res["vx"][tiny]),
    }


def _range(values: np.ndarray) -> list[float]:
    return [float(values.min()), float(values.max())] if values.size else []


def draw(result: PoincareResult, ax=None):
    """(s, vx+) with tiny hops in orange; returns the Figure."""
    fig, ax = figure_axes(ax, figsize=(6.5, 4.5))
    result.plot(ax=ax, projection="s_vx")
    k = result.meta["key_numbers"]
    ax.set_xlim(0, Params(**result.meta["params"]).s_max)
    ax.set_title(
        f"f = {result.meta['params']['f']:g} Hz: {k['collisions_drawn']} collisions, "
        f"{100 * k['tiny_hop_fraction']:.0f}% tiny hops\n"
        f"ensemble of {result['rate'].size}: median {k['ensemble_median_rate']:.2f} collisions "
        f"per period, {100 * k['ensemble_fraction_chattering']:.0f}% chattering "
        f"(> {CHATTER_RATE:g})",
        fontsize=10,
    )
    ax.legend(loc="upper right", fontsize=8, markerscale=4)
    return fig
