"""Tiny hops solved from the Taylor polynomial of their gap (core.billiard.tiny_hop).

The chattering hops that are most of the events at 50-80 Hz are solved by Newton on the
polynomial instead of the safe-step search.  Checked against the contact found in mpmath
from the same float64 inputs, against the independent quadratic-step search, and on the
cases it must refuse (a hop over a wedge, a floor falling faster than g, a long flight).

The error measure: the gap rate ``G'(0) = vyrel + vx xi0 / S0`` is a difference, so the
contact time of a hop inherits its relative rounding, ``eps (|vyrel| + |vx xi0| / S0) /
G'(0)`` (``cond`` below); every method, mpmath included, sees the same float64 inputs.
"""

import math

import numpy as np
import pytest
from flight_rules import both_rules, flight_starts, random_starts, rate_cond

from bbdyn import Params
from bbdyn.core.billiard import billiard_flight, tiny_hop
from bbdyn.core.status import OK
from bbdyn.core.tolerances import EPS

FREQS = (50.2, 70.2, 85.2)


def _starts(f, n_max=4000):
    kp, starts = flight_starts(f, True, n_max, 20 * n_max)
    assert len(starts) > 100  # chattering is there to be tested
    return kp, starts


@pytest.mark.parametrize("f", FREQS)
def test_tiny_hops_land_where_mpmath_finds_the_contact(f):
    from bbdyn.reference.billiard_mpmath import reference_flight

    kp, starts = _starts(f)
    pick = starts[np.random.default_rng(0).choice(len(starts), 30, replace=False)]
    for phase, xi0, vx, vyrel in pick:
        tau, k, _, _, n_steps, status = billiard_flight(phase, xi0, vx, vyrel, kp)
        assert status == OK and n_steps == 0 and k == 0.0
        ref = reference_flight(kp, phase, xi0, vx, vyrel, k, tau)[0]
        assert abs(tau - ref) <= 4 * EPS * ref * (1 + rate_cond(kp, xi0, vx, vyrel))


@pytest.mark.parametrize("f", FREQS)
def test_tiny_hops_agree_with_the_safe_step_search(f):
    kp, starts = _starts(f)
    out = np.zeros((len(starts), 11))
    both_rules(starts, kp, out)
    assert np.all(out[:, 5] == OK) and np.all(out[:, 10] == OK)
    assert np.array_equal(out[:, 1], out[:, 7])  # same tile
    phase, xi0, vx, vyrel = starts.T
    cond = rate_cond(kp, xi0, vx, vyrel)
    # each search is within a few eps tau (1 + cond) of the contact (the search stops at
    # ROOT_STEP_REL = 2 eps of the flight time)
    assert np.all(np.abs(out[:, 0] - out[:, 6]) <= 16 * EPS * out[:, 6] * (1 + cond))
    assert np.all(np.abs(out[:, 2] - out[:, 8]) <= 4 * EPS * kp.d)
    # vyrel^- = F'(tau): moved by the time difference (F'' <= g + A w^2) and by rounding
    scale = np.abs(vyrel) + (kp.g + kp.A * kp.w**2) * out[:, 6] * (1 + cond)
    assert np.all(np.abs(out[:, 3] - out[:, 9]) <= 64 * EPS * scale)


def test_tiny_hop_refuses_what_it_cannot_prove():
    kp = Params(f=70.0).kernel()
    half = 0.5 * kp.d

    def attempt(phase, xi0, vx, vyrel):
        S0 = math.sqrt((kp.R - xi0) * (kp.R + xi0))
        Gp = vyrel + vx * xi0 / S0
        return tiny_hop(math.sin(phase), math.cos(phase), xi0, S0, vx, vyrel, Gp, kp)[3]

    assert attempt(1.0, 0.2, 0.5, 1e-3)  # a chattering hop on the arc: solved
    # the same hop next to the wedge, moving over it: refused (and found on the next tile)
    assert not attempt(1.0, half - 1e-12, 0.5, 1e-3)
    tau, k = billiard_flight(1.0, half - 1e-12, 0.5, 1e-3, kp)[:2]
    assert k == 1.0 and tau > 0.0
    # the floor falling faster than g (sin(phase) < -1/Gamma): G is convex, refused
    assert not attempt(-math.pi / 2, 0.2, 0.5, 1e-3)
    # a long flight: the polynomial's remainder would move the contact, refused
    assert not attempt(1.0, 0.2, 0.5, 50.0)
    # just before the release phase the floor's pull g + A w^2 sin is still (barely) down,
    # but it turns up within the hop the parabola predicts: not provably concave, refused;
    # the search finds the particle carried away, far beyond that hop
    theta = math.pi + math.asin(1.0 / kp.gamma) - 1e-3
    assert not attempt(theta, 0.0, 0.0, 3e-4)
    tau0 = 6e-4 / (kp.g + kp.A * kp.w**2 * math.sin(theta))
    assert billiard_flight(theta, 0.0, 0.0, 3e-4, kp)[0] > 10 * tau0


@pytest.mark.parametrize(
    "params",
    [Params(f=70.0, R=1.2), Params(f=70.0, R=1e9), Params(f=45.0), Params(f=90.0, A=1.0)],
    ids=["steep_arcs", "flat_limit", "gamma_below_1", "large_amplitude"],
)
def test_random_hops_on_hard_floors(params):
    """Random hops (normal velocities 1e-9 to 1 mm/s, tangential 1e-6 to 1e2 mm/s, any phase,
    200 next to a wedge): tiny_hop agrees with the quadratic-step search everywhere, and with
    mpmath where they differ most, within what rounding allows.  Besides the cancellation in
    G'(0) (``cond``), near the release phase G''(0) = -g - A w^2 sin + R^2 vx^2 / S^3 is a
    difference too: ``cond_g`` = the sum of its magnitudes over its value."""
    from bbdyn.reference.billiard_mpmath import reference_flight

    kp = params.kernel()
    n = 20000
    phase, xi, vx, vyrel = random_starts(kp, 5, n, (-9, 0)).T
    S = np.sqrt((kp.R - xi) * (kp.R + xi))
    out = np.zeros((n, 11))
    both_rules(np.stack([phase, xi, vx, vyrel], 1), kp, out)
    assert np.all(out[:, 5] == OK) and np.all(out[:, 10] == OK)
    tiny = out[:, 4] == 0
    assert tiny.sum() > n / 3  # most of these short hops are solved from the polynomial
    assert np.array_equal(out[:, 1], out[:, 7])  # same tiles
    arc = kp.R**2 * vx**2 / S**3
    aw2 = kp.A * kp.w**2
    cond_g = (kp.g + aw2 * np.abs(np.sin(phase)) + arc) / np.abs(-kp.g - aw2 * np.sin(phase) + arc)
    scale = EPS * out[:, 6] * (1 + rate_cond(kp, xi, vx, vyrel) + cond_g)
    excess = np.abs(out[:, 0] - out[:, 6]) / scale
    assert excess[tiny].max() <= 4.0
    for i in np.argsort(-np.where(tiny, excess, 0.0))[:4]:
        ref = reference_flight(kp, phase[i], xi[i], vx[i], vyrel[i], out[i, 1], out[i, 0])[0]
        assert abs(out[i, 0] - ref) <= 4 * scale[i] * ref / out[i, 6]
