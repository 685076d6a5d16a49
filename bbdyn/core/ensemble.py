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

The kernels take named tuples: the loop state ``bbdyn.runs.Carry``, the times
``RunTimes``, what to observe (``Observables``, ensemble) or the feature thresholds
(``features.FeatureThresholds``), and the output arrays ``EnsembleOut`` (or
``features.FeatureOut``), one row per particle.
"""

import math

import numpy as np
from numba import njit, prange

from bbdyn.core.billiard import EventState, event_search, event_trig
from bbdyn.core.fast_forward import Particle, fast_forward
from bbdyn.core.features import Collision, block_of, feature_collision, feature_finish
from bbdyn.core.floor import arc_root, normal_velocity, xi_from_arc_length
from bbdyn.core.layout import (
    ACC_EX,
    ACC_EY,
    ACC_POT,
    ACC_STUCK,
    C_DEP_P,
    C_DEP_PH,
    C_DRAWS,
    C_K,
    C_KEY0,
    C_KEY1,
    C_LAM_P,
    C_NREL,
    C_NRING,
    C_PARTICLE,
    C_RUN,
    C_TILE0,
    C_TRAP,
    C_XI0,
    CARRY_WIDTH,
    CNT_COLLISIONS,
    CNT_EVENTS,
    CNT_JUMPS,
    CNT_RECORD,
    CNT_SKIPPED,
    CNT_STICKS,
    CNT_WIDTH,
    FF_LAGS,
    OBS_DISPLACEMENT,
    OBS_ENERGY,
    OBS_FAST_FORWARD,
    OBS_FF_CONVERGED,
    OBS_JUMPS,
    OBS_RECORD,
    REC_WIDTH,
    RUNNING,
    EnsembleOut,
    Observables,
    RunTimes,
    Window,
)
from bbdyn.core.noise import noisy_params
from bbdyn.core.observables import (
    displacement,
    integrate_blocks,
    is_before,
    split_row,
    time_between,
    trap_of,
)
from bbdyn.core.status import IMPACT, OK, RELEASE, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import FMA

#: The loop's entry points, and the buffer layouts (``core.layout``) of the arrays the API
#: layer allocates for it.
__all__ = [
    "initial_states",
    "leaving_floor",
    "start_particles",
    "particle_loop",
    "run_ensemble",
    "run_features",
    "ACC_EX",
    "ACC_EY",
    "ACC_POT",
    "ACC_STUCK",
    "CARRY_WIDTH",
    "CNT_COLLISIONS",
    "CNT_EVENTS",
    "CNT_JUMPS",
    "CNT_RECORD",
    "CNT_SKIPPED",
    "CNT_STICKS",
    "CNT_WIDTH",
    "FF_LAGS",
    "OBS_DISPLACEMENT",
    "OBS_ENERGY",
    "OBS_FAST_FORWARD",
    "OBS_FF_CONVERGED",
    "OBS_JUMPS",
    "OBS_RECORD",
    "REC_WIDTH",
    "RUNNING",
    "EnsembleOut",
    "Observables",
    "RunTimes",
]


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


@njit(cache=True, fastmath=FMA)
def start_particles(states, key0, key1, carry_state):
    """Write the loop state of particles starting at ``states`` (n, 7) into ``carry_state``;
    particle ``i`` draws its random restitution (``core.noise``) with the key ``(key0, key1)``
    (32-bit words) as particle ``i``, from flight 0."""
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
        carry_state[i, C_KEY0] = key0
        carry_state[i, C_KEY1] = key1
        carry_state[i, C_PARTICLE] = i
        carry_state[i, C_DRAWS] = 0.0


@njit(cache=True, fastmath=FMA)
def particle_loop(carry, i, budget, kp, times, out, obs, th, ff):
    """Integrate particle ``i`` for at most ``budget`` events toward the end; fill its outputs.

    The particle goes on from its loop state (row ``i`` of ``carry``: ``state``, columns
    ``C_*``, and the rings) and leaves it there: calling again goes on exactly where it
    stopped, so the numbers do not depend on how the run is cut.  Exactly one of ``obs``
    and ``th`` is None: it is an ensemble run (``obs``) or a features run (``th``; with
    displacement and energy, no fast-forward); numba compiles each kind without the
    other's code.

    Parameters
    ----------
    carry : bbdyn.runs.Carry
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
    noisy = kp.eta > 0.0
    draws = np.uint64(cs[C_DRAWS])  # flights that drew random restitution (core.noise)
    key0, key1 = np.uint64(cs[C_KEY0]), np.uint64(cs[C_KEY1])
    particle_id = np.uint64(cs[C_PARTICLE])
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
    particle = Particle(carry, i, kp, times, window, split, flags, out)  # for fast_forward
    trig = event_trig(phase, xi, kp)  # then carried from event to event
    while True:
        if n_done == budget:
            status = RUNNING
            break
        n_done += 1
        ev = EventState(periods, phase, tile, xi, vx, vyrel, kind)
        kp_ev = kp
        if noisy and kind != STICK:  # a flight: its collision draws alpha and beta
            kp_ev = noisy_params(kp, key0, key1, particle_id, draws)
            draws += np.uint64(1)
        nxt, status, nxt_trig = event_search(ev, trig, kp_ev)
        if status == STUCK_FOREVER:
            n_periods, n_phase = math.inf, 0.0
        elif status != OK:
            break
        else:
            n_periods, n_phase = nxt.periods, nxt.phase
        counts[CNT_EVENTS] += 1
        last = not is_before(n_periods, n_phase, end_p, end_ph)
        stuck = kind == STICK
        seg_end = (end_p, end_ph) if last else (n_periods, n_phase)
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

        periods, phase, tile, xi, vx, vyrel, kind = nxt
        trig = nxt_trig
        if kind == RELEASE:
            if ff is not None:  # compiled in only where it can run
                if do_ff:
                    K, dP, dl, n_rel, k = fast_forward(particle, n_rel, nxt, trig, k)
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
    cs[C_DRAWS] = draws
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
    place and do not depend on ``budget`` (see ``bbdyn.runs.Carry``).

    Parameters
    ----------
    carry : bbdyn.runs.Carry
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
        status[i] = particle_loop(carry, np.int64(i), budget, kp, times, out, obs, None, True)


@njit(cache=True, fastmath=FMA, parallel=True)
def run_features(carry, budget, kp, times, th, out):
    """Advance every running particle by at most ``budget`` events, filling the features.

    As ``run_ensemble`` (call again while some ``out.status`` is ``RUNNING``; the numbers
    do not depend on ``budget`` nor on the number of threads); each particle writes only
    its own rows.

    Parameters
    ----------
    carry : bbdyn.runs.Carry
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
        status[i] = particle_loop(carry, np.int64(i), budget, kp, times, out, None, th, None)
