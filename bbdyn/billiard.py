"""Single trajectories of the bouncing ball billiard (docs/model.md §2).

``simulate`` validates its input once, runs the exact event kernel
``bbdyn.core.billiard.billiard_event`` and returns a ``BilliardTrajectory``:
the collision record (suspended flow ``(s, vx+, vy+, t, l)`` and event kinds).
Ensembles and observables live elsewhere; they use the same kernel.

Example
-------
>>> from bbdyn import Params
>>> from bbdyn.billiard import simulate
>>> traj = simulate(Params(f=58.0), n_events=100, s0=1.0, vx0=10.0, vy0=30.0)
>>> traj["kind"].shape
(101,)
"""

from __future__ import annotations

import math
import time
from typing import ClassVar

import numpy as np

from bbdyn.core.billiard import EventArrays, EventState, billiard_run
from bbdyn.core.floor import arc_coordinates, xi_from_arc_length
from bbdyn.core.status import IMPACT, RELEASE, STATUS_MESSAGES, STICK, raise_for_status
from bbdyn.params import Params, check_params
from bbdyn.results import Result, make_meta
from bbdyn.runs import MAX_BYTES, MAX_PERIODS

__all__ = [
    "BilliardTrajectory",
    "floor_profile",
    "simulate",
    "state_from_section",
    "xi_at_arc_length",
]

_KINDS = (IMPACT, STICK, RELEASE)


def floor_profile(params: Params, xi) -> tuple[np.ndarray, np.ndarray]:
    """Arc length s from the left wedge and height b (mm) of the static floor at the local
    coordinates ``xi`` (mm, in [-d/2, d/2]; 0 is the arc top): docs/model.md §2.  Geometry
    only: the same for any noise amplitude ``eta``."""
    xi = np.ascontiguousarray(xi, dtype=np.float64)
    return arc_coordinates(xi, params.kernel(noise=True))


def xi_at_arc_length(params: Params, s: float) -> float:
    """Local coordinate xi (mm) of the floor point at arc length ``s`` (mm) from the left wedge
    (geometry only: the same for any noise amplitude ``eta``)."""
    return xi_from_arc_length(float(s), params.kernel(noise=True))


def state_from_section(
    params: Params, s: float, vx: float, vy: float, *, tile: float = 0.0, phase: float = 0.0
) -> tuple[float, float, float, float, float, float, int]:
    """Kernel state of a post-collision point ``(s, vx+, vy+)`` on the floor (docs/model.md §3).

    Parameters
    ----------
    params : Params
    s : float
        Arc length from the left wedge of the tile (mm), in [0, s_max].
    vx, vy : float
        Absolute post-collision velocity (mm/s); it must leave the arc.
    tile : float
        Tile index (integer).
    phase : float
        Phase w t at the collision (rad); the ensemble convention is t = 0.

    Returns
    -------
    (periods, phase, tile, xi, vx, vyrel, kind) with ``periods = 0`` and kind IMPACT.
    """
    for name, value in (("s", s), ("vx", vx), ("vy", vy), ("phase", phase)):
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
    if not 0.0 <= s <= params.s_max:
        raise ValueError(f"s must be in [0, s_max = {params.s_max}] mm, got {s}")
    if not 0.0 <= phase < 2.0 * math.pi:
        raise ValueError(f"phase must be in [0, 2 pi), got {phase}")
    _check_offset("tile", tile)
    kp = params.kernel()
    xi = xi_from_arc_length(s, kp)
    vyrel = vy + kp.A * kp.w * math.cos(phase)  # vy - u, u = -A w cos(phase)
    S = math.sqrt(kp.R**2 - xi**2)
    vn = vx * xi + vyrel * S
    if not vn > 0.0:
        raise ValueError(
            f"the velocity must leave the floor (normal component relative to the floor > 0), "
            f"got vx={vx}, vy={vy} at s={s}"
        )
    if abs(xi) >= 0.5 * kp.d and not vyrel * S > abs(vx * xi):
        # on a wedge the particle touches both arcs; the kernel continues it on the arc it
        # moves over, so the velocity must leave the neighbouring arc too
        raise ValueError(
            f"at a wedge (s = {s}) the velocity must leave both arcs, got vx={vx}, vy={vy}"
        )
    return 0.0, float(phase), float(tile), xi, float(vx), vyrel, IMPACT


class BilliardTrajectory(Result):
    """Collision record of one billiard trajectory (docs/model.md §2, suspended flow).

    Row 0 is the initial state; row i > 0 the state just after event i.
    Arrays (length n + 1): ``periods`` (whole driving periods), ``phase`` (w t mod
    2 pi, rad), ``t`` (s, convenience; loses precision beyond ~1e9 periods),
    ``tile`` (l), ``xi`` (mm from the tile centre), ``x`` (mm), ``s`` (arc length
    from the left wedge, mm), ``vx``, ``vy`` (absolute post-event velocity, mm/s),
    ``vyrel`` (vy - u, mm/s), ``y`` (height of the particle = floor, mm) and
    ``kind`` (IMPACT 0, STICK 1, RELEASE 2).  ``meta["status"]`` says why the run
    ended (``ok`` or ``stuck forever`` for Gamma <= 1).
    """

    kind: ClassVar[str] = "billiard_trajectory"

    def plot(self, ax=None):
        """Poincare projection (s, vx+) at impacts; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        impact = self["kind"] == IMPACT
        ax.plot(self["s"][impact], self["vx"][impact], ",", color="k")
        ax.set_xlabel("s (mm)")
        ax.set_ylabel("$v_x^+$ (mm/s)")
        return ax


def simulate(
    params: Params,
    *,
    n_events: int,
    state0: tuple | None = None,
    s0: float | None = None,
    vx0: float | None = None,
    vy0: float | None = None,
    max_bytes: float | None = None,
) -> BilliardTrajectory:
    """Run one trajectory for ``n_events`` events (impacts, sticks, releases).

    Parameters
    ----------
    params : Params
        Model parameters; ``beta = 1`` with ``alpha < 1`` is refused (sliding).
    n_events : int
        Number of events after the initial state (>= 1).
    state0 : tuple, optional
        Kernel state ``(periods, phase, tile, xi, vx, vyrel, kind)``.
    s0, vx0, vy0 : float, optional
        Alternatively, a post-collision state at t = 0 on tile 0 (docs/model.md §3),
        converted by ``state_from_section``.
    max_bytes : float, optional
        Refuse (ValueError, before allocating) runs whose arrays would take more bytes;
        default ``bbdyn.runs.MAX_BYTES``.  Raise it if you mean it.

    Returns
    -------
    BilliardTrajectory
        Shorter than ``n_events + 1`` rows if the particle got stuck for good
        (Gamma <= 1; ``meta["status"]``).

    Raises
    ------
    SimulationError
        If the kernel fails (see ``bbdyn.core.status``).
    """
    check_params(params)
    if isinstance(n_events, bool) or not isinstance(n_events, int | np.integer) or n_events < 1:
        raise ValueError(f"n_events must be an integer >= 1, got {n_events!r}")
    if state0 is None:
        if s0 is None or vx0 is None or vy0 is None:
            raise ValueError("give either state0 or all of s0, vx0, vy0")
        state0 = state_from_section(params, s0, vx0, vy0)
    elif s0 is not None or vx0 is not None or vy0 is not None:
        raise ValueError("give either state0 or s0, vx0, vy0, not both")
    state0 = _check_state(params, state0)
    kp = params.kernel()
    n = int(n_events) + 1
    _check_bytes(n, max_bytes)
    arrays = {
        "periods": np.empty(n),
        "phase": np.empty(n),
        "tile": np.empty(n),
        "xi": np.empty(n),
        "vx": np.empty(n),
        "vyrel": np.empty(n),
        "kind": np.empty(n, dtype=np.int64),
    }
    for name, value in zip(arrays, state0, strict=True):
        arrays[name][0] = value
    wall = time.perf_counter()
    out = EventArrays(*(a[1:] for a in arrays.values()))
    _, n_done, status = billiard_run(EventState(*state0), kp, n - 1, out)
    wall = time.perf_counter() - wall
    raise_for_status(status, f"billiard simulate at f = {params.f} Hz, event {n_done + 1}")
    arrays = {k: v[: n_done + 1] for k, v in arrays.items()}
    arrays.update(_derived(kp, arrays))
    meta = make_meta(
        params, wall_s=wall, status=STATUS_MESSAGES[status], n_events=int(n_done), state0=state0
    )
    return BilliardTrajectory(arrays, meta)


#: Float64 columns of a trajectory per recorded state: the kernel's 7 and ``_derived``'s 5,
#: plus the 2 temporaries of ``arc_coordinates``.
BYTES_PER_STATE = 8 * (7 + 5 + 2)


def _check_bytes(n_states: int, max_bytes: float | None) -> None:
    """Refuse a trajectory of ``n_states`` states above ``max_bytes`` (default ``MAX_BYTES``)."""
    max_bytes = MAX_BYTES if max_bytes is None else float(max_bytes)
    nbytes = n_states * BYTES_PER_STATE
    if nbytes > max_bytes:
        raise ValueError(
            f"n_events = {n_states - 1} would take {nbytes / 2**30:.3g} GiB of arrays (limit "
            f"max_bytes = {max_bytes / 2**30:.3g} GiB); use fewer events (an ensemble computes "
            "observables on the fly) or pass a larger max_bytes if you mean it"
        )


def _check_state(params: Params, state0) -> tuple:
    try:
        periods, phase, tile, xi, vx, vyrel, kind = state0
    except (TypeError, ValueError):
        raise ValueError(
            f"state0 must be (periods, phase, tile, xi, vx, vyrel, kind), got {state0!r}"
        ) from None
    values = tuple(float(v) for v in (periods, phase, tile, xi, vx, vyrel))
    for name, value in zip(("periods", "phase", "tile", "xi", "vx", "vyrel"), values, strict=True):
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
    periods, phase, tile, xi, vx, vyrel = values
    _check_offset("periods", periods)
    _check_offset("tile", tile)
    if not 0.0 <= phase < 2.0 * math.pi:
        raise ValueError(f"phase must be in [0, 2 pi), got {phase}")
    if not abs(xi) <= params.d / 2:
        raise ValueError(f"xi must be in [-d/2, d/2] = [-{params.d / 2}, {params.d / 2}], got {xi}")
    if kind not in _KINDS:
        raise ValueError(f"kind must be one of {_KINDS} (IMPACT, STICK, RELEASE), got {kind!r}")
    return periods, phase, tile, xi, vx, vyrel, int(kind)


def _check_offset(name: str, value: float) -> None:
    """Refuse a whole-number offset (``periods``, ``tile``) that is not an integer, or one
    of magnitude >= ``MAX_PERIODS`` = 2^52, beyond which the kernel's sums of the offset
    and a fraction (a phase, a position in the tile) are no longer exact."""
    if not abs(value) < MAX_PERIODS:
        raise ValueError(
            f"{name} must be an integer of magnitude < 2^52 = {MAX_PERIODS:.0f} (times and "
            f"positions are whole numbers plus a fraction, exact below 2^52), got {value}"
        )
    if value != math.floor(value):
        raise ValueError(f"{name} must be an integer, got {value}")


def _derived(kp, arrays: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Arc length, absolute velocity, height and time of each recorded state."""
    xi, phase = arrays["xi"], arrays["phase"]
    s, b = arc_coordinates(np.ascontiguousarray(xi, dtype=np.float64), kp)
    return {
        "s": s,
        "vy": arrays["vyrel"] - kp.A * kp.w * np.cos(phase),
        "y": -kp.A * np.sin(phase) + b,
        "x": (arrays["tile"] + 0.5) * kp.d + xi,
        "t": (arrays["periods"] + phase / (2.0 * np.pi)) * kp.period,
    }
