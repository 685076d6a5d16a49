"""The gap's Taylor polynomial over one arc, and the contacts solved from it.

Shared by the billiard's flights (``billiard.py``: ``tiny_hop`` and ``taylor_finish``) and
the flat ball's (``flat.py``: ``taylor_finish`` with ``xi = vx = 0``, where the arc's terms
vanish and the gap is the flat one).  The coefficients are those of ``tiny_hop``'s docstring
(``billiard.py``); the drive's terms of degree 5 and above are summed to degree 4, 8 or
TAYLOR_DEGREE (16), the lowest of these whose remainder is below eps of the rate
(``tail_terms``), by written-out Horner chains (``drive_tail``).
"""

import math
from typing import NamedTuple

from numba import njit

from bbdyn.core.fmath import clamp
from bbdyn.core.tolerances import (
    EPS,
    FMA,
    TAYLOR_DEGREE,
    TAYLOR_MAX_SPAN,
    TAYLOR_NEWTON_MAX,
    TAYLOR_NEWTON_REL,
)

#: Coefficients of the polynomials in ``z = y^2`` that make up the drive's tail
#: (``drive_tail``): ``(-1)^k / (2k + j)!`` for j = 4, 5, 6 and k = 0 .. 5.
_C4, _C5, _C6 = (tuple((-1) ** k / math.factorial(2 * k + j) for k in range(6)) for j in (4, 5, 6))
assert TAYLOR_DEGREE == 16  # drive_tail's Horner chains are written out to degree 16
#: 1 / N! for the degrees N = 4, 8, 16 that ``drive_tail`` offers.
_INV_4, _INV_8, _INV_16 = (1.0 / math.factorial(n) for n in (4, 8, 16))


class TilePoint(NamedTuple):
    """Where a flight is over its tile (``taylor_finish``); on a flat floor ``(0, R, 0,
    inf)``: the top of an arc that never ends."""

    xi: float  # the point over the tile, x - x_c (mm)
    S: float  # arc_root(xi) = sqrt(R^2 - xi^2) (mm, the caller's)
    vx: float  # horizontal velocity (mm/s)
    room: float  # time to the next tile crossing (s)


@njit(cache=True, fastmath=FMA, inline="always")
def tail_terms(aw, x, budget):
    """Terms per Horner chain of ``drive_tail``: 0, 2 or 6, the drive summed to degree
    ``N = 2 K + 4`` = 4, 8 or TAYLOR_DEGREE (16); the fewest whose remainder in the rate,
    ``A w x^N / N!`` over the span ``x = w u_max`` (rad; ``aw = A w``), is at most ``budget``
    (mm/s), or -1 if degree 16 leaves more.  The remainder in the gap is then at most
    ``u_max / (N + 1)`` times that (``|d^n/du^n A sin(theta + w u)| <= A w^n``).  Three
    degrees rather than the lowest sufficient one (benchmarks/flat_flights.py times the choices)."""
    x2 = x * x
    x4 = x2 * x2
    x8 = x4 * x4
    if aw * x4 * _INV_4 <= budget:
        return 0
    if aw * x8 * _INV_8 <= budget:
        return 2
    if aw * (x8 * x8) * _INV_16 <= budget:
        return 6
    return -1


@njit(cache=True, fastmath=FMA, inline="always")
def drive_tail(y, sn, cs, K):
    """``(T, T')`` to degree ``N = 2 K + 4`` (``K`` of ``tail_terms``): ``T = sum_{n=5..N}
    s_n y^(n-5) / n!``, ``T' = sum_{n=5..N} s_n y^(n-5) / (n-1)!`` with ``s_n =
    sin^(n)(theta)`` (``sn, cs`` its sine and cosine).  The drive's terms of degree >= 5 are
    ``A y^5 T`` in the gap and ``A w y^4 T'`` in its rate (``y = w u``).

    Split by the sign pattern of ``s_n`` (cos, -sin, -cos, sin, ...) into polynomials of ``z =
    y^2``, ``T = cos C5(z) - sin y C6(z)`` and ``T' = cos C4(z) - sin y C5(z)`` with ``Cj(z) =
    sum_{k<K} (-1)^k z^k / (2k + j)!``: three short Horner chains side by side, no loop.
    """
    if K == 0:
        return 0.0, 0.0
    z = y * y
    sy = sn * y
    if K == 2:
        c4 = _C4[0] + z * _C4[1]
        c5 = _C5[0] + z * _C5[1]
        c6 = _C6[0] + z * _C6[1]
        return cs * c5 - sy * c6, cs * c4 - sy * c5
    c4 = _C4[0] + z * (_C4[1] + z * (_C4[2] + z * (_C4[3] + z * (_C4[4] + z * _C4[5]))))
    c5 = _C5[0] + z * (_C5[1] + z * (_C5[2] + z * (_C5[3] + z * (_C5[4] + z * _C5[5]))))
    c6 = _C6[0] + z * (_C6[1] + z * (_C6[2] + z * (_C6[3] + z * (_C6[4] + z * _C6[5]))))
    return cs * c5 - sy * c6, cs * c4 - sy * c5


@njit(cache=True, fastmath=FMA, inline="always")
def gap_coefficients(sn, cs, xi, S, vx, kp):
    """Taylor coefficients of degree 2 to 4 of the gap over one arc (see ``tiny_hop``).

    At phase theta (``sn, cs``) and ``xi`` (mm, ``S = sqrt(R^2 - xi^2)``) with horizontal
    velocity ``vx`` (mm/s): returns ``(F_2, g_2, g_3, g_4)``, ``g_n = F_n + B_n`` (mm/s^n).
    """
    A, w, R = kp.A, kp.w, kp.R
    aw2 = A * w * w
    F2 = -kp.g - aw2 * sn
    if vx == 0.0:  # no arc terms (the flat ball, a release): the same numbers, no division
        return F2, F2, -aw2 * w * cs, aw2 * w * w * sn
    R2 = R * R
    inv_S = 1.0 / S
    S3 = inv_S * inv_S * inv_S
    S5 = S3 * inv_S * inv_S
    vx2 = vx * vx
    g2 = F2 + R2 * vx2 * S3
    g3 = -aw2 * w * cs + 3.0 * R2 * xi * vx2 * vx * S5
    g4 = aw2 * w * w * sn + 3.0 * R2 * (R2 + 4.0 * xi * xi) * vx2 * vx2 * S5 * inv_S * inv_S
    return F2, g2, g3, g4


@njit(cache=True, fastmath=FMA, inline="always")
def gap_jerk_bound(vx, kp):
    """Bound (mm/s^3) of the gap's third derivative on a tile: ``A w^3 + 3 R^2 h |vx|^3 /
    c0^5`` (h = d/2)."""
    if vx == 0.0:
        return kp.A * kp.w**3
    c0 = kp.c0
    c0_2 = c0 * c0
    avx = abs(vx)
    return kp.A * kp.w**3 + 3.0 * kp.R**2 * 0.5 * kp.d * avx * avx * avx / (c0_2 * c0_2 * c0)


@njit(cache=True, fastmath=FMA, inline="always")
def arc_remainder(vx, u, kp):
    """Bound (mm) of the arc's part of the gap's Taylor remainder after degree 4 over ``u``
    seconds: ``C5 |vx|^5 u^5 / 5!`` (``C5 = kp.arc5_bound``, see ``tiny_hop``)."""
    vu = abs(vx) * u
    return kp.arc5_bound * vu * vu * vu * vu * vu * (1.0 / 120.0)


@njit(cache=True, fastmath=FMA, inline="always")
def gap_series(t, G, Gp, g2, g3, g4, sn, cs, K, kp):
    """The gap's Taylor polynomial (mm) and its rate (mm/s) ``t`` s after a point where they
    are ``G, Gp``: ``G + Gp t + g_2 t^2/2 + g_3 t^3/6 + g_4 t^4/24 + A y^5 T`` and its
    derivative (``y = w t``, ``T`` of ``drive_tail`` with K terms; see ``tiny_hop``)."""
    A, w = kp.A, kp.w
    y = w * t
    T, Tp = drive_tail(y, sn, cs, K)
    y4 = y * y * y * y
    c2, c3, c4 = 0.5 * g2, g3 * (1.0 / 6.0), g4 * (1.0 / 24.0)
    P = G + t * (Gp + t * (c2 + t * (c3 + t * c4))) + A * y4 * y * T
    dP = Gp + t * (g2 + t * (3.0 * c3 + t * (4.0 * c4))) + A * w * y4 * Tp
    return P, dP


@njit(cache=True, fastmath=FMA, inline="always")
def series_rate(t, Fp, F2, sn, cs, A, w, K):
    """The rate ``F'`` (mm/s) ``t`` s after a point where it is ``Fp``, from its series:
    ``Fp + F_2 t + A w (-cos y^2 / 2 + sin y^3 / 6) + A w y^4 T'`` (``y = w t``, ``T'`` of
    ``drive_tail`` with K terms; the arc has no part in it)."""
    y = w * t
    Tp = drive_tail(y, sn, cs, K)[1]
    y2 = y * y
    return Fp + F2 * t + A * w * y2 * (-0.5 * cs + y * (sn * (1.0 / 6.0)) + y2 * Tp)


@njit(cache=True, fastmath=FMA, inline="always")
def taylor_finish(tau, G, Gp, Fp, sn, cs, point, kp):
    """The contact of a descending flight from the Taylor polynomial of its gap.

    ``tau`` s into a flight the gap is ``G > 0`` (mm) and falls, ``Gp = G' < 0`` (mm/s);
    ``sn, cs`` are the sine and cosine of the phase reached, ``point`` the ``TilePoint``
    reached, ``Fp = F'`` (mm/s).  Over ``u`` more seconds, with ``g_n`` of
    ``gap_coefficients`` there (see ``tiny_hop``),

        G(tau + u) = G + Gp u + g_2 u^2/2 + g_3 u^3/6 + g_4 u^4/24
                     + A sum_{n=5..N} s_n (w u)^n / n! + r(u).

    Accepted only if, up to ``u_max`` (``w u_max < TAYLOR_MAX_SPAN``):

    * the particle stays on the tile (``u_max < room``), and ``u_max <= tau``;
    * G keeps falling, so that the contact is the only root and lies before u_max
      (``G(u_max) <= G + G'_max u_max < 0``), with ``K3`` of ``gap_jerk_bound``: where G is
      concave up to the tangent line's landing ``u0 = G / |Gp|`` (``g_2 + K3 u0 <= 0``),
      ``u_max = u0`` and ``G' <= G'_max = Gp``; elsewhere ``u_max = 2 u0`` and ``G' <= Gp +
      u_max (g_2 + K3 u_max) = G'_max <= Gp / 2``;
    * the remainder moves it by less than eps tau (the safe-step search stops at
      ``ROOT_STEP_REL`` tau): N = 4, 8 or 16 (``tail_terms``) puts the drive's remainder
      in the rate below eps ``|G'_max|`` (the root moves by less than eps u_max / 5), the
      arc's is below eps ``|G'_max|`` tau / 2.

    Newton from the root of ``G + Gp u + g_2 u^2 / 2`` where ``g_2 < 0`` (in ``(0, u0]``,
    ``u0 = G / |Gp|``, and closer to the contact: fewer Newton steps), else from ``u0``.
    Returns ``(u, xi_c, F'_c, ok)``: time to the contact (s), its coordinate (mm), the
    vertical velocity relative to the floor there (mm/s); ``ok = False`` when a condition
    fails (the search then goes on with safe steps).
    """
    A, w = kp.A, kp.w
    xi, S, vx, room = point
    aw = A * w
    fail = (0.0, xi, Fp, False)
    u0 = G / -Gp
    if not (w * u0 < TAYLOR_MAX_SPAN and u0 < room and u0 <= tau):
        return fail
    F2, g2, g3, g4 = gap_coefficients(sn, cs, xi, S, vx, kp)
    K3 = gap_jerk_bound(vx, kp)
    if g2 + K3 * u0 <= 0.0:
        # concave up to u0: G' <= Gp there, so G(u0) < 0 and the contact is its only root
        u_max = u0
        slope = -Gp
    else:
        u_max = 2.0 * u0
        slope = -(Gp + u_max * (g2 + K3 * u_max))  # |G'| >= slope on [0, u_max]
        if not (w * u_max < TAYLOR_MAX_SPAN and u_max < room and u_max <= tau):
            return fail
        if not slope >= -0.5 * Gp:
            return fail
    x = w * u_max
    K = tail_terms(aw, x, EPS * slope)
    if not (K >= 0 and arc_remainder(vx, u_max, kp) <= 0.5 * EPS * slope * tau):
        return fail
    # the quadratic's root (no cancellation: Gp < 0), closer than u0 by O(g_3 u^3)
    t = 2.0 * G / (math.sqrt(Gp * Gp - 2.0 * g2 * G) - Gp) if g2 < 0.0 else u0
    for _ in range(TAYLOR_NEWTON_MAX):
        P, dP = gap_series(t, G, Gp, g2, g3, g4, sn, cs, K, kp)
        step = P / dP
        t -= step
        # the error Newton leaves, |P'' / 2 P'| step^2 with |P''| <= |g_2| + K3 t: negligible
        if step * step * (abs(g2) + K3 * abs(t)) <= TAYLOR_NEWTON_REL * (tau + t) * abs(dP):
            break
    else:
        return fail
    if not 0.0 < t < u_max:
        return fail
    half = 0.5 * kp.d
    xi_c = clamp(xi + vx * t, -half, half)
    return t, xi_c, series_rate(t, Fp, F2, sn, cs, A, w, K), True
