"""Poincaré projections of the billiard: collisions on the attractor (docs/model.md §2).

The suspended flow is recorded at every event ``(s, vx+, vy+, t, l)``; this
module collects it *on the attractor*, after a transient, and draws its
projections (s, vx+) and (y, vy+) (scenes S6, S7, S8 of docs/model.md §6).

Two sources:

* ``poincare``: the reference ensemble (or any box) is run for a transient
  with ``bbdyn.ensemble.ensemble``; the final states of some of its particles
  are continued with ``bbdyn.billiard.simulate`` for a number of events.  The
  collision rate of every particle over the transient's late window is kept
  (``rate``, collisions per driving period), a cheap sign of which attractor it
  reached when several coexist.
* ``poincare_trajectory``: one long trajectory from a post-collision state,
  its first events discarded.

Between events the motion is known in closed form (a parabola, or riding the
floor after a STICK); ``trajectory_pieces`` samples it with the floor under the
particle, and ``number_regions`` numbers the regions visited in a projection
in the order of their first visit.

Tiny hops.  A collision is a *tiny hop* when the flight after it lasts less
than ``TINY_HOP_PERIODS`` driving periods.  This is a display convention for
the creeps of docs/model.md §5 (long sequences of tiny hops), not physics:
flight times of a chattering sequence spread continuously from 1e-8 periods
up, so the threshold is placed well below the flights of the resonant motion
(0.1 to 3 periods at 58 to 88.4 Hz).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from bbdyn.billiard import BilliardTrajectory, simulate
from bbdyn.core.floor import arc_coordinates
from bbdyn.core.status import IMPACT, STICK
from bbdyn.ensemble import ensemble
from bbdyn.params import Params, check_params
from bbdyn.results import Result, make_meta

__all__ = [
    "PoincareResult",
    "TINY_HOP_PERIODS",
    "poincare",
    "poincare_trajectory",
    "trajectory_pieces",
    "number_regions",
    "visit_sequence",
]

#: A collision whose next flight is shorter than this many driving periods is a
#: tiny hop (drawn apart as part of a creep); see the module docstring.
TINY_HOP_PERIODS = 0.05

#: Columns of a trajectory kept per event (the kernel state and what is derived from it).
_COLUMNS = ("periods", "phase", "t", "tile", "xi", "x", "s", "vx", "vy", "vyrel", "y", "kind")

_PROJECTIONS = {
    "s_vx": ("s", "vx", "s (mm)", r"$v_x^+$ (mm/s)"),
    "y_vy": ("y", "vy", "y (mm)", r"$v_y^+$ (mm/s)"),
}


class PoincareResult(Result):
    """Events of one or more trajectories on the attractor (docs/model.md §2).

    Arrays, one row per event (all particles concatenated, each in time order):
    ``periods`` (whole driving periods), ``phase`` (w t mod 2 pi, rad), ``t`` (s),
    ``tile`` (l), ``xi`` (mm from the tile centre), ``x`` (mm), ``s`` (arc length from
    the left wedge, mm), ``vx``, ``vy`` (absolute post-event velocity, mm/s), ``vyrel``
    (vy - u, mm/s), ``y`` (height at the event = floor height, mm), ``kind`` (IMPACT,
    STICK, RELEASE), ``particle`` (index in the ensemble) and ``flight`` (time to the
    particle's next event in driving periods; NaN for its last event).  From
    ``poincare`` also ``rate`` (n,): collisions per driving period of every ensemble
    particle over the transient's late window.
    """

    kind: ClassVar[str] = "poincare"

    def impacts(self) -> np.ndarray:
        """Boolean mask of the collisions (kind IMPACT) whose next flight is known."""
        return (self["kind"] == IMPACT) & np.isfinite(self["flight"])

    def tiny_hops(self) -> np.ndarray:
        """Mask of collisions followed by a flight shorter than ``TINY_HOP_PERIODS``."""
        return self.impacts() & (self["flight"] < TINY_HOP_PERIODS)

    def plot(self, ax=None, projection: str = "s_vx", split_tiny: bool = True):
        """Draw a projection of the collisions; returns the axes.

        Parameters
        ----------
        projection : {"s_vx", "y_vy"}
            (s, vx+) or (y, vy+) at collisions.
        split_tiny : bool
            Draw tiny hops (creeps) in orange, other collisions in black.
        """
        import matplotlib.pyplot as plt

        if projection not in _PROJECTIONS:
            raise ValueError(f"projection must be one of {list(_PROJECTIONS)}, got {projection!r}")
        if ax is None:
            _, ax = plt.subplots()
        xname, yname, xlabel, ylabel = _PROJECTIONS[projection]
        tiny = self.tiny_hops() if split_tiny else np.zeros(self["kind"].shape, bool)
        other = self.impacts() & ~tiny
        size = 1.0 if other.sum() + tiny.sum() > 20000 else 3.0
        ax.scatter(self[xname][other], self[yname][other], s=size, c="k", lw=0, label="flights")
        if tiny.any():
            label = f"tiny hops (flight < {TINY_HOP_PERIODS} periods)"
            ax.scatter(self[xname][tiny], self[yname][tiny], s=3.0, c="C1", lw=0, label=label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        return ax


def _rows(traj: BilliardTrajectory, first: int, particle: int) -> dict:
    rows = {name: traj[name][first:] for name in _COLUMNS}
    t_periods = rows["periods"] + rows["phase"] / (2.0 * math.pi)
    rows["flight"] = np.append(np.diff(t_periods), np.nan)
    rows["particle"] = np.full(rows["kind"].shape, particle, dtype=np.int64)
    return rows


def _concat(parts: list[dict]) -> dict[str, np.ndarray]:
    return {name: np.concatenate([p[name] for p in parts]) for name in parts[0]}


def poincare(
    params: Params,
    *,
    n: int = 1000,
    transient: float = 20.0,
    particles: int = 10,
    n_events: int = 2000,
    seed=0,
    box=None,
) -> PoincareResult:
    """Collisions on the attractor(s) reached from an ensemble (docs/model.md §2, §3).

    Parameters
    ----------
    params : Params
    n : int
        Ensemble size (initial conditions from ``box``, default the reference box).
    transient : float
        Time (s) run and discarded before recording.
    particles : int
        The first ``particles`` particles (a random sample of the ensemble) are continued.
    n_events : int
        Events recorded per continued particle.
    seed, box
        As in ``bbdyn.ensemble.ensemble``.

    Returns
    -------
    PoincareResult
        ``particles * (n_events + 1)`` rows at most (fewer if a particle sticks for good).

    Examples
    --------
    >>> from bbdyn import Params
    >>> res = poincare(Params(f=85.2), n=20, transient=2.0, particles=2, n_events=100)
    >>> sorted(set(res["particle"].tolist()))
    [0, 1]
    """
    check_params(params)
    if isinstance(particles, bool) or int(particles) != particles or not 1 <= particles <= n:
        raise ValueError(f"particles must be an integer in [1, n = {n}], got {particles!r}")
    res = ensemble(params, n=n, t=transient, seed=seed, box=box, observables=())
    parts = []
    for i in range(int(particles)):
        traj = simulate(params, n_events=n_events, state0=tuple(res["final"][i]))
        parts.append(_rows(traj, 0, i))
    arrays = _concat(parts)
    arrays["rate"] = res["collisions"] / (res.meta["window_s"] * params.f)
    meta = make_meta(
        params,
        seed=seed,
        wall_s=res.meta["wall_s"],
        source="ensemble",
        n=n,
        transient=transient,
        particles=int(particles),
        n_events=n_events,
        box=res.meta["box"],
    )
    return PoincareResult(arrays, meta)


def poincare_trajectory(
    params: Params, *, s0: float, vx0: float, vy0: float, n_events: int, transient_events: int = 0
) -> PoincareResult:
    """Collisions of one trajectory from a post-collision state, the first ones discarded.

    Parameters
    ----------
    params : Params
    s0, vx0, vy0 : float
        Post-collision state at t = 0 on tile 0 (mm, mm/s), as in ``simulate``.
    n_events : int
        Events kept after the transient.
    transient_events : int
        Events run and discarded first.

    Returns
    -------
    PoincareResult
        One particle (index 0).
    """
    if isinstance(transient_events, bool) or int(transient_events) != transient_events:
        raise ValueError(f"transient_events must be an integer >= 0, got {transient_events!r}")
    if transient_events < 0:
        raise ValueError(f"transient_events must be an integer >= 0, got {transient_events!r}")
    traj = simulate(params, n_events=n_events + transient_events, s0=s0, vx0=vx0, vy0=vy0)
    arrays = _rows(traj, min(int(transient_events), traj["kind"].size - 1), 0)
    meta = make_meta(
        params,
        wall_s=traj.meta["wall_s"],
        source="trajectory",
        state0=(s0, vx0, vy0),
        n_events=n_events,
        transient_events=int(transient_events),
    )
    return PoincareResult(arrays, meta)


def trajectory_pieces(
    result: PoincareResult, start: int, stop: int, points: int = 40
) -> dict[str, np.ndarray]:
    """The continuous motion between events ``start`` and ``stop`` (rows of ``result``).

    Each interval is a parabola (after IMPACT or RELEASE) or the particle riding
    the floor at fixed x (after STICK), docs/model.md §2.  Times are measured
    from event ``start``, each interval's time as a difference of
    (periods, phase) so that long runs keep their precision.

    A flight ending in STICK also contains the chattering sequence that the kernel
    sums in closed form (``bbdyn.core.billiard.chatter_sum``, accepted only when it
    lasts ~1e-8 s or less); it is drawn as one parabola, which passes its last
    contact by that time (dipping ~1e-14 mm below the floor).

    Parameters
    ----------
    result : PoincareResult
    start, stop : int
        Row indices, ``start < stop``, of one particle.
    points : int
        Samples per interval (>= 2), both ends included.

    Returns
    -------
    dict of arrays, each of shape ``((stop - start) * points,)``
        ``t`` (s since event ``start``), ``x``, ``y`` (mm), ``floor`` (floor height
        under the particle at that time, mm) and ``event`` (row of the interval's
        starting event).
    """
    if not 0 <= start < stop < result["kind"].size:
        raise ValueError(f"need 0 <= start < stop < {result['kind'].size}, got {start}, {stop}")
    if result["particle"][start] != result["particle"][stop]:
        raise ValueError(f"rows {start} and {stop} belong to different particles")
    if int(points) != points or points < 2:
        raise ValueError(f"points must be an integer >= 2, got {points!r}")
    # the flights between recorded events: free fall, whatever restitution ended them (eta)
    kp = Params(**result.meta["params"]).kernel(noise=True)
    rows = np.arange(start, stop)
    periods, phase = result["periods"], result["phase"]
    dt = (periods[rows + 1] - periods[rows]) * kp.period + (phase[rows + 1] - phase[rows]) / kp.w
    offset = (periods[rows] - periods[start]) * kp.period + (phase[rows] - phase[start]) / kp.w
    tau = dt[:, None] * np.linspace(0.0, 1.0, int(points))[None, :]
    stuck = (result["kind"][rows] == STICK)[:, None]
    x0, y0 = result["x"][rows, None], result["y"][rows, None]
    vx, vy = result["vx"][rows, None], result["vy"][rows, None]
    theta = phase[rows, None] + kp.w * tau
    x = x0 + np.where(stuck, 0.0, tau * (vx + 0.5 * kp.g_t * tau))
    # Riding the floor: y = y_p(t) + b(xi) with b = y0 - y_p(t0).
    ride = y0 + kp.A * (np.sin(phase[rows, None]) - np.sin(theta))
    y = np.where(stuck, ride, y0 + vy * tau - 0.5 * kp.g * tau * tau)
    tile = np.floor(x / kp.d)
    # The particle itself sits on a wedge or tile edge at an event: take the tile recorded.
    at_event = tau == 0.0
    tile = np.where(at_event, result["tile"][rows, None], tile)
    xi = np.clip(x - (tile + 0.5) * kp.d, -0.5 * kp.d, 0.5 * kp.d)
    _, b = arc_coordinates(np.ascontiguousarray(xi.ravel()), kp)
    floor = -kp.A * np.sin(theta).ravel() + b
    return {
        "t": (offset[:, None] + tau).ravel(),
        "x": x.ravel(),
        "y": y.ravel(),
        "floor": floor,
        "event": np.repeat(rows, int(points)),
    }


def number_regions(u, v, bins: int = 24) -> np.ndarray:
    """Number the regions a sequence of points visits, in the order of first visit.

    Rule: the bounding box of the points ``(u_i, v_i)`` is cut into ``bins x bins``
    equal cells; occupied cells that touch (8-neighbourhood) form one region; regions
    are numbered 1, 2, ... in the order in which the sequence first enters them.
    The labels depend only on the sequence and ``bins``: they are unchanged by
    a positive rescaling of either coordinate (up to rounding at cell edges), and
    the first visits are labelled 1, 2, 3, ... in increasing order.

    Parameters
    ----------
    u, v : array_like, shape (n,)
        The points in sequence order (e.g. y and vy+ at successive collisions).
    bins : int
        Cells per axis (>= 1); coarser grids merge nearby clusters.

    Returns
    -------
    labels : int array, shape (n,)
        Region number (>= 1) of every point.

    Examples
    --------
    >>> number_regions([5.0, 0.0, 5.0, 0.1], [5.0, 0.0, 5.0, 0.0], bins=4).tolist()
    [1, 2, 1, 2]
    """
    from scipy import ndimage

    u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
    if u.shape != v.shape or u.ndim != 1 or u.size == 0:
        raise ValueError(
            f"u and v must be non-empty 1-d arrays of one shape, got {u.shape}, {v.shape}"
        )
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(v))):
        raise ValueError("u and v must be finite")
    if isinstance(bins, bool) or int(bins) != bins or bins < 1:
        raise ValueError(f"bins must be an integer >= 1, got {bins!r}")
    cells = [_cell_index(c, int(bins)) for c in (u, v)]
    occupied = np.zeros((int(bins), int(bins)), dtype=bool)
    occupied[cells[0], cells[1]] = True
    grid, _ = ndimage.label(occupied, structure=np.ones((3, 3), dtype=int))
    raw = grid[cells[0], cells[1]]
    _, first = np.unique(raw, return_index=True)
    first = np.sort(first)  # the first visit of each region, in time order
    renumber = np.zeros(grid.max() + 1, dtype=np.int64)
    renumber[raw[first]] = np.arange(1, first.size + 1)
    return renumber[raw]


def _cell_index(c: np.ndarray, bins: int) -> np.ndarray:
    lo, span = c.min(), np.ptp(c)
    if span == 0.0:
        return np.zeros(c.size, dtype=np.int64)
    return np.minimum(((c - lo) / span * bins).astype(np.int64), bins - 1)


def visit_sequence(labels) -> np.ndarray:
    """The labels with consecutive repeats removed: the order in which regions are visited."""
    labels = np.asarray(labels)
    if labels.size == 0:
        return labels
    keep = np.append(True, labels[1:] != labels[:-1])
    return labels[keep]
