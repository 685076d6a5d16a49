"""Run limits, chunked runs and failed particles: the machinery of every ensemble-like run.

``ensemble``, ``classify`` and the scans check a run before anything large is allocated
(``check_run``, ``check_n``, ``check_size``: limits ``MAX_PERIODS``, ``MAX_EVENTS``,
``MAX_BYTES``, with an estimate of events, CPU time and memory from the rate model
``EVENTS_PER_PERIOD``; ``allocate``), and run in chunks of about ``CHUNK_EVENTS`` events
(``run_chunked``): Ctrl-C stops a run between chunks, and the numbers do not depend on the
chunk size, since every particle's loop state (``Carry``) survives between chunks.  A
particle the kernel fails on is kept with its status (``failed_particles``,
``ON_FAILURE``); the estimators use the others.  Single trajectories use the same limits
(``MAX_BYTES``, ``MAX_PERIODS``).
"""

from __future__ import annotations

import contextlib
import math
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

from bbdyn.core.ensemble import start_particles
from bbdyn.core.layout import CARRY_WIDTH, CNT_WIDTH, RUNNING
from bbdyn.core.status import (
    BAD_STATE,
    FAILURES,
    NON_FINITE,
    OK,
    ROOT_NOT_CONVERGED,
    STATUS_MESSAGES,
    STUCK_FOREVER,
    SimulationError,
)
from bbdyn.params import Params

__all__ = [
    "check_run",
    "check_n",
    "check_size",
    "allocate",
    "RunWindow",
    "Carry",
    "new_carry",
    "noise_key",
    "run_chunked",
    "failed_particles",
    "numba_threads",
    "periods_phase",
]

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


# ---- run limits and validation ------------------------------------------------------------
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


#: Spawn key of a run's random-restitution stream under its seed (``noise_key``): "noise" in
#: ASCII, beyond any particle index (``ensemble.initial_conditions`` spawns by index).
NOISE_SPAWN_KEY = 0x6E6F697365


def noise_key(seed) -> tuple[int, int]:
    """The 64-bit key (two 32-bit words) of a run's random restitution (``core.noise``).

    From ``np.random.SeedSequence(seed)``'s child with spawn key ``NOISE_SPAWN_KEY``: a
    stream of its own, independent of the initial conditions drawn from the same seed
    (``seed=None``: fresh entropy, as for them).
    """
    root = np.random.SeedSequence(seed)
    child = np.random.SeedSequence(root.entropy, spawn_key=(*root.spawn_key, NOISE_SPAWN_KEY))
    k0, k1 = child.generate_state(2, np.uint32)
    return int(k0), int(k1)


def new_carry(states, ff_lags, pmax, noise_key=(0, 0)):
    """A ``Carry`` for particles starting at ``states`` (n, 7); rings of ``ff_lags``, ``pmax``.

    ``ff_lags`` is ``FF_LAGS`` with fast-forward, else 0 (no ring is kept); ``pmax`` the
    features' longest period, else 0; ``noise_key``: the key (two 32-bit words,
    ``noise_key(seed)``) of the random restitution, read only when ``eta > 0``.  Plain Python:
    it only allocates and starts.
    """
    n = states.shape[0]
    carry = Carry(
        np.zeros((n, CARRY_WIDTH)),
        np.zeros((n, ff_lags, 5)),
        np.zeros((n, ff_lags, 4)),
        np.zeros((n, ff_lags, CNT_WIDTH), dtype=np.int64),
        np.zeros((n, pmax, 3)),
    )
    start_particles(states, float(noise_key[0]), float(noise_key[1]), carry.state)
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
