"""Jacobian of the exact flat-ball impact map (docs/model.md §1), a numba kernel.

Used by the periodic-orbit solver and the tongue edges in ``bbdyn.flat.tongues``.
"""

import math

import numpy as np
from numba import njit

from bbdyn.core.flat import flat_flight
from bbdyn.core.plate import sin_minus_x
from bbdyn.core.status import NON_FINITE, OK
from bbdyn.core.tolerances import FMA


@njit(cache=True, fastmath=FMA)
def flat_map_jacobian(phase, vrel, kp):
    """One impact of the exact map and its Jacobian in ``(theta, vrel)``.

    Returns ``(dphase, vrel_new, jac, status)``: ``flat_map_jacobian_entries`` with
    the four entries in a new (2, 2) array (NaN unless ``status`` is ``OK``).
    """
    jac = np.full((2, 2), np.nan)
    x, vrel_new, j00, j01, j10, j11, status = flat_map_jacobian_entries(phase, vrel, kp)
    if status == OK:
        jac[0, 0], jac[0, 1], jac[1, 0], jac[1, 1] = j00, j01, j10, j11
    return x, vrel_new, jac, status


@njit(cache=True, fastmath=FMA)
def flat_map_jacobian_entries(phase, vrel, kp):
    """One impact of the exact map and its Jacobian in ``(theta, vrel)``.

    Implicit function theorem on the gap ``G(tau; theta, vrel) = vrel tau - g tau^2/2
    - rise(tau; theta) = 0`` (``core/flat.py``): ``dG/dtau = vrel-``,
    ``dG/dvrel = tau``, ``dG/dtheta = -(u(t+tau) - u(t) - a(t) tau) / w`` with the
    plate acceleration ``a = A w^2 sin(w t)``.  Differences of plate velocities
    and accelerations are written without cancellation, so short (chattering)
    flights are as accurate as long ones.

    Returns
    -------
    dphase : float
        Phase advance ``w tau`` (rad, not reduced mod 2 pi: the "lifted" map).
    vrel_new : float
        ``-alpha vrel-`` (mm/s).
    j00, j01, j10, j11 : float
        ``d(theta + dphase, vrel_new) / d(theta, vrel)`` by rows (no allocation:
        the tangent kernels call this once per impact).
    status : int
        ``OK``, a status of ``flat_flight``, or ``NON_FINITE`` for a grazing landing
        (``vrel- = 0``, where the map is not differentiable).
    """
    nan = math.nan
    tau, vrel_minus, status = flat_flight(phase, vrel, kp)
    if status != OK:
        return nan, nan, nan, nan, nan, nan, status
    if vrel_minus == 0.0:
        return nan, nan, nan, nan, nan, nan, NON_FINITE
    A, w, g = kp.A, kp.w, kp.g
    x = w * tau
    s0 = math.sin(phase)
    c0 = math.cos(phase)
    sin_x = math.sin(x)
    sin_half = math.sin(0.5 * x)
    a1 = A * w * w * math.sin(phase + x)
    # u(t+tau) - u(t) - a(t) tau, and a(t+tau) - a(t)
    du_lin = A * w * (2.0 * c0 * sin_half * sin_half + s0 * sin_minus_x(x))
    da = A * w * w * (c0 * sin_x - 2.0 * s0 * sin_half * sin_half)
    dtau_dtheta = du_lin / (w * vrel_minus)
    dtau_dvrel = -tau / vrel_minus
    j00 = 1.0 + w * dtau_dtheta
    j01 = w * dtau_dvrel
    # vrel- = vrel - g tau - (u(t+tau) - u(t))
    j10 = kp.alpha * ((g + a1) * dtau_dtheta + da / w)
    j11 = -kp.alpha * (1.0 - (g + a1) * dtau_dvrel)
    return x, -kp.alpha * vrel_minus, j00, j01, j10, j11, OK
