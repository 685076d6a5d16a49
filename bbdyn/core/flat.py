"""Exact impact map of the flat bouncing ball (docs/model.md §1).

State between events: time as ``(periods, phase)`` with ``phase = w t mod 2 pi``,
and the *relative* velocity ``vrel = v - u`` of the particle with respect to the
plate just after the event.  Working with the relative velocity keeps tiny
bounces (chattering) accurate: the absolute velocity ``v = vrel + u`` would
lose ``|u| / vrel`` in relative precision.

Gap after an event at phase ``theta`` (``s0 = sin theta``, ``c0 = cos theta``),
with ``tau`` the time since the event (see ``plate.py`` for ``rise`` and ``dvel``):

    G(tau)  = vrel tau - g tau^2 / 2 - rise(tau)        (mm)
    G'(tau) = vrel - g tau - dvel(tau)                  (mm/s)
    G''     = -g - A w^2 sin(theta + w tau),  so  -G'' <= M = g + A w^2.

First contact (the guarantee).  From a point ``tau_a`` with ``G(tau_a) > 0``,
``m = -G''(tau_a)`` (free from the sin/cos already computed) and
``|G'''| <= K = A w^3``, the cubic Taylor bound
``G(tau_a + s) >= G + G' s - m s^2 / 2 - K s^3 / 6`` holds for every s, and so does
the global quadratic one with ``-G'' <= M``.  The search steps by a lower bound of
the first positive root of these bounds (``cubic_safe_step``, a "safe step") and
therefore never passes a contact; it also skips, in one jump and without
evaluating inside it, the interval where the particle is above the plate's
highest point ``+A``, and the interval where the plate accelerates downward faster
than g (``G'' > 0``: no contact can start there).  Near a transversal contact the
error falls as ``e -> K e^3 / (3 |G'|)`` (cubic convergence from below); at an
exactly tangential (grazing) contact it converges linearly.  The search stops
when the upper Taylor bound ``G + G' s - m s^2 / 2 + K s^3 / 6`` is already
negative ``ROOT_STEP_REL`` times the flight time after the next safe step (the
contact is then bracketed to that width, and G' there follows from its Taylor
series to below eps ``|G'|``, so that last evaluation is skipped), when the safe step
is below ``ROOT_STEP_REL`` times the flight time, or when rounding makes ``G <= 0``.
Once the gap falls and its Taylor polynomial provably holds the only contact within
reach, the contact is solved from it by Newton instead (``taylor.taylor_finish``, the
billiard's finish with no arc terms; ``flat_flight_tol``).  All bounds hold up to the
rounding of G, G', G'' (a few ulp of their terms).
Kernels use ``error_model="numpy"``: they never raise; a division by zero gives
inf or nan, which the statuses report.

Impact law: ``v+ - u = alpha (u - v-)``, i.e. ``vrel+ = -alpha vrel-``.

Chattering: after an impact with small ``vrel+`` the particle bounces ever
lower in the effective gravity ``g_eff = g + A w^2 sin theta > 0``.  To leading
order the flights are ``2 vrel_k / g_eff`` with ``vrel_k = alpha^k vrel+``, whose
sum accumulates after ``tau_inf = 2 vrel+ / (g_eff (1 - alpha))``.  The variation
of ``g_eff`` over ``tau_inf`` changes this by at most about
``(|dg_eff/dt| + |d^2 g_eff/dt^2| tau_inf) tau_inf^2 / g_eff``; when that estimate is
below ``CHATTER_REL_TOL`` periods (and ``g_eff`` stays positive over the interval),
the rest of the sequence is summed in closed form and the particle sticks.
Stuck, it rides the plate until ``sin(w t) < -1/Gamma`` (release, with the
plate's velocity, ``vrel = 0``); for Gamma <= 1 it never leaves.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from bbdyn.core.fmath import fmin2
from bbdyn.core.plate import (
    advance_phase,
    plate_dvel,
    plate_rise,
    sin_cos,
)
from bbdyn.core.search import cubic_safe_step, time_above
from bbdyn.core.status import (
    BAD_STATE,
    IMPACT,
    NON_FINITE,
    OK,
    RELEASE,
    ROOT_NOT_CONVERGED,
    STICK,
    STUCK_FOREVER,
)
from bbdyn.core.taylor import taylor_finish
from bbdyn.core.tolerances import (
    CHATTER_REL_TOL,
    EPS,
    FMA,
    ROOT_MAX_STEPS,
    ROOT_STEP_REL,
    TAYLOR_MAX_SPAN,
)


class FlatState(NamedTuple):
    """State of the flat ball just after an event."""

    periods: float  # whole driving periods
    phase: float  # w t mod 2 pi (rad)
    vrel: float  # velocity relative to the plate (mm/s)
    kind: int  # IMPACT, STICK or RELEASE


class FlatArrays(NamedTuple):
    """Arrays of a run's events, one row per event (``flat_run``; float64, kind int64)."""

    periods: np.ndarray
    phase: np.ndarray
    vrel: np.ndarray
    kind: np.ndarray


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def flat_gap_phase(vrel, g, A, w, s0, c0, tau):
    """Gap G (mm), its rate G' (mm/s), and sin, cos of the phase theta + w tau.

    The phase's sine and cosine come from the same sin/cos pair of ``x/2`` by the
    addition formulas; they give ``G'' = -g - A w^2 sin`` and
    ``G''' = -A w^3 cos`` at no further cost.
    """
    x = w * tau
    # one sin/cos pair of x/2 gives sin x, 1 - cos x = 2 sin^2(x/2) without cancellation
    sin_half, cos_half = sin_cos(0.5 * x)
    sin_x = 2.0 * sin_half * cos_half
    G = vrel * tau - 0.5 * g * tau * tau - plate_rise(A, s0, c0, x, sin_x, sin_half)
    Gp = vrel - g * tau - plate_dvel(A, w, s0, c0, sin_x, sin_half)
    cos_x = 1.0 - 2.0 * sin_half * sin_half
    return G, Gp, s0 * cos_x + c0 * sin_x, c0 * cos_x - s0 * sin_x


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def flat_gap(vrel, g, A, w, s0, c0, tau):
    """Gap G (mm) and its rate G' (mm/s) at ``tau`` after an event at phase theta."""
    G, Gp, _, _ = flat_gap_phase(vrel, g, A, w, s0, c0, tau)
    return G, Gp


@njit(cache=True, fastmath=FMA, forceinline=True, error_model="numpy")
def flat_flight_tol(phase, vrel, kp, step_rel):
    """``flat_flight`` with stopping tolerance ``step_rel``, and its gap evaluations.

    Parameters
    ----------
    phase, vrel, kp
        As in ``flat_flight``.
    step_rel : float
        Stopping tolerance relative to the flight time; ``ROOT_STEP_REL`` (2 eps)
        in ``flat_flight``.  The iterates do not depend on it: it only decides
        when the convergence from below stops, so a looser tolerance returns an
        earlier iterate of the same sequence, after fewer evaluations.  At
        ``ROOT_STEP_REL`` (and below) a descending flight ends, once provably
        possible, with ``taylor.taylor_finish`` (Newton on the gap's Taylor
        polynomial, within eps of the flight time, counted as one evaluation); a
        looser tolerance keeps to the safe steps.

    Returns
    -------
    (tau, vrel_minus, status, n_evals)
        As ``flat_flight``, and the number of gap evaluations (the search's cost
        independently of machine load).

    Notes
    -----
    With ``d = step_rel tau`` and ``M = g + A w^2``: no contact lies before the
    returned ``tau`` (safe steps, whatever ``step_rel``), and the gap there is
    below ``|G'| d + M d^2 / 2``.  At a transversal contact ``tau`` is early by
    at most ``d (1 + M d / |G'|)`` to first order (within ``d`` when the upper
    Taylor bound brackets the contact).  Near an exactly grazing contact the
    iterates converge linearly (``e -> (2 - sqrt 2) e``) and stop once the step
    ``(sqrt 2 - 1) e`` is below ``d``: early by up to ``(1 + sqrt 2) d`` to first
    order in ``w d`` (2.6 d measured at ``step_rel = 1e-2``).  ``vrel_minus`` is
    ``G'`` at ``tau``, off by at most ``M`` times the time error.  A near miss
    whose minimum gap is below about ``M d^2 / 2`` is reported as a contact;
    with the default ``d`` that is below the rounding of G, with a loose one it
    is a real, wrong contact.
    """
    A, w, g, M = kp.A, kp.w, kp.g, kp.curv_bound
    aw2 = A * w * w
    K = aw2 * w  # |G'''| <= A w^3
    L = K * w  # |G''''| <= A w^4
    # Rounding allowance on m = -G'': a few ulp of its terms keeps the lower bound a bound.
    m_pad = 4.0 * EPS * M
    s0, c0 = sin_cos(phase)
    n_evals = 0
    tau = 0.0
    G, Gp, sn, cn = 0.0, vrel, s0, c0
    if kp.release_r <= phase < kp.release_e:
        # G'' > 0 until release_e and G(0) = 0, G'(0) >= 0: no contact before release_e.
        if vrel < 0.0:
            return 0.0, vrel, BAD_STATE, n_evals
        tau = (kp.release_e - phase) / w
    elif not vrel > 0.0:
        return 0.0, vrel, BAD_STATE, n_evals

    # Interval in which the particle is above +A, the plate's highest point: no contact there.
    # +A minus the plate height -A s0 at the start is A (1 + s0) >= 0.
    tau_up, tau_down = time_above(vrel - A * w * c0, A + A * s0, g)
    if tau > 0.0:
        if tau_up < tau < tau_down:
            tau = tau_down
        G, Gp, sn, cn = flat_gap_phase(vrel, g, A, w, s0, c0, tau)
        n_evals += 1

    finish = step_rel <= ROOT_STEP_REL
    for _ in range(ROOT_MAX_STEPS):
        if G <= 0.0 and tau > 0.0:
            return tau, fmin2(Gp, 0.0), OK, n_evals
        if finish and Gp < 0.0 and w * G < -TAYLOR_MAX_SPAN * Gp:
            # the billiard's Taylor finish on the flat gap (xi = vx = 0: no arc terms)
            u, _, Gp_c, solved = taylor_finish(tau, G, Gp, Gp, sn, cn, 0.0, kp.R, 0.0, math.inf, kp)
            if solved:
                return tau + u, fmin2(Gp_c, 0.0), OK, n_evals + 1
        m = g + aw2 * sn
        step = cubic_safe_step(G, Gp, m + m_pad, M, K)
        if step <= step_rel * tau:
            return tau, fmin2(Gp, 0.0), OK, n_evals
        tau_next = tau + step
        if tau_up < tau_next < tau_down:
            tau_next = tau_down
        else:
            # Upper Taylor bound just past the step: if it is negative, the contact
            # lies within step_rel tau after tau_next, and G' there follows
            # from its own Taylor series (remainder <= A w^4 s^3 / 6, below eps G').
            s = step + step_rel * tau_next
            upper = G + s * (Gp - s * (0.5 * m - s * (K / 6.0)))
            if upper < 0.0 and L * step * step * step <= 6.0 * EPS * abs(Gp):
                Gp_next = Gp - step * (m + 0.5 * step * K * cn)
                return tau_next, fmin2(Gp_next, 0.0), OK, n_evals
        tau = tau_next
        G, Gp, sn, cn = flat_gap_phase(vrel, g, A, w, s0, c0, tau)
        n_evals += 1
    return tau, Gp, ROOT_NOT_CONVERGED, n_evals


@njit(cache=True, fastmath=FMA, forceinline=True, error_model="numpy")
def flat_flight(phase, vrel, kp):
    """Time to the first contact after an event, and the relative velocity there.

    Parameters
    ----------
    phase : float
        Phase w t (rad, in [0, 2 pi)) of the event that starts the flight.
    vrel : float
        Relative velocity v - u (mm/s) just after it; > 0, or >= 0 where the
        plate accelerates downward faster than g (a release).
    kp : KernelParams

    Returns
    -------
    tau : float
        Flight time (s), > 0.
    vrel_minus : float
        Relative velocity v - u just before the contact (mm/s), <= 0.
    status : int
        ``OK``, ``BAD_STATE`` (vrel <= 0 where the plate holds the particle) or
        ``ROOT_NOT_CONVERGED``.
    """
    tau, vrel_minus, status, _ = flat_flight_tol(phase, vrel, kp, ROOT_STEP_REL)
    return tau, vrel_minus, status


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def chatter_time(phase, vrel, kp):
    """Accumulation time (s) of the chattering sequence started with ``vrel`` at ``phase``.

    Returns ``inf`` when the closed-form sum is not yet accurate to
    ``CHATTER_REL_TOL`` periods, or when the plate does not hold the particle
    (``g_eff <= 0`` somewhere in the interval), or for ``alpha = 1``.
    """
    A, w, g, alpha = kp.A, kp.w, kp.g, kp.alpha
    M = kp.curv_bound
    # Necessary condition first, without sin/cos: g_eff <= M, so tau_inf >= 2 vrel / (M (1 - alpha))
    # and the error estimate below is at least A w^4 tau_inf^3 / g_eff.
    if alpha >= 1.0:
        return math.inf
    tol = CHATTER_REL_TOL * kp.period
    v2 = 2.0 * vrel / (M * (1.0 - alpha))
    if A * w * w * w * w * v2 * v2 * v2 > tol * M:
        return math.inf
    sin_p, cos_p = sin_cos(phase)
    g_eff = g + A * w * w * sin_p
    if g_eff <= 0.0:
        return math.inf
    tau_inf = 2.0 * vrel / (g_eff * (1.0 - alpha))
    # g_eff must stay positive over the interval: its rate is at most A w^3.
    if A * w * w * w * tau_inf >= 0.5 * g_eff:
        return math.inf
    dg = A * w * w * w * abs(cos_p) + A * w * w * w * w * tau_inf
    if dg * tau_inf * tau_inf > tol * g_eff:
        return math.inf
    return tau_inf


@njit(cache=True, fastmath=FMA, forceinline=True, error_model="numpy")
def stick_release(periods, phase, kp):
    """Time of the release that ends a stick at ``(periods, phase)`` (flat ball and billiard).

    The floor holds a particle resting on it while its acceleration is above -g,
    i.e. outside the release window ``theta_r <= theta < theta_e`` (``kp.release_r``,
    ``kp.release_e``).  A stick inside the window lasts zero time: the particle leaves
    at once, at ``phase``.  Before it, the particle leaves at ``theta_r`` of the same
    period; from ``theta_e`` on, at ``theta_r`` of the next one.  The flight that
    follows starts with the floor's velocity and is the release flight of
    ``flat_flight`` and ``billiard_flight``.

    Returns ``(periods, phase, status)`` of the release: whole periods, phase
    (rad) and ``OK``, or the stick's own time and ``STUCK_FOREVER`` for
    Gamma <= 1 (no window: it never leaves).
    """
    theta_r, theta_e = kp.release_r, kp.release_e
    if theta_r < 0.0:
        return periods, phase, STUCK_FOREVER
    if theta_r <= phase < theta_e:
        return periods, phase, OK
    if phase < theta_r:
        return periods, theta_r, OK
    return periods + 1.0, theta_r, OK


@njit(cache=True, fastmath=FMA, forceinline=True, error_model="numpy")
def flat_event(periods, phase, vrel, kind, kp):
    """Advance the flat ball from one event to the next.

    Parameters
    ----------
    periods, phase : float
        Time of the current event as whole driving periods and phase (rad).
    vrel : float
        Relative velocity v - u just after it (mm/s); 0 for STICK.
    kind : int
        IMPACT, STICK or RELEASE.
    kp : KernelParams

    Returns
    -------
    (periods, phase, vrel, kind, status) of the next event.  ``status`` is
    ``STUCK_FOREVER`` (state unchanged) for a stuck particle with Gamma <= 1.
    """
    if kind == STICK:
        periods_r, phase_r, status = stick_release(periods, phase, kp)
        if status != OK:
            return periods, phase, 0.0, STICK, status
        return periods_r, phase_r, 0.0, RELEASE, OK

    tau, vrel_minus, status = flat_flight(phase, vrel, kp)
    if status != OK:
        return periods, phase, vrel, kind, status
    periods, phase = advance_phase(periods, phase, kp.w * tau)
    vrel_plus = -kp.alpha * vrel_minus
    if not math.isfinite(vrel_plus):
        return periods, phase, vrel_plus, IMPACT, NON_FINITE
    if vrel_plus == 0.0:
        # alpha = 0 (or a contact at zero relative speed): stuck where the plate holds it
        if kp.g + kp.A * kp.w * kp.w * sin_cos(phase)[0] > 0.0:
            return periods, phase, 0.0, STICK, OK
        return periods, phase, 0.0, IMPACT, OK
    tau_inf = chatter_time(phase, vrel_plus, kp)
    if tau_inf < math.inf:
        periods, phase = advance_phase(periods, phase, kp.w * tau_inf)
        return periods, phase, 0.0, STICK, OK
    return periods, phase, vrel_plus, IMPACT, OK


@njit(cache=True, fastmath=FMA, error_model="numpy")
def flat_run(state, kp, n_events, out):
    """Iterate ``flat_event`` for ``n_events`` events from ``state``.

    Parameters
    ----------
    state : FlatState
        The start (taken as three floats and an integer ``kind``).
    kp : KernelParams
    n_events : int
        Events to run.
    out : FlatArrays or None
        Event ``i`` goes into row ``i`` of each array (in place; at least ``n_events``
        rows); None stores nothing (benchmarks, transients).

    Returns ``(state, n_done, status)``: the last event (at a failure, the failing step's
    result), the events done and the status; the run stops early at a failure or at
    ``STUCK_FOREVER``.
    """
    periods, phase, vrel, kind = float(state[0]), float(state[1]), float(state[2]), int(state[3])
    for i in range(n_events):
        periods, phase, vrel, kind, status = flat_event(periods, phase, vrel, kind, kp)
        if status != OK:
            return FlatState(periods, phase, vrel, kind), i, status
        if out is not None:
            out.periods[i] = periods
            out.phase[i] = phase
            out.vrel[i] = vrel
            out.kind[i] = kind
    return FlatState(periods, phase, vrel, kind), n_events, OK
