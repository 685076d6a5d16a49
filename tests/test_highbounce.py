"""High-bounce (dissipative standard map) approximation and its error against the exact map."""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.flat import FlatArrays, FlatState, flat_run
from bbdyn.core.status import IMPACT, OK
from bbdyn.flat.highbounce import (
    flight_phase_error,
    hb_gamma_hi,
    hb_jacobian,
    hb_run,
    tongue_errors,
)
from bbdyn.flat.tongues import (
    k1_cos_phase,
    k1_orbit,
    params_at_gamma,
    tongue_gamma_hi,
    tongue_gamma_lo,
)


def _slope(xs, ys):
    return np.polyfit(np.log(xs), np.log(np.abs(ys)), 1)[0]


@pytest.mark.parametrize("k", [1, 2, 3])
def test_k1_orbit_of_the_map_is_the_closed_form_and_has_the_predicted_edges(k):
    alpha = 0.5
    lo, hi = tongue_gamma_lo(k, alpha), hb_gamma_hi(k, alpha)
    for gamma, stable in [(lo * 1.01, True), (hi * 0.999, True), (hi * 1.001, False)]:
        theta = 2 * math.pi - math.acos(k1_cos_phase(k, gamma, alpha))
        out_phase, out_V = np.empty(20000), np.empty(20000)
        n = hb_run(theta + 1e-6, 2 * math.pi * k, gamma, alpha, out_phase, out_V)
        assert n == 20000
        # the closed-form point is a fixed point: (theta + 2 pi k, V) -> same
        lam = np.abs(np.linalg.eigvals(hb_jacobian(theta, gamma, alpha)))
        assert (max(lam) < 1) == stable
        assert (abs(out_phase[-1] - theta) < 1e-9) == stable
        assert np.prod(lam) == pytest.approx(alpha, rel=1e-12)


def test_upper_edge_error_vanishes_like_one_over_k_squared():
    ks = np.array([4, 8, 16, 32])
    errors = [tongue_errors(int(k), 0.5)["gamma_hi"] for k in ks]
    assert all(e < 0 for e in errors)  # the approximation closes the tongue too early
    assert _slope(ks, errors) == pytest.approx(-2.0, abs=0.05)


def test_upper_edge_error_vanishes_like_one_minus_alpha_squared():
    gaps = np.array([1e-1, 5e-2, 2.5e-2, 1.25e-2])
    errors = [tongue_errors(1, 1 - gap)["gamma_hi"] for gap in gaps]
    assert _slope(gaps, errors) == pytest.approx(2.0, abs=0.1)
    assert tongue_errors(1, 1.0)["gamma_hi"] == 0.0


def test_lower_edge_and_k1_phases_agree_with_the_exact_map():
    # same fold, and the exact map's k/1 phase solves the high-bounce fixed-point equation
    assert tongue_errors(2, 0.3)["gamma_lo"] == 0.0
    p = params_at_gamma(2.5, alpha=0.5)
    o = k1_orbit(p, 1)
    assert math.cos(o.phase_stable) == pytest.approx(k1_cos_phase(1, 2.5, 0.5), rel=1e-15)
    assert 2 * p.w * o.v / p.g == pytest.approx(2 * math.pi, rel=1e-15)  # V = 2 pi k


def test_flight_phase_error_vanishes_in_the_high_bounce_limit():
    p = Params(f=60.0)
    thetas = np.linspace(0, 2 * math.pi, 64, endpoint=False)
    Vs = np.array([2 * math.pi * (n + 0.25) for n in (10, 20, 40, 80)])
    worst = []
    for V in Vs:
        errs = []
        for theta in thetas:
            vrel = V * p.g / (2 * p.w) + p.A * p.w * math.cos(theta)  # absolute v = V g / 2w
            errs.append(abs(flight_phase_error(p, theta, vrel)))
        worst.append(max(errs))
    assert _slope(Vs, worst) == pytest.approx(-1.0, abs=0.05)
    # leading term 2 Gamma (sin(theta + x) - sin theta) / V, at most 4 Gamma / V
    assert np.all(np.array(worst) * Vs <= 4 * p.gamma * 1.05)


def test_A_to_zero_at_fixed_gamma_is_not_a_limit_the_exact_map_only_depends_on_gamma():
    # named hard case: the brief's proposed limit; the exact dynamics is unchanged by it
    runs = []
    for A in (0.1, 1e-3):
        p = params_at_gamma(1.3, alpha=0.5, A=A)
        out = (np.empty(300), np.empty(300), np.empty(300), np.empty(300, np.int64))
        start = FlatState(0.0, 0.3, 2.7 * p.g / p.w, IMPACT)
        _, n, status = flat_run(start, p.kernel(), 300, FlatArrays(*out))
        assert status == OK and n == 300
        runs.append((out[0] + out[1] / (2 * math.pi), out[2] * p.w / p.g))
    # a chaotic transient amplifies rounding, so compare the first 30 impacts
    assert np.allclose(runs[0][0][:30], runs[1][0][:30], rtol=0, atol=1e-9)
    assert np.allclose(runs[0][1][:30], runs[1][1][:30], rtol=1e-9)
    assert tongue_gamma_hi(1, 0.5) - hb_gamma_hi(1, 0.5) > 0.05
