"""Motion of the vibrating floor, written for accuracy over short intervals.

The floor height is ``y_p(t) = -A sin(w t)`` (docs/model.md §1).  Every gap
function in bbdyn is measured relative to the floor's motion at the start of a
flight, so that a flight of 1e-9 s is as accurate as one of 1 s: instead of
differences of sines (which cancel) we use, with ``x = w tau`` and the phase
``theta = w t`` at the flight's start (``s0 = sin theta``, ``c0 = cos theta``),

    rise(tau)  = y_p(t + tau) - y_p(t) - u(t) tau
               = A [2 s0 sin^2(x/2) - c0 (sin x - x)]
    dvel(tau)  = u(t + tau) - u(t)
               = A w [2 c0 sin^2(x/2) + s0 sin x]

with the plate velocity ``u(t) = -A w cos(w t)``.  Both are O(tau^2) and
O(tau) exactly, with no cancellation.

``release_window`` and ``stick_release``: when a particle resting on the floor leaves it
(the same for the flat ball and the billiard: the floor's shape does not enter).
"""

import math

from numba import njit

from bbdyn.core.status import OK, STUCK_FOREVER
from bbdyn.core.tolerances import FMA

TWO_PI = 2.0 * math.pi
INV_TWO_PI = 1.0 / TWO_PI

# Cody-Waite split of pi/2 (fdlibm): 33 leading bits each, so k * _PIO2_1 and
# k * _PIO2_2 are exact for k < 2^20 and the reduced argument keeps full precision.
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_3 = 2.02226624871116645580e-21
_INV_PIO2 = 6.36619772367581382433e-01
#: Above this the Cody-Waite reduction loses accuracy; math.sin/cos take over.
_SINCOS_MAX = 2.0**19 * _PIO2_1
# Minimax coefficients of sin and cos on [-pi/4, pi/4] (fdlibm k_sin.c, k_cos.c).
_KS1 = -1.66666666666666324348e-01
_KS2 = 8.33333333332248946124e-03
_KS3 = -1.98412698298579493134e-04
_KS4 = 2.75573137070700676789e-06
_KS5 = -2.50507602534068634195e-08
_KS6 = 1.58969099521155010221e-10
_KC1 = 4.16666666666666019037e-02
_KC2 = -1.38888888888741095749e-03
_KC3 = 2.48015872894767294178e-05
_KC4 = -2.75573143513906633035e-07
_KC5 = 2.08757232129817482790e-09
_KC6 = -1.13596475577881948265e-11


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def sin_cos(y):
    """``(sin y, cos y)`` to about one ulp, inlined (a libm sincos call costs ~3x more).

    Cody-Waite reduction by pi/2 and the fdlibm kernels; ``|y|`` above 2^19 pi/2
    (a flight of ~1e6 rad) falls back to ``math.sin`` and ``math.cos``.
    """
    if not abs(y) < _SINCOS_MAX:
        return math.sin(y), math.cos(y)
    k = math.floor(y * _INV_PIO2 + 0.5)
    r = ((y - k * _PIO2_1) - k * _PIO2_2) - k * _PIO2_3
    z = r * r
    s = r + r * z * (_KS1 + z * (_KS2 + z * (_KS3 + z * (_KS4 + z * (_KS5 + z * _KS6)))))
    q = z * (_KC1 + z * (_KC2 + z * (_KC3 + z * (_KC4 + z * (_KC5 + z * _KC6)))))
    hz = 0.5 * z
    one_hz = 1.0 - hz
    # compensated 1 - z/2 + z^2 q (musl's __cos with a zero tail)
    c = one_hz + (((1.0 - one_hz) - hz) + z * q)
    quadrant = int(k) & 3
    if quadrant == 0:
        return s, c
    if quadrant == 1:
        return c, -s
    if quadrant == 2:
        return -s, -c
    return -c, s


#: Taylor coefficients (-1)^k / (2k+1)! of sin(x) - x, k = 1..9, as literals: a Horner
#: scheme of multiplications (a loop of divisions cost ~40 ns, half a gap evaluation).
#: For |x| < 0.5 the first omitted term, x^21 / 21!, is 1e-24 of x^3 / 6.
_S3 = -1.0 / 6.0
_S5 = 1.0 / 120.0
_S7 = -1.0 / 5040.0
_S9 = 1.0 / 362880.0
_S11 = -1.0 / 39916800.0
_S13 = 1.0 / 6227020800.0
_S15 = -1.0 / 1307674368000.0
_S17 = 1.0 / 355687428096000.0
_S19 = -1.0 / 121645100408832000.0


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def sin_minus_x(x):
    """``sin(x) - x`` without cancellation for small ``|x|`` (Taylor series below 0.5)."""
    if abs(x) >= 0.5:
        return math.sin(x) - x
    x2 = x * x
    poly = _S17 + x2 * _S19
    poly = _S15 + x2 * poly
    poly = _S13 + x2 * poly
    poly = _S11 + x2 * poly
    poly = _S9 + x2 * poly
    poly = _S7 + x2 * poly
    poly = _S5 + x2 * poly
    poly = _S3 + x2 * poly
    return x * x2 * poly


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def plate_rise(A, s0, c0, x, sin_x, sin_half):
    """y_p(t+tau) - y_p(t) - u(t) tau (mm) for x = w tau; sin_x = sin x, sin_half = sin(x/2)."""
    return A * (2.0 * s0 * sin_half * sin_half - c0 * sin_minus_x_given(x, sin_x))


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def sin_minus_x_given(x, sin_x):
    """``sin(x) - x`` reusing an already computed ``sin_x`` when that is accurate."""
    if abs(x) >= 0.5:
        return sin_x - x
    return sin_minus_x(x)


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def plate_dvel(A, w, s0, c0, sin_x, sin_half):
    """u(t+tau) - u(t) (mm/s) for x = w tau."""
    return A * w * (2.0 * c0 * sin_half * sin_half + s0 * sin_x)


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def plate_velocity(A, w, phase):
    """u = -A w cos(phase) (mm/s)."""
    return plate_velocity_cos(A, w, math.cos(phase))


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def plate_velocity_cos(A, w, cos_phase):
    """u (mm/s) from ``cos_phase = cos(phase)`` already computed."""
    return -A * w * cos_phase


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def plate_height_sin(A, sin_phase):
    """y_p = -A sin(phase) (mm) from ``sin_phase = sin(phase)`` already computed."""
    return -A * sin_phase


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def advance_phase(periods, phase, dphase):
    """Add ``dphase`` (rad, >= 0) to the time kept as (whole periods, phase in [0, 2 pi)).

    Returns the new ``(periods, phase)``; ``periods`` is an integer-valued float
    (exact up to 2^53 periods), so runs of 1e7 periods lose no precision.
    """
    total = phase + dphase
    whole = math.floor(total * INV_TWO_PI)  # a product, not a quotient: off by one at most
    phase_new = total - whole * TWO_PI
    if phase_new >= TWO_PI:  # rounding at the boundary
        phase_new -= TWO_PI
        whole += 1.0
    elif phase_new < 0.0:
        phase_new += TWO_PI
        whole -= 1.0
    return periods + whole, phase_new


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def release_window(gamma):
    """Phases (theta_r, theta_e) between which sin(theta) < -1/Gamma.

    A particle on the floor leaves at theta_r = pi + asin(1/Gamma); contact
    is impossible before theta_e = 2 pi - asin(1/Gamma) because the floor
    accelerates downward faster than g.  For Gamma <= 1 there is no window and
    both are returned as -1.
    """
    if gamma <= 1.0:
        return -1.0, -1.0
    a = math.asin(1.0 / gamma)
    return math.pi + a, TWO_PI - a


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
    return stick_release_in(periods, phase, kp.release_r, kp.release_e)


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def stick_release_in(periods, phase, theta_r, theta_e):
    """``stick_release`` in the window ``theta_r <= phase < theta_e`` (rad; both -1: none).

    The billiard on a tilted floor has a window that depends on the point
    (``billiard.tilted_window``).
    """
    if theta_r < 0.0:
        return periods, phase, STUCK_FOREVER
    if theta_r <= phase < theta_e:
        return periods, phase, OK
    if phase < theta_r:
        return periods, theta_r, OK
    return periods + 1.0, theta_r, OK
