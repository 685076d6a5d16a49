"""Motion of the vibrating floor, written for accuracy over short intervals.

The floor height is ``y_p(t) = -A sin(w t)`` (MODEL.md section 1).  Every gap
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
"""

import math

from numba import njit

TWO_PI = 2.0 * math.pi


@njit(cache=True, inline="always")
def sin_minus_x(x):
    """``sin(x) - x`` without cancellation for small |x| (Taylor series below 0.5)."""
    if abs(x) >= 0.5:
        return math.sin(x) - x
    x2 = x * x
    # -x^3/3! + x^5/5! - ... ; nine terms reach machine precision for |x| < 0.5
    term = -x * x2 / 6.0
    total = term
    for k in range(2, 11):
        term = -term * x2 / ((2 * k) * (2 * k + 1))
        total += term
    return total


@njit(cache=True, inline="always")
def plate_rise(A, s0, c0, x, sin_x, sin_half):
    """y_p(t+tau) - y_p(t) - u(t) tau (mm) for x = w tau; sin_x = sin x, sin_half = sin(x/2)."""
    return A * (2.0 * s0 * sin_half * sin_half - c0 * sin_minus_x_given(x, sin_x))


@njit(cache=True, inline="always")
def sin_minus_x_given(x, sin_x):
    """``sin(x) - x`` reusing an already computed ``sin_x`` when that is accurate."""
    if abs(x) >= 0.5:
        return sin_x - x
    return sin_minus_x(x)


@njit(cache=True, inline="always")
def plate_dvel(A, w, s0, c0, sin_x, sin_half):
    """u(t+tau) - u(t) (mm/s) for x = w tau."""
    return A * w * (2.0 * c0 * sin_half * sin_half + s0 * sin_x)


@njit(cache=True, inline="always")
def plate_velocity(A, w, phase):
    """u = -A w cos(phase) (mm/s)."""
    return -A * w * math.cos(phase)


@njit(cache=True, inline="always")
def plate_height(A, phase):
    """y_p = -A sin(phase) (mm)."""
    return -A * math.sin(phase)


@njit(cache=True, inline="always")
def advance_phase(periods, phase, dphase):
    """Add ``dphase`` (rad, >= 0) to the time kept as (whole periods, phase in [0, 2 pi)).

    Returns the new ``(periods, phase)``; ``periods`` is an integer-valued float
    (exact up to 2^53 periods), so runs of 1e7 periods lose no precision.
    """
    total = phase + dphase
    whole = math.floor(total / TWO_PI)
    phase_new = total - whole * TWO_PI
    if phase_new >= TWO_PI:  # rounding at the boundary
        phase_new -= TWO_PI
        whole += 1.0
    elif phase_new < 0.0:
        phase_new += TWO_PI
        whole -= 1.0
    return periods + whole, phase_new


@njit(cache=True, inline="always")
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
