"""Search primitives shared by the flat ball's and the billiard's first-contact searches.

A search steps through a flight by *safe steps*: from a point with gap ``G > 0`` and rate
``G'``, a step before which a lower bound of the gap stays positive, so no contact is
passed (``flat.py`` and ``billiard.py`` derive their bounds).  ``safe_step`` is the step of
the quadratic bound (curvature ``M``), ``cubic_safe_step`` that of the cubic one (local
curvature ``m``, jerk ``K``); ``time_above`` the interval a free flight spends above a
height, which a search crosses without evaluating the gap.
"""

import math

from numba import njit

from bbdyn.core.fmath import fmin2
from bbdyn.core.tolerances import FMA


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
