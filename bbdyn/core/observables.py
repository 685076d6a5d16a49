"""Exact observables along billiard trajectories (docs/model.md §3 and §4).

Between two events a particle either flies on a parabola or, after a STICK,
rides the floor.  Both motions are known in closed form, so time integrals of
the energies over any sub-interval are computed exactly (no sampling):

* flight from an event at height ``y0`` with velocities ``(vx, vy0)``:
  ``y = y0 + vy0 tau - g tau^2 / 2``, ``vy = vy0 - g tau``.  ``E_y = vy^2/2`` and
  ``g y`` are quadratics in ``tau``, so Simpson's rule on ``[ta, tb]`` is exact
  and free of the cancellation of ``tb^3 - ta^3``; ``E_x = vx^2/2`` is constant.
* stuck at ``xi`` on the floor: ``y = -A sin(w t) + b(xi)``, ``vy = u = -A w cos(w t)``,
  ``vx = 0``, with ``b(xi) = sqrt(R^2 - xi^2) - c0`` the height of the arc above
  the wedges.  Over a whole period ``<E_y> = A^2 w^2 / 4`` and ``<g y> = g b``.

Traps (docs/model.md §4): wedge ``l`` sits at ``x = l d`` between the tops of
the bumps of tiles ``l - 1`` and ``l``, so a contact in tile ``l`` at ``xi < 0``
is in trap ``l`` and one at ``xi >= 0`` in trap ``l + 1`` (a contact exactly on a
top is given to the right-hand trap).

Time is kept as ``(periods, phase)``; differences of such times are formed
period part first, so they keep full relative precision in long runs.
"""

import math

from numba import njit

from bbdyn.core.features import block_of
from bbdyn.core.floor import floor_height_rel
from bbdyn.core.layout import ACC_EX, ACC_EY, ACC_POT, ACC_STUCK, Window
from bbdyn.core.plate import plate_height_sin, plate_velocity_cos
from bbdyn.core.status import STICK
from bbdyn.core.tolerances import FMA


@njit(cache=True, fastmath=FMA, inline="always")
def time_between(periods1, phase1, periods0, phase0, w, period):
    """Time (s) from ``(periods0, phase0)`` to ``(periods1, phase1)``; negative if earlier."""
    return (periods1 - periods0) * period + (phase1 - phase0) / w


@njit(cache=True, fastmath=FMA, inline="always")
def is_before(periods1, phase1, periods0, phase0):
    """True if time ``(periods1, phase1)`` is strictly earlier than ``(periods0, phase0)``."""
    return periods1 < periods0 or (periods1 == periods0 and phase1 < phase0)


@njit(cache=True, fastmath=FMA, forceinline=True)
def flight_integrals(vx, vy0, y0, g, ta, tb):
    """Integrals over ``[ta, tb]`` (s after the flight's start) of one parabolic flight.

    Parameters
    ----------
    vx, vy0 : float
        Horizontal and vertical velocity (mm/s) at the start of the flight.
    y0 : float
        Height (mm) at the start of the flight.
    g : float
        Gravitational acceleration (mm/s^2).
    ta, tb : float
        Integration limits (s), ``0 <= ta <= tb``.

    Returns
    -------
    (I_Ex, I_Ey, I_pot) : floats
        Integrals of ``vx^2/2``, ``vy^2/2`` and ``g y`` (kg mm^2 / s); their sum is
        the integral of ``E`` (docs/model.md §3), which is constant in flight.
    """
    dt = tb - ta
    tm = 0.5 * (ta + tb)
    va = vy0 - g * ta
    vm = vy0 - g * tm
    vb = vy0 - g * tb
    ya = y0 + ta * (vy0 - 0.5 * g * ta)
    ym = y0 + tm * (vy0 - 0.5 * g * tm)
    yb = y0 + tb * (vy0 - 0.5 * g * tb)
    I_Ex = 0.5 * vx * vx * dt
    I_Ey = dt * (va * va + 4.0 * vm * vm + vb * vb) * (1.0 / 12.0)
    I_pot = g * dt * (ya + 4.0 * ym + yb) * (1.0 / 6.0)
    return I_Ex, I_Ey, I_pot


@njit(cache=True, fastmath=FMA, inline="always")
def tilt_kinetic_x(vx, g_t, ta, tb):
    """What a pull ``g_t`` (mm/s^2) along a tilted floor adds over ``[ta, tb]`` to the integral
    of ``vx^2 / 2`` (kg mm^2 / s): the integral of ``(vx + g_t t)^2 / 2 - vx^2 / 2`` =
    ``g_t [vx (tb^2 - ta^2) / 2 + g_t (tb^3 - ta^3) / 6]``, differences as products."""
    dt = tb - ta
    return g_t * dt * (0.5 * vx * (tb + ta) + g_t * (tb * tb + tb * ta + ta * ta) * (1.0 / 6.0))


@njit(cache=True, fastmath=FMA, forceinline=True)
def stuck_integrals(A, w, g, b, phase_a, dt):
    """Integrals over ``dt`` seconds from phase ``phase_a`` of a particle riding the floor.

    Parameters
    ----------
    A, w, g : float
        Amplitude (mm), angular frequency (rad/s), gravity (mm/s^2).
    b : float
        Height of the contact point above the wedges, ``b(xi)`` (mm).
    phase_a : float
        Phase ``w t`` at the start (rad).
    dt : float
        Duration (s), >= 0.

    Returns
    -------
    (I_Ey, I_pot) : floats
        Integrals of ``u^2/2 = A^2 w^2 cos^2(w t) / 2`` and of ``g (b - A sin(w t))``
        (kg mm^2 / s); ``E_x = 0`` while stuck.
    """
    phase_b = phase_a + w * dt
    # int cos^2 = dt/2 + (sin 2 theta_b - sin 2 theta_a) / (4 w); the difference of
    # sines is written as a product so short intervals keep their relative accuracy.
    dsin2 = 2.0 * math.cos(phase_a + phase_b) * math.sin(w * dt)
    I_Ey = 0.5 * A * A * w * w * (0.5 * dt + dsin2 / (4.0 * w))
    # int -A sin = A (cos theta_b - cos theta_a) / w = -2 A sin(mid) sin(w dt / 2) / w
    dcos = -2.0 * math.sin(0.5 * (phase_a + phase_b)) * math.sin(0.5 * w * dt)
    I_pot = g * (b * dt + A * dcos / w)
    return I_Ey, I_pot


@njit(cache=True, fastmath=FMA, inline="always")
def trap_of(tile, xi):
    """Trap (wedge index, integer-valued float) of a contact at ``xi`` in tile ``tile``."""
    if xi >= 0.0:
        return tile + 1.0
    return tile


@njit(cache=True, fastmath=FMA, inline="always")
def displacement(tile, xi, tile0, xi0, d):
    """``x - x0`` (mm) between ``(tile, xi)`` and ``(tile0, xi0)``, the tile part first.

    The tile difference is an exact integer, so the result keeps full precision
    for any distance travelled.
    """
    return (tile - tile0) * d + (xi - xi0)


# Inlined into the event loop, as integrate_blocks: called with the EventState tuple, the two
# calls cost about 2 % of the ensemble's speed (python benchmarks/kernel_buffers.py).
@njit(cache=True, fastmath=FMA, inline="always")
def accumulate_interval(acc, j, ev, trig, b, lo, hi, kp, energy):
    """Add to row ``j`` of ``acc`` the integrals over ``[lo, hi]`` of the motion since ``ev``.

    ``ev`` is an ``EventState`` (a flight follows it, or the floor is ridden after a STICK),
    ``trig`` the sine and cosine of its phase; ``lo`` and ``hi`` are ``(periods, phase)``
    pairs inside the interval; ``b`` is the height ``b(xi)`` of the event point above the
    wedges (mm).  Columns ``ACC_*``: the
    stuck time (s) always, the energy integrals (kg mm^2/s) with ``energy``.
    """
    w, period = kp.w, kp.period
    if ev.kind == STICK:
        dt = time_between(hi[0], hi[1], lo[0], lo[1], w, period)
        acc[j, ACC_STUCK] += dt
        if energy:
            I_Ey, I_pot = stuck_integrals(kp.A, w, kp.g, b, lo[1], dt)
            acc[j, ACC_EY] += I_Ey
            acc[j, ACC_POT] += I_pot
        return
    if energy:
        ta = time_between(lo[0], lo[1], ev.periods, ev.phase, w, period)
        tb = time_between(hi[0], hi[1], ev.periods, ev.phase, w, period)
        y0 = plate_height_sin(kp.A, trig[0]) + b
        vy0 = ev.vyrel + plate_velocity_cos(kp.A, w, trig[1])
        I_Ex, I_Ey, I_pot = flight_integrals(ev.vx, vy0, y0, kp.g, ta, tb)
        acc[j, ACC_EX] += I_Ex
        acc[j, ACC_EY] += I_Ey
        acc[j, ACC_POT] += I_pot
        if kp.g_t != 0.0:  # tilted: E_x of vx + g_t t (after the untilted sums, bit for bit)
            acc[j, ACC_EX] += tilt_kinetic_x(ev.vx, kp.g_t, ta, tb)


# Inlined into the event loop (see accumulate_interval).
@njit(cache=True, fastmath=FMA, inline="always")
def integrate_blocks(acc, ev, trig, hi, window, kp, energy):
    """Integrate the motion since the event ``ev`` up to ``hi``, per block of the window.

    ``trig`` is ``sin_cos`` of the event's phase; ``hi`` a ``(periods,
    phase)`` pair; the part of ``[ev, hi]`` inside the ``window`` (a ``Window``) is cut at
    the block boundaries ``p0 + j L`` (phase 0) and added to row ``j`` of ``acc`` (shape
    (nb, >= 4)) by ``accumulate_interval``.
    """
    p0, L, nb = window.p0, window.L, window.nb
    p1 = p0 + nb * L
    lo_p, lo_ph = ev.periods, ev.phase
    if is_before(lo_p, lo_ph, p0, 0.0):
        lo_p, lo_ph = p0, 0.0
    hi_p, hi_ph = hi
    if is_before(p1, 0.0, hi_p, hi_ph):
        hi_p, hi_ph = p1, 0.0
    if not is_before(lo_p, lo_ph, hi_p, hi_ph):
        return
    b = floor_height_rel(ev.xi, kp) if energy else 0.0
    if nb == 1:  # one block (an ensemble's window): [lo, hi] lies in it
        accumulate_interval(acc, 0, ev, trig, b, (lo_p, lo_ph), (hi_p, hi_ph), kp, energy)
        return
    # from lo's block on, until the block that holds hi
    j = block_of(lo_p, p0, L, nb)
    while True:
        a_p, a_ph = lo_p, lo_ph
        if is_before(a_p, a_ph, p0 + j * L, 0.0):
            a_p, a_ph = p0 + j * L, 0.0
        z_p, z_ph = hi_p, hi_ph
        if is_before(p0 + (j + 1) * L, 0.0, z_p, z_ph):
            z_p, z_ph = p0 + (j + 1) * L, 0.0
        if is_before(a_p, a_ph, z_p, z_ph):
            accumulate_interval(acc, j, ev, trig, b, (a_p, a_ph), (z_p, z_ph), kp, energy)
        if j == nb - 1 or not is_before(p0 + (j + 1) * L, 0.0, hi_p, hi_ph):
            return
        j += 1


@njit(cache=True, fastmath=FMA)
def split_row(acc, ev, trig, hi, p0, split, kp, energy):
    """Row 1 of ``acc`` := row 0 plus the part in ``[p0, split]`` of the motion ``ev`` to ``hi``.

    Called once per particle, for the interval from the event ``ev`` (before ``split``
    whole periods, phase 0) to ``hi`` (a ``(periods, phase)`` pair at or after it), before
    the interval is added to row 0 (the window ``[p0, ...]``).  Row 0 then holds the
    integrals up to ``ev``: without fast-forward, the same sums in the same order as a
    run whose window ends at ``split``, so row 1 is bitwise what that run gives.
    """
    for c in range(4):
        acc[1, c] = acc[0, c]
    if p0 < split:
        integrate_blocks(acc[1:], ev, trig, hi, Window(p0, split - p0, 1), kp, energy)
