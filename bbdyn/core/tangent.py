"""Tangent dynamics of the exact flat-ball impact map (docs/lyapunov.md), numba kernels.

The state just after an event is ``(theta, vrel)`` (phase in rad, lifted: the
map adds ``w tau``; relative velocity in mm/s).  A tangent vector is carried
from impact to impact by the Jacobian of the exact map
(``core.flat_jacobian.flat_map_jacobian_entries``: implicit-function theorem on
the gap, flight and impact in one matrix).  Two tangent vectors are kept
orthonormal by Gram-Schmidt after every impact (the QR method); the logs of the
diagonal of R add up to the two Lyapunov exponents.

Sticking.  A chattering sequence that accumulates (or an impact at zero relative
speed where the plate holds the particle) ends in a stick, and the stick ends at
the release phase ``theta_r`` fixed by Gamma alone (``core.plate.stick_release``;
the accumulation point has ``g_eff > 0``, so it lies outside the release window
and the stick never lasts zero time).  The state after the release therefore
does not depend on the state before the stick: the tangent map of the whole
stick is the zero matrix, a factor ``log 0 = -inf`` in the growth.  The kernels
count such *collapses* instead of adding ``-inf``, and keep the finite growth
between collapses as well (the *conditional* exponent): the frame restarts with
the identity at the first impact after the release.  Not at the release itself:
at ``theta_r`` the floor's acceleration is ``-g``, so a particle released later
flies the same flight to first order (its position and velocity differ by
``O(dtheta^2)``); the phase column of the release flight's Jacobian is 0, and the
velocity column acts on a perturbation a release never has (it leaves at zero
relative velocity).  Carried through it, the identity's first column would
contribute ``log`` of a rounding error per stick, whatever the dynamics, instead
of the growth between sticks.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from bbdyn.core.flat import flat_event
from bbdyn.core.flat_jacobian import flat_map_jacobian_entries
from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import IMPACT, OK, RELEASE, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import FMA


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def gram_schmidt_2(q00, q10, q01, q11, j00, j01, j10, j11):
    """One QR step of the 2D frame: ``J Q = Q' R``.

    ``Q`` has columns ``(q00, q10)`` and ``(q01, q11)`` (orthonormal).  Returns
    the new columns and ``log R[0, 0], log R[1, 1]`` (dimensionless; ``-inf``
    when a column vanishes).  The second diagonal entry comes from the
    projection (not from the determinant), so that the sum of the two logs is an
    independent check of ``log |det J|``.
    """
    a0 = j00 * q00 + j01 * q10
    a1 = j10 * q00 + j11 * q10
    b0 = j00 * q01 + j01 * q11
    b1 = j10 * q01 + j11 * q11
    r00 = math.hypot(a0, a1)
    e0, e1 = a0 / r00, a1 / r00
    r01 = e0 * b0 + e1 * b1
    c0, c1 = b0 - r01 * e0, b1 - r01 * e1
    r11 = math.hypot(c0, c1)
    return e0, e1, c0 / r11, c1 / r11, math.log(r00), math.log(r11)


@njit(cache=True, fastmath=FMA, inline="always", error_model="numpy")
def event_time(periods, phase):
    """Time of an event in driving periods (float)."""
    return periods + phase / TWO_PI


class TangentWindows(NamedTuple):
    """Output arrays of a tangent run (``flat_tangent_run``, ``billiard_tangent_run``), one
    entry per window."""

    log: np.ndarray  # sums of the logarithms of the growth factors
    collisions: np.ndarray  # int64: impacts (flat ball), IMPACT and STICK events (billiard)
    collapses: np.ndarray  # int64: collapses of the tangent vector (sticks)
    time: np.ndarray  # driving periods of the window's last event


@njit(cache=True, fastmath=FMA, error_model="numpy")
def flat_tangent_run(state, kp, t_ends, frame, out):
    """Advance one flat ball through events with its tangent frame, window by window.

    Parameters
    ----------
    state : tuple
        State ``(periods, phase, vrel, kind)`` of the current event (``core.flat.flat_event``).
    kp : KernelParams
    t_ends : ndarray (n_windows,)
        Ends of the windows in driving periods, increasing.  An event belongs to
        the first window whose end is not before it; the run stops at the first
        event after ``t_ends[-1]``.
    frame : ndarray (4,)
        Orthonormal frame ``(q00, q10, q01, q11)`` (in/out).
    out : TangentWindows
        Per window: ``log`` (n_windows, 2), the sums of ``log R[0, 0]`` and ``log R[1, 1]``
        over its impacts, and ``collisions`` (impacts carried by the Jacobian) and
        ``collapses`` (sticks), added to; ``time`` (driving periods) of its last event
        (overwritten; untouched for a window without events).

    Returns
    -------
    (state, status)
        The last event; ``status`` is ``OK``, ``STUCK_FOREVER`` (Gamma <= 1: stuck
        for good, counted as a collapse, the windows after it have no events) or
        a failure status of ``flat_event``.
    """
    periods, phase, vrel, kind = state
    out_log, out_impacts, out_collapses, out_time = out
    q00, q10, q01, q11 = frame[0], frame[1], frame[2], frame[3]
    n_w = t_ends.shape[0]
    j = 0
    t = event_time(periods, phase)
    while j < n_w and t > t_ends[j]:
        j += 1
    status = OK
    j00 = j01 = j10 = j11 = 0.0
    while j < n_w:
        collapse = kind == STICK
        released = kind == RELEASE
        if not (collapse or released):
            _, _, j00, j01, j10, j11, status = flat_map_jacobian_entries(phase, vrel, kp)
            if status != OK:
                break
        periods, phase, vrel, kind, status = flat_event(periods, phase, vrel, kind, kp)
        if status == STUCK_FOREVER:
            out_collapses[j] += 1
            out_time[j] = t
            break
        if status != OK:
            break
        t = event_time(periods, phase)
        while j < n_w - 1 and t > t_ends[j]:
            j += 1
        if collapse or kind == STICK:
            # the state after the stick's release does not depend on the state before it
            out_collapses[j] += 1
            q00, q10, q01, q11 = 1.0, 0.0, 0.0, 1.0
        elif kind == IMPACT:
            if released:  # nor does this landing, to first order (module docstring): restart
                q00, q10, q01, q11 = 1.0, 0.0, 0.0, 1.0
            else:
                q00, q10, q01, q11, l0, l1 = gram_schmidt_2(
                    q00, q10, q01, q11, j00, j01, j10, j11
                )
                out_log[j, 0] += l0
                out_log[j, 1] += l1
            out_impacts[j] += 1
        out_time[j] = t
        if t > t_ends[j]:
            j += 1
    frame[0], frame[1], frame[2], frame[3] = q00, q10, q01, q11
    return (periods, phase, vrel, kind), status
