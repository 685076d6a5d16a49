"""The fast flat-map kernel keeps its guarantees (issue 2 speed work).

Each speed device is checked against an independent fact: the inlined sin/cos and
sin(x) - x against mpmath, the cubic safe-step search against the plain global
quadratic search (same first root, fewer evaluations), the predicted final G'
against a direct evaluation, and the chattering pre-check against the full test.
"""

import math

import mpmath
import numpy as np
import pytest
from numba import njit

from bbdyn import Params
from bbdyn.core.flat import (
    FlatArrays,
    FlatState,
    chatter_time,
    flat_run,
)
from bbdyn.core.plate import sin_cos, sin_minus_x
from bbdyn.core.search import flat_flight_tol, flat_gap, safe_step
from bbdyn.core.status import IMPACT, OK, STICK
from bbdyn.core.tolerances import CHATTER_REL_TOL, EPS, ROOT_MAX_STEPS, ROOT_STEP_REL


@pytest.mark.parametrize(
    ("lo", "hi"), [(0.0, 7.0), (-7.0, 0.0), (7.0, 1e4)], ids=["one_turn", "negative", "long"]
)
def test_sin_cos_agrees_with_mpmath(lo, hi):
    """Absolute error at most one ulp of 1 (the kernel multiplies them by A)."""
    y = np.random.default_rng(3).uniform(lo, hi, 3000)
    y = np.concatenate([y, [lo, hi, math.pi, math.pi / 2, 3 * math.pi / 2]])
    for v in y:
        s, c = sin_cos(float(v))
        X = mpmath.mpf(float(v))
        assert abs(s - mpmath.sin(X)) <= EPS and abs(c - mpmath.cos(X)) <= EPS, v


def test_sin_cos_small_argument_is_relatively_exact_and_large_falls_back():
    for v in np.geomspace(1e-300, 0.1, 200):
        s, c = sin_cos(float(v))
        assert abs(s - mpmath.sin(mpmath.mpf(float(v)))) <= EPS * s and c <= 1.0
    assert sin_cos(1e7) == (math.sin(1e7), math.cos(1e7))


def test_sin_minus_x_is_relatively_accurate():
    x = np.concatenate([np.linspace(-0.5, 0.5, 4001), np.geomspace(1e-6, 0.4999, 400)])
    with mpmath.workdps(50):
        for v in x[x != 0]:
            X = mpmath.mpf(float(v))
            exact = mpmath.sin(X) - X
            assert abs((sin_minus_x(float(v)) - exact) / exact) <= 4 * EPS, v


@njit(cache=True)
def _plain_flight(phase, vrel, kp):
    """The plain search: global quadratic safe steps with M only, from tau = 0 (no jumps).

    Returns (tau, evaluations); an independent route to the same first root.
    """
    s0, c0 = math.sin(phase), math.cos(phase)
    tau, G, Gp = 0.0, 0.0, vrel
    for n in range(ROOT_MAX_STEPS):
        if G <= 0.0 and tau > 0.0:
            return tau, n
        step = safe_step(G, Gp, kp.curv_bound)
        if step <= ROOT_STEP_REL * tau:
            return tau, n
        tau += step
        G, Gp = flat_gap(vrel, kp.g, kp.A, kp.w, s0, c0, tau)
    return math.nan, ROOT_MAX_STEPS


def _impact_states(f, alpha, n=3000):
    """Post-impact states (phase, vrel) along a long run, after a transient."""
    kp = Params(f=f, alpha=alpha).kernel()
    out = (np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64))
    start = FlatState(0.0, 0.5, 100.0, IMPACT)
    assert flat_run(start, kp, n, FlatArrays(*out))[1:] == (n, OK)
    keep = out[3][100:] == IMPACT
    return kp, out[1][100:][keep], out[2][100:][keep]


@pytest.mark.parametrize(
    ("f", "alpha"),
    [(58.0, 0.5), (85.2, 0.5), (82.0, 0.8), (95.0, 0.5)],
    ids=["tongue_58Hz_chatter", "85.2Hz", "chaotic_82Hz", "95Hz"],
)
def test_cubic_search_finds_the_plain_search_root_with_fewer_evaluations(f, alpha):
    """Same first contact as the global quadratic search (to a few ulp of the flight),
    so no earlier root is skipped, and at most as many gap evaluations in the mean.

    The returned G' (from a Taylor series when the last evaluation is skipped)
    matches G' evaluated at the returned time within rounding of its terms.
    """
    kp, phases, vrels = _impact_states(f, alpha)
    n_fast, n_plain = 0, 0
    for phase, vrel in zip(phases, vrels, strict=True):
        tau, vm, status, n = flat_flight_tol(phase, vrel, kp, ROOT_STEP_REL)
        tau_plain, n_p = _plain_flight(phase, vrel, kp)
        assert status == OK
        s0, c0 = math.sin(phase), math.cos(phase)
        _, Gp = flat_gap(vrel, kp.g, kp.A, kp.w, s0, c0, tau)
        _, Gp_plain = flat_gap(vrel, kp.g, kp.A, kp.w, s0, c0, tau_plain)
        # a contact time off by dt leaves a gap of |G'| dt: the rounding of the gap's
        # terms (a few ulp of vrel tau, g tau^2, A) divided by |G'|
        rounding = 8 * EPS * (vrel * tau + kp.g * tau * tau + 2 * kp.A) / max(abs(Gp), 1e-300)
        assert abs(tau - tau_plain) <= 4 * ROOT_STEP_REL * tau + rounding, (phase, vrel)
        scale = abs(Gp) + vrel + 2 * kp.A * kp.w + kp.g * tau
        assert abs(vm - min(Gp, 0.0)) <= 16 * EPS * scale + kp.curv_bound * (
            abs(tau - tau_plain) + ROOT_STEP_REL * tau
        )
        n_fast += n
        n_plain += n_p
    assert n_fast < n_plain


@pytest.mark.parametrize("f", [58.0, 85.2], ids=["58Hz", "85.2Hz"])
def test_chatter_precheck_never_rejects_what_the_full_test_accepts(f):
    """The sin/cos-free necessary condition of chatter_time changes no decision."""
    kp = Params(f=f).kernel()
    rng = np.random.default_rng(11)
    A, w, g, a = kp.A, kp.w, kp.g, kp.alpha
    n_accepted = 0
    phases, vrels = rng.uniform(0, 2 * math.pi, 4000), 10 ** rng.uniform(-12, -2, 4000)
    for phase, vrel in zip(phases, vrels, strict=True):
        g_eff = g + A * w * w * math.sin(phase)
        full = math.inf
        if g_eff > 0:
            t = 2 * vrel / (g_eff * (1 - a))
            dg = A * w**3 * abs(math.cos(phase)) + A * w**4 * t
            if A * w**3 * t < 0.5 * g_eff and dg * t * t <= CHATTER_REL_TOL * kp.period * g_eff:
                full = t
        got = chatter_time(float(phase), float(vrel), kp)
        # the two sines differ by an ulp; g_eff = g + A w^2 sin may cancel
        assert got == full or abs(got - full) <= 4 * EPS * full * kp.curv_bound / g_eff
        n_accepted += math.isfinite(full)
    assert 100 < n_accepted < 3900  # both branches are exercised


def test_chattering_still_ends_in_sticks():
    kp, _, _ = _impact_states(58.0, 0.5)
    n = 2000
    out = (np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64))
    start = FlatState(0.0, 0.5, 100.0, IMPACT)
    assert flat_run(start, kp, n, FlatArrays(*out))[1:] == (n, OK)
    assert np.count_nonzero(out[3] == STICK) > 10
