"""Scene S8: a piece of trajectory at 88.4 Hz and (y, vy+) at collisions, regions numbered.

One particle of the reference ensemble after a transient (``bbdyn.poincare.poincare``).
Left: its path (x, y) over ``piece_events`` events (parabolas, and riding the floor
after a stick) above the floor under it.  Right: (y, vy+) at its collisions; the
regions are numbered in the order of their first visit by
``bbdyn.poincare.number_regions`` (occupied cells of a ``bins x bins`` grid that
touch form one region); only regions holding at least ``LABEL_MIN_FRACTION`` of
the collisions are labelled.
"""

from __future__ import annotations

import numpy as np

from bbdyn.params import Params
from bbdyn.poincare import (
    PoincareResult,
    number_regions,
    poincare,
    trajectory_pieces,
    visit_sequence,
)

TITLE = "Orbit at 88.4 Hz: trajectory piece and (y, vy+) at collisions, regions in visiting order"
QUICK = {"f": 88.4, "n": 20, "transient": 10.0, "n_events": 400, "piece_events": 13, "bins": 24}
FULL = {"f": 88.4, "n": 20, "transient": 40.0, "n_events": 5000, "piece_events": 13, "bins": 24}

#: Regions with fewer collisions than this fraction are drawn but not numbered.
LABEL_MIN_FRACTION = 0.02


def compute(settings: dict, seed: int = 0) -> PoincareResult:
    """One particle's collisions, the path over the first ``piece_events`` events, region labels."""
    res = poincare(
        Params(f=float(settings["f"])),
        n=int(settings["n"]),
        transient=float(settings["transient"]),
        particles=1,
        n_events=int(settings["n_events"]),
        seed=seed,
    )
    pieces = trajectory_pieces(res, 0, min(int(settings["piece_events"]), res["kind"].size - 1))
    impacts = res.impacts()
    labels = np.zeros(res["kind"].size, dtype=np.int64)
    labels[impacts] = number_regions(res["y"][impacts], res["vy"][impacts], int(settings["bins"]))
    res.arrays.update({"piece_" + k: v for k, v in pieces.items()})
    res.arrays["region"] = labels
    counts = np.bincount(labels[impacts])[1:]
    major = np.flatnonzero(counts >= LABEL_MIN_FRACTION * impacts.sum()) + 1
    seq = visit_sequence(labels[impacts])
    res.meta["key_numbers"] = {
        "collisions": int(impacts.sum()),
        "regions": int(counts.size),
        "major_regions": int(major.size),
        "fraction_in_major_regions": float(counts[major - 1].sum() / impacts.sum()),
        "visit_sequence_start": seq[:24].tolist(),
        "cycle_order": cycle_order(seq[:24], major),
        "mean_flight_periods": float(np.mean(res["flight"][impacts])),
    }
    return res


def cycle_order(seq, major) -> list[int]:
    """Order of the ``major`` regions in the cycle that the visits ``seq`` go round.

    Every visit goes on to a region later in the order, or back to region 1 (regions are
    numbered by first visit, so one that the first cycle leaves out is numbered late).
    Visits to other regions are skipped; ``[]`` if the visits admit no such order.
    """
    import graphlib

    keep = set(int(r) for r in major)
    visits = [int(r) for r in seq if int(r) in keep]
    graph = graphlib.TopologicalSorter()
    for a, b in zip(visits[:-1], visits[1:], strict=True):
        if b != 1 and a != b:
            graph.add(b, a)
    try:
        return list(graph.static_order())
    except graphlib.CycleError:
        return []


def draw(result: PoincareResult, ax=None):
    """Path and (y, vy+) panels; with ``ax`` given, only (y, vy+). Returns the Figure."""
    import matplotlib.pyplot as plt

    if ax is None:
        fig, (ax_path, ax) = plt.subplots(1, 2, figsize=(12, 4.8), layout="constrained")
        _draw_path(result, ax_path)
        m = result.meta
        fig.suptitle(f"f = {m['params']['f']:g} Hz: one particle of an ensemble of n = {m['n']}"
                     f" after a transient of t = {m['transient']:g} s, then {m['n_events']} "
                     "events", fontsize=10)  # fmt: skip
    else:
        fig = ax.figure
    impacts = result.impacts()
    y, vy, labels = result["y"][impacts], result["vy"][impacts], result["region"][impacts]
    ax.scatter(y, vy, c=labels % 10, cmap="tab10", vmin=0, vmax=9, s=6, lw=0)
    counts = np.bincount(labels)[1:]
    for region in np.flatnonzero(counts >= LABEL_MIN_FRACTION * labels.size) + 1:
        sel = labels == region
        ax.annotate(
            str(region),
            (np.median(y[sel]), np.median(vy[sel])),
            xytext=(6, 6),
            textcoords="offset points",
            fontsize=12,
            weight="bold",
        )
    k = result.meta["key_numbers"]
    seq = " ".join(str(v) for v in k["visit_sequence_start"][:18])
    ax.set(xlabel="y (mm)", ylabel=r"$v_y^+$ (mm/s)")
    ax.set_title(f"{k['collisions']} collisions; regions visited: {seq} ...", fontsize=9)
    return fig


def _draw_path(result: PoincareResult, ax) -> None:
    x, y, floor = result["piece_x"], result["piece_y"], result["piece_floor"]
    event = result["piece_event"]
    for i in np.unique(event):
        sel = event == i
        ax.plot(x[sel], y[sel], "C0-", lw=1)
        ax.plot(x[sel], floor[sel], "-", color="0.5", lw=0.8)
    ends = np.unique(event)
    ax.plot(result["x"][ends], result["y"][ends], "ko", ms=3, label="collisions")
    ax.plot([], [], "-", color="0.5", label="floor under the particle")
    t_ms = 1e3 * result["piece_t"][-1]
    ax.set(xlabel="x (mm)", ylabel="y (mm)")
    ax.set_title(f"path over {ends.size} flights, {t_ms:.0f} ms", fontsize=9)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(0.0, -0.12), ncol=2, frameon=False)
