"""Cubic safe steps of the billiard's first-contact search (issue 12) against the quadratic rule.

``flight_rule(..., cubic=False)`` (``quadratic_flight``, ``tests/flight_rules.py``) is the
previous search (global curvature bound M); the kernel uses the cubic rule (``cubic=True``).
Both must find the same contact (the first one: no step may pass it), at the same time within
the stated error, checked against the mpmath reference; in non-chaotic runs the event
sequences coincide.
"""

import numpy as np
import pytest
from flight_rules import event_rule, flight_rule
from numba import njit

from bbdyn import Params
from bbdyn.core.billiard import billiard_flight
from bbdyn.core.status import IMPACT, OK
from bbdyn.core.tolerances import IMPACT_TIME_TOL
from bbdyn.scenes.b2_billiard import CASE, _reference

FREQUENCIES = (50.2, 58.0, 70.0, 85.2)
#: Non-chaotic at these frequencies from CASE's start: 1e4 events follow one orbit.
REGULAR = (50.2, 58.0)
N_EVENTS = 10_000


@njit(cache=True)
def run_rule(state, kp, cubic, out):
    """``N`` events of ``event_rule`` from ``state``; rows of ``out``: periods + phase
    / 2 pi, tile, xi, vx, vyrel, kind.  Returns the status."""
    periods, phase, tile, xi, vx, vyrel = state[0], state[1], state[2], state[3], state[4], state[5]
    kind = int(state[6])
    for i in range(out.shape[1]):
        periods, phase, tile, xi, vx, vyrel, kind, status = event_rule(
            periods, phase, tile, xi, vx, vyrel, kind, kp, cubic
        )
        if status != OK:
            return status
        out[0, i] = periods + phase / (2.0 * np.pi)
        out[1, i], out[2, i], out[3, i], out[4, i], out[5, i] = tile, xi, vx, vyrel, kind
    return OK


@njit(cache=True)
def flights_both(starts, kp, out):
    """Both rules from each start (rows phase, xi, vx, vyrel); ``out`` rows: tau, k, steps for
    the quadratic rule, then for the cubic one, then vyrel_minus of each.  Returns the first
    failure status or OK."""
    for i in range(starts.shape[0]):
        for r in range(2):
            tau, k, _, vym, n, status = flight_rule(
                starts[i, 0], starts[i, 1], starts[i, 2], starts[i, 3], kp, r == 1
            )
            if status != OK:
                return status
            out[3 * r, i], out[3 * r + 1, i], out[3 * r + 2, i] = tau, k, n
            out[6 + r, i] = vym
    return OK


def _run(f, cubic):
    kp = Params(f=f).kernel()
    out = np.empty((6, N_EVENTS))
    assert run_rule(np.array(CASE["start"], dtype=float), kp, cubic, out) == OK
    return out


@pytest.fixture(scope="module", params=FREQUENCIES)
def flights(request):
    """Flight starts after the impacts of a quadratic-rule run, and both rules' flights."""
    f = request.param
    run = _run(f, False)
    impacts = run[5] == IMPACT
    starts = np.ascontiguousarray(
        np.stack([2 * np.pi * (run[0] % 1.0), run[2], run[3], run[4]], axis=1)[impacts]
    )
    out = np.empty((8, starts.shape[0]))
    kp = Params(f=f).kernel()
    assert flights_both(starts, kp, out) == OK
    return f, kp, starts, out


def test_same_contact_tile_and_fewer_steps(flights):
    """Every flight ends on the same tile with both rules (none passes the first contact),
    at times agreeing to IMPACT_TIME_TOL, with velocities before the contact agreeing to
    what that time error makes (|G''| <= M), and the cubic rule takes fewer steps on average."""
    f, kp, starts, out = flights
    assert starts.shape[0] > 0.9 * N_EVENTS
    np.testing.assert_array_equal(out[4], out[1])
    assert np.max(np.abs(out[3] - out[0])) <= IMPACT_TIME_TOL
    assert np.max(np.abs(out[7] - out[6])) <= kp.curv_bound * IMPACT_TIME_TOL
    assert out[5].mean() < out[2].mean()


def test_cubic_times_match_mpmath(flights):
    """The cubic rule's flight times agree with the mpmath root within IMPACT_TIME_TOL, as
    the quadratic rule's do (the flights where the two rules differ most, and random ones)."""
    _, kp, starts, out = flights
    diff = np.abs(out[3] - out[0])
    pick = np.concatenate(
        [np.argsort(-diff)[:8], np.random.default_rng(0).choice(diff.size, 8, replace=False)]
    )
    ref = _reference(kp, np.ascontiguousarray(starts[pick]), out[4, pick], out[3, pick])
    assert np.max(np.abs(out[3, pick] - ref[:, 0])) <= IMPACT_TIME_TOL
    assert np.max(np.abs(out[0, pick] - ref[:, 0])) <= IMPACT_TIME_TOL


@pytest.mark.parametrize("f", REGULAR)
def test_regular_run_same_events(f):
    """1e4 events where the dynamics is not chaotic: the same kinds, counts and tiles, event
    times within IMPACT_TIME_TOL (s) and velocities within what that time error makes."""
    quad, cub = _run(f, False), _run(f, True)
    np.testing.assert_array_equal(cub[5], quad[5])
    np.testing.assert_array_equal(cub[1], quad[1])
    assert np.max(np.abs(cub[0] - quad[0])) / f <= IMPACT_TIME_TOL
    kp = Params(f=f).kernel()
    dv = np.max(np.abs(cub[3:5] - quad[3:5]))
    assert dv <= kp.curv_bound * IMPACT_TIME_TOL


def test_flight_start_in_every_phase_same_contact():
    """Random starts (all phases, both directions, from wedges to tops) at 85.2 Hz: same tile,
    times within IMPACT_TIME_TOL."""
    kp = Params(f=85.2).kernel()
    rng = np.random.default_rng(12)
    n = 4000
    phase = rng.uniform(0, 2 * np.pi, n)
    xi = rng.uniform(-0.5, 0.5, n) * kp.d
    vx = rng.normal(0, 30, n)
    vy = np.abs(rng.normal(0, 80, n)) + 1e-3 + np.abs(vx * xi) / kp.R  # leaves the arc
    starts = np.ascontiguousarray(np.stack([phase, xi, vx, vy], axis=1))
    out = np.empty((8, n))
    assert flights_both(starts, kp, out) == OK
    np.testing.assert_array_equal(out[4], out[1])
    assert np.max(np.abs(out[3] - out[0])) <= IMPACT_TIME_TOL
    tau, k = billiard_flight(*starts[0], kp)[:2]
    assert (tau, k) == (out[3, 0], out[4, 0])
