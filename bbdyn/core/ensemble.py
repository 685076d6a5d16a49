"""Ensembles of independent billiard particles with on-the-fly observables.

Each particle is integrated event by event with ``billiard_event`` from its own
initial state up to ``t_end``; between events its motion (a parabola, or riding
the floor after a STICK) is known exactly, so every observable is evaluated or
integrated in closed form (``observables.py``) on the way.  Nothing is stored
per event unless a collision record is asked for: memory is proportional to the
ensemble (and to the number of sample times and buffer sizes), not to the run.

``prange`` runs over particles; each writes only its own rows of the output
arrays and nothing is reduced across particles here, so the numbers do not
depend on the number of threads or on scheduling.

Conventions (MODEL.md sections 3 and 4):

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
  are recorded in it; the collision record covers ``record_window``.
"""

import math

from numba import njit, prange

from bbdyn.core.billiard import billiard_event
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

#: Columns of the per-particle integrals ``acc``: int E_x, int E_y, int g y, stuck time
#: (kg mm^2/s and s), all over the energy window.
ACC_EX, ACC_EY, ACC_POT, ACC_STUCK = 0, 1, 2, 3
#: Columns of the per-particle counts: events in the run, collisions, STICKs and
#: jumps in the energy window.
CNT_EVENTS, CNT_COLLISIONS, CNT_STICKS, CNT_JUMPS = 0, 1, 2, 3
#: Columns of the collision record: periods, phase, tile, xi, vx, vyrel, kind.
REC_WIDTH = 7


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
def run_particle(
    i,
    state,
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
    record_n,
    final,
):
    """Integrate particle ``i`` from ``state`` to ``end`` and write its rows of the outputs.

    Parameters
    ----------
    i : int
        Particle index (row of every output array).
    state : array, shape (7,)
        ``periods, phase, tile, xi, vx, vyrel, kind`` of the initial event.
    kp : KernelParams
    end : array, shape (2,)
        End of the run, ``(periods, phase)``.
    window_periods : array, shape (2,)
        Energy window in whole periods ``[p0, p1]``.
    sample_periods, sample_phase : arrays, shape (m,)
        Sample times, sorted, within ``[start, end]``.
    record_window : array, shape (4,)
        ``(periods0, phase0, periods1, phase1)`` of the collision record.
    flags : int
        OR of the ``OBS_*`` flags.
    disp, acc, counts, jump_len, jump_time, record, record_n, final : arrays
        Outputs (see ``run_ensemble``); rows ``i`` are written in place.

    Returns
    -------
    status : int
        ``OK`` or ``STUCK_FOREVER`` (normal ends) or the kernel's failure status.
    """
    periods, phase, tile, xi, vx, vyrel = (
        state[0],
        state[1],
        state[2],
        state[3],
        state[4],
        state[5],
    )
    kind = int(state[6])
    tile0, xi0 = tile, xi
    do_disp = (flags & OBS_DISPLACEMENT) != 0
    energy = (flags & OBS_ENERGY) != 0
    do_jumps = (flags & OBS_JUMPS) != 0
    do_record = (flags & OBS_RECORD) != 0 and i < record.shape[0]
    w0 = (window_periods[0], 0.0)
    w1 = (window_periods[1], 0.0)
    rec0 = (record_window[0], record_window[1])
    rec1 = (record_window[2], record_window[3])
    n_samples = sample_periods.shape[0]
    k = 0
    trap = trap_of(tile, xi)
    cap = jump_len.shape[1]
    status = OK
    while True:
        nxt = billiard_event(periods, phase, tile, xi, vx, vyrel, kind, kp)
        status = nxt[7]
        if status == STUCK_FOREVER:
            n_periods, n_phase = math.inf, 0.0
        elif status != OK:
            break
        else:
            n_periods, n_phase = nxt[0], nxt[1]
        counts[i, CNT_EVENTS] += 1
        last = not is_before(n_periods, n_phase, end[0], end[1])
        seg_end = (end[0], end[1]) if last else (n_periods, n_phase)
        stuck = kind == STICK
        b = floor_height_rel(xi, kp) if energy else 0.0

        # energy window part of [event, seg_end]
        lo = (periods, phase)
        if is_before(lo[0], lo[1], w0[0], w0[1]):
            lo = w0
        hi = seg_end
        if is_before(w1[0], w1[1], hi[0], hi[1]):
            hi = w1
        if is_before(lo[0], lo[1], hi[0], hi[1]):
            accumulate_interval(acc, i, stuck, periods, phase, b, vx, vyrel, lo, hi, kp, energy)

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
                disp[i, k] = displacement(tile, x, tile0, xi0, kp.d)
                k += 1
        if last:
            break

        periods, phase, tile, xi, vx, vyrel, kind = (
            nxt[0],
            nxt[1],
            nxt[2],
            nxt[3],
            nxt[4],
            nxt[5],
            nxt[6],
        )
        if kind == RELEASE:
            continue
        in_window = not is_before(periods, phase, w0[0], w0[1]) and is_before(
            periods, phase, w1[0], w1[1]
        )
        if in_window:
            counts[i, CNT_COLLISIONS] += 1
            if kind == STICK:
                counts[i, CNT_STICKS] += 1
        new_trap = trap_of(tile, xi)
        if new_trap != trap:
            if in_window:
                j = counts[i, CNT_JUMPS]
                if do_jumps and j < cap:
                    jump_len[i, j] = int(new_trap - trap)
                    jump_time[i, j] = periods * kp.period + phase / kp.w
                counts[i, CNT_JUMPS] = j + 1
            trap = new_trap
        if (
            do_record
            and not is_before(periods, phase, rec0[0], rec0[1])
            and not is_before(rec1[0], rec1[1], periods, phase)
        ):
            r = record_n[i]
            if r < record.shape[1]:
                record[i, r, 0] = periods
                record[i, r, 1] = phase
                record[i, r, 2] = tile
                record[i, r, 3] = xi
                record[i, r, 4] = vx
                record[i, r, 5] = vyrel
                record[i, r, 6] = kind
            record_n[i] = r + 1
    final[i, 0] = periods
    final[i, 1] = phase
    final[i, 2] = tile
    final[i, 3] = xi
    final[i, 4] = vx
    final[i, 5] = vyrel
    final[i, 6] = kind
    # a failed particle leaves NaN where it could not say where it was
    if status != OK and status != STUCK_FOREVER:
        for kk in range(k, n_samples):
            disp[i, kk] = math.nan
    return status


@njit(cache=True, parallel=True)
def run_ensemble(
    states,
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
    record_n,
    final,
    status,
):
    """Integrate every particle (in parallel over particles) and fill the outputs in place.

    Parameters
    ----------
    states : array, shape (n, 7)
        Initial events ``periods, phase, tile, xi, vx, vyrel, kind`` (see ``run_particle``).
    kp, end, window_periods, sample_periods, sample_phase, record_window, flags
        As in ``run_particle``.
    disp : array, shape (n, m) or (n, 0)
        ``x(t_k) - x(0)`` (mm) at the sample times.
    acc : array, shape (n, 4)
        Integrals over the energy window, columns ``ACC_*``; must start at zero.
    counts : int64 array, shape (n, 4)
        Event counts, columns ``CNT_*``; must start at zero.
    jump_len : int64 array, shape (n, cap); jump_time : array, shape (n, cap)
        Trap changes (units of d) and their times (s); ``counts[:, CNT_JUMPS]`` may
        exceed ``cap`` (overflow: the extra jumps are counted, not stored).
    record : array, shape (n_rec, cap_rec, 7); record_n : int64 array, shape (n_rec,)
        Collision record of the first ``n_rec`` particles inside ``record_window``.
    final : array, shape (n, 7)
        The last event before ``end`` (the state the run would continue from).
    status : int64 array, shape (n,)
        Per-particle status (``OK``, ``STUCK_FOREVER`` or a failure).
    """
    for i in prange(states.shape[0]):
        status[i] = run_particle(
            i,
            states[i],
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
            record_n,
            final,
        )
