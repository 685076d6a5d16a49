"""Exact integrals over flights and stuck intervals (bbdyn/core/observables.py).

Checked against scipy quadrature of the same closed-form motion, against the
harmonic closed form of a particle glued to the floor, and against identities
(additivity, conservation of E in flight).
"""

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import IntegrationWarning, quad

from bbdyn.core.observables import (
    displacement,
    flight_integrals,
    is_before,
    stuck_integrals,
    time_between,
    trap_of,
)
from bbdyn.core.tolerances import OBS_INTEGRAL_REL_TOL, QUAD_REL_TOL

G = 9800.0
A = 0.1

FLIGHTS = {
    "long_high_flight": (35.0, 120.0, 0.01, 0.0, 0.024),
    "sub_interval": (-12.0, 80.0, -0.05, 0.003, 0.011),
    "tiny_hop": (0.3, 0.02, 0.015, 0.0, 4e-6),
    "tiny_piece_late": (5.0, 60.0, 0.0, 0.0100, 0.0100001),
    "falling_only": (1.0, -5.0, 0.2, 0.0, 0.002),
}


def _quad(fun, a, b):
    # quad warns when rounding stops it short of QUAD_REL_TOL over several periods of an
    # oscillating integrand; the comparisons below bound the remaining difference anyway.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IntegrationWarning)
        value, _ = quad(fun, a, b, epsabs=0.0, epsrel=QUAD_REL_TOL, limit=200)
    return value


@pytest.mark.parametrize(("vx", "vy0", "y0", "ta", "tb"), FLIGHTS.values(), ids=FLIGHTS.keys())
def test_flight_integrals_match_quadrature(vx, vy0, y0, ta, tb):
    I_Ex, I_Ey, I_pot = flight_integrals(vx, vy0, y0, G, ta, tb)
    ref_Ey = _quad(lambda t: 0.5 * (vy0 - G * t) ** 2, ta, tb)
    ref_pot = _quad(lambda t: G * (y0 + vy0 * t - 0.5 * G * t * t), ta, tb)
    assert I_Ex == pytest.approx(0.5 * vx * vx * (tb - ta), rel=OBS_INTEGRAL_REL_TOL)
    assert I_Ey == pytest.approx(ref_Ey, rel=OBS_INTEGRAL_REL_TOL)
    # g y changes sign in some flights: compare on the scale of |g y|
    scale = _quad(lambda t: abs(G * (y0 + vy0 * t - 0.5 * G * t * t)), ta, tb)
    assert abs(I_pot - ref_pot) <= OBS_INTEGRAL_REL_TOL * scale


@pytest.mark.parametrize(("vx", "vy0", "y0", "ta", "tb"), FLIGHTS.values(), ids=FLIGHTS.keys())
def test_total_energy_is_constant_in_flight(vx, vy0, y0, ta, tb):
    E = 0.5 * (vx * vx + vy0 * vy0) + G * y0
    total = sum(flight_integrals(vx, vy0, y0, G, ta, tb))
    scale = (0.5 * (vx * vx + vy0 * vy0) + G * abs(y0) + 0.5 * G * G * tb * tb) * (tb - ta)
    assert abs(total - E * (tb - ta)) <= OBS_INTEGRAL_REL_TOL * scale


def test_flight_integrals_are_additive():
    rng = np.random.default_rng(1)
    for _ in range(200):
        vx, vy0 = rng.uniform(-50, 50), rng.uniform(-10, 150)
        y0 = rng.uniform(-0.1, 0.1)
        ta, tm, tb = np.sort(rng.uniform(0, 0.03, 3))
        whole = np.array(flight_integrals(vx, vy0, y0, G, ta, tb))
        parts = np.array(flight_integrals(vx, vy0, y0, G, ta, tm)) + np.array(
            flight_integrals(vx, vy0, y0, G, tm, tb)
        )
        scale = np.abs(whole) + 0.5 * G * G * tb**3 + G * abs(y0) * tb
        assert np.all(np.abs(whole - parts) <= OBS_INTEGRAL_REL_TOL * scale)


STUCK = {
    "quarter_period": (58.0, 0.3, 0.25),
    "from_release_window": (85.2, 4.2, 0.1),
    "tiny_interval": (70.0, 1.0, 1e-7),
    "several_periods_gamma_below_one": (40.0, 2.0, 3.6),
}


@pytest.mark.parametrize(("f", "phase_a", "periods"), STUCK.values(), ids=STUCK.keys())
def test_stuck_integrals_match_quadrature(f, phase_a, periods):
    w = 2 * math.pi * f
    b = 0.013
    dt = periods / f
    I_Ey, I_pot = stuck_integrals(A, w, G, b, phase_a, dt)
    ref_Ey = _quad(lambda t: 0.5 * (A * w * math.cos(phase_a + w * t)) ** 2, 0, dt)
    ref_pot = _quad(lambda t: G * (b - A * math.sin(phase_a + w * t)), 0, dt)
    assert I_Ey == pytest.approx(ref_Ey, rel=OBS_INTEGRAL_REL_TOL)
    scale = G * (b + A) * dt
    assert abs(I_pot - ref_pot) <= OBS_INTEGRAL_REL_TOL * scale


@pytest.mark.parametrize("phase_a", [0.0, 1.0, 4.5, 6.2])
def test_glued_particle_has_the_harmonic_period_averages(phase_a):
    # Over a whole period: <u^2/2> = A^2 w^2 / 4 and <g y> = g b (the mean of -g A sin is 0).
    f, b = 85.2, 0.007
    w = 2 * math.pi * f
    I_Ey, I_pot = stuck_integrals(A, w, G, b, phase_a, 1.0 / f)
    assert I_Ey * f == pytest.approx(A * A * w * w / 4, rel=OBS_INTEGRAL_REL_TOL)
    assert abs(I_pot * f - G * b) <= OBS_INTEGRAL_REL_TOL * G * A


def test_time_differences_keep_precision_in_long_runs():
    f = 85.2
    w, period = 2 * math.pi * f, 1 / f
    # 1e7 periods in: the difference of two nearby times is exact to rounding of the phases.
    dt = time_between(1e7 + 1.0, 0.5, 1e7, 6.0, w, period)
    assert dt == pytest.approx((2 * math.pi + 0.5 - 6.0) / w, rel=8 * OBS_INTEGRAL_REL_TOL)
    assert is_before(3.0, 6.2, 4.0, 0.1)
    assert not is_before(4.0, 0.1, 4.0, 0.1)
    assert is_before(4.0, 0.1, 4.0, 0.2)


@pytest.mark.parametrize(
    ("tile", "xi", "trap"),
    [(0.0, -0.3, 0.0), (0.0, 0.3, 1.0), (-5.0, -1.0, -5.0), (-5.0, 0.0, -4.0), (7.0, 1.0, 8.0)],
    ids=["left_half", "right_half", "left_wedge", "bump_top_goes_right", "right_wedge"],
)
def test_traps_are_bounded_by_bump_tops(tile, xi, trap):
    assert trap_of(tile, xi) == trap


def test_displacement_over_a_million_tiles_keeps_sub_nanometre_precision():
    d = 2.0
    assert displacement(1e6, 0.25, 0.0, -0.5, d) == 2e6 + 0.75
    assert displacement(-3.0, 1e-12, -3.0, 0.0, d) == 1e-12
