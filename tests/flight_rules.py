"""Helpers shared by the tests of the Taylor contacts (test_tiny_hop, test_taylor_finish).

``flight_starts`` collects the flights of a run; ``both_rules`` runs the current
first-contact search and the independent quadratic-step search (``quadratic_flight``, the
previous rule) on the same flights;
``rate_cond`` is the cancellation in the gap rate at a flight's start, ``eps (|vyrel| + |vx
xi0| / S0) / G'(0)``, inherited by every method.
"""

import numpy as np
from numba import njit

from bbdyn import Params
from bbdyn.core.billiard import (
    billiard_event,
    billiard_flight,
    collide,
    crossing_time,
    segment_gap_phase,
    tangent_departure,
    tile_offset,
)
from bbdyn.core.floor import arc_root
from bbdyn.core.fmath import fmax2, fmin2
from bbdyn.core.plate import advance_phase, sin_cos, stick_release
from bbdyn.core.search import flat_flight_tol, safe_step, time_above
from bbdyn.core.status import BAD_STATE, OK, RELEASE, ROOT_NOT_CONVERGED, STICK
from bbdyn.core.tolerances import DEPARTURE_REL_TOL, ROOT_MAX_STEPS, ROOT_STEP_REL
from bbdyn.ensemble import ensemble


@njit(cache=True)
def flight_rule(phase, xi0, vx, vyrel, kp, cubic):
    """The first contact from the phase and point alone: ``billiard_flight`` (``cubic``) or
    ``quadratic_flight``."""
    if cubic:
        return billiard_flight(phase, xi0, vx, vyrel, kp)
    sn, cs = sin_cos(phase)
    return quadratic_flight(phase, sn, cs, xi0, arc_root(xi0, kp), vx, vyrel, kp)


@njit(cache=True)
def event_rule(periods, phase, tile, xi, vx, vyrel, kind, kp, cubic):
    """``billiard_event`` (``cubic``), or its event with ``quadratic_flight`` as the search."""
    if cubic:
        return billiard_event(periods, phase, tile, xi, vx, vyrel, kind, kp)
    if kind == STICK:
        periods_r, phase_r, status = stick_release(periods, phase, kp)
        kind_r = RELEASE if status == OK else STICK
        return periods_r, phase_r, tile, xi, 0.0, 0.0, kind_r, status
    sn, cs = sin_cos(phase)
    tau, k, xi_c, vyrel_minus, _, status = quadratic_flight(
        phase, sn, cs, xi, arc_root(xi, kp), vx, vyrel, kp
    )
    if status != OK:
        return periods, phase, tile, xi, vx, vyrel, kind, status
    periods, phase = advance_phase(periods, phase, kp.w * tau)
    sn_c, cs_c = sin_cos(phase)
    nxt, status, _ = collide(periods, phase, sn_c, cs_c, tile + k, xi_c, vx, vyrel_minus, kp)
    return nxt.periods, nxt.phase, nxt.tile, nxt.xi, nxt.vx, nxt.vyrel, nxt.kind, status


@njit(cache=True)
def quadratic_flight(phase, sn, cs, xi0, S0, vx, vyrel, kp):
    """The first-contact search with the quadratic step rule: ``flight_search``'s safe steps
    from the global curvature bound M alone (``safe_step``), with no tiny hop, no Taylor
    finish and no upper-bound exit; the same arguments and returns."""
    d, R, w, g, M = kp.d, kp.R, kp.w, kp.g, kp.curv_bound
    half = 0.5 * d
    k_base = 0.0
    if vx > 0.0 and xi0 >= half:
        xi0 = -half
        k_base = 1.0
    elif vx < 0.0 and xi0 <= -half:
        xi0 = half
        k_base = -1.0
    if k_base != 0.0:
        S0 = arc_root(xi0, kp)
    inv_S0 = 1.0 / S0
    Gp = vyrel + vx * xi0 * inv_S0
    if abs(Gp) <= DEPARTURE_REL_TOL * (abs(vyrel) + abs(vx * xi0) * inv_S0):
        Gp = 0.0
    direction = 1.0 if vx > 0.0 else -1.0
    tau = 0.0
    k = 0.0
    G = 0.0
    lift = xi0 * xi0 / (R + S0)
    G_env = -lift
    G_envp = vyrel
    xi = xi0
    tc = crossing_time(xi0, k, vx, d)
    theta_r, theta_e = kp.release_r, kp.release_e
    if vx == 0.0 and theta_r < phase < theta_e:
        tau, vrel_minus, status, n_evals = flat_flight_tol(phase, vyrel, kp, ROOT_STEP_REL)
        return tau, k_base, xi0, vrel_minus, n_evals, status
    tau_up, tau_down = time_above(vyrel - kp.A * w * cs, kp.A * (1.0 + sn) + lift, g)
    if theta_r <= phase < theta_e:
        if Gp < 0.0:
            return 0.0, k_base, xi0, vyrel, 0, BAD_STATE
        tau = fmin2((theta_e - phase) / w, tc)
        if tau == tc:
            k += direction
    elif Gp == 0.0:
        tau = tangent_departure(sn, xi0, S0, vx, tc, kp)
        if tau == 0.0:
            return 0.0, k_base, xi0, vyrel, 0, BAD_STATE
        if tau == tc:
            k += direction
    elif not Gp > 0.0:
        return 0.0, k_base, xi0, vyrel, 0, BAD_STATE
    tc = fmax2(crossing_time(xi0, k, vx, d), tau)
    known = tau == 0.0
    for n in range(ROOT_MAX_STEPS):
        if not known:
            if tau_up < tau < tau_down:
                tau = tau_down
                k = tile_offset(xi0, vx, tau, d)
            G, Gp, G_env, G_envp, xi, _, _, _ = segment_gap_phase(
                tau, k, sn, cs, xi0, S0, vx, vyrel, kp
            )
            tc = fmax2(crossing_time(xi0, k, vx, d), tau)
        known = False
        if G <= 0.0 and tau > 0.0:
            return tau, k + k_base, xi, G_envp, n, OK
        s_tile = safe_step(G, Gp, M)
        if s_tile <= ROOT_STEP_REL * tau:
            return tau, k + k_base, xi, G_envp, n, OK
        s_env = safe_step(G_env, G_envp, M) if G_env > 0.0 else 0.0
        room = tc - tau
        if s_env > fmin2(s_tile, room):
            tau += s_env
            k = tile_offset(xi0, vx, tau, d)
        elif s_tile >= room:
            tau = tc
            k += direction
        else:
            tau += s_tile
    return tau, k + k_base, xi, G_envp, ROOT_MAX_STEPS, ROOT_NOT_CONVERGED


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
