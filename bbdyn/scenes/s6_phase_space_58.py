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
from bbdyn.poincare import TINY_HOP_PERIODS, PoincareResult, poincare

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
    """(s, vx+) at collisions (left) and the flight time to the next collision on a log axis
    (right), tiny hops in orange; with ``ax`` given, only (s, vx+) there.  Returns the Figure.

    The right panel spreads the tiny hops (flights down to 1e-7 periods), which pile up at a
    few points of (s, vx+), over their flight times and the phases of the drive."""
    import matplotlib.pyplot as plt

    if ax is None:
        fig, (ax, ax_t) = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
        _draw_flight_times(result, ax_t)
    else:
        fig, ax_t = ax.figure, None
    result.plot(ax=ax, projection="s_vx")
    ax.set_xlim(0, Params(**result.meta["params"]).s_max)
    ax.set_title(r"$(s, v_x^+)$ at collisions", fontsize=10)
    fig.suptitle(_title(result), fontsize=10)
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=8, markerscale=4,
               frameon=False)  # fmt: skip
    return fig


def _title(result: PoincareResult) -> str:
    """f (Hz), ensemble size n, transient t (s), particles and events drawn, and the counts."""
    m, k = result.meta, result.meta["key_numbers"]
    return (
        f"f = {m['params']['f']:g} Hz: n = {m['n']} particles run for a transient of "
        f"t = {m['transient']:g} s, then {m['n_events']} events of {m['particles']} of them: "
        f"{k['collisions_drawn']} collisions, {100 * k['tiny_hop_fraction']:.0f}% tiny hops\n"
        f"median {k['ensemble_median_rate']:.2f} collisions per period over the ensemble, "
        f"{100 * k['ensemble_fraction_chattering']:.0f}% of it chattering "
        f"(> {CHATTER_RATE:g} collisions per period)"
    )


def _draw_flight_times(result: PoincareResult, ax) -> None:
    """Flight time from each collision to the next (driving periods, log) against the drive
    phase of the collision (rad)."""
    impacts, tiny = result.impacts(), result.tiny_hops()
    flight, s = result["flight"], np.mod(result["phase"], 2 * np.pi)
    other = impacts & ~tiny & (flight > 0)
    size = 1.0 if impacts.sum() > 20000 else 3.0
    ax.scatter(s[other], flight[other], s=size, c="k", lw=0)
    ax.scatter(s[tiny & (flight > 0)], flight[tiny & (flight > 0)], s=size, c="C1", lw=0)
    ax.axhline(TINY_HOP_PERIODS, color="C1", lw=0.8, ls="--")
    ax.set(yscale="log", xlim=(0, 2 * np.pi), xlabel=r"drive phase $\omega t$ mod $2\pi$ (rad)",
           ylabel="flight to the next collision (periods, log)")  # fmt: skip
    ax.set_title(f"flight times; dashed: tiny-hop limit {TINY_HOP_PERIODS:g} periods",
                 fontsize=10)  # fmt: skip
