"""Geometry of the billiard floor: one circular arc per tile (docs/model.md §2).

Positions are kept as (tile l, local coordinate ``xi = x - x_c``) with
``x_c = (l + 1/2) d`` and ``-d/2 <= xi <= d/2``, so that far tiles lose no
precision.  Relative to the moving floor level ``y_p(t)`` (the wedges) the
arc's height is

    b(xi) = sqrt(R^2 - xi^2) - c0,   c0 = sqrt(R^2 - d^2/4)        (docs/model.md, Y(x, t))

with ``b(+-d/2) = 0`` at the wedges and ``b(0) = h`` at the top.  Every
difference of heights is written as a product (no cancellation of square
roots), so gaps of 1e-15 mm near a wedge or a top keep their relative accuracy.

Normal and tangent at ``xi`` (``S = sqrt(R^2 - xi^2)``):
``n = (xi, S) / R`` points out of the scatterer; ``t = (S, -xi) / R`` points
in the direction of increasing arc length ``s = R (asin(xi / R) + asin(d / 2R))``
(clockwise from the left wedge, 0 <= s <= s_max, top at s_max / 2).
"""

import math

import numpy as np
from numba import njit

from bbdyn.core.fmath import clamp
from bbdyn.core.tolerances import FMA


@njit(cache=True, fastmath=FMA, inline="always")
def arc_root(xi, kp):
    """S = sqrt(R^2 - xi^2) (mm): the height of the arc point above the arc centre."""
    return math.sqrt((kp.R - xi) * (kp.R + xi))


@njit(cache=True, fastmath=FMA, inline="always")
def floor_height_rel(xi, kp):
    """Arc height b(xi) above the wedges (mm), ``(d/2 - xi)(d/2 + xi) / (S + c0)``."""
    half = 0.5 * kp.d
    return (half - xi) * (half + xi) / (arc_root(xi, kp) + kp.c0)


@njit(cache=True, fastmath=FMA, inline="always")
def floor_slope(xi, kp):
    """Slope db/dxi = -xi / S of the arc (dimensionless)."""
    return -xi / arc_root(xi, kp)


@njit(cache=True, fastmath=FMA, inline="always")
def floor_drop(dx, xi0, xi1, S0, S1):
    """b(xi0) - b(xi1) (mm) as ``dx (xi1 + xi0) / (S0 + S1)``, without cancellation.

    ``dx = xi1 - xi0`` is passed separately because the caller knows it exactly
    (``vx tau`` within one tile); ``S0, S1`` are ``arc_root`` at ``xi0, xi1``.
    """
    return dx * (xi1 + xi0) / (S0 + S1)


@njit(cache=True, fastmath=FMA, inline="always")
def arc_length(xi, kp):
    """Arc length s (mm) from the left wedge to ``xi``, clockwise: R (asin(xi/R) + asin(d/2R))."""
    return kp.R * (math.asin(xi / kp.R) + math.asin(0.5 * kp.d / kp.R))


@njit(cache=True, fastmath=FMA, inline="always")
def xi_from_arc_length(s, kp):
    """Inverse of ``arc_length``: xi = R sin(s / R - asin(d / 2R)) (mm), clamped to the tile."""
    half = 0.5 * kp.d
    xi = kp.R * math.sin(s / kp.R - math.asin(half / kp.R))
    return clamp(xi, -half, half)


@njit(cache=True, fastmath=FMA, inline="always")
def normal_velocity(xi, S, vx, vy, R):
    """Components (V_n, V_t) of a velocity (vx, vy) along n = (xi, S)/R and t = (S, -xi)/R.

    Multiplied by ``1 / R``, not divided by R: a division fewer on each bounce's chain (the
    reciprocal is hoisted out of the event loop)."""
    inv_R = 1.0 / R
    return (vx * xi + vy * S) * inv_R, (vx * S - vy * xi) * inv_R


@njit(cache=True, fastmath=FMA, inline="always")
def from_normal_velocity(xi, S, vn, vt, R):
    """Cartesian (vx, vy) of the velocity with components (V_n, V_t) at ``xi``."""
    inv_R = 1.0 / R
    return (vn * xi + vt * S) * inv_R, (vn * S - vt * xi) * inv_R


@njit(cache=True, fastmath=FMA, inline="always")
def bounce(xi, vx, vyrel, kp):
    """Restitution law at the arc point ``xi`` (docs/model.md §2).

    Parameters
    ----------
    xi : float
        Local coordinate of the contact (mm), in [-d/2, d/2].
    vx, vyrel : float
        Particle velocity relative to the floor just before the contact (mm/s);
        the floor moves vertically only, so ``vx`` is also the absolute one.
    kp : KernelParams

    Returns
    -------
    vx, vyrel, vn, vt : float
        Relative velocity after the contact (mm/s) and its normal and tangential
        components, ``V_n+ = -alpha V_n-`` and ``V_t+ = beta V_t-``.
    """
    return bounce_at(xi, arc_root(xi, kp), vx, vyrel, kp)


@njit(cache=True, fastmath=FMA, inline="always")
def bounce_at(xi, S, vx, vyrel, kp):
    """``bounce`` with ``S = arc_root(xi)`` (mm) already known to the caller."""
    vn, vt = normal_velocity(xi, S, vx, vyrel, kp.R)
    vn = -kp.alpha * vn
    vt = kp.beta * vt
    vx_new, vy_new = from_normal_velocity(xi, S, vn, vt, kp.R)
    return vx_new, vy_new, vn, vt


@njit(cache=True, fastmath=FMA)
def arc_coordinates(xi, kp):
    """Arc length s and height b (mm) of every local coordinate in the array ``xi``."""
    s = np.empty_like(xi)
    b = np.empty_like(xi)
    for i in range(xi.shape[0]):
        s[i] = arc_length(xi[i], kp)
        b[i] = floor_height_rel(xi[i], kp)
    return s, b
