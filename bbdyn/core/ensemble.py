"""Ensembles of independent billiard particles with on-the-fly observables.

Each particle is integrated event by event with ``billiard_event`` from its own
initial state up to ``t_end`` by one loop, ``particle_loop``, shared by the
ensemble observables (``run_ensemble``) and the classification features
(``run_features``, accumulators in ``features.py``); flags switch the
accumulators on.  Between events the motion (a parabola, or riding the floor
after a STICK) is known exactly, so every observable is evaluated or integrated
in closed form (``observables.py``) on the way.  Nothing is stored
per event unless a collision record is asked for: memory is proportional to the
ensemble (and to the number of sample times and buffer sizes), not to the run.

``prange`` runs over particles; each writes only its own rows of the output
arrays and nothing is reduced across particles here, so the numbers do not
depend on the number of threads or on scheduling.

Conventions (docs/model.md §3 and §4):

* times are ``(periods, phase)``; the end of the run, the energy window
  ``[window_periods[0], window_periods[1]]`` (whole periods, phase 0) and the
  sample times are given that way;
* a *collision* is an IMPACT or a STICK event (a STICK is the impact that starts a
  chattering sequence, summed in closed form by the event kernel); the trap
  sequence is read at collisions; RELEASE events leave from the STICK point;
* chattering sequences are integrated as the flight that ends in them: the
  kernel sums them in closed form only once their duration is below rounding
  of a period, so they carry no measurable weight;
* event counts, stuck time and energy integrals cover the energy window; jumps
  are recorded in it; the collision record covers ``record_window``.  The window
  ``[p0, p0 + nb L]`` may be cut into ``nb`` blocks of ``L`` periods (features);
  the ensemble uses one block.
"""

import math

import numpy as np
from numba import njit, prange

from bbdyn.core.billiard import billiard_event
from bbdyn.core.features import block_of, feature_collision, feature_finish
from bbdyn.core.floor import arc_root, floor_height_rel, normal_velocity, xi_from_arc_length
from bbdyn.core.observables import (
    displacement,
    flight_integrals,
    is_before,
    stuck_integrals,
    time_between,
    trap_of,
)
from bbdyn.core.plate import plate_height, plate_velocity
from bbdyn.core.status import IMPACT, OK, RELEASE, STICK, STUCK_FOREVER

#: Bit flags selecting the observables an ensemble computes.
OBS_DISPLACEMENT = 1
OBS_ENERGY = 2
OBS_JUMPS = 4
OBS_RECORD = 8
#: Classification features (``features.py``); set by ``run_features`` only.
OBS_FEATURES = 16
#: Fast-forward of exactly periodic stick-release cycles (``fast_forward``); ignored
#: with features and for recorded particles.
OBS_FAST_FORWARD = 32
#: Releases remembered to detect a cycle: lags 1 .. FF_LAGS.
FF_LAGS = 8

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
#: remembered.
C_TILE0, C_XI0, C_K, C_TRAP, C_DEP_P, C_DEP_PH = 7, 8, 9, 10, 11, 12
C_NRING, C_RUN, C_NREL = 13, 14, 15
CARRY_WIDTH = 16


@njit(cache=True)
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
        vn, _ = normal_velocity(xi, arc_root(xi, kp), ics[i, 1], vyrel, kp.R)
        if not vn > 0.0 and first_bad < 0:
            first_bad = i
        states[i, 0] = 0.0
        states[i, 1] = 0.0
        states[i, 2] = 0.0
        states[i, 3] = xi
        states[i, 4] = ics[i, 1]
        states[i, 5] = vyrel
        states[i, 6] = IMPACT
    return first_bad


@njit(cache=True)
def accumulate_interval(acc, i, stuck, periods, phase, tile_xi_b, vx, vyrel, lo, hi, kp, energy):
    """Add the integrals over ``[lo, hi]`` of the motion since the event at ``(periods, phase)``.

    ``lo`` and ``hi`` are ``(periods, phase)`` pairs inside the interval; ``tile_xi_b`` is the
    height ``b(xi)`` of the event point above the wedges (mm).
    """
    w, period = kp.w, kp.period
    if stuck:
        dt = time_between(hi[0], hi[1], lo[0], lo[1], w, period)
        acc[i, ACC_STUCK] += dt
        if energy:
            I_Ey, I_pot = stuck_integrals(kp.A, w, kp.g, tile_xi_b, lo[1], dt)
            acc[i, ACC_EY] += I_Ey
            acc[i, ACC_POT] += I_pot
        return
    if energy:
        ta = time_between(lo[0], lo[1], periods, phase, w, period)
        tb = time_between(hi[0], hi[1], periods, phase, w, period)
        y0 = plate_height(kp.A, phase) + tile_xi_b
        vy0 = vyrel + plate_velocity(kp.A, w, phase)
        I_Ex, I_Ey, I_pot = flight_integrals(vx, vy0, y0, kp.g, ta, tb)
        acc[i, ACC_EX] += I_Ex
        acc[i, ACC_EY] += I_Ey
        acc[i, ACC_POT] += I_pot


@njit(cache=True)
def integrate_blocks(acc, stuck, periods, phase, xi, vx, vyrel, lo, hi, win, kp, energy):
    """Integrate the motion since the event at ``(periods, phase)`` over ``[lo, hi]``, per block.

    ``lo`` and ``hi`` are ``(periods, phase)`` pairs; the part inside the window
    ``win = (p0, L, nb)`` is cut at the block boundaries ``p0 + j L`` (phase 0) and
    added to row ``j`` of ``acc`` by ``accumulate_interval``.
    """
    p0, L, nb = win
    p1 = p0 + nb * L
    lo_p, lo_ph = lo
    if is_before(lo_p, lo_ph, p0, 0.0):
        lo_p, lo_ph = p0, 0.0
    hi_p, hi_ph = hi
    if is_before(p1, 0.0, hi_p, hi_ph):
        hi_p, hi_ph = p1, 0.0
    if not is_before(lo_p, lo_ph, hi_p, hi_ph):
        return
    b = floor_height_rel(xi, kp) if energy else 0.0
    for j in range(block_of(lo_p, p0, L, nb), block_of(hi_p, p0, L, nb) + 1):
        a_p, a_ph = lo_p, lo_ph
        if is_before(a_p, a_ph, p0 + j * L, 0.0):
            a_p, a_ph = p0 + j * L, 0.0
        z_p, z_ph = hi_p, hi_ph
        if is_before(p0 + (j + 1) * L, 0.0, z_p, z_ph):
            z_p, z_ph = p0 + (j + 1) * L, 0.0
        if is_before(a_p, a_ph, z_p, z_ph):
            accumulate_interval(
                acc, j, stuck, periods, phase, b, vx, vyrel, (a_p, a_ph), (z_p, z_ph), kp, energy
            )


@njit(cache=True)
def fast_forward(
    rel, rel_acc, rel_cnt, n_rel, periods, phase, tile, xi, k, bound, win, acc, counts
):
    """Skip whole stick-release cycles once a release state repeats bitwise.

    Exactness: a RELEASE leaves at ``phase = theta_r`` with ``vx = vyrel = 0`` relative to
    the floor, and ``billiard_event`` uses ``periods`` and ``tile`` only by adding whole
    numbers to them (exact below 2^53), so the events after a release are functions of
    ``(phase, xi, vx, vyrel)``, translated in periods and tiles.  If this release equals,
    bit for bit, the one ``p`` releases back (``dP`` periods and ``dl`` tiles earlier),
    every later cycle repeats the last one exactly, shifted by ``(dP, dl)`` (the release
    velocities are always 0, so ``(phase, xi)`` is compared).  Its
    contributions are the changes of the accumulators over the last cycle, added ``K``
    times: counts exactly; integrals to rounding (a product instead of a running sum, see
    ``tolerances.SUM_ROUND_PER_TERM``).  Only cycles inside one zone are skipped: the last
    cycle and the ``K`` skipped ones contain no window boundary, no sample time (``k``
    unchanged, ``bound`` the next one) and no recorded jump (none was seen in a stick-release
    cycle; a drifting cycle is simulated) and end before ``end``; around those the loop runs
    normally.

    Parameters
    ----------
    rel : array, shape (FF_LAGS, 6)
        Ring of releases ``phase, xi, periods, tile, zone, k`` (zone 0, 1, 2: before, in,
        after the window; ``k`` the next sample index then).
    rel_acc, rel_cnt : arrays, shapes (FF_LAGS, 4), (FF_LAGS, CNT_WIDTH)
        Accumulators ``acc[0, :4]`` and ``counts`` at those releases.
    n_rel : int
        Releases pushed so far.
    periods, phase, tile, xi : float
        This release.
    k : int
        Next sample index; ``bound`` its time ``(periods, phase)`` or the end.
    win, acc, counts
        As in ``particle_loop`` (``acc`` with one block).

    Returns
    -------
    (K, dP, dl, n_rel) : whole cycles skipped (0: none), cycle length (periods), tile shift,
    and the new ring count (reset to 0 after a skip).
    """
    p0, L, nb = win
    p1 = p0 + nb * L
    zone = (
        0.0
        if is_before(periods, phase, p0, 0.0)
        else (1.0 if is_before(periods, phase, p1, 0.0) else 2.0)
    )
    for lag in range(1, min(n_rel, FF_LAGS) + 1):
        r = rel[(n_rel - lag) % FF_LAGS]
        if r[0] != phase or r[1] != xi:
            continue
        s = (n_rel - lag) % FF_LAGS
        if r[4] != zone or r[5] != k or rel_cnt[s, CNT_JUMPS] != counts[CNT_JUMPS]:
            break
        dP = periods - r[2]
        dl = tile - r[3]
        nxt_zone = p0 if zone == 0.0 else (p1 if zone == 1.0 else math.inf)
        b_p, b_ph = bound
        if is_before(nxt_zone, 0.0, b_p, b_ph):
            b_p, b_ph = nxt_zone, 0.0
        K = int(min((b_p - periods) // dP, 2.0**52 / dP))
        while K > 0 and not is_before(periods + K * dP, phase, b_p, b_ph):
            K -= 1
        if K < 1:
            break
        for c in range(4):
            acc[0, c] += K * (acc[0, c] - rel_acc[s, c])
        n_cycle = counts[CNT_EVENTS] - rel_cnt[s, CNT_EVENTS]
        for c in range(CNT_WIDTH):
            counts[c] += K * (counts[c] - rel_cnt[s, c])  # CNT_SKIPPED: no skip in the cycle
        counts[CNT_SKIPPED] += K * n_cycle
        return K, dP, dl, 0
    s = n_rel % FF_LAGS
    rel[s, 0], rel[s, 1], rel[s, 2], rel[s, 3] = phase, xi, periods, tile
    rel[s, 4], rel[s, 5] = zone, k
    for c in range(4):
        rel_acc[s, c] = acc[0, c]
    for c in range(CNT_WIDTH):
        rel_cnt[s, c] = counts[c]
    return 0, 0.0, 0.0, n_rel + 1


@njit(cache=True)
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


@njit(cache=True)
def particle_loop(
    cs, rel, rel_acc, rel_cnt, ring, budget, kp, end, win, sample_periods, sample_phase,
    record_window, flags, fpar, acc, disp, counts, jump_len, jump_time, record, final, hist,
    kcount, glob, mism,
):  # fmt: skip
    """Integrate one particle for at most ``budget`` events toward ``end``; feed the accumulators.

    The particle goes on from its loop state ``cs`` (and rings ``rel, rel_acc, rel_cnt``,
    ``ring``, a particle's rows of a
    ``bbdyn.ensemble.Carry``) and leaves it there: calling again goes on
    exactly where it stopped, so the numbers do not depend on how the run is cut.

    Parameters
    ----------
    cs : array, shape (CARRY_WIDTH,)
        Loop state, columns ``C_*`` (``start_particles``); updated in place.
    rel, rel_acc, rel_cnt, ring : arrays
        The particle's rings; updated in place.
    budget : int
        Events (calls of ``billiard_event``) at most in this call.
    kp : KernelParams
    end : array, shape (2,)
        End of the run, ``(periods, phase)``.
    win : tuple
        ``(p0, L, nb)``: the window starts at ``p0`` whole periods and is cut into ``nb``
        blocks of ``L`` periods.
    sample_periods, sample_phase : arrays, shape (m,)
        Sample times, sorted, within ``[start, end]``.
    record_window : array, shape (4,)
        ``(periods0, phase0, periods1, phase1)`` of the collision record.
    flags : int
        OR of the ``OBS_*`` flags.
    fpar : tuple
        Feature thresholds ``(tiny, k_tol, kmax, hist_width)`` (see ``feature_particle``).
    acc : array, shape (nb, >= 4)
        Block integrals, columns ``ACC_*`` (and ``features.BF_*`` with features).
    disp : array, shape (m,)
        ``x - x(0)`` (mm) at the sample times.
    counts : int64 array, shape (CNT_WIDTH,)
        Counts, columns ``CNT_*``.
    jump_len, jump_time : arrays, shape (cap,)
        Trap changes in the window (units of d) and their times (s).
    record : array, shape (cap_rec, REC_WIDTH)
        Collision record (written with ``OBS_RECORD``).
    final : array, shape (7,)
        The last event before ``end`` (written when the particle ends).
    hist, kcount, glob, mism : arrays
        Feature rows (see ``features.feature_collision``), written with ``OBS_FEATURES``.

    Returns
    -------
    status : int
        ``RUNNING`` if the budget ran out first, else ``OK`` or ``STUCK_FOREVER`` (normal
        ends) or the kernel's failure status.
    """
    periods, phase, tile, xi, vx, vyrel = cs[0], cs[1], cs[2], cs[3], cs[4], cs[5]
    kind = int(cs[6])
    tile0, xi0 = cs[C_TILE0], cs[C_XI0]
    k = int(cs[C_K])
    trap = cs[C_TRAP]
    dep_periods, dep_phase = cs[C_DEP_P], cs[C_DEP_PH]  # last departure (features' flights)
    n_ring, run, n_rel = int(cs[C_NRING]), int(cs[C_RUN]), int(cs[C_NREL])
    do_disp = (flags & OBS_DISPLACEMENT) != 0
    energy = (flags & OBS_ENERGY) != 0
    do_jumps = (flags & OBS_JUMPS) != 0
    do_record = (flags & OBS_RECORD) != 0
    do_feat = (flags & OBS_FEATURES) != 0
    do_ff = (flags & OBS_FAST_FORWARD) != 0 and not do_feat and not do_record
    p0, L, nb = win
    p1 = p0 + nb * L
    rec0 = (record_window[0], record_window[1])
    rec1 = (record_window[2], record_window[3])
    n_samples = sample_periods.shape[0]
    cap = jump_len.shape[0]
    status = OK
    n_done = 0
    while True:
        if n_done == budget:
            status = RUNNING
            break
        n_done += 1
        nxt = billiard_event(periods, phase, tile, xi, vx, vyrel, kind, kp)
        status = nxt[7]
        if status == STUCK_FOREVER:
            n_periods, n_phase = math.inf, 0.0
        elif status != OK:
            break
        else:
            n_periods, n_phase = nxt[0], nxt[1]
        counts[CNT_EVENTS] += 1
        last = not is_before(n_periods, n_phase, end[0], end[1])
        stuck = kind == STICK
        seg_end = (end[0], end[1]) if last else (n_periods, n_phase)
        integrate_blocks(
            acc, stuck, periods, phase, xi, vx, vyrel, (periods, phase), seg_end, win, kp, energy
        )

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
        if kind == RELEASE:
            if do_ff:
                bound = (end[0], end[1])
                if k < n_samples and is_before(sample_periods[k], sample_phase[k], end[0], end[1]):
                    bound = (sample_periods[k], sample_phase[k])
                K, dP, dl, n_rel = fast_forward(
                    rel, rel_acc, rel_cnt, n_rel, periods, phase, tile, xi, k, bound, win, acc,
                    counts,
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
                if do_jumps and j < cap:
                    jump_len[j] = int(new_trap - trap)
                    jump_time[j] = periods * kp.period + phase / kp.w
                counts[CNT_JUMPS] = j + 1
            if do_feat:
                n_ring, run = feature_collision(
                    acc, block_of(periods, p0, L, nb), hist, kcount, glob, mism, ring, n_ring,
                    run, phase, vyrel, kind, flight, jumped, fpar, kp,
                )  # fmt: skip
        trap = new_trap
        if (
            do_record
            and not is_before(periods, phase, rec0[0], rec0[1])
            and not is_before(rec1[0], rec1[1], periods, phase)
        ):
            r = counts[CNT_RECORD]
            if r < record.shape[0]:
                record[r, 0] = periods
                record[r, 1] = phase
                record[r, 2] = tile
                record[r, 3] = xi
                record[r, 4] = vx
                record[r, 5] = vyrel
                record[r, 6] = kind
            counts[CNT_RECORD] = r + 1
    cs[0], cs[1], cs[2], cs[3], cs[4], cs[5], cs[6] = periods, phase, tile, xi, vx, vyrel, kind
    cs[C_K], cs[C_TRAP], cs[C_DEP_P], cs[C_DEP_PH] = k, trap, dep_periods, dep_phase
    cs[C_NRING], cs[C_RUN], cs[C_NREL] = n_ring, run, n_rel
    if status == RUNNING:
        return status
    for c in range(7):
        final[c] = cs[c]
    if status != OK and status != STUCK_FOREVER:
        # a failed particle leaves NaN where it could not say where it was
        for kk in range(k, n_samples):
            disp[kk] = math.nan
        return status
    if do_feat:
        feature_finish(glob, mism, n_ring, run)
    return status


@njit(cache=True, parallel=True)
def run_ensemble(
    carry,
    budget,
    kp,
    end,
    window_periods,
    sample_periods,
    sample_phase,
    record_window,
    flags,
    disp,
    acc,
    counts,
    jump_len,
    jump_time,
    record,
    final,
    status,
):
    """Advance every running particle by at most ``budget`` events (prange over particles).

    Call it again while some ``status`` is ``RUNNING``: the outputs are filled in place
    and do not depend on ``budget`` (see ``bbdyn.ensemble.Carry``).

    Parameters
    ----------
    carry : bbdyn.ensemble.Carry
        Loop states (``bbdyn.ensemble.new_carry``; rings of ``FF_LAGS`` with fast-forward,
        ``pmax`` 0).
    budget : int
        Events per particle at most in this call (>= 1).
    kp, end, sample_periods, sample_phase, record_window, flags
        As in ``particle_loop``.
    window_periods : array, shape (2,)
        Energy window in whole periods ``[p0, p1]`` (one block).
    disp : array, shape (n, m) or (n, 0)
        ``x(t_k) - x(0)`` (mm) at the sample times.
    acc : array, shape (n, 1, 4)
        Integrals over the energy window, columns ``ACC_*``; must start at zero.
    counts : int64 array, shape (n, CNT_WIDTH)
        Counts, columns ``CNT_*``; must start at zero.  ``CNT_JUMPS`` may exceed the
        jump capacity and ``CNT_RECORD`` the record capacity (counted, not stored).
    jump_len : int64 array, shape (n, cap); jump_time : array, shape (n, cap)
        Trap changes (units of d) and their times (s).
    record : array, shape (n_rec, cap_rec, 7)
        Collision record of the first ``n_rec`` particles inside ``record_window``.
    final : array, shape (n, 7)
        The last event before ``end`` (the state the run would continue from).
    status : int64 array, shape (n,)
        Per-particle status: ``RUNNING`` on entry for the particles to advance; on return
        ``RUNNING``, ``OK``, ``STUCK_FOREVER`` or a failure.
    """
    win = (window_periods[0], window_periods[1] - window_periods[0], 1)
    fpar = (0.0, 0.0, 0, 1.0)
    no_record = np.zeros((0, REC_WIDTH))
    none = np.zeros(0)
    for i in prange(status.shape[0]):
        if status[i] != RUNNING:
            continue
        in_record = i < record.shape[0]
        status[i] = particle_loop(
            carry.state[i], carry.rel[i], carry.rel_acc[i], carry.rel_cnt[i], carry.ring[i],
            budget, kp, end, win, sample_periods, sample_phase, record_window,
            flags if in_record else flags & ~OBS_RECORD, fpar, acc[i], disp[i], counts[i],
            jump_len[i], jump_time[i], record[i] if in_record else no_record, final[i],
            none, none, none, none,
        )  # fmt: skip


@njit(cache=True, parallel=True)
def run_features(
    carry, budget, kp, end, p0, L, nb, tiny, k_tol, kmax, hist_width, sample_periods,
    sample_phase, disp, counts, blocks, hist, kcount, glob, mism, status,
):  # fmt: skip
    """Advance every running particle by at most ``budget`` events, filling the features.

    As ``run_ensemble`` (call again while some ``status`` is ``RUNNING``; the numbers do
    not depend on ``budget`` nor on the number of threads); each particle writes only
    its own rows.

    Parameters
    ----------
    carry : bbdyn.ensemble.Carry
        Loop states (``bbdyn.ensemble.new_carry``; fast-forward rings of length 0, ``ring``
        of ``pmax``).
    budget : int
        Events per particle at most in this call (>= 1).
    kp : KernelParams
    end : array, shape (2,)
        End of the run ``(periods, phase)``; at or after ``p0 + nb L`` periods.
    p0, L : float
        Window start and block length (whole periods).
    nb : int
        Number of blocks.
    tiny, k_tol : float
        Tiny-hop bound and locking tolerance (in periods).
    kmax : int
        Largest locking number counted.
    hist_width : float
        Width (periods) of the flight-time histogram bins.
    sample_periods, sample_phase : arrays, shape (m,)
        Sample times of the displacement, sorted, within ``[0, end]``.
    disp : array, shape (n, m)
        ``x(t_k) - x(0)`` (mm) at the sample times.
    counts : int64 array, shape (n, CNT_WIDTH)
        The loop's counts; zero on entry.
    blocks, hist, kcount, glob, mism : arrays
        Outputs (``features.py``), shapes (n, nb, BF_WIDTH), (n, nbins), (n, kmax + 1),
        (n, G_WIDTH), (n, pmax); zero on entry.
    status : int64 array, shape (n,)
        As in ``run_ensemble``.
    """
    no_record = np.zeros(4)
    fpar = (tiny, k_tol, kmax, hist_width)
    flags = OBS_DISPLACEMENT | OBS_ENERGY | OBS_FEATURES
    for i in prange(status.shape[0]):
        if status[i] != RUNNING:
            continue
        status[i] = particle_loop(
            carry.state[i], carry.rel[i], carry.rel_acc[i], carry.rel_cnt[i], carry.ring[i],
            budget, kp, end, (p0, L, nb), sample_periods, sample_phase, no_record, flags, fpar,
            blocks[i], disp[i], counts[i], np.zeros(0, dtype=np.int64), np.zeros(0),
            np.zeros((0, REC_WIDTH)), np.zeros(7), hist[i], kcount[i], glob[i], mism[i],
        )  # fmt: skip
