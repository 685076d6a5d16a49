"""Fast-forward: whole stick-release cycles skipped once a particle's releases repeat.

The particle loop (``core.ensemble.particle_loop``) calls ``fast_forward`` at each RELEASE;
it keeps a ring of the last ``FF_LAGS`` releases and, once this release repeats one of them,
skips as many copies of the cycle between them as fit before the next boundary.

Exactness.  A RELEASE leaves at ``phase = theta_r`` with ``vx = vyrel = 0`` relative to the
floor, and ``billiard_event`` uses ``periods`` and ``tile`` only by adding whole numbers to
them (exact below 2^53), so the events after a release are functions of ``(phase, xi, vx,
vyrel)``, translated in periods and tiles.  If this release equals, bit for bit, the one
``p`` releases back (``dP`` periods and ``dl`` tiles earlier), every later cycle repeats the
last one exactly, shifted by ``(dP, dl)`` (the release velocities are always 0, so ``(phase,
xi)`` is compared).  With ``OBS_FF_CONVERGED`` a cycle that has converged onto a fixed point
within ``FF_DRIFT_TOL`` (``converged_cycle``, a proven bound on the drift ahead) is skipped
the same way: the skipped releases are then this one's, within that bound of the
event-by-event run's.  Its contributions are the changes of the accumulators over the last
cycle, added ``K`` times: counts exactly; integrals to rounding (a product instead of a
running sum, see ``tolerances.SUM_ROUND_PER_TERM``).  Only cycles inside one zone are
skipped: the last cycle and the ``K`` skipped ones contain no window boundary and no
recorded jump (none was seen in a stick-release cycle; a drifting cycle is simulated), and
the skipped ones end before the end; around those the loop runs normally.  The positions at
the sample times inside the skipped cycles come from the cycle run once more from this
release (``cycle_samples``: in the bitwise mode the event-by-event run's bit for bit); where
that fails, the skip ends before the next sample time.  After a skip the ring keeps the
cycle's releases, moved to its last skipped copy (``skip_cycles``), and this release, moved
the same way, so that the cycle is recognised again one cycle later (older releases are
forgotten: ``xi = inf`` matches no release).  The split of the energy window is no bound
(the skips, and so the window's integrals, are those of a run without it): if a skipped
cycle passes it, row 1 of ``blocks`` gets the whole cycles before it the same way and the
cycle that passes it from ``integrate_to_split``.

The release map (``release_map``; converged cycles).  A RELEASE at ``theta_r = pi +
asin(1/Gamma)`` (``stick_release``) leaves with the floor's velocity, whatever came before:
the state after it is the point ``x = tile d + xi`` alone (mm).  The events up to the p-th
release after it define the *release map* ``x -> F(x)``, smooth while the sequence of events
(tiles, kinds, wedge reflections) stays the same.  Its derivative, the *multiplier* ``lam =
F'(x)``, is carried along by the tangent dynamics of ``billiard_tangent``
(``billiard_tangent_event``, bitwise the events of ``billiard_event``): a tangent vector
``e_x`` at the first release, multiplied by each event's Jacobian, ends at the last release
as ``lam e_x`` (that release's Jacobian keeps only the ``x`` component).

Where ``|lam| < 1`` the cycle contracts onto a fixed point ``x*`` of F, and by the mean
value theorem ``|x - x*| <= |F(x) - x| / (1 - |lam|)`` to first order in ``x - x*``: a
proven bound on how far the releases still drift.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from bbdyn.core.billiard import EventState, event_search, event_trig
from bbdyn.core.billiard_tangent import billiard_tangent_event
from bbdyn.core.layout import (
    C_LAM,
    C_LAM_P,
    C_LAM_XI,
    C_TILE0,
    C_XI0,
    CNT_EVENTS,
    CNT_JUMPS,
    CNT_SKIPPED,
    CNT_WIDTH,
    FF_LAGS,
    OBS_DISPLACEMENT,
    OBS_ENERGY,
    OBS_FF_CONVERGED,
    Window,
)
from bbdyn.core.observables import displacement, integrate_blocks, is_before, time_between
from bbdyn.core.status import OK, RELEASE, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import FF_DRIFT_TOL, FF_ENERGY_REL_TOL, FMA

#: Distance (mm) within which a remembered multiplier decides that a converged-cycle bound
#: is hopeless (``converged_cycle``; an economy only: no bound relies on it).
FF_LAM_NEAR = 1e-9


class Particle(NamedTuple):
    """One particle's run as the fast-forward sees it (built once by ``particle_loop``)."""

    carry: tuple  # bbdyn.runs.Carry: the loop state and the rings of releases
    i: int  # the particle (its row of carry and out)
    kp: tuple  # KernelParams
    times: tuple  # RunTimes: the end and the sample times
    window: tuple  # Window: the energy window (one block)
    split: float  # end of the window's first part (whole periods)
    flags: int  # Observables.flags
    out: tuple  # EnsembleOut


@njit(cache=True, fastmath=FMA)
def release_map(periods, phase, tile, xi, releases, max_events, kp):
    """Run ``releases`` stick-release cycles from a RELEASE at ``theta_r`` with its tangent.

    Parameters
    ----------
    periods, phase, tile, xi : float
        The release (it leaves at rest relative to the floor).
    releases : int
        Releases to reach (the lag p of the cycle).
    max_events : int
        Events at most (the caller's cycle length: more means another sequence).
    kp : KernelParams

    Returns
    -------
    (lam, periods, phase, tile, xi, events, ok)
        The multiplier ``dF/dx``, the release reached, the events taken; ``ok = False``
        when the kernel fails, ``max_events`` pass first, or the last release is not one at
        ``theta_r`` (a release at once inside the window carries its phase too).
    """
    J = np.empty((4, 4))
    W = np.empty((4, 4))
    T = np.empty((4, 4))
    v0, v1, v2, v3 = 0.0, 1.0, 0.0, 0.0  # d(theta, x, vx, vyrel) per dx at the start
    # kind as a plain int64, not the literal RELEASE: numba would compile the tangent event
    # twice, once for each type (3 s)
    vx, vyrel, kind = 0.0, 0.0, np.int64(RELEASE)
    left = releases
    for n in range(1, max_events + 1):
        out = billiard_tangent_event(periods, phase, tile, xi, vx, vyrel, kind, kp, (J, W, T))
        if out[7] != OK:
            break
        periods, phase, tile, xi, vx, vyrel, kind = out[:7]
        v0, v1, v2, v3 = (
            J[0, 0] * v0 + J[0, 1] * v1 + J[0, 2] * v2 + J[0, 3] * v3,
            J[1, 0] * v0 + J[1, 1] * v1 + J[1, 2] * v2 + J[1, 3] * v3,
            J[2, 0] * v0 + J[2, 1] * v1 + J[2, 2] * v2 + J[2, 3] * v3,
            J[3, 0] * v0 + J[3, 1] * v1 + J[3, 2] * v2 + J[3, 3] * v3,
        )
        if kind == RELEASE:
            left -= 1
            if left == 0:
                ok = J[0, 0] == 0.0  # released at theta_r, not at once inside the window
                return v1, periods, phase, tile, xi, n, ok
    return np.nan, periods, phase, tile, xi, max_events, False


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
    trig = event_trig(ev.phase, ev.xi, kp)
    while is_before(ev.periods, ev.phase, split, 0.0):
        nxt, status, nxt_trig = event_search(ev, trig, kp)
        if status != OK and status != STUCK_FOREVER:
            return
        hi_p, hi_ph = split, 0.0
        if status == OK and is_before(nxt.periods, nxt.phase, split, 0.0):
            hi_p, hi_ph = nxt.periods, nxt.phase
        integrate_blocks(rows, ev, trig, (hi_p, hi_ph), half, kp, energy)
        # hi: that event's time unless the end
        ev = EventState(hi_p, hi_ph, nxt.tile, nxt.xi, nxt.vx, nxt.vyrel, nxt.kind)
        trig = nxt_trig


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
    Accepted at a release at ``theta_r`` (``release_map``) with lag ``p`` (``2 p <= FF_LAGS``)
    only if:

    * the last two p-cycles are the same sequence: the same periods, tile shift and zone,
      and the same change of every count (events, collisions, sticks, jumps);
    * their integrals agree, ``|I_last - I_before| <= FF_ENERGY_REL_TOL |I_last|`` for
      each of the four (``ACC_*``): the integrals vary over the distance between their
      releases by less than that;
    * the release map F (``release_map``) contracts, ``|lam| < 1``, and the drift still ahead
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
        if ev.phase != kp.release_r or kp.g_t != 0.0:  # tilted: no tangent dynamics
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
def cycle_samples(particle, ev, trig, lag, n_cycle, dP, dl, K, k):
    """Positions at the sample times ``k, k + 1, ...`` inside the ``K`` cycles skipped from
    the release ``ev`` (see ``fast_forward``), into ``disp``; returns ``(k, ok)``, ``k`` the
    first sample after them.

    The cycle from ``ev`` is run once more, event by event from the loop's own state
    (``trig`` its ``Trig``), as the loop would run it; a
    sample ``j`` cycles on is placed in it at its time less ``j dP`` periods, its tile ``j dl``
    on.  Periods and tiles are whole numbers, so in the bitwise mode the positions are the
    event-by-event run's bit for bit.  ``ok = False`` (nothing written) unless the cycle run
    again makes ``n_cycle`` events and ends at the ``lag``-th release ``dP`` periods and ``dl``
    tiles on, at the same phase.
    """
    carry, i, kp, times = particle.carry, particle.i, particle.kp, particle.times
    disp = particle.out.displacement[i]
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
    state = ev
    releases = 0
    for e in range(n_cycle):
        cycle[e, 0], cycle[e, 1], cycle[e, 2], cycle[e, 3] = state[:4]
        cycle[e, 4], cycle[e, 5] = state.vx, 1.0 if state.kind == STICK else 0.0
        state, status, trig = event_search(state, trig, kp)
        if status != OK:
            return k, False
        releases += state.kind == RELEASE
    periods, phase, tile, kind = state.periods, state.phase, state.tile, state.kind
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
def skip_cycles(particle, n_rel, lag, ev, trig, zone, k):
    """Skip as many copies of the cycle of the last ``lag`` releases (of ``n_rel``) as fit
    before the end in ``zone`` (see ``fast_forward``), the positions at the sample times
    inside them from ``cycle_samples`` (or, where it fails, only those before the next sample
    time); returns ``(K, dP, dl, k)``, ``K = 0`` if none fits, ``k`` the next sample.  The
    cycle's releases in the ring move with the particle to the last skipped copy: periods,
    tiles, integrals and counts by what the skip adds to them."""
    carry, i, kp, times, window, split, flags, out = particle
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
        k_new, ok = cycle_samples(particle, ev, trig, lag, n_cycle, dP, dl, K, k)
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
            release = EventState(
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
def fast_forward(particle, n_rel, ev, trig, k):
    """Skip whole stick-release cycles of particle ``i`` once its releases repeat.

    Why the skipped cycles are exact, and what is skipped: the module docstring.

    Parameters
    ----------
    particle : Particle
        The particle's run: ``carry`` (row ``i`` of its rings, updated in place: ``rel``
        (FF_LAGS, 5), the releases ``phase, xi, periods, tile, zone`` (zone 0, 1, 2: before,
        in, after the window); ``rel_acc`` (FF_LAGS, 4) and ``rel_cnt`` (FF_LAGS,
        CNT_WIDTH), the particle's ``blocks[0, :4]`` and ``counts`` at those releases);
        ``times``, ``window``, ``split``; ``flags`` (energy integrals ``OBS_ENERGY``,
        positions ``OBS_DISPLACEMENT``, converged cycles ``OBS_FF_CONVERGED``); ``out``, whose
        row ``i`` of ``blocks`` and ``counts`` is advanced by the skipped cycles and its
        ``displacement`` written at the sample times inside them.
    n_rel : int
        Releases pushed so far.
    ev : EventState
        This release.
    trig : Trig
        Sine and cosine of its phase and its arc root (mm), as the loop carries them.
    k : int
        The next sample time's index.

    Returns
    -------
    (K, dP, dl, n_rel, k) : whole cycles skipped (0: none), cycle length (periods), tile
    shift, the new ring count and the next sample index.
    """
    carry, i, kp, times, window, split, flags, out = particle
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
        K, dP, dl, k = skip_cycles(particle, n_rel, lag, ev, trig, zone, k)
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
