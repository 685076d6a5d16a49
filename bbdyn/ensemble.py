"""Ensembles of billiard particles and their steady-state observables (docs/model.md §3).

``ensemble`` draws (or takes) initial conditions, runs ``core.ensemble.run_ensemble``
in parallel over particles and returns an ``EnsembleResult``: per-particle
displacements at the sample times, period-averaged energies, stuck fractions,
collision and jump counts, optionally the jump sequences and a collision record.

Initial conditions are post-collision states on the floor of tile 0 at t = 0,
given as ``(s, vx+, vy+)``: arc length from the left wedge (mm) and absolute
velocities (mm/s).  Particle ``i`` draws row ``i`` of one ``(n, 3)`` array of
uniforms from ``np.random.default_rng(np.random.SeedSequence(seed))`` (drawn again
from its own stream if that state moves into the arc, ``initial_conditions``), so its
initial condition depends only on the seed and on ``i`` (not on ``n``, nor on
the number of threads).

Runs are checked before anything large is allocated (``check_run``, ``check_n``,
``check_size``: limits ``MAX_PERIODS``, ``MAX_EVENTS``, ``MAX_BYTES``, with an estimate
of events, CPU time and memory from the rate model ``EVENTS_PER_PERIOD``), and run in
chunks of about ``CHUNK_EVENTS`` events (``run_chunked``): Ctrl-C stops a run between
chunks, and the numbers do not depend on the chunk size.  A particle the kernel fails on
is kept with its status (``failed_particles``, ``on_failure``); the estimators use the
others.  ``bbdyn.classify`` uses the same checks and chunked runs.
"""

from __future__ import annotations

import contextlib
import math
import time
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from bbdyn.core.status import (
    BAD_STATE,
    FAILURES,
    FAST_FORWARD_MODES,
    NON_FINITE,
    OK,
    ROOT_NOT_CONVERGED,
    STATUS_MESSAGES,
    STUCK_FOREVER,
    SimulationError,
)
from bbdyn.params import Params, check_params
from bbdyn.results import Result, make_meta

__all__ = ["Box", "reference_box", "initial_conditions", "ensemble", "EnsembleResult"]

OBSERVABLES = ("displacement", "energy", "jumps", "record")
#: What ``ensemble`` and ``classify`` do with particles the kernel failed on.
ON_FAILURE = ("keep", "raise")
#: Short names of the run status codes (``bbdyn.core.status``), as in ``meta["failures"]``.
STATUS_NAMES = {
    OK: "ok",
    STUCK_FOREVER: "stuck_forever",
    ROOT_NOT_CONVERGED: "root_not_converged",
    NON_FINITE: "non_finite",
    BAD_STATE: "bad_state",
}


@dataclass(frozen=True)
class Box:
    """A box of post-collision initial conditions, uniform in each coordinate.

    ``s`` in mm (within ``[0, s_max]``), ``vx`` and ``vy`` in mm/s; ``vy`` is
    drawn in the half-open ``(vy[0], vy[1]]`` so that ``vy > 0`` for a lower bound 0.
    """

    s: tuple[float, float]
    vx: tuple[float, float]
    vy: tuple[float, float]

    def __post_init__(self) -> None:
        for name in ("s", "vx", "vy"):
            lo, hi = (float(v) for v in getattr(self, name))
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"box {name} must be finite with low <= high, got ({lo}, {hi})")
            object.__setattr__(self, name, (lo, hi))


def reference_box(params: Params) -> Box:
    """The reference box of docs/model.md: ``0 <= s <= s_max``, ``|vx+| <= 40``,
    ``0 < vy+ <= 40`` (mm/s)."""
    return Box(s=(0.0, params.s_max), vx=(-40.0, 40.0), vy=(0.0, 40.0))


#: Draws per batch, and most batches, when a particle's first draw from a box does not
#: leave the floor (``initial_conditions``).
REDRAW_BATCH, MAX_REDRAW_BATCHES = 64, 16


def initial_conditions(
    params: Params, n: int, seed, box: Box | None = None, *, phase: float = 0.0
) -> np.ndarray:
    """``n`` initial conditions ``(s, vx+, vy+)`` drawn uniformly from the part of ``box``
    that leaves the floor; shape (n, 3).

    Particle ``i`` takes row ``i`` of one ``(n, 3)`` array of uniforms from
    ``np.random.default_rng(np.random.SeedSequence(seed))``.  A row whose velocity moves into
    the arc relative to the floor at phase ``phase`` (rad; not a post-collision state: near
    the wedges of a steep arc, R close to d/2) is drawn again from the particle's own
    stream ``SeedSequence(entropy, spawn_key=(i,))`` until it leaves the floor.  So the
    draws are uniform on the part of the box that leaves the floor, particle ``i`` still
    depends only on the seed and ``i``, and where the whole box leaves the floor (the
    reference box at the default R = 25 mm) the rows are the first draws.  ValueError if a
    particle finds no such state in ``REDRAW_BATCH * MAX_REDRAW_BATCHES`` draws (a box
    (almost) entirely moving into the floor).
    """
    box = reference_box(params) if box is None else box
    entropy = np.random.SeedSequence(seed)
    out = _box_points(box, np.random.default_rng(entropy).random((n, 3)))
    u = -params.A * params.w * math.cos(phase)  # the floor's velocity
    for i in np.flatnonzero(~_leaving_floor(params, out, u)):
        stream = np.random.default_rng(
            np.random.SeedSequence(entropy.entropy, spawn_key=(*entropy.spawn_key, int(i)))
        )
        for _ in range(MAX_REDRAW_BATCHES):
            draws = _box_points(box, stream.random((REDRAW_BATCH, 3)))
            good = np.flatnonzero(_leaving_floor(params, draws, u))
            if good.size:
                out[i] = draws[good[0]]
                break
        else:
            raise ValueError(
                f"box {box} has (almost) no post-collision states: particle {i} found none "
                f"that leaves the floor in {REDRAW_BATCH * MAX_REDRAW_BATCHES} draws; choose "
                "velocities that move away from the arc (vy+ above the floor's velocity "
                f"{u:.4g} mm/s)"
            )
    return out


def _box_points(box: Box, u: np.ndarray) -> np.ndarray:
    """Points ``(s, vx, vy)`` of ``box`` from uniforms ``u`` in [0, 1), shape (m, 3)."""
    out = np.empty(u.shape)
    out[:, 0] = box.s[0] + (box.s[1] - box.s[0]) * u[:, 0]
    out[:, 1] = box.vx[0] + (box.vx[1] - box.vx[0]) * u[:, 1]
    out[:, 2] = box.vy[1] - (box.vy[1] - box.vy[0]) * u[:, 2]  # in (lo, hi]
    return out


def _leaving_floor(params: Params, ics: np.ndarray, u: float) -> np.ndarray:
    """Which rows ``(s, vx+, vy+)`` of ``ics`` leave the floor moving at ``u`` (mm/s)."""
    from bbdyn.core.ensemble import leaving_floor

    ok = np.empty(ics.shape[0], dtype=np.bool_)
    leaving_floor(ics, u, params.kernel(), ok)
    return ok


def kernel_states(params: Params, ics: np.ndarray) -> np.ndarray:
    """Kernel states of post-collision initial conditions ``(s, vx+, vy+)`` at t = 0."""
    from bbdyn.core.ensemble import initial_states

    s = ics[:, 0]
    if np.any((s < 0) | (s > params.s_max)):
        raise ValueError(f"initial s must be in [0, s_max = {params.s_max}] mm")
    states = np.empty((ics.shape[0], 7))
    bad = initial_states(ics, params.kernel(), states)
    if bad >= 0:
        raise ValueError(
            f"initial conditions must leave the floor (post-collision states); particle {bad}, "
            f"(s, vx, vy) = {tuple(ics[bad])}, moves into the arc"
        )
    return states


def periods_phase(times_s: np.ndarray, f: float) -> tuple[np.ndarray, np.ndarray]:
    """Split times (s) into whole periods and phase w t mod 2 pi."""
    cycles = np.asarray(times_s, dtype=float) * f
    whole = np.floor(cycles)
    return whole, (cycles - whole) * 2.0 * math.pi


@contextlib.contextmanager
def numba_threads(threads: int | None):
    """Run the block with ``threads`` numba threads (all if None); yields the number used."""
    if threads is not None and not 1 <= int(threads) <= numba.config.NUMBA_NUM_THREADS:
        raise ValueError(f"threads must be in [1, {numba.config.NUMBA_NUM_THREADS}], got {threads}")
    old = numba.get_num_threads()
    if threads is not None:
        numba.set_num_threads(int(threads))
    try:
        yield numba.get_num_threads()
    finally:
        numba.set_num_threads(old)


# ---- run limits and validation (shared with bbdyn.classify) --------------------------------
#: Fewest particles of an ensemble drawn from a box: every ensemble average comes with a
#: standard error over particles (sample standard deviation), which needs two.
N_MIN = 2
#: Conservative rate model for size estimates: events (impacts, sticks, releases) per
#: particle and per driving period.  Measured at the reference parameters over 30-100 Hz
#: without fast-forward: at most 27 (62.5 Hz; about 1300 collisions per particle per s
#: at 50-62 Hz), below 9 above 64 Hz, 0.1 below Gamma = 1 (``tests/test_run_limits.py``
#: checks the bound).  Other parameters can differ: the estimate is then rougher.
EVENTS_PER_PERIOD = 50.0
#: CPU time per event and thread (s) for the time estimate, measured 0.2-0.4 us at
#: 58-85 Hz on the reference machine.
EVENT_COST_S = 0.5e-6
#: Refuse runs estimated above this many events (at most about 140 h of one thread by
#: the estimate; real runs make fewer events) unless the caller raises ``max_events``.
MAX_EVENTS = 1e12
#: Refuse runs whose arrays would take more than this many bytes unless the caller
#: raises ``max_bytes``.
MAX_BYTES = 4 * 2**30
#: Longest run in driving periods: times are kept as (whole periods, phase), and whole
#: numbers are exact in a float below 2^52 (``core.ensemble.fast_forward`` relies on it).
MAX_PERIODS = 2.0**52
#: Events per chunk, summed over the particles of a run: the kernels return to Python
#: (where Ctrl-C is handled and progress reported) about every CHUNK_EVENTS * EVENT_COST_S
#: / threads seconds (a fraction of a second).
CHUNK_EVENTS = 1_000_000


@dataclass(frozen=True)
class RunWindow:
    """A validated run: ``t`` and ``transient`` (s); the averaging window of ``blocks`` blocks
    of ``L`` whole driving periods from ``p0 = ceil(transient f)``."""

    t: float
    transient: float
    p0: float
    L: float
    blocks: int


def check_n(n) -> int:
    """``n`` as an int if it is an integer >= ``N_MIN`` (particles drawn from a box)."""
    if isinstance(n, bool) or not isinstance(n, int | float | np.integer) or int(n) != n:
        raise ValueError(f"n must be an integer >= {N_MIN}, got {n!r}")
    if n < N_MIN:
        raise ValueError(
            f"n must be an integer >= {N_MIN} (ensemble averages carry a standard error over "
            f"particles, which needs two), got {n}; for one trajectory give initial=[[s, vx, vy]]"
        )
    return int(n)


def check_run(params: Params, t, transient, blocks: int = 1) -> RunWindow:
    """Validate the run time ``t`` (s, at most ``MAX_PERIODS`` periods) and ``transient`` (s);
    cut the averaging window.

    The window covers ``blocks`` blocks of ``L = floor((floor(t f) - p0) / blocks)`` whole
    periods from ``p0 = ceil(transient f)``; ``L >= 1`` is required.
    """
    t = float(t)
    if not (math.isfinite(t) and t > 0):
        raise ValueError(f"t must be a finite time > 0 s, got {t}")
    if not t * params.f <= MAX_PERIODS:
        raise ValueError(
            f"t must be at most 2^52 driving periods = {MAX_PERIODS / params.f:.4g} s at "
            f"f = {params.f} Hz (times are whole periods plus a phase, exact below 2^52), got {t}"
        )
    transient = float(transient)
    if not 0.0 <= transient < t:
        raise ValueError(f"transient must be in [0, t = {t}) s, got {transient}")
    p0 = float(math.ceil(transient * params.f))
    L = float(math.floor((math.floor(t * params.f) - p0) / blocks))
    if L < 1:
        raise ValueError(
            f"no room for {blocks} whole driving period(s) between transient = {transient} s and "
            f"t = {t} s at f = {params.f} Hz: make t longer or the transient shorter"
        )
    return RunWindow(t, transient, p0, L, int(blocks))


def check_size(
    params: Params, n: int, t: float, nbytes: float, *, max_events=MAX_EVENTS, max_bytes=MAX_BYTES
) -> dict[str, float]:
    """Estimate a run's events, CPU time and memory; refuse it above the limits.

    ``n`` particles for ``t`` seconds at ``EVENTS_PER_PERIOD`` events per driving period
    (a conservative rate model: real runs make fewer); ``nbytes`` the memory of the arrays.
    Returns the estimate ``{"events", "cpu_s", "bytes"}``; raises ValueError naming it and
    what to do if ``events > max_events`` or ``bytes > max_bytes``.
    """
    events = float(n) * float(t) * params.f * EVENTS_PER_PERIOD
    est = {"events": events, "cpu_s": events * EVENT_COST_S, "bytes": float(nbytes)}
    said = (
        f"n = {n} particles for t = {t:g} s at f = {params.f} Hz: up to {events:.3g} events, "
        f"up to about {est['cpu_s'] / 3600:.3g} h of CPU time, {nbytes / 2**30:.3g} GiB of arrays"
    )
    if not events <= max_events:
        raise ValueError(
            f"run too long: {said} (limit max_events = {max_events:.3g}); reduce n or t, "
            "or pass a larger max_events if you mean it"
        )
    if not nbytes <= max_bytes:
        raise ValueError(
            f"run too large: {said} (limit max_bytes = {max_bytes / 2**30:.3g} GiB); reduce n, "
            "the sample times or the buffers, or pass a larger max_bytes if you mean it"
        )
    return est


def allocate(shapes: dict[str, tuple], *, extra: float, limits: dict) -> tuple[dict, dict]:
    """Zero arrays of ``shapes`` (name -> (shape, dtype)) once ``check_size`` accepts them.

    ``extra`` (bytes) counts the other arrays of the run; ``limits`` are the other
    arguments of ``check_size``.  Returns the arrays and ``check_size``'s estimate.
    """
    nbytes = sum(math.prod(shape) * np.dtype(dtype).itemsize for shape, dtype in shapes.values())
    estimate = check_size(nbytes=nbytes + extra, **limits)
    return {name: np.zeros(shape, dtype) for name, (shape, dtype) in shapes.items()}, estimate


# ---- chunked runs and failed particles -----------------------------------------------------
class Carry(NamedTuple):
    """Per-particle loop state carried from one chunk of events to the next (kernel argument).

    Taken by ``core.ensemble.run_ensemble`` and ``run_features``.

    ``state`` (n, CARRY_WIDTH), columns ``C_*``; the fast-forward rings ``rel``
    (n, FF_LAGS or 0, 5), ``rel_acc`` (n, ., 4), ``rel_cnt`` (int64, n, ., CNT_WIDTH)
    (see ``core.ensemble.fast_forward``); the features' ring of the last collisions ``ring``
    (n, pmax or 0, 3) (see ``features.feature_collision``).  Everything a particle's
    loop needs to go on lives here, so a run cut into chunks makes the same
    operations in the same order as one uncut run: the numbers are bitwise equal.
    """

    state: np.ndarray
    rel: np.ndarray
    rel_acc: np.ndarray
    rel_cnt: np.ndarray
    ring: np.ndarray


def new_carry(states, ff_lags, pmax):
    """A ``Carry`` for particles starting at ``states`` (n, 7); rings of ``ff_lags``, ``pmax``.

    ``ff_lags`` is ``FF_LAGS`` with fast-forward, else 0 (no ring is kept); ``pmax`` the
    features' longest period, else 0.  Plain Python: it only allocates and starts.
    """
    from bbdyn.core.ensemble import CARRY_WIDTH, CNT_WIDTH, start_particles

    n = states.shape[0]
    carry = Carry(
        np.zeros((n, CARRY_WIDTH)),
        np.zeros((n, ff_lags, 5)),
        np.zeros((n, ff_lags, 4)),
        np.zeros((n, ff_lags, CNT_WIDTH), dtype=np.int64),
        np.zeros((n, pmax, 3)),
    )
    start_particles(states, carry.state)
    return carry


def run_chunked(advance, carry, status, end_periods, *, chunk_events=None, progress=None):
    """Call ``advance(budget)`` until no particle is running; return between chunks.

    ``advance`` runs a kernel (``core.ensemble.run_ensemble`` or ``run_features``) for at most
    ``budget = chunk_events // n`` events per particle (``chunk_events`` default
    ``CHUNK_EVENTS``); the kernels carry each particle's state (``carry``) across calls, so
    the numbers do not depend on ``chunk_events``.  Python runs between chunks: Ctrl-C
    (KeyboardInterrupt) stops the run there, and ``progress`` (a callable, optional) gets
    the fraction of the simulated time done, in [0, 1].
    """
    from bbdyn.core.ensemble import RUNNING

    chunk_events = CHUNK_EVENTS if chunk_events is None else int(chunk_events)
    if chunk_events < 1:
        raise ValueError(f"chunk_events must be an integer >= 1, got {chunk_events}")
    status[:] = RUNNING
    budget = max(1, chunk_events // max(1, status.size))
    while True:
        advance(budget)
        running = status == RUNNING
        if progress is not None:
            ahead = np.minimum(carry.state[:, 0], end_periods)
            progress(float(np.mean(np.where(running, ahead / end_periods, 1.0))))
        if not running.any():
            return


def failed_particles(status: np.ndarray, ics: np.ndarray, on_failure: str) -> dict:
    """Handle particles whose kernel status is a failure; return their count and reasons.

    ``on_failure="raise"``: raise ``SimulationError`` naming the first failed particle.
    ``"keep"``: warn (RuntimeWarning) and go on with the others; raise all the same if no
    particle succeeded.  Returns ``{"n_failed": k, "failures": {status name: count}}``.
    """
    if on_failure not in ON_FAILURE:
        raise ValueError(f"on_failure must be one of {ON_FAILURE}, got {on_failure!r}")
    failed = np.flatnonzero(np.isin(status, FAILURES))
    reasons = {STATUS_NAMES[int(c)]: int(np.count_nonzero(status == c)) for c in FAILURES}
    out = {"n_failed": int(failed.size), "failures": {k: v for k, v in reasons.items() if v}}
    if not failed.size:
        return out
    i = failed[0]
    said = (
        f"{failed.size} of {status.size} particle(s) failed ({out['failures']}), e.g. particle "
        f"{i} from (s, vx, vy) = {tuple(float(v) for v in ics[i])}: "
        f"{STATUS_MESSAGES[int(status[i])]}"
    )
    if on_failure == "raise" or failed.size == status.size:
        raise SimulationError(said)
    warnings.warn(
        f"{said}; the observables cover the {status.size - failed.size} others "
        "(status per particle in the result; on_failure='raise' to stop instead)",
        RuntimeWarning,
        stacklevel=3,
    )
    return out


def ensemble(
    params: Params,
    *,
    t: float,
    n: int | None = None,
    seed=None,
    box: Box | None = None,
    initial=None,
    sample_times=None,
    transient: float | None = None,
    observables=("displacement", "energy"),
    jump_capacity: int = 1024,
    record_particles: int = 0,
    record_window: tuple[float, float] | None = None,
    record_capacity: int = 4096,
    threads: int | None = None,
    fast_forward: str | bool = "converged",
    on_failure: str = "keep",
    max_events: float = MAX_EVENTS,
    max_bytes: float = MAX_BYTES,
    chunk_events: int | None = None,
    progress=None,
) -> EnsembleResult:
    """Run an ensemble of independent particles for ``t`` seconds.

    Parameters
    ----------
    params : Params
    t : float
        Simulated time (s), > 0.
    n : int, optional
        Number of particles drawn from ``box`` (default 1000), >= ``N_MIN`` = 2 (every
        ensemble average carries a standard error); not with ``initial``.
    seed : int or None
        Seed of ``np.random.SeedSequence``; stored in the metadata.
    box : Box, optional
        Box of initial conditions; default ``reference_box(params)``.
    initial : array of shape (n, 3), optional
        Explicit post-collision initial conditions ``(s, vx+, vy+)`` at t = 0 in tile 0
        (one row or more; standard errors need two that succeed).
    sample_times : array, optional
        Times (s) in ``[0, t]`` at which displacements are recorded; default 101
        equally spaced times including 0 and ``t``.
    transient : float, optional
        Time (s) discarded before averaging; default ``t / 5``.  Averages cover the
        whole driving periods from ``ceil(transient f)`` to ``floor(t f)``.
    observables : sequence of str
        Any of ``"displacement"``, ``"energy"``, ``"jumps"``, ``"record"``.  Stuck
        fractions and collision counts are always computed.
    jump_capacity : int
        Jumps stored per particle (more are counted, not stored).
    record_particles, record_window, record_capacity
        With ``"record"``: the collisions of the first ``record_particles`` particles
        in ``record_window`` (s; default the whole run), at most ``record_capacity`` each.
    threads : int, optional
        Number of numba threads (default: numba's current setting).  Results do
        not depend on it.
    fast_forward : {"converged", "bitwise", "off"} or bool
        Skip whole stick-release cycles (``core.ensemble.fast_forward``; not for recorded
        particles).  ``"bitwise"``: once a release repeats bit for bit; the same events,
        counts, jumps and displacements, integrals to rounding.  ``"converged"`` (default,
        also ``True``): besides, once a cycle has converged to within ``FF_DRIFT_TOL`` =
        1e-12 mm (``core.ensemble.converged_cycle``: a proven bound on the drift ahead from
        the cycle's multiplier, integrals of the last two cycles equal to
        ``FF_ENERGY_REL_TOL`` = 1e-12): the same counts, positions within 1e-12 mm,
        integrals within 1e-12 relative.  ``"off"`` (also ``False``): event by event.
    on_failure : {"keep", "raise"}
        What to do when the kernel fails for some particles (``status`` a failure, e.g.
        a non-finite state): ``"keep"`` (default) warns and keeps the others, which are
        exactly what they would be alone; the result's ``status`` says which failed,
        ``meta["n_failed"]`` and ``meta["failures"]`` how many and why, and its
        estimators use the particles that succeeded (a failure that depends on the
        initial condition can bias them: read the warning).  ``"raise"`` raises
        ``SimulationError``.  If every particle fails, it raises either way.
    max_events, max_bytes : float
        Refuse (ValueError, with an estimate of time and memory) runs estimated above
        this many events (rate model ``EVENTS_PER_PERIOD``) or this much array memory;
        defaults ``MAX_EVENTS``, ``MAX_BYTES``.  Raise them if you mean it.
    chunk_events : int, optional
        Events per kernel call over all particles (default ``CHUNK_EVENTS``): between calls Ctrl-C
        stops the run and ``progress`` is told.  The numbers do not depend on it.
    progress : callable, optional
        Called between chunks with the fraction of the simulated time done, in [0, 1].

    Returns
    -------
    EnsembleResult

    Examples
    --------
    >>> from bbdyn import Params
    >>> res = ensemble(Params(f=85.2), n=20, t=2.0, seed=1)   # doctest: +SKIP
    >>> D, D_se = res.D()                                     # doctest: +SKIP
    """
    from bbdyn.core import ensemble as core

    check_params(params)
    if on_failure not in ON_FAILURE:
        raise ValueError(f"on_failure must be one of {ON_FAILURE}, got {on_failure!r}")
    unknown = set(observables) - set(OBSERVABLES)
    if unknown:
        raise ValueError(f"observables must be among {OBSERVABLES}, got {sorted(unknown)}")
    run = check_run(params, t, float(t) / 5 if transient is None else transient)
    t, transient = run.t, run.transient
    window = np.array([run.p0, run.p0 + run.L])
    halves = [run.p0, float(math.floor(run.p0 + run.L / 2)), run.p0 + run.L]  # [p0, split, p1]
    if initial is not None:
        if n is not None or box is not None:
            raise ValueError("give either initial or (n, box), not both")
        ics = np.array(initial, dtype=float, ndmin=2)
        if ics.ndim != 2 or ics.shape[1] != 3 or ics.shape[0] < 1 or not np.all(np.isfinite(ics)):
            raise ValueError(f"initial must be a finite (n, 3) array, n >= 1, got {ics.shape}")
        n = ics.shape[0]
    else:
        n = check_n(1000 if n is None else n)
    sample_times = _sample_times(sample_times, t, "displacement" in observables)
    s_periods, s_phase = periods_phase(sample_times, params.f)
    end_periods, end_phase = periods_phase(np.array([t]), params.f)
    times = core.RunTimes(end_periods[0], end_phase[0], run.p0, run.L, 1, s_periods, s_phase)
    rec_t = (0.0, t) if record_window is None else tuple(float(v) for v in record_window)

    flags = 0
    for name, flag in (
        ("displacement", core.OBS_DISPLACEMENT),
        ("energy", core.OBS_ENERGY),
        ("jumps", core.OBS_JUMPS),
        ("record", core.OBS_RECORD),
    ):
        if name in observables:
            flags |= flag
    mode = fast_forward_mode(fast_forward)
    if mode != "off":
        flags |= core.OBS_FAST_FORWARD
    if mode == "converged":
        flags |= core.OBS_FF_CONVERGED
    obs = core.Observables(flags, *periods_phase(np.array(rec_t), params.f), halves[1])
    cap = int(jump_capacity) if "jumps" in observables else 0
    n_rec = min(int(record_particles), n) if "record" in observables else 0
    rec_cap = int(record_capacity) if n_rec else 0
    lags = core.FF_LAGS if mode != "off" else 0
    out, estimate = allocate(
        {
            "displacement": ((n, s_periods.size), float),
            "blocks": ((n, 2, 4), float),  # the energy window and its first half
            "counts": ((n, core.CNT_WIDTH), np.int64),
            "jump_len": ((n, cap), np.int64),
            "jump_time": ((n, cap), float),
            "record": ((n_rec, rec_cap, core.REC_WIDTH), float),
            "final": ((n, 7), float),
            "status": ((n,), np.int64),
        },
        # initial conditions, their uniforms, states and the carried loop states
        extra=n * 8 * (3 + 3 + 7 + core.CARRY_WIDTH + lags * (6 + 4 + core.CNT_WIDTH)),
        limits={"params": params, "n": n, "t": t, "max_events": max_events, "max_bytes": max_bytes},
    )
    if initial is None:
        ics = initial_conditions(params, n, seed, box)
    carry = new_carry(kernel_states(params, ics), lags, 0)
    buffers = core.EnsembleOut(**out)
    disp, acc, counts, status = buffers.displacement, buffers.blocks, buffers.counts, buffers.status

    def advance(budget):
        core.run_ensemble(carry, budget, params.kernel(), times, obs, buffers)

    start, cpu_start = time.perf_counter(), time.process_time()
    with numba_threads(threads) as used_threads:
        run_chunked(
            advance, carry, status, end_periods[0] + end_phase[0] / (2 * math.pi),
            chunk_events=chunk_events, progress=progress,
        )  # fmt: skip
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
    failed = failed_particles(status, ics, on_failure)

    t_window = (window[1] - window[0]) / params.f
    arrays = {
        "initial": ics,
        "status": status,
        "sample_times": sample_times,
        "displacement": disp,
        "stuck_fraction": acc[:, 0, core.ACC_STUCK] / t_window,
        "collisions": counts[:, core.CNT_COLLISIONS],
        "sticks": counts[:, core.CNT_STICKS],
        "jumps": counts[:, core.CNT_JUMPS],
        "events": counts[:, core.CNT_EVENTS],
        "skipped_events": counts[:, core.CNT_SKIPPED],
        "final": out["final"],
    }
    if "energy" in observables:
        arrays["E_x"] = acc[:, 0, core.ACC_EX] / t_window
        arrays["E_y"] = acc[:, 0, core.ACC_EY] / t_window
        arrays["E_pot"] = acc[:, 0, core.ACC_POT] / t_window
        arrays["E"] = arrays["E_x"] + arrays["E_y"] + arrays["E_pot"]
        arrays.update(_energy_halves(acc, halves, params.f, status))
    if "jumps" in observables:
        arrays["jump_len"] = out["jump_len"]
        arrays["jump_time"] = out["jump_time"]
    if n_rec:
        arrays["record"] = out["record"]
        arrays["record_n"] = counts[:n_rec, core.CNT_RECORD]
    meta = make_meta(
        params,
        seed=seed,
        wall_s=wall,
        cpu_s=cpu,
        t=t,
        n=n,
        transient=transient,
        window_periods=window.tolist(),
        window_s=t_window,
        halves_periods=halves,
        observables=list(observables),
        threads=used_threads,
        fast_forward=mode,
        box=None if initial is not None else vars(box or reference_box(params)),
        estimate=estimate,
        **failed,
    )
    return EnsembleResult(arrays, meta)


def fast_forward_mode(fast_forward) -> str:
    """The fast-forward mode of ``ensemble``: one of FAST_FORWARD_MODES (True is
    ``"converged"``, False ``"off"``); ValueError otherwise."""
    if fast_forward is True or fast_forward is False:
        return "converged" if fast_forward else "off"
    if fast_forward not in FAST_FORWARD_MODES:
        raise ValueError(f"fast_forward must be one of {FAST_FORWARD_MODES}, got {fast_forward!r}")
    return fast_forward


def _energy_halves(acc: np.ndarray, cuts: list, f: float, status: np.ndarray) -> dict:
    """Energies averaged over the early and late half of the window, shape (n, 2) each.

    ``acc`` (n, 2, 4): the kernel's integrals over the window ``[p0, p1]`` and over
    ``[p0, split]``, ``cuts = [p0, split, p1]`` (whole periods), ``f`` in Hz.  The late
    half is the whole minus the early one.  NaN for a window of one period (no halves)
    and for the particles that failed (``status``; they have no late half).
    """
    from bbdyn.core.ensemble import ACC_EX, ACC_EY, ACC_POT

    p0, split, p1 = cuts
    n = acc.shape[0]
    out = {}
    for name, col in (("E_x", ACC_EX), ("E_y", ACC_EY), ("E_pot", ACC_POT)):
        halves = np.full((n, 2), math.nan)
        if split > p0:
            early, whole = acc[:, 1, col], acc[:, 0, col]
            halves[:, 0] = early / ((split - p0) / f)
            halves[:, 1] = (whole - early) / ((p1 - split) / f)
        halves[np.isin(status, FAILURES)] = math.nan
        out[name + "_halves"] = halves
    out["E_halves"] = out["E_x_halves"] + out["E_y_halves"] + out["E_pot_halves"]
    return out


def _sample_times(sample_times, t: float, wanted: bool) -> np.ndarray:
    """Validated sample times (s) in ``[0, t]``: default 101 equally spaced; none if not wanted."""
    if sample_times is None:
        sample_times = np.linspace(0.0, t, 101)
    sample_times = np.asarray(sample_times, dtype=float)
    if sample_times.ndim != 1 or np.any(np.diff(sample_times) < 0):
        raise ValueError("sample_times must be a sorted one-dimensional array")
    if sample_times.size and (sample_times[0] < 0 or sample_times[-1] > t):
        raise ValueError(f"sample_times must lie in [0, t = {t}] s")
    return sample_times if wanted else sample_times[:0]


class EnsembleResult(Result):
    """Per-particle observables of an ensemble run (arrays) and its settings (meta).

    Arrays: ``initial`` (n, 3) ``(s, vx+, vy+)``; ``status`` (n,); ``sample_times`` (m,) s;
    ``displacement`` (n, m) mm; ``E, E_x, E_y, E_pot`` (n,) period-averaged energies
    (kg mm^2/s^2) over the window, and ``E_halves`` ... ``E_pot_halves`` (n, 2) over its
    early and late half (whole periods ``meta["halves_periods"] = [p0, split, p1]``,
    ``split = floor((p0 + p1) / 2)``; NaN for failed particles and a one-period window);
    ``stuck_fraction`` (n,); ``collisions``, ``sticks``,
    ``jumps`` (n,) counts in the window; ``events`` (n,) in the whole run, of which
    ``skipped_events`` (n,) were fast-forwarded; ``final`` (n, 7)
    the last event before t (periods, phase, tile, xi, vx, vyrel, kind); with jumps
    ``jump_len``, ``jump_time`` (n, cap); with a record ``record`` (n_rec, cap, 7)
    (periods, phase, tile, xi, vx, vyrel, kind) and ``record_n``.

    A particle whose kernel failed (``status`` in ``core.status.FAILURES``; ``meta["n_failed"]``
    of them, ``meta["failures"]`` by status name) keeps its rows, NaN displacements after
    the failure and integrals up to it; the estimators (``msd``, ``D``, ``summary``,
    ``jump_data``) use the particles that succeeded (``ok``) only.
    """

    kind = "ensemble"

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask (n,) of the particles that reached the end (status not a failure)."""
        return ~np.isin(self["status"], FAILURES)

    def msd(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample times (s) and the mean squared displacement (mm^2) over the ``ok`` particles."""
        return self["sample_times"], np.mean(self["displacement"][self.ok] ** 2, axis=0)

    def D(self, window=(0.5, 1.0)) -> tuple[float, float]:
        """Einstein D and its standard error (mm^2/s) over the ``ok`` particles (>= 2 needed).

        ``bbdyn.diffusion.einstein_D``.
        """
        from bbdyn.diffusion import einstein_D

        return einstein_D(self["sample_times"], self["displacement"][self.ok], window=window)

    def jump_data(self):
        """The jumps in the averaging window as ``bbdyn.approx.JumpData``.

        Times are measured from the start of the window (``t_total`` is its length).
        Raises ValueError if the run did not record jumps or a buffer overflowed.
        """
        from bbdyn.approx.jumps import JumpData

        if "jump_len" not in self.arrays:
            raise ValueError("jumps were not recorded: run with observables including 'jumps'")
        ok = self.ok
        counts, cap = self["jumps"][ok], self["jump_len"].shape[1]
        if np.any(counts > cap):
            raise ValueError(
                f"{np.count_nonzero(counts > cap)} particle(s) made more than jump_capacity = "
                f"{cap} jumps (up to {counts.max()}); run again with a larger jump_capacity"
            )
        t0 = self.meta["window_periods"][0] / self.meta["params"]["f"]
        return JumpData.from_particles(
            [row[:k] for row, k in zip(self["jump_len"][ok], counts, strict=True)],
            [row[:k] - t0 for row, k in zip(self["jump_time"][ok], counts, strict=True)],
            t_total=self.meta["window_s"],
            d=self.meta["params"]["d"],
        )

    def summary(self, window=(0.5, 1.0)) -> dict:
        """Means with standard errors over the ``ok`` particles (plain numbers, for JSON).

        Also ``n_ok``, ``n_failed`` and ``failures`` (status name -> count).  Standard
        errors (and D) are NaN with fewer than two ``ok`` particles.
        """
        ok = self.ok
        n = int(np.count_nonzero(ok))
        out: dict = {"n_ok": n, "n_failed": int(ok.size - n)}
        out["failures"] = dict(self.meta.get("failures", {}))
        if self["displacement"].shape[1] >= 2:
            D = self.D(window) if n >= 2 else (math.nan, math.nan)
            out["D"], out["D_se"] = (float(v) for v in D)
        names = ["E", "E_x", "E_y", "E_pot", "stuck_fraction"]
        for name in names:
            if name in self.arrays:
                values = self[name][ok]
                out[name] = float(values.mean())
                out[name + "_se"] = float(values.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan
        rate = self["collisions"][ok] / self.meta["window_s"]
        out["collisions_per_particle_per_s"] = float(rate.mean())
        out["jumps_per_particle_per_s"] = float(np.mean(self["jumps"][ok]) / self.meta["window_s"])
        w = 2 * math.pi * self.meta["params"]["f"]
        out["E_reference"] = 0.5 * (self.meta["params"]["A"] * w) ** 2
        return out

    def plot(self, ax=None):
        """Mean squared displacement against time, with the late-window Einstein fit."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        times, msd = self.msd()
        ax.plot(times, msd, ".", label="MSD")
        if times.size >= 2:
            D, se = self.D()
            late = times >= 0.5 * times[-1]
            fit = np.polyfit(times[late], msd[late], 1)
            ax.plot(times[late], np.polyval(fit, times[late]), "-", label=f"D = {D:.3g} ± {se:.2g}")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(r"$\langle (x - x_0)^2 \rangle$ (mm$^2$)")
        ax.set_title(f"f = {self.meta['params']['f']} Hz, n = {self.meta['n']}")
        ax.legend()
        return ax
