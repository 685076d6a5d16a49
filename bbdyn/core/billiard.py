"""Exact event-driven dynamics of the bouncing ball billiard (docs/model.md §2).

State after an event: time as ``(periods, phase)`` (``phase = w t mod 2 pi``);
position as ``(tile, xi)`` (``tile`` an integer-valued float, ``xi = x - x_c`` in
[-d/2, d/2]); the particle is on the floor, ``y = y_p(t) + b(xi)`` (``floor.py``);
``vx`` its horizontal velocity and ``vyrel = vy - u(t)`` its vertical velocity
relative to the floor (relative velocities keep tiny bounces accurate, see
``flat.py``); ``kind`` in {IMPACT, STICK, RELEASE}.

The ladder, one function per rung: ``flight_search`` (first contact; ``flight_gap`` is
the gap at a time) -> ``collide`` (restitution, wedge rule, chattering) -> ``event_search``
(a flight and its collision, or a release by ``plate.stick_release``).  The rungs take and
return the event state as an ``EventState`` and carry the sine and cosine of its phase and
the arc root of its point as a ``Trig`` (computed once per event); ``billiard_event`` and
``billiard_flight`` compute the ``Trig`` themselves.

Gap.  After an event at phase theta and ``xi0``, with ``tau`` the time since it,

    G(tau) = vyrel tau - g tau^2/2 - rise(tau) - [b(xi(tau)) - b(xi0)]      (mm)

with ``xi(tau) = xi0 + vx tau`` shifted by -+d at each tile crossing (crossing
times are analytic).  At a crossing ``G`` is continuous but ``G'`` drops by
``d |vx| / c0`` (the wedge is a valley: a concave kink), so a step is capped at
the crossing and the bound restarted there with the right derivative.  The
floor is never above ``y_p + h``, so the *envelope gap* ``G_env = G - (h -
b(xi))`` (the floor replaced by the plane ``y_p + h``, i.e. the flat ball's gap
minus a constant) is a lower bound of ``G`` with no kinks: its safe steps may
jump over many tiles.  Each step is the larger of the envelope step and the
tile step capped at the crossing.  The interval in which the particle is above
``A + h`` (the floor's highest point ever) is skipped analytically: a step ending
inside it goes on to its end before the gap is evaluated.

Safe steps (the lower bound).  Within one tile segment ``G`` is smooth and

    -G''(tau) = g + A w^2 sin(theta + w tau) + b''(xi) vx^2 <= g + A w^2 sin(theta + w tau)

because the arc is a cap (``b'' < 0``, so ``b'' vx^2 <= 0``); for ``G_env`` the
same holds with equality (no arc term), on every tile.  The right side is at most
``M = g + A w^2`` and changes at most at the rate ``K = A w^3``, so from a point
``tau_a`` with ``m = g + A w^2 sin(theta + w tau_a)`` (the sine comes free from
the gap's evaluation; ``m`` is padded by a few ulp of M for rounding)
``-G''(tau_a + u) <= min(M, m + K u)``.  Integrating twice from ``tau_a``,

    G(tau_a + s) >= G + G' s - m s^2/2 - K s^3/6   and   G(tau_a + s) >= G + G' s - M s^2/2

up to the next tile crossing (for ``G_env``: for every s), with ``G, G'`` the
values at ``tau_a`` (right derivative after a crossing).  ``cubic_safe_step``
(``search.py``) returns an ``s`` before which one of these lower bounds stays
positive, never shorter than the quadratic step with M.  A tile step is capped
at the crossing, where the bound is restarted; an envelope step needs no cap.

Guarantee: every step ends at a time before which a lower bound of ``G`` is
positive, so the first contact is never skipped, whatever the number of tiles
crossed; the search stops when the tile step is below ``ROOT_STEP_REL`` times
the flight time (the contact time is then known to a few ulp), when rounding
makes ``G <= 0``, or when the *upper* Taylor bound is already
negative ``ROOT_STEP_REL`` times the flight time after a tile step, still on the
tile: with ``-G'' >= g + A w^2 sin - K u - R^2 vx^2 / c0^3`` (``-b''`` is
largest at the wedges, ``S = c0``) the contact is then bracketed to that width
and the step's end is returned without evaluating there (``F'`` from its Taylor
series, remainder ``A w^4 s^3 / 6`` below eps ``|F'|``, as in ``flat.py``).
Near a transversal contact the cubic step converges cubically from below
(``flat.py``), so flights whose quadratic steps crawl (``m << M``: the floor
accelerating downward, the 50 Hz chatter hops) need few steps.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from bbdyn.core.floor import arc_root, bounce, bounce_at, floor_drop
from bbdyn.core.fmath import clamp, fmax2, fmin2
from bbdyn.core.plate import advance_phase, release_window, sin_cos, stick_release_in
from bbdyn.core.search import (
    cubic_safe_step,
    flat_flight_tol,
    flat_gap_phase,
    time_above,
)
from bbdyn.core.status import (
    BAD_STATE,
    IMPACT,
    NON_FINITE,
    OK,
    RELEASE,
    ROOT_NOT_CONVERGED,
    STICK,
)
from bbdyn.core.taylor import (
    TilePoint,
    arc_remainder,
    gap_coefficients,
    gap_jerk_bound,
    gap_series,
    series_rate,
    tail_terms,
    taylor_finish,
)
from bbdyn.core.tolerances import (
    CHATTER_REL_TOL,
    DEPARTURE_MARGIN,
    DEPARTURE_MAX_TRIES,
    DEPARTURE_REL_TOL,
    DEPARTURE_SHRINK,
    EPS,
    FMA,
    ROOT_MAX_STEPS,
    ROOT_STEP_REL,
    SERIES_MAX_TERMS,
    TAYLOR_MAX_SPAN,
    TAYLOR_NEWTON_MAX,
    TAYLOR_NEWTON_REL,
    WEDGE_MAX_REFLECTIONS,
    WEDGE_TOL,
)


class EventState(NamedTuple):
    """State just after an event (see the module docstring)."""

    periods: float  # whole driving periods
    phase: float  # w t mod 2 pi (rad)
    tile: float  # tile index (integer-valued)
    xi: float  # mm from the tile centre, in [-d/2, d/2]
    vx: float  # horizontal velocity (mm/s)
    vyrel: float  # vertical velocity relative to the floor (mm/s)
    kind: int  # IMPACT, STICK or RELEASE


class EventArrays(NamedTuple):
    """Arrays of a run's events, one row per event (``billiard_run``; float64, kind int64)."""

    periods: np.ndarray
    phase: np.ndarray
    tile: np.ndarray
    xi: np.ndarray
    vx: np.ndarray
    vyrel: np.ndarray
    kind: np.ndarray


class Trig(NamedTuple):
    """What an event loop carries from one event to the next (``event_trig``)."""

    sn: float  # sin(phase)
    cs: float  # cos(phase)
    S: float  # arc_root(xi) (mm)


@njit(cache=True, fastmath=FMA, inline="always")
def crossing_time(xi0, k, vx, d):
    """Time (s) at which a flight from ``xi0`` leaves tile offset ``k``; inf for vx = 0."""
    if vx > 0.0:
        return ((k + 0.5) * d - xi0) / vx
    if vx < 0.0:
        return ((k - 0.5) * d - xi0) / vx
    return math.inf


@njit(cache=True, fastmath=FMA, inline="always")
def tile_offset(xi0, vx, tau, d):
    """Tile offset (integer-valued float) of the point reached at ``tau`` from ``xi0``.

    A point on a wedge belongs to the tile the particle is moving into: the left one
    for ``vx < 0`` (a flight leaving a wedge by less than its rounding stays there).
    """
    pos = (xi0 + 0.5 * d + vx * tau) / d
    if vx < 0.0:
        return math.ceil(pos) - 1.0
    return math.floor(pos)


@njit(cache=True, fastmath=FMA, inline="always")
def tilted_tile_offset(xi0, vx, at, tau, d):
    """``tile_offset`` of a tilted flight, ``xi(tau) = xi0 + vx tau + at tau^2 / 2``.

    The wedge rule uses the sign of the velocity ``vx + at tau`` reached at ``tau``.
    """
    pos = (xi0 + 0.5 * d + tau * (vx + 0.5 * at * tau)) / d
    if vx + at * tau < 0.0:
        return math.ceil(pos) - 1.0
    return math.floor(pos)


@njit(cache=True, fastmath=FMA, inline="always")
def tile_at(xi0, vx, tau, kp):
    """Tile offset reached at ``tau``: ``tile_offset``, or ``tilted_tile_offset`` for g_t != 0."""
    if kp.g_t == 0.0:
        return tile_offset(xi0, vx, tau, kp.d)
    return tilted_tile_offset(xi0, vx, kp.g_t, tau, kp.d)


@njit(cache=True, fastmath=FMA, inline="always")
def exit_root(c, vx, at, right):
    """Root of ``at tau^2 / 2 + vx tau + c = 0`` at which ``vx + at tau = +sq`` (``right``) or
    ``-sq`` (left), ``sq = sqrt(vx^2 - 2 at c)``: the time a parabolic motion passes the level
    ``-c`` upwards (right) or downwards (left); inf if it never does.

    Written without cancellation: ``-2 c / (vx + sq)`` for the right root, ``2 c / (sq - vx)``
    for the left one, and ``(+-sq - vx) / at`` where that denominator vanishes.
    """
    disc = vx * vx - 2.0 * at * c
    if not disc > 0.0:  # never reached, or touched at the turning point: no crossing
        return math.inf
    sq = math.sqrt(disc)
    if right:
        den = vx + sq
        if den > 0.0:
            return -2.0 * c / den
        return (sq - vx) / at if at != 0.0 else math.inf
    den = sq - vx
    if den > 0.0:
        return 2.0 * c / den
    return (-sq - vx) / at if at != 0.0 else math.inf


@njit(cache=True, fastmath=FMA, inline="always")
def tilted_crossing(xi0, k, vx, at, tau, d):
    """Next time (s) at or after ``tau`` at which a tilted flight leaves tile offset ``k``.

    The flight is ``xi(t) = xi0 + vx t + at t^2 / 2`` (it may turn around).  It leaves
    through the right wedge ``(k + 1/2) d`` only moving right and through the left one only
    moving left (``exit_root``); a parabola passes each level at most once each way, so the
    first such root at or after ``tau`` is the exit, and the root at which the particle
    entered the tile (the other way) is never taken for it.  Returns ``(tc, direction)``,
    ``direction`` = +1 or -1 the side it leaves by (``tc = inf`` if it never does).
    """
    t_right = exit_root(xi0 - (k + 0.5) * d, vx, at, True)
    t_left = exit_root(xi0 - (k - 0.5) * d, vx, at, False)
    if not t_right >= tau:
        t_right = math.inf
    if not t_left >= tau:
        t_left = math.inf
    if t_left < t_right:
        return t_left, -1.0
    return t_right, 1.0


@njit(cache=True, fastmath=FMA, inline="always")
def tilted_window(xi0, S0, vx, kp):
    """Release window ``(theta_r, theta_e)`` (rad) of a tilted floor at ``xi0`` (docs/model.md,
    "Tilt").

    Resting at ``xi0`` (``vx = 0``) the normal force vanishes when ``g + A w^2 sin(phase) =
    g_t xi0 / S0`` (``g`` the normal component): the window of ``Gamma = A w^2 / (g - g_t
    xi0 / S0)``.  After a start with ``vx = 0`` the particle moves towards ``g_t``, so ``g_t
    xi / S`` only grows and ``G'' > 0`` in that window on the tile.  For ``vx != 0`` the
    window is that of ``Gamma = A w^2 / (g + tilt_curv)``, in which ``G'' > 0`` everywhere.
    """
    aw2 = kp.A * kp.w * kp.w
    if vx == 0.0:
        return release_window(aw2 / (kp.g - kp.g_t * xi0 / S0))
    return release_window(aw2 / (kp.g + kp.tilt_curv))


@njit(cache=True, fastmath=FMA, inline="always")
def segment_gap_phase(tau, k, phase_sin, phase_cos, xi0, S0, vx, vyrel, kp):
    """``segment_gap`` and the sine and cosine of the phase reached at ``tau``.

    Returns ``(G, G', G_env, F', xi, S, sin, cos)`` with ``S = arc_root(xi)`` (mm); the
    phase's sine and cosine come free from the gap's own evaluation (``flat_gap_phase``) and
    give the local curvature bound ``g + A w^2 sin`` of the cubic safe step.
    """
    half = 0.5 * kp.d
    F, Fp, sn, cn = flat_gap_phase(vyrel, kp.g, kp.A, kp.w, phase_sin, phase_cos, tau)
    if kp.g_t == 0.0:
        dx = vx * tau - k * kp.d
        vx_tau = vx
    else:  # tilted: xi moves on a parabola
        dx = tau * (vx + 0.5 * kp.g_t * tau) - k * kp.d
        vx_tau = vx + kp.g_t * tau
    xi = clamp(xi0 + dx, -half, half)
    S = arc_root(xi, kp)
    G = F + floor_drop(dx, xi0, xi, S0, S)
    Gp = Fp + vx_tau * xi / S
    G_env = F - xi0 * xi0 / (kp.R + S0)  # h - b(xi0) = xi0^2 / (R + S0)
    return G, Gp, G_env, Fp, xi, S, sn, cn


@njit(cache=True, fastmath=FMA, inline="always")
def segment_gap(tau, k, phase_sin, phase_cos, xi0, S0, vx, vyrel, kp):
    """Gap and rates at ``tau`` with the particle over tile offset ``k``.

    Returns ``(G, G', G_env, F', xi)``: the gap to the arc (mm), its right
    derivative on tile ``k`` (mm/s), the envelope gap to the plane ``y_p + h``,
    its derivative ``F' = vyrel - g tau - dvel(tau)`` (also the vertical velocity
    relative to the floor) and the local coordinate reached (clamped to the tile).
    """
    G, Gp, G_env, Fp, xi, _, _, _ = segment_gap_phase(
        tau, k, phase_sin, phase_cos, xi0, S0, vx, vyrel, kp
    )
    return G, Gp, G_env, Fp, xi


@njit(cache=True, fastmath=FMA)
def flight_gap(phase, xi0, vx, vyrel, tau, kp):
    """Gap (mm) between the particle and the floor under it, ``tau`` s after an event.

    Independent of the search's bookkeeping (the tile is found from the
    position), for checks: ``G >= 0`` during a flight, ``G = 0`` at its end.
    """
    k = tile_at(xi0, vx, tau, kp)
    S0 = arc_root(xi0, kp)
    sn, cs = sin_cos(phase)
    G = segment_gap(tau, k, sn, cs, xi0, S0, vx, vyrel, kp)[0]
    return G


@njit(cache=True, fastmath=FMA, inline="always")
def tangent_departure(sn, xi0, S0, vx, tc, kp):
    """A time (s) up to which a flight leaving tangentially (G(0) = G'(0) = 0) stays clear.

    With ``G''(0) = -g - A w^2 sin(theta) + R^2 vx^2 / S0^3 > 0`` (the convex arc
    falls away faster than the particle), ``G(tau) >= G''(0) tau^2/2 - J tau^3/6``
    with ``J = A w^3 + 3 R^2 |xi|_max |vx|^3 / S_min^5`` bounding ``|G'''|`` on the tile
    segment; the returned ``tau <= tc`` has ``J tau < DEPARTURE_MARGIN G''(0)`` (1.5), hence
    ``G > 0`` for 0 < t <= tau.  Returns 0 if ``G''(0) <= 0`` (it cannot leave).
    """
    A, w, R, g_t = kp.A, kp.w, kp.R, kp.g_t
    half = 0.5 * kp.d
    G2 = -kp.g - A * w * w * sn + R * R * vx * vx / (S0 * S0 * S0)
    if g_t != 0.0:
        G2 += g_t * xi0 / S0  # -b'(xi0) g_t
    if not G2 > 0.0:
        return 0.0
    tau = tc if tc < math.inf else 1.0 / w
    for _ in range(DEPARTURE_MAX_TRIES):
        if g_t == 0.0:
            xm = fmin2(fmax2(abs(xi0), abs(xi0 + vx * tau)), half)
            Sm = arc_root(xm, kp)
            J = A * w * w * w + 3.0 * R * R * xm * abs(vx) ** 3 / Sm**5
        else:
            # |xi'| <= v and |xi| <= xm on [0, tau]; the jerk gains -3 b'' xi' g_t
            v = abs(vx) + abs(g_t) * tau
            xm = fmin2(abs(xi0) + tau * (abs(vx) + 0.5 * abs(g_t) * tau), half)
            Sm = arc_root(xm, kp)
            J = A * w * w * w + 3.0 * R * R * (xm * v**3 / Sm**5 + v * abs(g_t) / Sm**3)
        if J * tau < DEPARTURE_MARGIN * G2:
            return tau
        tau = fmin2(0.5 * tau, DEPARTURE_SHRINK * G2 / J)
    return 0.0


@njit(cache=True, fastmath=FMA, inline="always")
def tangent_rate(xi0, S0, vx, vyrel):
    """The gap's rate ``G'(0) = vyrel + vx xi0 / S0 = R V.n / S0`` (mm/s) of a flight from
    ``xi0`` (``S0 = arc_root(xi0)``), and whether it is 0 within the rounding of its terms
    (``DEPARTURE_REL_TOL``): a tangent departure, which must not count as leaving."""
    inv_S0 = 1.0 / S0
    Gp = vyrel + vx * xi0 * inv_S0
    return Gp, abs(Gp) <= DEPARTURE_REL_TOL * (abs(vyrel) + abs(vx * xi0) * inv_S0)


@njit(cache=True, fastmath=FMA, inline="always")
def tiny_hop(sn, cs, xi0, S0, vx, vyrel, Gp, kp):
    """A short hop on one arc, solved from the Taylor polynomial of its gap (chattering).

    From an impact at phase theta (``sn, cs`` its sine and cosine) at ``xi0`` (``S0 =
    sqrt(R^2 - xi0^2)``) with gap rate ``Gp = G'(0) > 0``, the gap over the tile is

        G(tau) = sum_{n=1..N} g_n tau^n / n! + r(tau),   g_n = F_n + B_n,
        F_1 = vyrel, F_2 = -g - A w^2 sin, F_n = A w^n sin^(n)(theta) for n >= 3
        (the flat gap: F_3 = -A w^3 cos, F_4 = A w^4 sin, F_5 = A w^5 cos, ...),
        B_1 = vx xi0 / S0, B_2 = R^2 vx^2 / S0^3, B_3 = 3 R^2 xi0 vx^3 / S0^5,
        B_4 = 3 R^2 (R^2 + 4 xi0^2) vx^4 / S0^7, B_n = 0 for n >= 5  (the arc, b(xi0) - b(xi))

    with ``|r| <= A w^(N+1) tau^(N+1) / (N+1)! + C5 |vx|^5 tau^5 / 5!``, ``C5 = 15 R^2 h (3
    R^2 + 4 h^2) / c0^9`` (``kp.arc5_bound``) bounding the fifth derivative of S on the tile
    (h = d/2).  Accepted only if, up to ``tau_max = 2 tau_0`` (``tau_0 = -2 g_1 / g_2``, the
    parabola's hop):

    * the particle stays on the tile and ``G'' <= g_2 + K3 tau_max < 0``, with ``K3`` bounding
      the third derivative (``gap_jerk_bound``): G is concave, so its only root in ``(0,
      tau_max]`` is the contact (``G(tau_max) < 0`` follows from the same bound);
    * the remainder moves that root by less than eps tau_0: N = 4, 8 or 16 (``tail_terms``)
      puts the drive's remainder in the rate below eps g_1 (in the gap below 0.4 eps g_1
      tau_0), and
      the arc's is below eps g_1 tau_0 / 2.

    The root of ``G / tau`` (no root at 0, no cancellation) is then found by Newton from
    tau_0.  Returns ``(tau, xi, vyrel_minus, ok)``: flight time (s), contact coordinate
    (mm), vertical velocity relative to the floor there (mm/s, ``F'`` from its series);
    ``ok = False`` when any condition fails (the caller then searches with safe steps).
    """
    A, w, half = kp.A, kp.w, 0.5 * kp.d
    aw = A * w
    F2, g2, g3, g4 = gap_coefficients(sn, cs, xi0, S0, vx, kp)
    fail = (0.0, xi0, vyrel, False)
    if not g2 < 0.0:
        return fail
    tau0 = -2.0 * Gp / g2
    tau_max = 2.0 * tau0
    x = w * tau_max
    if not (x < TAYLOR_MAX_SPAN and abs(xi0 + vx * tau_max) < half):
        return fail
    K3 = gap_jerk_bound(vx, kp)
    K = tail_terms(aw, x, EPS * Gp)
    if not (K >= 0 and g2 + K3 * tau_max < 0.0):
        return fail
    if not arc_remainder(vx, tau_max, kp) <= 0.5 * EPS * Gp * tau0:
        return fail
    # Newton on Q = G / tau (polynomial: Q = P / tau), Q' = (G' - Q) / tau
    q2, q3 = g3 * (1.0 / 6.0), g4 * (1.0 / 24.0)
    t = tau0
    for _ in range(TAYLOR_NEWTON_MAX):
        P, dG = gap_series(t, 0.0, Gp, g2, g3, g4, sn, cs, K, kp)
        # Q = P / t, t^2 Q' = dG t - P: the step Q / Q' with one division
        t_old = t
        t2_dQ = dG * t - P
        step = P * t / t2_dQ
        t -= step
        # Newton leaves an error of about |Q'' / 2 Q'| step^2; |Q''| <= 2 |q2| + 6 |q3| t +
        # A w^3 w t (the drive's tail's is below A w^4 t / 9 for w t < 1): stop once negligible
        curv = 2.0 * abs(q2) + 6.0 * abs(q3) * t + aw * w * w * w * t
        if step * step * curv * (t_old * t_old) <= TAYLOR_NEWTON_REL * t * abs(t2_dQ):
            break
    else:
        return fail
    if not 0.0 < t < tau_max:
        return fail
    return t, xi0 + vx * t, series_rate(t, vyrel, F2, sn, cs, A, w, K), True


@njit(cache=True, fastmath=FMA, forceinline=True)
def flight_search(phase, sn, cs, xi0, S0, vx, vyrel, kp):
    """First contact with the floor after an event (see the module docstring).

    Parameters
    ----------
    phase : float
        Phase w t (rad) of the event that starts the flight.
    sn, cs : float
        ``sin_cos(phase)`` (``plate.py``): the event loop computes them once per
        event and shares them with ``collide`` and the observables (``event_search``).
    xi0, vx, vyrel : float
        Local coordinate (mm) and velocity relative to the floor (mm/s) just
        after it; the velocity must leave the arc (``V . n > 0``), or may be
        tangent (``V . n = 0``) inside the release window where the floor
        accelerates downward faster than g.
    S0 : float
        ``arc_root(xi0)`` (mm): ``collide`` computed it for its bounce, and the event
        loop carries it to the next flight (a square root fewer per event).
    kp : KernelParams

    Returns
    -------
    tau : float
        Flight time (s).
    k : float
        Tile offset of the contact (integer-valued).
    xi : float
        Local coordinate of the contact on tile ``tile + k`` (mm).
    vyrel_minus : float
        Vertical velocity relative to the floor just before the contact (mm/s).
    n_steps : int
        Safe steps taken (a cost measure; 0 for a tiny hop solved by ``tiny_hop``).
    status : int
        ``OK``, ``BAD_STATE`` or ``ROOT_NOT_CONVERGED``.
    """
    d, R, w, g, g_t = kp.d, kp.R, kp.w, kp.g, kp.g_t
    tilted = g_t != 0.0
    tilt = kp.tilt_curv  # bound of -b' g_t in -G'' (0 untilted)
    M = kp.curv_bound + tilt
    half = 0.5 * d
    k_base = 0.0
    # A particle on a wedge moving away from its tile starts on the neighbour (at rest on
    # a tilted floor, it moves the way g_t pulls).
    move = vx if vx != 0.0 else g_t
    if move > 0.0 and xi0 >= half:
        xi0 = -half
        k_base = 1.0
    elif move < 0.0 and xi0 <= -half:
        xi0 = half
        k_base = -1.0
    if k_base != 0.0:
        S0 = arc_root(xi0, kp)
    Gp, tangent = tangent_rate(xi0, S0, vx, vyrel)
    if tangent:
        Gp = 0.0  # tangent departure (alpha = 0): rounding of V.n = 0 must not count
    elif Gp > 0.0 and abs(xi0) < half and not tilted:  # tiny_hop takes xi linear in tau
        tau, xi, vyrel_minus, solved = tiny_hop(sn, cs, xi0, S0, vx, vyrel, Gp, kp)
        if solved:
            return tau, k_base, xi, vyrel_minus, 0, OK

    aw2 = kp.A * w * w
    K = aw2 * w  # |d/dtau (g + A w^2 sin)| <= A w^3
    L = K * w  # |d^2/dtau^2 (g + A w^2 sin)| <= A w^4
    arc_curv = R * R * vx * vx / (kp.c0 * kp.c0 * kp.c0)  # max of -b'' vx^2 on a tile
    m_pad = 4.0 * EPS * M  # rounding allowance keeping g + A w^2 sin an upper bound
    direction = 1.0 if vx > 0.0 else -1.0
    tau = 0.0
    k = 0.0
    sn_t, cn_t = sn, cs  # sine and cosine of the phase reached at tau
    G = 0.0
    lift = xi0 * xi0 / (R + S0)  # h - b(xi0)
    G_env = -lift
    G_envp = vyrel
    xi = xi0
    S = S0
    if tilted:
        tc, direction = tilted_crossing(xi0, k, vx, g_t, 0.0, d)
        theta_r, theta_e = tilted_window(xi0, S0, vx, kp)
    else:
        tc = crossing_time(xi0, k, vx, d)
        theta_r, theta_e = kp.release_r, kp.release_e  # where sin(phase) < -1/Gamma
    if vx == 0.0 and theta_r < phase < theta_e and not tilted:
        # Released inside the window (a stick there lasts zero time): the particle stays
        # over xi0, so G is the flat ball's gap.  Near theta_e its contact is of third order
        # (G'' -> 0), which the flat search's cubic bound finds in a few steps where the
        # quadratic bound M here would crawl (~1/sqrt(theta_e - phase) steps).
        tau, vrel_minus, status, n_evals = flat_flight_tol(phase, vyrel, kp, ROOT_STEP_REL)
        return tau, k_base, xi0, vrel_minus, n_evals, status
    # Interval in which the particle is above A + h, the floor's highest point ever: no
    # contact there, so a step that ends inside it goes on to its end unevaluated.
    tau_up, tau_down = time_above(vyrel - kp.A * w * cs, kp.A * (1.0 + sn) + lift, g)

    if theta_r <= phase < theta_e:
        # G'' > 0 on a tile until theta_e and G(0) = 0, G'(0) >= 0: no contact before
        # theta_e or the first tile crossing, whichever comes first.
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
    if tilted:
        tc, direction = tilted_crossing(xi0, k, vx, g_t, tau, d)
    else:
        tc = fmax2(crossing_time(xi0, k, vx, d), tau)

    known = tau == 0.0  # the gap is known at tau: G = 0 at the start, else evaluated below
    for n in range(ROOT_MAX_STEPS):
        if not known:
            if tau_up < tau < tau_down:
                tau = tau_down
                k = tile_at(xi0, vx, tau, kp)
            G, Gp, G_env, G_envp, xi, S, sn_t, cn_t = segment_gap_phase(
                tau, k, sn, cs, xi0, S0, vx, vyrel, kp
            )
            if tilted:
                tc, direction = tilted_crossing(xi0, k, vx, g_t, tau, d)
            else:
                tc = fmax2(crossing_time(xi0, k, vx, d), tau)
        known = False
        if G <= 0.0 and tau > 0.0:
            return tau, k + k_base, xi, G_envp, n, OK
        if Gp < 0.0 and w * G < -TAYLOR_MAX_SPAN * Gp and not tilted:  # xi linear in tau
            point = TilePoint(xi, S, vx, tc - tau)
            u, xi_c, Fp_c, solved = taylor_finish(tau, G, Gp, G_envp, sn_t, cn_t, point, kp)
            if solved:
                return tau + u, k + k_base, xi_c, Fp_c, n + 1, OK
        # -G'' <= m + K s ahead of tau (on the tile, and for the envelope everywhere)
        m_drive = g + aw2 * sn_t + m_pad
        m = m_drive + tilt
        s_tile = cubic_safe_step(G, Gp, m, M, K)
        if s_tile <= ROOT_STEP_REL * tau:
            return tau, k + k_base, xi, G_envp, n, OK
        s_env = cubic_safe_step(G_env, G_envp, m, M, K) if G_env > 0.0 else 0.0
        room = tc - tau
        if s_env > fmin2(s_tile, room):
            tau += s_env
            k = tile_at(xi0, vx, tau, kp)
        elif s_tile >= room:
            tau = tc
            k += direction
        else:
            tau_next = tau + s_tile
            # Upper Taylor bound (-G'' >= m_low - K u on the tile): negative just past the
            # step, the contact lies within ROOT_STEP_REL tau_next after tau_next; F' there
            # follows from its Taylor series (remainder <= A w^4 s^3 / 6, below eps F').
            s_up = s_tile + ROOT_STEP_REL * tau_next
            if tilted:  # the largest |xi'| on the step (xi' is linear in tau)
                v_up = fmax2(abs(vx + g_t * tau), abs(vx + g_t * (tau + s_up)))
                arc_curv = R * R * v_up * v_up / (kp.c0 * kp.c0 * kp.c0)
            m_low = m_drive - 2.0 * m_pad - arc_curv - tilt
            upper = G + s_up * (Gp - s_up * (0.5 * m_low - s_up * (K / 6.0)))
            bracketed = upper < 0.0 and s_up < room  # contact on this tile
            if bracketed and L * s_tile**3 <= 6.0 * EPS * abs(G_envp):
                Fp = G_envp - s_tile * (m_drive - m_pad + 0.5 * s_tile * K * cn_t)
                if tilted:
                    dx = tau_next * (vx + 0.5 * g_t * tau_next) - k * d
                else:
                    dx = vx * tau_next - k * d
                xi = clamp(xi0 + dx, -half, half)
                return tau_next, k + k_base, xi, Fp, n + 1, OK
            tau = tau_next
    return tau, k + k_base, xi, G_envp, ROOT_MAX_STEPS, ROOT_NOT_CONVERGED


@njit(cache=True, fastmath=FMA)
def billiard_flight(phase, xi0, vx, vyrel, kp):
    """First contact with the floor after an event: ``flight_search`` from the
    phase and point alone (``sin_cos`` and ``arc_root`` here).

    Returns ``(tau, k, xi, vyrel_minus, n_steps, status)`` (see ``flight_search``).
    """
    sn, cs = sin_cos(phase)
    return flight_search(phase, sn, cs, xi0, arc_root(xi0, kp), vx, vyrel, kp)


@njit(cache=True, fastmath=FMA, inline="always")
def shrinking_series(eps, q, r):
    """``F = sum_{m >= 0} eps^m / (1 - q r^m)``, ``dF/deps`` and a bound of F's rest, for
    ``0 <= eps, q, r < 1``.

    Summed until the rest of the derivative's series (it bounds the rest of F's), at
    most ``m eps^(m-1) / ((1 - eps)^2 (1 - q))`` from term m on, is below half an ulp of
    F, or for ``SERIES_MAX_TERMS`` terms; returns ``(F, dF/deps, rest)`` with ``rest =
    eps^m / ((1 - eps)(1 - q))`` bounding what the terms from m on would add to F.
    """
    total = 1.0 / (1.0 - q)
    slope = 0.0
    power = 1.0  # eps^(m-1) once term m is added
    rm = 1.0  # r^m
    for m in range(1, SERIES_MAX_TERMS + 1):
        if m * power <= 0.5 * EPS * total * (1.0 - eps) ** 2 * (1.0 - q):
            break
        rm *= r
        slope += m * power / (1.0 - q * rm)
        power *= eps
        total += power / (1.0 - q * rm)
    return total, slope, power * eps / ((1.0 - eps) * (1.0 - q))


@njit(cache=True, fastmath=FMA, inline="always")
def chatter_sum(cs, xi, S, vn, vt, g_eff, kp):
    """Closed-form sum of a chattering sequence on an arc (derivations/chattering.py).

    After an impact at a phase with cosine ``cs``, with small normal velocity ``vn``
    (mm/s) at ``xi`` (``S = sqrt(R^2 - xi^2)``) the particle hops in the normal pull
    ``g0 = (g_eff S - g_t^tilt xi) / R`` of the floor-frame gravity ``(g_t^tilt, -g_eff)``
    (``g_t^tilt = kp.g_t``, 0 untilted), less the centrifugal term of the convex arc.  The
    tangential velocity is multiplied by beta at each bounce, so hop k feels ``g0 (1 - eps
    beta^(2k))``, ``eps = vt^2 / (R g0)``, and lasts ``tau_k =
    alpha^k tau_0 / (1 - eps beta^(2k))``, ``tau_0 = 2 vn / g0``.  Expanding in eps and
    summing over k first::

        tau_inf = tau_0 sum_m eps^m / (1 - alpha beta^(2m)),
        ds = vt tau_0 sum_m eps^m / (1 - alpha beta^(2m+1))
             + g_t tau_0^2 [alpha beta / ((1 - alpha^2)(1 - alpha beta)) + 1 / (2 (1 - alpha^2))]

    (``shrinking_series``: F(eps; alpha, beta^2) and F(eps; alpha beta, beta^2); ``g_t =
    (g_eff xi + g_t^tilt S) / R`` the tangential pull, whose term takes the flat flights and
    is off by at most ``eps (2 - eps) / (1 - eps)^2`` of itself; the velocity it adds in
    each hop is carried, damped by beta, into the later hops: the geometric sums above).

    Neglected: the change of the drive during the sequence (rate at most ``A w^3 |cos| +
    A w^4 tau_inf``), which moves ``tau_inf`` by about ``rate tau_inf^2 / g_n``; and
    changes of the pull itself, each moving ``tau_inf`` by ``tau_inf`` times their size
    over ``g_n = g0 (1 - eps)``: the turn of the normal over ``ds`` (``(g_eff + |g_t^tilt|)
    |ds| / R``, the pull's size times the angle),
    the tangential speed gained from ``g_t`` (``(2 |vt| |g_t| tau_inf + (g_t tau_inf)^2) /
    R``) and the arc's curvature over a hop's height (``eps g0 (vn^2 / g_n + (vt tau_0)^2
    / R) / R``); and the series' rest beyond the terms summed (``shrinking_series``).  The
    sum is accepted only when all of this is below ``CHATTER_REL_TOL`` periods
    (tests/test_billiard_chatter_reference.py checks the time of rest against the sequence
    solved bounce by bounce in mpmath).

    Returns ``(tau_inf, ds)``; ``tau_inf = inf`` when not accepted, for ``alpha = 1`` (no
    accumulation) and for ``beta = 1`` (sliding, not modelled).
    """
    A, w, alpha, beta, R = kp.A, kp.w, kp.alpha, kp.beta, kp.R
    if alpha >= 1.0 or beta >= 1.0:
        return math.inf, 0.0
    # the floor-frame pull (g_t, -g_eff) along -n and t, times R (tilt: g_t != 0)
    pull_n = g_eff * S - kp.g_t * xi
    pull_t = g_eff * xi + kp.g_t * S
    # the drive must not undo the pull during the sequence: its normal part changes at most
    # at A w^3 S / R against g0 = pull_n / R (untilted: A w^3 against g_eff)
    g_hold = g_eff if kp.g_t == 0.0 else pull_n / S
    g0 = pull_n / R
    eps = vt * vt / pull_n
    g_n = g0 * (1.0 - eps)
    tau0 = 2.0 * vn / g0
    aw3 = A * w * w * w
    cos_abs = abs(cs)
    budget = CHATTER_REL_TOL * kp.period * g_n
    # Most impacts fail already with the series' first term, tau_inf >= tau_0 / (1 - alpha)
    # (every test below grows with tau_inf): refuse them before summing the series.
    tau_low = tau0 * (1.0 / (1.0 - alpha))
    drive_low = (aw3 * cos_abs + aw3 * w * tau_low) * tau_low
    if not (aw3 * tau_low < 0.5 * g_hold and drive_low * tau_low <= budget):
        return math.inf, 0.0
    F, _, rest_F = shrinking_series(eps, alpha, beta * beta)
    tau_inf = tau0 * F
    if not aw3 * tau_inf < 0.5 * g_hold:
        return math.inf, 0.0
    ab = alpha * beta
    g_t = pull_t / R
    one_a2 = 1.0 - alpha * alpha
    H, _, rest_H = shrinking_series(eps, ab, beta * beta)
    ds = vt * tau0 * H + g_t * tau0 * tau0 * (ab / (one_a2 * (1.0 - ab)) + 0.5 / one_a2)
    ds_bound = abs(ds) + abs(vt) * tau0 * rest_H
    drive = (aw3 * cos_abs + aw3 * w * tau_inf) * tau_inf
    gained = (2.0 * abs(vt) * abs(g_t) + g_t * g_t * tau_inf) * tau_inf / R
    curvature = eps * g0 * (vn * vn / g_n + (vt * tau0) ** 2 / R) / R
    pull = drive + (abs(g_eff) + abs(kp.g_t)) * ds_bound / R + gained + curvature
    if not pull * tau_inf + tau0 * rest_F * g_n <= budget:
        return math.inf, 0.0
    return tau_inf, ds


@njit(cache=True, fastmath=FMA, inline="always")
def wedge_reflect(tile, xi, vx, vy, vn, vt, kp):
    """Wedge rule: reflect on the neighbouring arc while the velocity points into it.

    A contact at a wedge (``xi = +-d/2`` after snapping) was resolved with the
    normal of the arc the particle was over.  If the new velocity points into
    the neighbouring arc, the particle hits it at once, at the same point and
    time: reflect there too, and repeat.  The wedge is very obtuse (its tangents
    differ by 2 asin(d/2R)), so this ends after one or two reflections; after
    ``WEDGE_MAX_REFLECTIONS`` the particle is taken to have collapsed into the
    wedge (returned with ``ok = False``).  A velocity tangent to the neighbour
    within rounding (``|V.n| <= DEPARTURE_REL_TOL`` times its terms, the test of
    ``billiard_flight``) touches it: it is reflected there too, since a flight
    cannot start from it.

    Returns ``(tile, xi, vx, vy, vn, vt, ok)``.
    """
    half = 0.5 * kp.d
    for _ in range(WEDGE_MAX_REFLECTIONS):
        tol = DEPARTURE_REL_TOL * (abs(vy) * kp.c0 + abs(vx) * half)
        if xi >= half and vx > 0.0 and (vy * kp.c0 - vx * half) <= tol:
            tile += 1.0
            xi = -half
        elif xi <= -half and vx < 0.0 and (vy * kp.c0 + vx * half) <= tol:
            tile -= 1.0
            xi = half
        else:
            return tile, xi, vx, vy, vn, vt, True
        vx, vy, vn, vt = bounce(xi, vx, vy, kp)
    return tile, xi, vx, vy, vn, vt, False


@njit(cache=True, fastmath=FMA, inline="always")
def snap_to_wedge(xi, kp):
    """Put a contact within ``WEDGE_TOL * d`` of a wedge on the wedge (``xi = +-d/2``)."""
    half = 0.5 * kp.d
    if xi >= half - WEDGE_TOL * kp.d:
        return half
    if xi <= -half + WEDGE_TOL * kp.d:
        return -half
    return xi


@njit(cache=True, fastmath=FMA, inline="always")
def lands_at_once(periods, phase, vyrel, g_eff, kp):
    """True if a flight leaving a wedge lands again within the rounding of the time.

    From the wedge (the lowest point around it) a particle with vertical
    velocity ``vyrel`` (mm/s) relative to the floor, in the effective gravity
    ``g_eff > 0`` (mm/s^2), is back on the floor within ``2 vyrel / g_eff``.
    If that does not change ``(periods, phase)``, every later bounce in the
    wedge happens at the same instant too (a floor at rest for that instant
    adds no energy): the particle has collapsed into the wedge, like after
    ``WEDGE_MAX_REFLECTIONS`` (an event-by-event run would repeat zero-time
    events until the gap underflows).
    """
    if not g_eff > 0.0:
        return False
    p1, ph1 = advance_phase(periods, phase, kp.w * 2.0 * fmax2(vyrel, 0.0) / g_eff)
    return p1 == periods and ph1 == phase


@njit(cache=True, fastmath=FMA, forceinline=True)
def collide(periods, phase, sn, cs, tile, xi, vx, vyrel, kp):
    """Apply the collision at ``(tile, xi)`` and decide whether chattering ends in a stick.

    ``sn, cs`` are ``sin_cos(phase)`` (``plate.py``) of the contact.  A contact
    within ``WEDGE_TOL * d`` of a wedge is put on the wedge and treated by
    ``wedge_reflect``; a collapse into the wedge (``wedge_reflect`` gives up, or
    ``lands_at_once``) is a STICK there.  Returns ``(state, status, trig)``: the
    ``EventState`` after the collision, the status and its ``Trig``.
    """
    half = 0.5 * kp.d
    xi = snap_to_wedge(xi, kp)
    S = arc_root(xi, kp)
    vx, vyrel, vn, vt = bounce_at(xi, S, vx, vyrel, kp)
    tile, xi_r, vx, vyrel, vn, vt, ok = wedge_reflect(tile, xi, vx, vyrel, vn, vt, kp)
    if xi_r != xi:  # reflected onto a neighbour's wedge
        xi = xi_r
        S = arc_root(xi, kp)
    g_eff = kp.g + kp.A * kp.w * kp.w * sn
    if not ok or (abs(xi) == half and lands_at_once(periods, phase, vyrel, g_eff, kp)):
        return EventState(periods, phase, tile, xi, 0.0, 0.0, STICK), OK, Trig(sn, cs, S)
    if not (math.isfinite(vx) and math.isfinite(vyrel)):
        state = EventState(periods, phase, tile, xi, vx, vyrel, IMPACT)
        return state, NON_FINITE, Trig(sn, cs, S)
    tilted = kp.g_t != 0.0
    # pressed onto the arc: the floor-frame pull along -n, (g_eff S - g_t xi) / R, is > 0
    pressed = g_eff > 0.0 if not tilted else g_eff * S - kp.g_t * xi > 0.0
    if pressed and kp.beta < 1.0:
        if not tilted:
            g_n = (g_eff * S - vt * vt) / kp.R
        else:
            g_n = (g_eff * S - kp.g_t * xi - vt * vt) / kp.R
        if g_n > 0.0:
            # vn = 0, or a rounding of 0 after a tangent wedge reflection; tilted, also a
            # velocity the flight search takes for tangent (it could not leave: g_n > 0)
            if vn <= 0.0 or (tilted and tangent_rate(xi, S, vx, vyrel)[1]):
                return EventState(periods, phase, tile, xi, 0.0, 0.0, STICK), OK, Trig(sn, cs, S)
            tau_inf, ds = chatter_sum(cs, xi, S, vn, vt, g_eff, kp)
            if tau_inf < math.inf:
                # Rotate the contact point by the angle ds / R along the arc; a
                # drift past the wedge ends in the wedge (it is below 1e-9 mm).
                c = math.cos(ds / kp.R)
                s = math.sin(ds / kp.R)
                xi = clamp(xi * c + S * s, -half, half)
                periods, phase = advance_phase(periods, phase, kp.w * tau_inf)
                sn, cs = sin_cos(phase)
                state = EventState(periods, phase, tile, xi, 0.0, 0.0, STICK)
                return state, OK, Trig(sn, cs, arc_root(xi, kp))
    return EventState(periods, phase, tile, xi, vx, vyrel, IMPACT), OK, Trig(sn, cs, S)


@njit(cache=True, fastmath=FMA, inline="always")
def uphill_wedge(tile, xi, kp):
    """A point resting in a wedge of a tilted floor, on the arc that ``g_t`` pushes it into.

    In the wedge the particle touches both arcs; the tangential pull presses it onto the
    arc rising ahead of it (the left end of the right tile for ``g_t > 0``), which holds
    it longest, so that arc's release window applies.  Returns ``(tile, xi)``.
    """
    half = 0.5 * kp.d
    if kp.g_t > 0.0 and xi >= half:
        return tile + 1.0, -half
    if kp.g_t < 0.0 and xi <= -half:
        return tile - 1.0, half
    return tile, xi


@njit(cache=True, fastmath=FMA, inline="always")
def event_trig(phase, xi, kp):
    """The ``Trig`` of an event state: ``sin_cos(phase)`` and ``arc_root(xi)`` (mm)."""
    sn, cs = sin_cos(phase)
    return Trig(sn, cs, arc_root(xi, kp))


@njit(cache=True, fastmath=FMA, forceinline=True)
def event_search(state, trig, kp):
    """Advance the billiard from one event to the next (docs/model.md §2).

    Parameters
    ----------
    state : EventState
        The current event: time ``(periods, phase)``, position ``(tile, xi)`` on the floor,
        velocity ``(vx, vyrel)`` relative to the floor just after it (0, 0 for STICK) and
        its ``kind``.
    trig : Trig
        ``sin_cos(phase)`` and ``arc_root(xi)`` of ``state`` (computed once per event: the
        flight and ``collide`` use them, and so do the observables of the event loop).
    kp : KernelParams

    Returns
    -------
    (state, status, trig)
        The ``EventState`` of the next event, the status and the event's ``Trig``.
        A stuck particle is released with the floor's velocity at ``theta_r = pi +
        asin(1/Gamma)``, or at once if it stuck inside the release window (a wedge
        collapse while the floor falls faster than g; ``stick_release``); for
        Gamma <= 1 the state is returned unchanged with ``STUCK_FOREVER``.
    """
    periods, phase, tile, xi, vx, vyrel, kind = state
    if kind == STICK:
        if kp.g_t == 0.0:
            window = (kp.release_r, kp.release_e)
        else:
            tile, xi = uphill_wedge(tile, xi, kp)
            window = tilted_window(xi, trig.S, 0.0, kp)
        periods_r, phase_r, status = stick_release_in(periods, phase, window[0], window[1])
        if status != OK:
            return EventState(periods, phase, tile, xi, 0.0, 0.0, STICK), status, trig
        sn_r, cs_r = sin_cos(phase_r)
        released = EventState(periods_r, phase_r, tile, xi, 0.0, 0.0, RELEASE)
        return released, OK, Trig(sn_r, cs_r, trig.S)

    tau, k, xi_c, vyrel_minus, _, status = flight_search(
        phase, trig.sn, trig.cs, xi, trig.S, vx, vyrel, kp
    )
    if status != OK:
        return state, status, trig
    periods, phase = advance_phase(periods, phase, kp.w * tau)
    sn_c, cs_c = sin_cos(phase)
    if kp.g_t != 0.0:  # tilted: the pull along the floor changed vx during the flight
        vx = vx + kp.g_t * tau
    return collide(periods, phase, sn_c, cs_c, tile + k, xi_c, vx, vyrel_minus, kp)


@njit(cache=True, fastmath=FMA)
def billiard_event(periods, phase, tile, xi, vx, vyrel, kind, kp):
    """Advance the billiard from one event to the next: ``event_search`` (cubic steps) from
    the state alone (``event_trig`` here).

    Returns ``(periods, phase, tile, xi, vx, vyrel, kind, status)`` of the next event.

    >>> from bbdyn import Params
    >>> ev = billiard_event(0.0, 0.0, 0.0, 0.3, 10.0, 50.0, IMPACT, Params(f=58.0).kernel())
    >>> ev[-1] == OK and ev[0] + ev[1] > 0.0
    True
    """
    state = EventState(periods, phase, tile, xi, vx, vyrel, kind)
    nxt, status, _ = event_search(state, event_trig(phase, xi, kp), kp)
    return nxt.periods, nxt.phase, nxt.tile, nxt.xi, nxt.vx, nxt.vyrel, nxt.kind, status


@njit(cache=True, fastmath=FMA)
def billiard_run(state, kp, n_events, out):
    """Iterate ``event_search`` (cubic steps) for ``n_events`` events from ``state``.

    Parameters
    ----------
    state : EventState
        The start (taken as six floats and an integer ``kind``).
    kp : KernelParams
    n_events : int
        Events to run.
    out : EventArrays or None
        Event ``i`` goes into row ``i`` of each array (in place; at least ``n_events``
        rows); None stores nothing (benchmarks, transients).

    Returns ``(state, n_done, status)``: the last event (at a failure, the failing step's
    result), the events done and the status; the run stops early at a failure or at
    ``STUCK_FOREVER``.  The loop carries each event's ``Trig`` (as the ensemble does).
    """
    p, ph, tile, xi, vx, vyrel, kind = state
    ev = EventState(float(p), float(ph), float(tile), float(xi), float(vx), float(vyrel), int(kind))
    trig = event_trig(ev.phase, ev.xi, kp)
    for i in range(n_events):
        ev, status, trig = event_search(ev, trig, kp)
        if status != OK:
            return ev, i, status
        if out is not None:
            out.periods[i] = ev.periods
            out.phase[i] = ev.phase
            out.tile[i] = ev.tile
            out.xi[i] = ev.xi
            out.vx[i] = ev.vx
            out.vyrel[i] = ev.vyrel
            out.kind[i] = ev.kind
    return ev, n_events, OK
