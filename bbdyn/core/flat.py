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
billiard's finish with no arc terms; ``search.flat_flight_tol``).  All bounds hold up to the
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

from bbdyn.core.plate import (
    advance_phase,
    sin_cos,
    stick_release,
)
from bbdyn.core.search import flat_flight_tol
from bbdyn.core.status import (
    IMPACT,
    NON_FINITE,
    OK,
    RELEASE,
    STICK,
)
from bbdyn.core.tolerances import (
    CHATTER_REL_TOL,
    FMA,
    ROOT_STEP_REL,
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
