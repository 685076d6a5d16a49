"""Invariant checks shared by the billiard tests (not a test module itself)."""

import math

import numpy as np
from numba import njit

from bbdyn.core.billiard import EventArrays, EventState, billiard_run, flight_gap
from bbdyn.core.floor import floor_height_rel
from bbdyn.core.status import IMPACT, RELEASE, STICK
from bbdyn.core.tolerances import EPS, GAP_REL_TOL

TWO_PI = 2.0 * math.pi


@njit(cache=True)
def flight_violations(periods, phase, xi, vx, vyrel, kind, kp, n_samples):
    """Worst scaled gap violations of a recorded run.

    For every flight that ends in an impact (a flight ending in STICK contains
    the summed chattering sequence and is not one parabola), the gap at
    ``n_samples`` interior times must be >= -tol and the gap at the recorded
    contact must be 0 within tol; tol is ``GAP_REL_TOL`` times the magnitude of
    the gap's terms (plus the rounding of the recorded phase times |G'|).
    Returns ``(worst_interior, worst_end, n_backwards)``: gaps in units of tol
    (<= 1 means fine) and the number of events whose time goes backwards.
    """
    worst_in = 0.0
    worst_end = 0.0
    back = 0
    for i in range(phase.shape[0] - 1):
        dt = ((periods[i + 1] - periods[i]) * TWO_PI + (phase[i + 1] - phase[i])) / kp.w
        if dt < 0.0:
            back += 1
        if kind[i] == STICK or kind[i + 1] == STICK:
            continue
        scale_v = abs(vyrel[i]) + kp.g * dt + kp.A * kp.w + abs(vx[i]) * kp.d / kp.c0
        scale = scale_v * dt + kp.A + floor_height_rel(0.0, kp)
        ulp_t = 8.0 * (TWO_PI * max(periods[i + 1], 1.0)) / kp.w * 2.2e-16
        tol = GAP_REL_TOL * scale + scale_v * ulp_t
        for j in range(1, n_samples + 1):
            tau = dt * j / (n_samples + 1.0)
            G = flight_gap(phase[i], xi[i], vx[i], vyrel[i], tau, kp)
            worst_in = max(worst_in, -G / tol)
        if kind[i + 1] == IMPACT:
            G = flight_gap(phase[i], xi[i], vx[i], vyrel[i], dt, kp)
            worst_end = max(worst_end, abs(G) / tol)
    return worst_in, worst_end, back


def run_arrays(kp, state0, n_events):
    """Run the kernel from ``state0`` and return the arrays (row 0 = state0) and status."""
    n = n_events + 1
    out = [np.empty(n) for _ in range(6)] + [np.empty(n, dtype=np.int64)]
    for a, v in zip(out, state0, strict=True):
        a[0] = v
    rows = EventArrays(*(a[1:] for a in out))
    _, n_done, status = billiard_run(EventState(*state0), kp, n_events, rows)
    return [a[: n_done + 1] for a in out], status


def release_window_phases(gamma):
    """``(theta_r, theta_e)`` of the window sin(theta) < -1/Gamma, from the closed form."""
    a = math.asin(1.0 / gamma)
    return math.pi + a, TWO_PI - a


def stick_phase(gamma, where):
    """A stick phase named ``where``: at theta_r, mid-window, 4 ulp before or after theta_e."""
    theta_r, theta_e = release_window_phases(gamma)
    return {
        "theta_r": theta_r,
        "middle": 0.5 * (theta_r + theta_e),
        "just_before_theta_e": theta_e * (1 - 4 * EPS),
        "theta_e": theta_e * (1 + 4 * EPS),
    }[where]


STICK_PHASES = ["theta_r", "middle", "just_before_theta_e", "theta_e"]


def window_sticks(phase, kind, gamma):
    """Indices of the sticks inside the release window ``theta_r <= phase < theta_e``."""
    if gamma <= 1.0:
        return np.empty(0, dtype=np.int64)
    theta_r, theta_e = release_window_phases(gamma)
    return np.flatnonzero((kind == STICK) & (theta_r <= phase) & (phase < theta_e))


def late_sticks(periods, phase, kind, gamma):
    """Number of sticks inside the release window not followed at once by their release.

    A stick at ``theta_r <= phase < theta_e`` (the floor falls faster than g) lasts zero
    time: the next event must be a RELEASE at the same ``(periods, phase)``.
    """
    i = window_sticks(phase[:-1], kind[:-1], gamma)
    ok = (kind[i + 1] == RELEASE) & (periods[i + 1] == periods[i]) & (phase[i + 1] == phase[i])
    return int(np.count_nonzero(~ok))
