"""The kernels the work-precision benchmarks time (``bbdyn bench flat``, ``bbdyn bench
billiard``; scenes ``b2_flat``, ``b2_billiard``).

``flat_one_step`` and ``billiard_one_step`` run one flight (and for the billiard its
impact law) from each of many start states; ``billiard_continuous`` runs events for their
time alone; ``flight_profile`` counts what those events cost (safe steps, tiny hops,
collisions, sticks).
"""

import math

from numba import njit

from bbdyn.core.billiard import (
    EventState,
    billiard_flight,
    billiard_run,
    event_search,
    event_trig,
    snap_to_wedge,
)
from bbdyn.core.floor import bounce
from bbdyn.core.search import flat_flight_tol
from bbdyn.core.status import OK, STICK


@njit(cache=True)
def flat_one_step(phases, vrels, kp, step_rel, out_tau, out_vrel_minus):
    """``flat_flight_tol`` at ``step_rel`` from each start state in turn (in place).

    Returns ``(n_evals, status)``: the gap evaluations of all flights and the
    first bad status (``OK`` if none).  ``step_rel = ROOT_STEP_REL`` is ``flat_flight``.
    """
    n_evals = 0
    for i in range(phases.shape[0]):
        tau, vm, status, n = flat_flight_tol(phases[i], vrels[i], kp, step_rel)
        n_evals += n
        if status != OK:
            return n_evals, status
        out_tau[i] = tau
        out_vrel_minus[i] = vm
    return n_evals, OK


@njit(cache=True)
def billiard_one_step(starts, kp, out_tau, out_k, out_xi, out_vx, out_vy):
    """``billiard_flight`` then the restitution law from each start (rows ``phase, xi, vx, vyrel``).

    Writes the flight time (s), tile offset, contact ``xi`` (mm) and the absolute
    post-impact velocity (mm/s, before any chattering decision) in place; returns
    the first failure status or ``OK``.
    """
    for i in range(starts.shape[0]):
        phase = starts[i, 0]
        tau, k, xi, vym, _, status = billiard_flight(
            phase, starts[i, 1], starts[i, 2], starts[i, 3], kp
        )
        if status != OK:
            return status
        xi = snap_to_wedge(xi, kp)
        vx, vyrel, _, _ = bounce(xi, starts[i, 2], vym, kp)
        out_tau[i] = tau
        out_k[i] = k
        out_xi[i] = xi
        out_vx[i] = vx
        out_vy[i] = vyrel - kp.A * kp.w * math.cos(phase + kp.w * tau)
    return OK


@njit(cache=True)
def billiard_continuous(state, kp, n_events):
    """Status of ``n_events`` events of ``billiard_run`` from ``state`` (for timing)."""
    start = EventState(state[0], state[1], state[2], state[3], state[4], state[5], state[6])
    return billiard_run(start, kp, n_events, None)[2]


@njit(cache=True)
def flight_profile(state, kp, n_events):
    """Cost profile of ``n_events`` events from ``state``, on the event path of
    ``billiard_continuous`` (``event_search``).

    Returns ``(steps, flights, tiny, collisions, sticks, status)``: safe steps summed over
    flights, flights, flights solved without a safe step (tiny hops, ``tiny_hop``),
    collisions (IMPACT or STICK) and STICK events.
    """
    periods, phase, tile, xi, vx, vyrel = state[0], state[1], state[2], state[3], state[4], state[5]
    kind = int(state[6])
    trig = event_trig(phase, xi, kp)
    steps = 0
    flights = 0
    tiny = 0
    collisions = 0
    sticks = 0
    for _ in range(n_events):
        if kind != STICK:
            n_steps = billiard_flight(phase, xi, vx, vyrel, kp)[4]
            steps += n_steps
            tiny += n_steps == 0
            flights += 1
        nxt, status, trig = event_search(
            EventState(periods, phase, tile, xi, vx, vyrel, kind), trig, kp
        )
        periods, phase, tile, xi, vx, vyrel, kind = nxt
        if status != OK:
            return steps, flights, tiny, collisions, sticks, status
        if kind != 2:  # IMPACT or STICK
            collisions += 1
        if kind == STICK:
            sticks += 1
    return steps, flights, tiny, collisions, sticks, OK
