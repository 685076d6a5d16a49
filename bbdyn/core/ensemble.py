"""Ensembles of independent billiard particles with on-the-fly observables.

Each particle is integrated event by event with ``billiard_event`` from its own
initial state up to ``t_end`` by one loop, ``particle_loop``, shared by the
ensemble observables (``run_ensemble``) and the classification features
(``run_features``, accumulators in ``features.py``); the ``OBS_*`` flags switch
the ensemble's observables on, the feature thresholds the features.  Between
events the motion (a parabola, or riding the floor after a STICK) is known
exactly, so every observable is evaluated or integrated in closed form
(``observables.py``) on the way.  Nothing is stored
per event unless a collision record is asked for: memory is proportional to the
ensemble (and to the number of sample times and buffer sizes), not to the run.

``prange`` runs over particles; each writes only its own rows of the output
arrays and nothing is reduced across particles here, so the numbers do not
depend on the number of threads or on scheduling.

Conventions (docs/model.md §3 and §4):

* times are ``(periods, phase)``; the end of the run, the window (whole periods,
  phase 0) and the sample times are given that way (``RunTimes``);
* a *collision* is an IMPACT or a STICK event (a STICK is the impact that starts a
  chattering sequence, summed in closed form by the event kernel); the trap
  sequence is read at collisions; RELEASE events leave from the STICK point;
* chattering sequences are integrated as the flight that ends in them: the
  kernel sums them in closed form only once their duration is below rounding
  of a period, so they carry no measurable weight;
* event counts, stuck time and energy integrals cover the energy window; jumps
  are recorded in it; the collision record covers the record window
  (``Observables``).  The window ``[p0, p0 + nb L]`` may be cut into ``nb`` blocks
  of ``L`` periods (features); the ensemble uses one block, and integrates its first
  part ``[p0, split]`` into a second row besides (``split_row``: the energy halves).

The kernels take named tuples: the loop state ``bbdyn.ensemble.Carry``, the times
``RunTimes``, what to observe (``Observables``, ensemble) or the feature thresholds
(``features.FeatureThresholds``), and the output arrays ``EnsembleOut`` (or
``features.FeatureOut``), one row per particle.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from bbdyn.core.billiard import billiard_event_trig
from bbdyn.core.cycle import release_map
from bbdyn.core.features import Collision, block_of, feature_collision, feature_finish
from bbdyn.core.floor import arc_root, floor_height_rel, normal_velocity, xi_from_arc_length
from bbdyn.core.observables import (
    displacement,
    flight_integrals,
    is_before,
    stuck_integrals,
    time_between,
    trap_of,
)
from bbdyn.core.plate import plate_height_sin, plate_velocity_cos, sin_cos
from bbdyn.core.status import IMPACT, OK, RELEASE, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import FF_DRIFT_TOL, FF_ENERGY_REL_TOL, FMA

#: Bit flags selecting the observables an ensemble computes.
OBS_DISPLACEMENT = 1
OBS_ENERGY = 2
OBS_JUMPS = 4
OBS_RECORD = 8
#: Fast-forward of exactly periodic stick-release cycles (``fast_forward``); ignored
#: for recorded particles (and never made with features).
OBS_FAST_FORWARD = 32
#: With OBS_FAST_FORWARD: skip also cycles converged to within FF_DRIFT_TOL that do not
#: repeat bit for bit (``converged_cycle``).
OBS_FF_CONVERGED = 64
#: Releases remembered to detect a cycle: lags 1 .. FF_LAGS (converged cycles: lags up to
#: FF_LAGS / 2, two cycles are compared).
FF_LAGS = 12
#: Distance (mm) within which a remembered multiplier decides that a converged-cycle bound
#: is hopeless (``converged_cycle``; an economy only: no bound relies on it).
FF_LAM_NEAR = 1e-9

#: Columns of the per-particle integrals ``acc``: int E_x, int E_y, int g y, stuck time
#: (kg mm^2/s and s), all over the energy window.
ACC_EX, ACC_EY, ACC_POT, ACC_STUCK = 0, 1, 2, 3
#: Columns of the per-particle counts: events in the run, collisions, STICKs and
#: jumps in the energy window, collisions in the record window, events skipped by
#: ``fast_forward`` (included in CNT_EVENTS).
CNT_EVENTS, CNT_COLLISIONS, CNT_STICKS, CNT_JUMPS, CNT_RECORD, CNT_SKIPPED = 0, 1, 2, 3, 4, 5
CNT_WIDTH = 6
#: Columns of the collision record: periods, phase, tile, xi, vx, vyrel, kind.
REC_WIDTH = 7
#: Status of a particle that has not reached the end yet (between chunks); the finished
#: ones carry a ``core.status`` code (>= 0).
RUNNING = -1
#: Columns of a particle's loop state ``carry.state`` (``bbdyn.ensemble.Carry``; everything
#: ``particle_loop`` keeps between events): the last event ``periods, phase, tile, xi, vx,
#: vyrel, kind``, the start ``tile0, xi0``, the next sample index, the trap, the last
#: departure ``(periods, phase)``, the feature ring count and tiny-hop run, the releases
#: remembered, and the last multiplier of ``converged_cycle``: its lag, release point and
#: ``abs(lam)``.
C_TILE0, C_XI0, C_K, C_TRAP, C_DEP_P, C_DEP_PH = 7, 8, 9, 10, 11, 12
C_NRING, C_RUN, C_NREL = 13, 14, 15
C_LAM_P, C_LAM_XI, C_LAM = 16, 17, 18
CARRY_WIDTH = 19


class Event(NamedTuple):
    """A particle's state just after an event (the columns of ``final`` and of the record)."""

    periods: float  # whole driving periods
    phase: float  # w t mod 2 pi (rad)
    tile: float
    xi: float  # mm, on the tile's arc
    vx: float  # mm/s
    vyrel: float  # mm/s, relative to the floor
    kind: int  # IMPACT, STICK or RELEASE (core.status)


class Window(NamedTuple):
    """The averaging window: ``nb`` blocks of ``L`` whole periods from ``p0`` (phase 0)."""

    p0: float
    L: float
    nb: int


class RunTimes(NamedTuple):
    """When a run ends and when it measures (kernel argument); times as ``(periods, phase)``.

    ``end_periods, end_phase``: the end of the run.  The window starts at ``p0`` whole
    periods (phase 0) and is cut into ``nb`` blocks of ``L`` whole periods (the ensemble's
    energy window is one block).  ``sample_periods, sample_phase``, shape (m,): the
    displacement's sample times, sorted, within ``[0, end]`` (m = 0: none).
    """

    end_periods: float
    end_phase: float
    p0: float
    L: float
    nb: int
    sample_periods: np.ndarray
    sample_phase: np.ndarray


class Observables(NamedTuple):
    """What ``run_ensemble`` observes (kernel argument).

    ``flags``: OR of the ``OBS_*`` flags.  ``record_periods, record_phase``, shape (2,):
    start and end of the window of the collision record (with ``OBS_RECORD``).
    ``split_periods``: whole periods (phase 0) in ``[p0, p0 + L]`` that end the first
    part of the energy window, row 1 of ``EnsembleOut.blocks``.
    """

    flags: int
    record_periods: np.ndarray
    record_phase: np.ndarray
    split_periods: float


class EnsembleOut(NamedTuple):
    """Output arrays of ``run_ensemble``, row ``i`` for particle ``i`` (kernel argument).

    Filled in place; all but ``status`` must start at zero.  ``counts`` stays a table
    (``fast_forward`` differences whole rows).  ``blocks``: row 0 the energy window
    ``[p0, p0 + L]``, row 1 its first part ``[p0, split]`` (``Observables.split_periods``;
    row 1 is written once the particle passes the split, see ``split_row``).
    """

    displacement: np.ndarray  # (n, m): x(t_k) - x(0) (mm) at the sample times
    blocks: np.ndarray  # (n, 2, 4): integrals over the energy window and its first part, ACC_*
    counts: np.ndarray  # int64 (n, CNT_WIDTH): columns CNT_*
    jump_len: np.ndarray  # int64 (n, cap): trap changes in the window (units of d)
    jump_time: np.ndarray  # (n, cap): their times (s)
    record: np.ndarray  # (n_rec, cap_rec, REC_WIDTH): collisions of the first n_rec particles
    final: np.ndarray  # (n, 7): the last event before the end (``Event`` fields)
    status: np.ndarray  # int64 (n,): RUNNING on entry to advance; then a core.status code


@njit(cache=True, fastmath=FMA, inline="always")
def leaves_floor(s, vx, vyrel, kp):
    """Whether a velocity ``(vx, vyrel)`` (mm/s, relative to the floor) at arc length ``s``
    (mm from the left wedge) leaves the arc: a post-collision state (normal component > 0)."""
    xi = xi_from_arc_length(s, kp)
    vn, _ = normal_velocity(xi, arc_root(xi, kp), vx, vyrel, kp.R)
    return vn > 0.0


@njit(cache=True, fastmath=FMA)
def leaving_floor(ics, u, kp, ok):
    """``ok[i]``: whether ``ics[i] = (s, vx+, vy+)`` (absolute velocities) leaves the floor
    moving with velocity ``u`` (mm/s), as ``initial_states`` checks it."""
    for i in range(ics.shape[0]):
        ok[i] = leaves_floor(ics[i, 0], ics[i, 1], ics[i, 2] - u, kp)


@njit(cache=True, fastmath=FMA)
def initial_states(ics, kp, states):
    """Kernel states of post-collision initial conditions on the floor of tile 0 at t = 0.

    Parameters
    ----------
    ics : array, shape (n, 3)
        ``s`` (arc length from the left wedge, mm), ``vx+``, ``vy+`` (absolute, mm/s).
    kp : KernelParams
    states : array, shape (n, 7)
        Output, written in place: ``periods, phase, tile, xi, vx, vyrel, kind``.

    Returns
    -------
    first_bad : int
        Index of the first state moving into the floor (relative normal velocity
        <= 0, not a post-collision state), or -1 if all are valid.
    """
    first_bad = -1
    u0 = -kp.A * kp.w  # floor velocity at phase 0
    for i in range(ics.shape[0]):
        xi = xi_from_arc_length(ics[i, 0], kp)
        vyrel = ics[i, 2] - u0
        if not leaves_floor(ics[i, 0], ics[i, 1], vyrel, kp) and first_bad < 0:
            first_bad = i
        states[i, 0] = 0.0
        states[i, 1] = 0.0
        states[i, 2] = 0.0
        states[i, 3] = xi
        states[i, 4] = ics[i, 1]
        states[i, 5] = vyrel
        states[i, 6] = IMPACT
    return first_bad


# Inlined into the event loop, as integrate_blocks: called with the Event tuple, the two
# calls cost about 2 % of the ensemble's speed (python benchmarks/kernel_buffers.py).
@njit(cache=True, fastmath=FMA, inline="always")
def accumulate_interval(acc, j, ev, trig, b, lo, hi, kp, energy):
    """Add to row ``j`` of ``acc`` the integrals over ``[lo, hi]`` of the motion since ``ev``.

    ``ev`` is an ``Event`` (a flight follows it, or the floor is ridden after a STICK),
    ``trig`` the sine and cosine of its phase; ``lo`` and ``hi`` are ``(periods, phase)``
    pairs inside the interval; ``b`` is the height ``b(xi)`` of the event point above the
    wedges (mm).  Columns ``ACC_*``: the
    stuck time (s) always, the energy integrals (kg mm^2/s) with ``energy``.
    """
    w, period = kp.w, kp.period
    if ev.kind == STICK:
        dt = time_between(hi[0], hi[1], lo[0], lo[1], w, period)
        acc[j, ACC_STUCK] += dt
        if energy:
            I_Ey, I_pot = stuck_integrals(kp.A, w, kp.g, b, lo[1], dt)
            acc[j, ACC_EY] += I_Ey
            acc[j, ACC_POT] += I_pot
        return
    if energy:
        ta = time_between(lo[0], lo[1], ev.periods, ev.phase, w, period)
        tb = time_between(hi[0], hi[1], ev.periods, ev.phase, w, period)
        y0 = plate_height_sin(kp.A, trig[0]) + b
        vy0 = ev.vyrel + plate_velocity_cos(kp.A, w, trig[1])
        I_Ex, I_Ey, I_pot = flight_integrals(ev.vx, vy0, y0, kp.g, ta, tb)
        acc[j, ACC_EX] += I_Ex
        acc[j, ACC_EY] += I_Ey
        acc[j, ACC_POT] += I_pot


# Inlined into the event loop (see accumulate_interval).
@njit(cache=True, fastmath=FMA, inline="always")
def integrate_blocks(acc, ev, trig, hi, window, kp, energy):
    """Integrate the motion since the event ``ev`` up to ``hi``, per block of the window.

    ``trig`` is ``sin_cos`` of the event's phase; ``hi`` a ``(periods,
    phase)`` pair; the part of ``[ev, hi]`` inside the ``window`` (a ``Window``) is cut at
    the block boundaries ``p0 + j L`` (phase 0) and added to row ``j`` of ``acc`` (shape
    (nb, >= 4)) by ``accumulate_interval``.
    """
    p0, L, nb = window.p0, window.L, window.nb
    p1 = p0 + nb * L
    lo_p, lo_ph = ev.periods, ev.phase
    if is_before(lo_p, lo_ph, p0, 0.0):
        lo_p, lo_ph = p0, 0.0
    hi_p, hi_ph = hi
    if is_before(p1, 0.0, hi_p, hi_ph):
        hi_p, hi_ph = p1, 0.0
    if not is_before(lo_p, lo_ph, hi_p, hi_ph):
        return
    b = floor_height_rel(ev.xi, kp) if energy else 0.0
    if nb == 1:  # one block (an ensemble's window): [lo, hi] lies in it
        accumulate_interval(acc, 0, ev, trig, b, (lo_p, lo_ph), (hi_p, hi_ph), kp, energy)
        return
    # from lo's block on, until the block that holds hi
    j = block_of(lo_p, p0, L, nb)
    while True:
        a_p, a_ph = lo_p, lo_ph
        if is_before(a_p, a_ph, p0 + j * L, 0.0):
            a_p, a_ph = p0 + j * L, 0.0
        z_p, z_ph = hi_p, hi_ph
        if is_before(p0 + (j + 1) * L, 0.0, z_p, z_ph):
            z_p, z_ph = p0 + (j + 1) * L, 0.0
        if is_before(a_p, a_ph, z_p, z_ph):
            accumulate_interval(acc, j, ev, trig, b, (a_p, a_ph), (z_p, z_ph), kp, energy)
        if j == nb - 1 or not is_before(p0 + (j + 1) * L, 0.0, hi_p, hi_ph):
            return
        j += 1


@njit(cache=True, fastmath=FMA)
def split_row(acc, ev, trig, hi, p0, split, kp, energy):
    """Row 1 of ``acc`` := row 0 plus the part in ``[p0, split]`` of the motion ``ev`` to ``hi``.

    Called once per particle, for the interval from the event ``ev`` (before ``split``
    whole periods, phase 0) to ``hi`` (a ``(periods, phase)`` pair at or after it), before
    the interval is added to row 0 (the window ``[p0, ...]``).  Row 0 then holds the
    integrals up to ``ev``: without fast-forward, the same sums in the same order as a
    run whose window ends at ``split``, so row 1 is bitwise what that run gives.
    """
    for c in range(4):
        acc[1, c] = acc[0, c]
    if p0 < split:
        integrate_blocks(acc[1:], ev, trig, hi, Window(p0, split - p0, 1), kp, energy)


@njit(cache=True, fastmath=FMA)
def integrate_to_split(acc, ev, p0, split, kp, energy):
    """Add to row 1 of ``acc`` the motion from the event ``ev`` up to ``split``, event by event.

    For ``fast_forward``: the cycle a skip carries over ``split`` (whole periods, phase 0)
    is simulated again from its release ``ev`` up to the split; the part in ``[p0, split]``
    of each interval is added (``integrate_blocks``).  The events are those the skipped
    cycle makes (``fast_forward``: the same, translated), so this cannot fail; a failure
    status stops it all the same.
    """
    half = Window(p0, split - p0, 1)
    rows = acc[1:]
    periods, phase, tile, xi, vx, vyrel, kind = ev
    trig = sin_cos(phase)
    S = arc_root(xi, kp)
    while is_before(periods, phase, split, 0.0):
        nxt = billiard_event_trig(
            periods, phase, trig[0], trig[1], S, tile, xi, vx, vyrel, kind, kp
        )
        if nxt[7] != OK and nxt[7] != STUCK_FOREVER:
            return
        hi_p, hi_ph = split, 0.0
        if nxt[7] == OK and is_before(nxt[0], nxt[1], split, 0.0):
            hi_p, hi_ph = nxt[0], nxt[1]
        ev_now = Event(periods, phase, tile, xi, vx, vyrel, kind)
        integrate_blocks(rows, ev_now, trig, (hi_p, hi_ph), half, kp, energy)
        periods, phase, tile, xi, vx, vyrel = hi_p, hi_ph, nxt[2], nxt[3], nxt[4], nxt[5]
        kind, trig, S = nxt[6], (nxt[8], nxt[9]), nxt[10]  # hi: that event's time unless the end


@njit(cache=True, fastmath=FMA, inline="always")
def release_zone(periods, phase, window):
    """Zone of a release: 0, 1, 2 before, in, after the window (a skip stays in one)."""
    p1 = window.p0 + window.nb * window.L
    if is_before(periods, phase, window.p0, 0.0):
        return 0.0
    return 1.0 if is_before(periods, phase, p1, 0.0) else 2.0


@njit(cache=True, fastmath=FMA)
def converged_cycle(carry, i, n_rel, ev, acc, counts, kp):
    """Lag p of a cycle that has converged to within ``FF_DRIFT_TOL``; 0 if none.

    For ``fast_forward`` in its converged mode, where a cycle converges onto a fixed point
    but never repeats bit for bit (its rounding keeps the releases a few ulp apart).
    Accepted at a release at ``theta_r`` (``core.cycle``) with lag ``p`` (``2 p <= FF_LAGS``)
    only if:

    * the last two p-cycles are the same sequence: the same periods, tile shift and zone,
      and the same change of every count (events, collisions, sticks, jumps);
    * their integrals agree, ``|I_last - I_before| <= FF_ENERGY_REL_TOL |I_last|`` for
      each of the four (``ACC_*``): the integrals vary over the distance between their
      releases by less than that;
    * the release map F (``core.cycle``) contracts, ``|lam| < 1``, and the drift still ahead
      is bounded: with ``x_n = F(x_{n-p})`` and the fixed point ``x* = F(x*)``, ``x_n - x* =
      lam (x_{n-p} - x*)`` (mean value theorem), so ``|x_n - x*| <= |lam| |x_n - x_{n-p}| /
      (1 - |lam|) <= FF_DRIFT_TOL``.

    ``lam`` comes from ``release_map`` (one more cycle from this release with the tangent
    dynamics, which must make the same events); it is remembered with the lag and the release
    point in ``carry.state`` (``C_LAM*``) and used again while one of the cycle's last p
    releases stays within ``FF_DRIFT_TOL`` of that point (the multiplier of a cycle is the
    same from each of its releases; F' changes by ``F''`` times that distance).  Within
    ``FF_LAM_NEAR`` of it, a remembered ``lam`` whose bound fails by more than a factor 2
    stops the search without a new run (a slowly converging cycle would otherwise run one
    at every release); the bound itself always uses a ``lam`` from within ``FF_DRIFT_TOL``.
    """
    rel, rel_acc, rel_cnt, cs = carry.rel[i], carry.rel_acc[i], carry.rel_cnt[i], carry.state[i]
    for p in range(1, min(n_rel, FF_LAGS) // 2 + 1):
        s1 = (n_rel - p) % FF_LAGS
        s2 = (n_rel - 2 * p) % FF_LAGS
        step = abs(ev.xi - rel[s1, 1])
        if step > FF_DRIFT_TOL or abs(rel[s1, 1] - rel[s2, 1]) > FF_DRIFT_TOL:
            continue
        r1, r2 = rel[s1], rel[s2]
        if r1[0] != ev.phase or r2[0] != ev.phase:
            continue
        dP = ev.periods - r1[2]
        if r1[2] - r2[2] != dP or ev.tile - r1[3] != r1[3] - r2[3] or r1[4] != r2[4]:
            continue
        if ev.phase != kp.release_r:
            return 0
        same = True
        for c in range(CNT_WIDTH):
            same = same and counts[c] - rel_cnt[s1, c] == rel_cnt[s1, c] - rel_cnt[s2, c]
        for c in range(4):
            last = acc[0, c] - rel_acc[s1, c]
            before = rel_acc[s1, c] - rel_acc[s2, c]
            same = same and abs(last - before) <= FF_ENERGY_REL_TOL * abs(last)
        if not same:
            continue
        # the shortest lag that passes decides (its multiples are the same cycle repeated);
        # the multiplier is the cycle's, whichever of its p releases it was computed from
        near = abs(ev.xi - cs[C_LAM_XI])
        for j in range(1, p):
            near = min(near, abs(rel[(n_rel - j) % FF_LAGS, 1] - cs[C_LAM_XI]))
        if cs[C_LAM_P] == p and near <= FF_LAM_NEAR:
            lam = cs[C_LAM]  # hopeless with the multiplier of a release that near: no new run
            if not (lam < 1.0 and lam * step <= 2.0 * FF_DRIFT_TOL * (1.0 - lam)):
                return 0
        if not (cs[C_LAM_P] == p and near <= FF_DRIFT_TOL):
            n_cycle = counts[CNT_EVENTS] - rel_cnt[s1, CNT_EVENTS]
            lam, P, ph, tile, _, events, ok = release_map(
                ev.periods, ev.phase, ev.tile, ev.xi, p, n_cycle, kp
            )
            same_cycle = events == n_cycle and P - ev.periods == dP and ph == ev.phase
            same_cycle = same_cycle and tile - ev.tile == ev.tile - r1[3]
            cs[C_LAM_P], cs[C_LAM_XI] = p, ev.xi
            cs[C_LAM] = abs(lam) if ok and same_cycle else math.inf
        lam = cs[C_LAM]
        return p if lam < 1.0 and lam * step <= FF_DRIFT_TOL * (1.0 - lam) else 0
    return 0


@njit(cache=True, fastmath=FMA, inline="always")
def cycles_before(periods, phase, dP, b_p, b_ph):
    """Whole cycles of ``dP`` periods from ``(periods, phase)`` that end strictly before
    ``(b_p, b_ph)`` (>= 0)."""
    K = int(min((b_p - periods) // dP, 2.0**52 / dP))
    while K > 0 and not is_before(periods + K * dP, phase, b_p, b_ph):
        K -= 1
    return max(K, 0)


@njit(cache=True, fastmath=FMA)
def cycle_samples(carry, i, ev, trig, S, lag, n_cycle, dP, dl, K, k, times, kp, disp):
    """Positions at the sample times ``k, k + 1, ...`` inside the ``K`` cycles skipped from
    the release ``ev`` (see ``fast_forward``), into ``disp``; returns ``(k, ok)``, ``k`` the
    first sample after them.

    The cycle from ``ev`` is run once more, event by event from the loop's own state
    (``trig = (sin, cos)`` of its phase, ``S`` its arc root), as the loop would run it; a
    sample ``j`` cycles on is placed in it at its time less ``j dP`` periods, its tile ``j dl``
    on.  Periods and tiles are whole numbers, so in the bitwise mode the positions are the
    event-by-event run's bit for bit.  ``ok = False`` (nothing written) unless the cycle run
    again makes ``n_cycle`` events and ends at the ``lag``-th release ``dP`` periods and ``dl``
    tiles on, at the same phase.
    """
    tile0, xi0 = carry.state[i, C_TILE0], carry.state[i, C_XI0]
    sample_periods, sample_phase = times.sample_periods, times.sample_phase
    end_p = ev.periods + K * dP
    k_end = k
    while k_end < sample_periods.shape[0] and is_before(
        sample_periods[k_end], sample_phase[k_end], end_p, ev.phase
    ):
        k_end += 1
    if k_end == k:
        return k, True
    # the cycle from ev: each event's periods, phase, tile, xi, vx and whether it sticks
    cycle = np.empty((n_cycle + 1, 6))
    periods, phase, tile, xi, vx, vyrel, kind = ev
    sn, cs = trig
    releases = 0
    for e in range(n_cycle):
        cycle[e, 0], cycle[e, 1], cycle[e, 2], cycle[e, 3] = periods, phase, tile, xi
        cycle[e, 4], cycle[e, 5] = vx, 1.0 if kind == STICK else 0.0
        nxt = billiard_event_trig(periods, phase, sn, cs, S, tile, xi, vx, vyrel, kind, kp)
        if nxt[7] != OK:
            return k, False
        periods, phase, tile, xi, vx, vyrel, kind = nxt[:7]
        sn, cs, S = nxt[8], nxt[9], nxt[10]
        releases += kind == RELEASE
    same = kind == RELEASE and releases == lag and phase == ev.phase
    if not (same and periods == ev.periods + dP and tile == ev.tile + dl):
        return k, False
    cycle[n_cycle, 0], cycle[n_cycle, 1] = periods, phase
    j_last, e = -1, 0
    for m in range(k, k_end):
        # the copy j of the cycle holding the sample: a sample at an event's time belongs to
        # the interval that event starts, as in the loop
        j = cycles_before(ev.periods, ev.phase, dP, sample_periods[m], sample_phase[m])
        if ev.periods + (j + 1) * dP == sample_periods[m] and ev.phase == sample_phase[m]:
            j += 1
        s_p = sample_periods[m] - j * dP  # the sample's time in the cycle from ev
        if j != j_last:
            j_last, e = j, 0
        while is_before(cycle[e + 1, 0], cycle[e + 1, 1], s_p, sample_phase[m]) or (
            cycle[e + 1, 0] == s_p and cycle[e + 1, 1] == sample_phase[m]
        ):
            e += 1
        x = cycle[e, 3]
        if cycle[e, 5] == 0.0:
            x += cycle[e, 4] * time_between(
                s_p, sample_phase[m], cycle[e, 0], cycle[e, 1], kp.w, kp.period
            )
        disp[m] = displacement(cycle[e, 2] + j * dl, x, tile0, xi0, kp.d)
    return k_end, True


@njit(cache=True, fastmath=FMA)
def skip_cycles(carry, i, n_rel, lag, ev, trig, S, zone, k, times, window, split, kp, flags, out):
    """Skip as many copies of the cycle of the last ``lag`` releases (of ``n_rel``) as fit
    before the end in ``zone`` (see ``fast_forward``), the positions at the sample times
    inside them from ``cycle_samples`` (or, where it fails, only those before the next sample
    time); returns ``(K, dP, dl, k)``, ``K = 0`` if none fits, ``k`` the next sample.  The
    cycle's releases in the ring move with the particle to the last skipped copy: periods,
    tiles, integrals and counts by what the skip adds to them."""
    rel, rel_acc, rel_cnt = carry.rel[i], carry.rel_acc[i], carry.rel_cnt[i]
    acc, counts = out.blocks[i], out.counts[i]
    energy = (flags & OBS_ENERGY) != 0
    periods, phase, tile, xi = ev.periods, ev.phase, ev.tile, ev.xi
    s = (n_rel - lag) % FF_LAGS
    r = rel[s]
    if r[4] != zone or rel_cnt[s, CNT_JUMPS] != counts[CNT_JUMPS]:
        return 0, 0.0, 0.0, k
    dP = periods - r[2]
    dl = tile - r[3]
    n_cycle = counts[CNT_EVENTS] - rel_cnt[s, CNT_EVENTS]
    p0 = window.p0
    p1 = p0 + window.nb * window.L
    nxt_zone = p0 if zone == 0.0 else (p1 if zone == 1.0 else math.inf)
    b_p, b_ph = times.end_periods, times.end_phase
    if is_before(nxt_zone, 0.0, b_p, b_ph):
        b_p, b_ph = nxt_zone, 0.0
    K = cycles_before(periods, phase, dP, b_p, b_ph)
    if K > 0 and (flags & OBS_DISPLACEMENT) != 0:
        k_new, ok = cycle_samples(
            carry, i, ev, trig, S, lag, n_cycle, dP, dl, K, k, times, kp, out.displacement[i]
        )
        if ok:
            k = k_new
        elif k < times.sample_periods.shape[0]:
            s_p, s_ph = times.sample_periods[k], times.sample_phase[k]
            if is_before(s_p, s_ph, b_p, b_ph):
                K = cycles_before(periods, phase, dP, s_p, s_ph)
    if K < 1:
        return 0, 0.0, 0.0, k
    if is_before(periods, phase, split, 0.0):
        # cycles ending before the split, and does the next skipped one pass it?
        K_split = int(min(K, (split - periods) // dP))
        while K_split > 0 and not is_before(periods + K_split * dP, phase, split, 0.0):
            K_split -= 1
        if K_split < K:
            for c in range(4):
                acc[1, c] = acc[0, c] + K_split * (acc[0, c] - rel_acc[s, c])
            release = Event(
                periods + K_split * dP, phase, tile + K_split * dl, xi, ev.vx, ev.vyrel, ev.kind
            )
            integrate_to_split(acc, release, p0, split, kp, energy)
    for c in range(4):
        added = K * (acc[0, c] - rel_acc[s, c])
        acc[0, c] += added
        for j in range(1, lag + 1):
            rel_acc[(n_rel - j) % FF_LAGS, c] += added
    for c in range(CNT_WIDTH):
        added = K * (counts[c] - rel_cnt[s, c])  # CNT_SKIPPED: no skip in the cycle
        if c == CNT_SKIPPED:
            added += K * n_cycle
        counts[c] += added
        for j in range(1, lag + 1):
            rel_cnt[(n_rel - j) % FF_LAGS, c] += added
    for j in range(1, lag + 1):
        rel[(n_rel - j) % FF_LAGS, 2] += K * dP
        rel[(n_rel - j) % FF_LAGS, 3] += K * dl
    return K, dP, dl, k


@njit(cache=True, fastmath=FMA, inline="always")
def fast_forward(carry, i, n_rel, ev, trig, S, k, times, window, split, kp, flags, out):
    """Skip whole stick-release cycles of particle ``i`` once its releases repeat.

    Exactness: a RELEASE leaves at ``phase = theta_r`` with ``vx = vyrel = 0`` relative to
    the floor, and ``billiard_event`` uses ``periods`` and ``tile`` only by adding whole
    numbers to them (exact below 2^53), so the events after a release are functions of
    ``(phase, xi, vx, vyrel)``, translated in periods and tiles.  If this release equals,
    bit for bit, the one ``p`` releases back (``dP`` periods and ``dl`` tiles earlier),
    every later cycle repeats the last one exactly, shifted by ``(dP, dl)`` (the release
    velocities are always 0, so ``(phase, xi)`` is compared).  With ``OBS_FF_CONVERGED`` a cycle
    that has converged onto a fixed point within ``FF_DRIFT_TOL`` (``converged_cycle``, a
    proven bound on the drift ahead) is skipped the same way: the skipped releases are then
    this one's, within that bound of the event-by-event run's.  Its
    contributions are the changes of the accumulators over the last cycle, added ``K``
    times: counts exactly; integrals to rounding (a product instead of a running sum, see
    ``tolerances.SUM_ROUND_PER_TERM``).  Only cycles inside one zone are skipped: the last
    cycle and the ``K`` skipped ones contain no window boundary and no recorded jump (none
    was seen in a stick-release cycle; a drifting cycle is simulated), and the skipped ones
    end before the end; around those the loop runs normally.  The positions at the sample
    times inside the skipped cycles come from the cycle run once more from this release
    (``cycle_samples``: in the bitwise mode the event-by-event run's bit for bit); where that
    fails, the skip ends before the next sample time.  After a skip the ring keeps the
    cycle's releases, moved to its last skipped copy (``skip_cycles``), and this release,
    moved the same way, so that the cycle is recognised again one cycle later (older releases
    are forgotten: ``xi = inf`` matches no release).  The split of the energy window is no
    bound (the skips, and so the window's integrals, are those of a run without it): if a
    skipped cycle passes it, row 1 of ``blocks`` gets the whole cycles before it the same way
    and the cycle that passes it from ``integrate_to_split``.

    Parameters
    ----------
    carry : bbdyn.ensemble.Carry
        Row ``i`` of its rings (updated in place): ``rel`` (FF_LAGS, 5), the releases
        ``phase, xi, periods, tile, zone`` (zone 0, 1, 2: before, in, after the window);
        ``rel_acc`` (FF_LAGS, 4) and ``rel_cnt``
        (FF_LAGS, CNT_WIDTH), the particle's ``blocks[0, :4]`` and ``counts`` at those releases.
    i : int
        The particle.
    n_rel : int
        Releases pushed so far.
    ev : Event
        This release.
    trig, S : (float, float), float
        Sine and cosine of its phase and its arc root (mm), as the loop carries them.
    k : int
        The next sample time's index.
    times : RunTimes
        The end and the sample times.
    window : Window
        The window (one block).
    split : float
        End of the first part of the window (whole periods, ``Observables.split_periods``).
    kp : KernelParams
    flags : int
        ``Observables.flags``: energy integrals (``OBS_ENERGY``), positions
        (``OBS_DISPLACEMENT``), and whether converged cycles are skipped as well as bitwise
        repeats (``OBS_FF_CONVERGED``).
    out : EnsembleOut
        Row ``i`` of ``blocks`` and ``counts`` is advanced by the skipped cycles, and its
        ``displacement`` written at the sample times inside them.

    Returns
    -------
    (K, dP, dl, n_rel, k) : whole cycles skipped (0: none), cycle length (periods), tile
    shift, the new ring count and the next sample index.
    """
    rel, rel_acc, rel_cnt = carry.rel[i], carry.rel_acc[i], carry.rel_cnt[i]
    acc, counts = out.blocks[i], out.counts[i]
    periods, phase, tile, xi = ev.periods, ev.phase, ev.tile, ev.xi
    zone = release_zone(periods, phase, window)
    lag = 0
    for p in range(1, min(n_rel, FF_LAGS) + 1):
        s = (n_rel - p) % FF_LAGS
        if rel[s, 1] == xi and rel[s, 0] == phase:
            lag = p
            break
    if lag == 0 and (flags & OBS_FF_CONVERGED) != 0 and n_rel >= 2:
        near = abs(rel[(n_rel - 1) % FF_LAGS, 1] - xi)
        for p in range(2, min(n_rel, FF_LAGS) // 2 + 1):
            near = min(near, abs(rel[(n_rel - p) % FF_LAGS, 1] - xi))
        if near <= FF_DRIFT_TOL:  # a candidate: the full test
            lag = converged_cycle(carry, i, n_rel, ev, acc, counts, kp)
    K, dP, dl = 0, 0.0, 0.0
    if lag > 0:
        K, dP, dl, k = skip_cycles(
            carry, i, n_rel, lag, ev, trig, S, zone, k, times, window, split, kp, flags, out
        )
    if K > 0:
        for p in range(lag + 1, min(n_rel, FF_LAGS) + 1):
            rel[(n_rel - p) % FF_LAGS, 1] = math.inf  # forgotten: older than the cycle
    s = n_rel % FF_LAGS
    rel[s, 0], rel[s, 1], rel[s, 2], rel[s, 3] = phase, xi, periods + K * dP, tile + K * dl
    rel[s, 4] = zone
    for c in range(4):
        rel_acc[s, c] = acc[0, c]
    for c in range(CNT_WIDTH):
        rel_cnt[s, c] = counts[c]
    return K, dP, dl, n_rel + 1, k


@njit(cache=True, fastmath=FMA)
def start_particles(states, carry_state):
    """Write the loop state of particles starting at ``states`` (n, 7) into ``carry_state``."""
    for i in range(states.shape[0]):
        for c in range(7):
            carry_state[i, c] = states[i, c]
        carry_state[i, C_TILE0] = states[i, 2]
        carry_state[i, C_XI0] = states[i, 3]
        carry_state[i, C_K] = 0.0
        carry_state[i, C_TRAP] = trap_of(states[i, 2], states[i, 3])
        carry_state[i, C_DEP_P] = states[i, 0]
        carry_state[i, C_DEP_PH] = states[i, 1]
        carry_state[i, C_NRING] = 0.0
        carry_state[i, C_RUN] = 0.0
        carry_state[i, C_NREL] = 0.0
        carry_state[i, C_LAM_P] = 0.0


@njit(cache=True, fastmath=FMA)
def particle_loop(carry, i, budget, kp, times, out, obs, th):
    """Integrate particle ``i`` for at most ``budget`` events toward the end; fill its outputs.

    The particle goes on from its loop state (row ``i`` of ``carry``: ``state``, columns
    ``C_*``, and the rings) and leaves it there: calling again goes on exactly where it
    stopped, so the numbers do not depend on how the run is cut.  Exactly one of ``obs``
    and ``th`` is None: it is an ensemble run (``obs``) or a features run (``th``; with
    displacement and energy, no fast-forward); numba compiles each kind without the
    other's code.

    Parameters
    ----------
    carry : bbdyn.ensemble.Carry
        Loop states; row ``i`` is updated in place.
    i : int
        The particle.
    budget : int
        Events (calls of ``billiard_event``) at most in this call.
    kp : KernelParams
    times : RunTimes
        End, window (``nb`` blocks) and sample times.
    out : EnsembleOut or features.FeatureOut
        Output arrays; row ``i`` is written (``displacement``, ``blocks``, ``counts``; with
        ``obs`` the jumps, record and ``final``; with ``th`` the features).
    obs : Observables or None
        What an ensemble run observes; jumps are stored with ``OBS_JUMPS``, the record
        with ``OBS_RECORD`` for the particles with a row in ``out.record``.
    th : features.FeatureThresholds or None
        The feature thresholds (see ``features.feature_collision``).

    Returns
    -------
    status : int
        ``RUNNING`` if the budget ran out first, else ``OK`` or ``STUCK_FOREVER`` (normal
        ends) or the kernel's failure status.
    """
    cs = carry.state[i]
    acc, disp, counts = out.blocks[i], out.displacement[i], out.counts[i]
    periods, phase, tile, xi, vx, vyrel = cs[0], cs[1], cs[2], cs[3], cs[4], cs[5]
    kind = int(cs[6])
    tile0, xi0 = cs[C_TILE0], cs[C_XI0]
    k = int(cs[C_K])
    trap = cs[C_TRAP]
    dep_periods, dep_phase = cs[C_DEP_P], cs[C_DEP_PH]  # last departure (features' flights)
    n_ring, run, n_rel = int(cs[C_NRING]), int(cs[C_RUN]), int(cs[C_NREL])
    if obs is not None:
        flags = obs.flags
        do_record = (flags & OBS_RECORD) != 0 and i < out.record.shape[0]
    else:
        flags = OBS_DISPLACEMENT | OBS_ENERGY
        do_record = False
    do_disp = (flags & OBS_DISPLACEMENT) != 0
    energy = (flags & OBS_ENERGY) != 0
    do_jumps = (flags & OBS_JUMPS) != 0
    do_ff = (flags & OBS_FAST_FORWARD) != 0 and not do_record
    end_p, end_ph = times.end_periods, times.end_phase
    window = Window(times.p0, times.L, times.nb)
    p0, L, nb = window
    p1 = p0 + nb * L
    split = p0  # an ensemble integrates [p0, split] into row 1 of its blocks as well
    if obs is not None:
        split = obs.split_periods
    sample_periods, sample_phase = times.sample_periods, times.sample_phase
    n_samples = sample_periods.shape[0]
    status = OK
    n_done = 0
    trig = sin_cos(phase)  # then carried from event to event, as is S
    S = arc_root(xi, kp)
    while True:
        if n_done == budget:
            status = RUNNING
            break
        n_done += 1
        nxt = billiard_event_trig(
            periods, phase, trig[0], trig[1], S, tile, xi, vx, vyrel, kind, kp
        )
        status = nxt[7]
        if status == STUCK_FOREVER:
            n_periods, n_phase = math.inf, 0.0
        elif status != OK:
            break
        else:
            n_periods, n_phase = nxt[0], nxt[1]
        counts[CNT_EVENTS] += 1
        last = not is_before(n_periods, n_phase, end_p, end_ph)
        stuck = kind == STICK
        seg_end = (end_p, end_ph) if last else (n_periods, n_phase)
        ev = Event(periods, phase, tile, xi, vx, vyrel, kind)
        if obs is not None:  # the interval that passes the split (once): row 1 of the blocks
            hi_p, hi_ph = seg_end
            if is_before(periods, phase, split, 0.0) and not is_before(hi_p, hi_ph, split, 0.0):
                split_row(acc, ev, trig, seg_end, p0, split, kp, energy)
        integrate_blocks(acc, ev, trig, seg_end, window, kp, energy)

        # positions at the sample times inside this interval (all remaining ones if last)
        if do_disp:
            while k < n_samples and (
                last or is_before(sample_periods[k], sample_phase[k], n_periods, n_phase)
            ):
                x = xi
                if not stuck:
                    x += vx * time_between(
                        sample_periods[k], sample_phase[k], periods, phase, kp.w, kp.period
                    )
                disp[k] = displacement(tile, x, tile0, xi0, kp.d)
                k += 1
        if last:
            break

        periods, phase, tile, xi, vx, vyrel = nxt[0], nxt[1], nxt[2], nxt[3], nxt[4], nxt[5]
        kind = nxt[6]
        trig, S = (nxt[8], nxt[9]), nxt[10]
        if kind == RELEASE:
            if do_ff:
                K, dP, dl, n_rel, k = fast_forward(
                    carry, i, n_rel, Event(periods, phase, tile, xi, vx, vyrel, kind), trig, S,
                    k, times, window, split, kp, flags, out,
                )  # fmt: skip
                periods += K * dP
                tile += K * dl
                trap += K * dl
            dep_periods, dep_phase = periods, phase
            continue
        # a collision (IMPACT or STICK); an IMPACT departs at once, a STICK releases later
        flight = time_between(periods, phase, dep_periods, dep_phase, kp.w, kp.period) / kp.period
        dep_periods, dep_phase = periods, phase
        new_trap = trap_of(tile, xi)
        jumped = new_trap != trap
        in_window = not is_before(periods, phase, p0, 0.0) and is_before(periods, phase, p1, 0.0)
        if in_window:
            counts[CNT_COLLISIONS] += 1
            if kind == STICK:
                counts[CNT_STICKS] += 1
            if jumped:
                j = counts[CNT_JUMPS]
                if obs is not None:
                    if do_jumps and j < out.jump_len.shape[1]:
                        out.jump_len[i, j] = int(new_trap - trap)
                        out.jump_time[i, j] = periods * kp.period + phase / kp.w
                counts[CNT_JUMPS] = j + 1
            if th is not None:
                hit = Collision(block_of(periods, p0, L, nb), phase, vyrel, kind, flight, jumped)
                n_ring, run = feature_collision(out, i, carry.ring[i], n_ring, run, hit, th, kp)
        trap = new_trap
        if obs is not None:
            if (
                do_record
                and not is_before(periods, phase, obs.record_periods[0], obs.record_phase[0])
                and not is_before(obs.record_periods[1], obs.record_phase[1], periods, phase)
            ):
                r = counts[CNT_RECORD]
                if r < out.record.shape[1]:
                    rec = out.record[i, r]
                    rec[0], rec[1], rec[2], rec[3] = periods, phase, tile, xi
                    rec[4], rec[5], rec[6] = vx, vyrel, kind
                counts[CNT_RECORD] = r + 1
    cs[0], cs[1], cs[2], cs[3], cs[4], cs[5], cs[6] = periods, phase, tile, xi, vx, vyrel, kind
    cs[C_K], cs[C_TRAP], cs[C_DEP_P], cs[C_DEP_PH] = k, trap, dep_periods, dep_phase
    cs[C_NRING], cs[C_RUN], cs[C_NREL] = n_ring, run, n_rel
    if status == RUNNING:
        return status
    if obs is not None:
        for c in range(7):
            out.final[i, c] = cs[c]
    if status != OK and status != STUCK_FOREVER:
        # a failed particle leaves NaN where it could not say where it was
        for kk in range(k, n_samples):
            disp[kk] = math.nan
        return status
    if th is not None:
        feature_finish(out.glob[i], out.mismatch[i], n_ring, run)
    return status


@njit(cache=True, fastmath=FMA, parallel=True)
def run_ensemble(carry, budget, kp, times, obs, out):
    """Advance every running particle by at most ``budget`` events (prange over particles).

    Call it again while some ``out.status`` is ``RUNNING``: the outputs are filled in
    place and do not depend on ``budget`` (see ``bbdyn.ensemble.Carry``).

    Parameters
    ----------
    carry : bbdyn.ensemble.Carry
        Loop states (``bbdyn.ensemble.new_carry``; rings of ``FF_LAGS`` with fast-forward,
        ``pmax`` 0).
    budget : int
        Events per particle at most in this call (>= 1).
    kp : KernelParams
    times : RunTimes
        End, energy window (one block: ``nb = 1``, ``L`` its length) and sample times.
    obs : Observables
        Flags, record window and the split of the energy window.
    out : EnsembleOut
        Outputs.  ``counts[:, CNT_JUMPS]`` may exceed the jump capacity and
        ``counts[:, CNT_RECORD]`` the record capacity (counted, not stored).  ``status``:
        ``RUNNING`` on entry for the particles to advance; on return ``RUNNING``, ``OK``,
        ``STUCK_FOREVER`` or a failure.
    """
    status = out.status  # a local: prange dropped the stores through ``out.status[i]``
    for i in prange(status.shape[0]):
        if status[i] != RUNNING:
            continue
        # prange's index is unsigned in the parallel loop and signed when numba first types
        # it: the same type in both, or particle_loop is compiled twice (10 s more)
        status[i] = particle_loop(carry, np.int64(i), budget, kp, times, out, obs, None)


@njit(cache=True, fastmath=FMA, parallel=True)
def run_features(carry, budget, kp, times, th, out):
    """Advance every running particle by at most ``budget`` events, filling the features.

    As ``run_ensemble`` (call again while some ``out.status`` is ``RUNNING``; the numbers
    do not depend on ``budget`` nor on the number of threads); each particle writes only
    its own rows.

    Parameters
    ----------
    carry : bbdyn.ensemble.Carry
        Loop states (``bbdyn.ensemble.new_carry``; fast-forward rings of length 0, ``ring``
        of ``pmax``).
    budget : int
        Events per particle at most in this call (>= 1).
    kp : KernelParams
    times : RunTimes
        End (at or after ``p0 + nb L`` periods), window of ``nb`` blocks of ``L`` periods
        and the displacement's sample times.
    th : features.FeatureThresholds
    out : features.FeatureOut
        Outputs, zero on entry (``status`` as in ``run_ensemble``).
    """
    status = out.status  # a local: prange dropped the stores through ``out.status[i]``
    for i in prange(status.shape[0]):
        if status[i] != RUNNING:
            continue
        status[i] = particle_loop(carry, np.int64(i), budget, kp, times, out, None, th)
