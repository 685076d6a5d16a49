"""Helpers shared by the tests of the Taylor contacts (test_tiny_hop, test_taylor_finish).

``flight_starts`` collects the flights of a run; ``both_rules`` runs the current
first-contact search and the independent quadratic-step search on the same flights;
``rate_cond`` is the cancellation in the gap rate at a flight's start, ``eps (|vyrel| + |vx
xi0| / S0) / G'(0)``, inherited by every method.
"""

import numpy as np
from numba import njit

from bbdyn import Params
from bbdyn.core.billiard import (
    EventState,
    billiard_event,
    billiard_flight,
    event_search,
    event_trig,
    flight_search,
)
from bbdyn.core.floor import arc_root
from bbdyn.core.plate import sin_cos
from bbdyn.core.status import OK, STICK
from bbdyn.ensemble import ensemble


@njit(cache=True)
def flight_rule(phase, xi0, vx, vyrel, kp, cubic):
    """``flight_search`` from the phase and point alone, with the cubic (``cubic``) or the
    quadratic step rule."""
    sn, cs = sin_cos(phase)
    return flight_search(phase, sn, cs, xi0, arc_root(xi0, kp), vx, vyrel, kp, cubic)


@njit(cache=True)
def event_rule(periods, phase, tile, xi, vx, vyrel, kind, kp, cubic):
    """``billiard_event`` with the cubic (``cubic``) or the quadratic step rule."""
    state = EventState(periods, phase, tile, xi, vx, vyrel, kind)
    nxt, status, _ = event_search(state, event_trig(phase, xi, kp), kp, cubic)
    return nxt.periods, nxt.phase, nxt.tile, nxt.xi, nxt.vx, nxt.vyrel, nxt.kind, status


@njit(cache=True)
def both_rules(starts, kp, out):
    """Flights from ``starts`` rows ``(phase, xi, vx, vyrel)``.  Columns of ``out``: tau, k,
    xi, vyrel^-, steps, status of the current search, then tau, k, xi, vyrel^-, status of the
    quadratic-step search."""
    for j in range(starts.shape[0]):
        phase, xi0, vx, vyrel = starts[j, 0], starts[j, 1], starts[j, 2], starts[j, 3]
        a = flight_rule(phase, xi0, vx, vyrel, kp, True)
        b = flight_rule(phase, xi0, vx, vyrel, kp, False)
        out[j, 0], out[j, 1], out[j, 2], out[j, 3], out[j, 4], out[j, 5] = a
        out[j, 6], out[j, 7], out[j, 8], out[j, 9], _, out[j, 10] = b


def rate_cond(kp, xi0, vx, vyrel):
    """``(|vyrel| + |vx xi0| / S0) / G'(0)``: the relative conditioning of the gap rate."""
    S0 = np.sqrt((kp.R - xi0) * (kp.R + xi0))
    return (np.abs(vyrel) + np.abs(vx * xi0) / S0) / (vyrel + vx * xi0 / S0)


@njit(cache=True)
def _flight_starts(state, kp, n_events, tiny, out):
    """Start states ``(phase, xi, vx, vyrel)`` of the flights of a run from ``state``: those
    solved by ``tiny_hop`` (0 safe steps) if ``tiny``, else those found by safe steps."""
    periods, phase, tile, xi, vx, vyrel = state[0], state[1], state[2], state[3], state[4], state[5]
    kind = int(state[6])
    j = 0
    for _ in range(n_events):
        if kind != STICK and j < out.shape[0]:
            if (billiard_flight(phase, xi, vx, vyrel, kp)[4] == 0) == tiny:
                out[j, 0], out[j, 1], out[j, 2], out[j, 3] = phase, xi, vx, vyrel
                j += 1
        periods, phase, tile, xi, vx, vyrel, kind, status = billiard_event(
            periods, phase, tile, xi, vx, vyrel, kind, kp
        )
        if status != OK:
            break
    return j


def flight_starts(f, tiny, n_max, n_events):
    """``(kp, starts)``: up to ``n_max`` flight starts (rows ``phase, xi, vx, vyrel``) within
    ``n_events`` events of one particle of a 3 s run at ``f`` Hz (seed 2); see
    ``_flight_starts``."""
    params = Params(f=f)
    kp = params.kernel()
    state = np.asarray(ensemble(params, t=3.0, n=2, seed=2, threads=1)["final"])[0]
    out = np.zeros((n_max, 4))
    j = _flight_starts(state, kp, n_events, tiny, out)
    return kp, out[:j]


def random_starts(kp, seed, n, log_vn):
    """``n`` random flight starts ``(phase, xi, vx, vyrel)`` over one tile: any phase, 200
    next to a wedge, horizontal velocities 1e-6 to 1e2 mm/s (log-uniform, either sign) and
    ``R V.n / S`` (the gap rate ``G'(0)``) log-uniform in ``10**log_vn`` times R (mm/s)."""
    rng = np.random.default_rng(seed)
    half = 0.5 * kp.d
    xi = rng.uniform(-half, half, n)
    xi[:200] = half * (1 - 1e-12) * np.sign(rng.uniform(-1, 1, 200))
    vx = rng.normal(0, 1, n) * 10 ** rng.uniform(-6, 2, n)
    S = np.sqrt((kp.R - xi) * (kp.R + xi))
    vyrel = (10 ** rng.uniform(*log_vn, n) * kp.R - vx * xi) / S  # leaving the arc
    phase = rng.uniform(0, 2 * np.pi, n)
    return np.stack([phase, xi, vx, vyrel], 1)
