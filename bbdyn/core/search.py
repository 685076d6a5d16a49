"""Search primitives shared by the flat ball's and the billiard's first-contact searches.

A search steps through a flight by *safe steps*: from a point with gap ``G > 0`` and rate
``G'``, a step before which a lower bound of the gap stays positive, so no contact is
passed (``flat.py`` and ``billiard.py`` derive their bounds).  ``safe_step`` is the step of
the quadratic bound (curvature ``M``), ``cubic_safe_step`` that of the cubic one (local
curvature ``m``, jerk ``K``); ``time_above`` the interval a free flight spends above a
height, which a search crosses without evaluating the gap.

``flat_flight_tol`` is the whole search over a flat floor (``flat.py`` describes its
guarantee): the flat ball's flight, and the billiard's wherever the floor's shape drops
out (``vx = 0`` on an arc's top, ``billiard.py``), with ``flat_gap_phase`` the gap it
evaluates.
"""

import math

from numba import njit

from bbdyn.core.fmath import fmin2
from bbdyn.core.plate import plate_dvel, plate_rise, sin_cos
from bbdyn.core.status import BAD_STATE, OK, ROOT_NOT_CONVERGED
from bbdyn.core.taylor import TilePoint, taylor_finish
from bbdyn.core.tolerances import EPS, FMA, ROOT_MAX_STEPS, ROOT_STEP_REL, TAYLOR_MAX_SPAN


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def safe_step(G, Gp, M):
    """Positive root of ``G + Gp s - M s^2 / 2 = 0`` (G >= 0, M > 0), without cancellation.

    At ``G = 0`` (a flight's start) the root is ``(Gp + |Gp|) / M`` with no square root:
    the same number, since the rounded square root of the rounded ``Gp^2`` is ``|Gp|``.
    """
    if G == 0.0:
        return (Gp + abs(Gp)) / M
    r = math.sqrt(Gp * Gp + 2.0 * M * G)
    if Gp >= 0.0:
        return (Gp + r) / M
    return 2.0 * G / (r - Gp)


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def cubic_safe_step(G, Gp, m, M, K):
    """A step s > 0 before which the gap cannot vanish, from its cubic Taylor bound.

    With ``m >= -G''`` at the current point, ``|G'''| <= K = A w^3`` and
    ``-G'' <= M`` everywhere,

        G(tau + s) >= G + G' s - m s^2 / 2 - K s^3 / 6 >= G + G' s - c s^2 / 2

    for ``0 <= s <= h`` with ``c = min(M, m + K h / 3)``.  Taking ``h`` the root
    for curvature ``m`` (an overestimate of the cubic's first root) and the step
    the root for ``c`` (``<= h`` because ``c >= m``) gives a safe step short of
    the cubic's first root by only ``O(K^2)``: near a transversal contact the
    error falls as ``e -> K e^3 / (3 |G'|)`` (cubic convergence from below).
    Where ``m <= 0`` it is the global quadratic step with ``M``.  Where the gap falls
    (``G' < 0``), ``h = G / |G'|`` bounds that root from above without its square root
    (``r = sqrt(G'^2 + 2 m G) >= |G'|`` in the root ``2 G / (r - G')``): one square root
    fewer on the search's chain, for a ``c`` larger by at most ``K G / (3 |G'|)``.
    """
    if not m > 0.0:
        h = math.inf
    elif Gp < 0.0:
        h = G / -Gp
    else:
        h = safe_step(G, Gp, m)
    return safe_step(G, Gp, fmin2(M, m + K * h * (1.0 / 3.0)))


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def time_above(v, height, g):
    """``(tau_up, tau_down)`` (s): when a particle leaving at ``v`` (mm/s, absolute) rises
    above ``height`` (mm, >= 0) over its start and falls back below it, ``y = v t - g t^2 /
    2``; ``(inf, -inf)`` if it never does."""
    disc = v * v - 2.0 * g * height
    if v > 0.0 and disc > 0.0:
        # (v -+ sqrt(disc)) / g, the smaller as 2 height / (v + sqrt(disc)) (no cancellation):
        # two divisions side by side, not one waiting for the other
        v_plus = v + math.sqrt(disc)
        return 2.0 * height / v_plus, v_plus / g
    return math.inf, -math.inf


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
            flat = TilePoint(0.0, kp.R, 0.0, math.inf)
            u, _, Gp_c, solved = taylor_finish(tau, G, Gp, Gp, sn, cn, flat, kp)
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
