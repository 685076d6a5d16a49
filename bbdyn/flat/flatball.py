"""The flat bouncing ball: exact impact map, trajectories and ensembles (docs/model.md §1).

User-facing layer over the numba kernel ``bbdyn.core.flat``: it validates the
initial state once, runs the kernel, turns failures into exceptions and returns
result objects.  Time is kept as (whole periods, phase ``w t mod 2 pi``) and
velocities after events relative to the plate, as in the kernel.
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.core.flat import FlatArrays, FlatState, flat_run
from bbdyn.core.status import (
    EVENT_NAMES,
    IMPACT,
    OK,
    RELEASE,
    STATUS_MESSAGES,
    STICK,
    STUCK_FOREVER,
    raise_for_status,
)
from bbdyn.params import Params
from bbdyn.results import Result, make_meta

__all__ = ["FlatTrajectory", "FlatEnsemble", "simulate_flat", "flat_ensemble", "flat_heights"]

TWO_PI = 2.0 * math.pi


class FlatTrajectory(Result):
    """Events of one flat-ball trajectory; row 0 is the initial state.

    Arrays (shape (n + 1,)): ``periods`` (whole driving periods, integer-valued
    float), ``phase`` (w t mod 2 pi, rad), ``vrel`` (velocity relative to the
    plate just after the event, mm/s), ``v`` (absolute velocity, mm/s) and
    ``kind`` (IMPACT, STICK, RELEASE of ``bbdyn.core.status``).  ``meta['status']``
    is ``'ok'`` or ``'stuck_forever'`` (Gamma <= 1: the run ended early).
    """

    kind = "flat_trajectory"

    @property
    def t(self) -> np.ndarray:
        """Event times (s): (periods + phase / 2 pi) / f."""
        f = self.meta["params"]["f"]
        return (self["periods"] + self["phase"] / TWO_PI) / f

    @property
    def params(self) -> Params:
        """The parameters of the run."""
        return Params(**self.meta["params"])

    def heights(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Particle and plate heights (mm) at times ``t`` (s); see ``flat_heights``."""
        return flat_heights(self, t)

    def plot(self, ax=None, *, what: str = "map"):
        """Draw the trajectory and return the axes.

        ``what='map'``: the impact map, impact phase against the absolute
        post-impact velocity (stick and release events marked).  ``what='path'``:
        the height y(t) of the particle (parabolas, riding while stuck) and of the plate.
        """
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        if what == "map":
            for code, marker in ((IMPACT, "."), (STICK, "x"), (RELEASE, "^")):
                sel = self["kind"] == code
                ax.plot(self["phase"][sel], self["v"][sel], marker, ls="", label=EVENT_NAMES[code])
            ax.set_xlim(0, TWO_PI)
            ax.set_xlabel(r"phase $\omega t$ mod $2\pi$ (rad)")
            ax.set_ylabel("velocity after the event (mm/s)")
            ax.legend()
        elif what == "path":
            t_ev = self.t
            t = np.linspace(t_ev[0], t_ev[-1], max(2000, 20 * len(t_ev)))
            t = np.union1d(t, t_ev)  # draw the corners at the impacts exactly
            y, y_plate = self.heights(t)
            ax.plot(t, y_plate, color="0.5", label="plate")
            ax.plot(t, y, label="particle")
            ax.set_xlabel("t (s)")
            ax.set_ylabel("height y (mm)")
            ax.legend()
        else:
            raise ValueError(f"what must be 'map' or 'path', got {what!r}")
        return ax


class FlatEnsemble(Result):
    """Trajectories of an ensemble, padded with NaN (kind -1) after an early end.

    Arrays of shape (n, n_events + 1) as in ``FlatTrajectory``, plus ``phase0``,
    ``vrel0`` (the sampled initial states) and ``n_done`` (events computed per member).
    """

    kind = "flat_ensemble"

    def member(self, i: int) -> FlatTrajectory:
        """Member ``i`` as a ``FlatTrajectory`` (padding removed)."""
        n = int(self["n_done"][i]) + 1
        arrays = {k: self[k][i, :n] for k in ("periods", "phase", "vrel", "v", "kind")}
        status = "ok" if n == self["periods"].shape[1] else "stuck_forever"
        return FlatTrajectory(arrays, {**self.meta, "status": status, "member": i})

    def plot(self, ax=None):
        """Impact map of all members: impact phase against absolute post-impact velocity."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        sel = self["kind"] == IMPACT
        ax.plot(self["phase"][sel], self["v"][sel], ",", ls="")
        ax.set_xlim(0, TWO_PI)
        ax.set_xlabel(r"impact phase $\omega t$ mod $2\pi$ (rad)")
        ax.set_ylabel("velocity after impact (mm/s)")
        return ax


def _initial_state(kp, phase0, v0, vrel0, periods0, stuck):
    """Validated kernel start (periods, phase, vrel, kind) from the user's arguments."""
    if not isinstance(periods0, int | np.integer) or periods0 < 0:
        raise ValueError(f"periods0 must be an integer >= 0, got {periods0!r}")
    if not math.isfinite(phase0):
        raise ValueError(f"phase0 must be finite, got {phase0}")
    whole = math.floor(phase0 / TWO_PI)
    periods = float(periods0 + whole)
    phase = phase0 - whole * TWO_PI
    if phase >= TWO_PI:
        phase, periods = 0.0, periods + 1.0
    if stuck:
        if v0 is not None or vrel0 is not None:
            raise ValueError("v0 and vrel0 must be None for a stuck start (stuck=True)")
        return periods, phase, 0.0, STICK
    if (v0 is None) == (vrel0 is None):
        raise ValueError("give exactly one of v0 (absolute) and vrel0 (relative), mm/s")
    u = -kp.A * kp.w * math.cos(phase)
    vrel = float(vrel0) if vrel0 is not None else float(v0) - u
    if not math.isfinite(vrel):
        given = v0 if vrel0 is None else vrel0
        raise ValueError(f"the initial velocity must be finite, got {given}")
    releasing = kp.release_r <= phase < kp.release_e  # the plate falls away faster than g
    if vrel > 0.0:
        return periods, phase, vrel, IMPACT
    if vrel == 0.0 and releasing:
        return periods, phase, 0.0, RELEASE
    raise ValueError(
        f"the particle must leave the plate: relative velocity v - u must be > 0 mm/s "
        f"(or 0 where sin(phase) < -1/Gamma), got {vrel} at phase {phase}; use stuck=True "
        "for a particle resting on the plate"
    )


def simulate_flat(
    params: Params,
    *,
    n_events: int,
    phase0: float = 0.0,
    v0: float | None = None,
    vrel0: float | None = None,
    periods0: int = 0,
    stuck: bool = False,
) -> FlatTrajectory:
    """Iterate the exact flat-ball map for ``n_events`` events (docs/model.md §1).

    Parameters
    ----------
    params : Params
    n_events : int
        Number of events (impacts, sticks, releases) after the start, >= 1.
    phase0 : float
        Phase w t (rad) of the start; any finite value (reduced mod 2 pi).
    v0, vrel0 : float, optional
        Exactly one: absolute velocity, or velocity relative to the plate
        (mm/s), just after the start.  The particle must leave the plate.
    periods0 : int
        Whole driving periods before the start (>= 0).
    stuck : bool
        Start resting on the plate (then v0 and vrel0 must be None).

    Returns
    -------
    FlatTrajectory
        ``n_events + 1`` rows (fewer if Gamma <= 1 ends the run, ``meta['status']``).

    Examples
    --------
    >>> traj = simulate_flat(Params(f=58.0), n_events=10, vrel0=100.0)
    >>> traj["phase"].shape
    (11,)
    """
    if not isinstance(n_events, int | np.integer) or n_events < 1:
        raise ValueError(f"n_events must be an integer >= 1, got {n_events!r}")
    kp = params.kernel()
    state = _initial_state(kp, phase0, v0, vrel0, periods0, stuck)
    start = time.perf_counter()
    arrays, status = _run(kp, state, int(n_events))
    meta = make_meta(
        params,
        wall_s=time.perf_counter() - start,
        status="stuck_forever" if status == STUCK_FOREVER else "ok",
        status_message=STATUS_MESSAGES[status],
        n_events=int(n_events),
    )
    return FlatTrajectory(arrays, meta)


def _run(kp, state, n_events):
    """Kernel run from ``state``; arrays with the start as row 0, trimmed at an early end."""
    periods = np.empty(n_events + 1)
    phase = np.empty(n_events + 1)
    vrel = np.empty(n_events + 1)
    kind = np.empty(n_events + 1, dtype=np.int64)
    periods[0], phase[0], vrel[0], kind[0] = state
    out = FlatArrays(periods[1:], phase[1:], vrel[1:], kind[1:])
    _, n_done, status = flat_run(FlatState(*state), kp, n_events, out)
    raise_for_status(status, "simulate_flat")
    n = n_done + 1
    arrays = {"periods": periods[:n], "phase": phase[:n], "vrel": vrel[:n], "kind": kind[:n]}
    arrays["v"] = arrays["vrel"] - kp.A * kp.w * np.cos(arrays["phase"])
    return arrays, status if status == STUCK_FOREVER else OK


def flat_ensemble(
    params: Params,
    n: int,
    *,
    n_events: int,
    seed: int,
    v_box: tuple[float, float] = (0.0, 40.0),
) -> FlatEnsemble:
    """Run ``n`` trajectories from random initial states on the plate.

    Member i draws its phase uniformly in [0, 2 pi) and its relative velocity
    uniformly in (v_lo, v_hi] mm/s from ``np.random.SeedSequence(seed).spawn(n)[i]``,
    so its numbers depend only on (seed, i).

    Returns
    -------
    FlatEnsemble
        Arrays (n, n_events + 1); members that end early (Gamma <= 1) are padded with NaN.

    Examples
    --------
    >>> ens = flat_ensemble(Params(f=58.0), 4, n_events=10, seed=1)
    >>> ens["phase"].shape
    (4, 11)
    """
    if not isinstance(n, int | np.integer) or n < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    if not isinstance(n_events, int | np.integer) or n_events < 1:
        raise ValueError(f"n_events must be an integer >= 1, got {n_events!r}")
    v_lo, v_hi = (float(x) for x in v_box)
    if not (math.isfinite(v_lo) and math.isfinite(v_hi) and 0.0 <= v_lo < v_hi):
        raise ValueError(f"v_box must be (lo, hi) with 0 <= lo < hi mm/s, got {v_box}")
    kp = params.kernel()
    start = time.perf_counter()
    shape = (n, n_events + 1)
    out = {k: np.full(shape, np.nan) for k in ("periods", "phase", "vrel", "v")}
    out["kind"] = np.full(shape, -1, dtype=np.int64)
    phase0, vrel0, n_done = np.empty(n), np.empty(n), np.empty(n, dtype=np.int64)
    for i, child in enumerate(np.random.SeedSequence(seed).spawn(n)):
        u1, u2 = np.random.default_rng(child).random(2)
        phase0[i] = TWO_PI * u1
        vrel0[i] = v_hi - (v_hi - v_lo) * u2  # in (lo, hi]: never 0
        arrays, _ = _run(kp, (0.0, phase0[i], vrel0[i], IMPACT), int(n_events))
        m = len(arrays["phase"])
        n_done[i] = m - 1
        for key, value in arrays.items():
            out[key][i, :m] = value
    out.update(phase0=phase0, vrel0=vrel0, n_done=n_done)
    meta = make_meta(
        params,
        seed=seed,
        wall_s=time.perf_counter() - start,
        n=int(n),
        n_events=int(n_events),
        v_box=[v_lo, v_hi],
    )
    return FlatEnsemble(out, meta)


def flat_heights(traj: FlatTrajectory, t) -> tuple[np.ndarray, np.ndarray]:
    """Heights of the particle and the plate (mm) at times ``t`` (s) between events.

    Between events the particle flies on the parabola of docs/model.md §1,
    ``y = y_p(t_i) + v_i (t - t_i) - g (t - t_i)^2 / 2``; while stuck it rides the
    plate, ``y = y_p(t) = -A sin(w t)``.  Times outside [t_0, t_last] give NaN.

    Returns
    -------
    y, y_plate : ndarray
        Same shape as ``t``.
    """
    p = traj.params
    t = np.asarray(t, dtype=float)
    t_ev = traj.t
    y_plate = -p.A * np.sin(p.w * t)
    i = np.clip(np.searchsorted(t_ev, t, side="right") - 1, 0, len(t_ev) - 1)
    dt = t - t_ev[i]
    y0 = -p.A * np.sin(traj["phase"][i])
    y = y0 + traj["v"][i] * dt - 0.5 * p.g * dt * dt
    y = np.where(traj["kind"][i] == STICK, y_plate, y)
    outside = (t < t_ev[0]) | (t > t_ev[-1])
    return np.where(outside, np.nan, y), y_plate
