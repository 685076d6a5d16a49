"""The chattering sums of the kernels are the series summed in derivations/chattering.py,
and both equal a bounce-by-bounce sum."""

import math

import numpy as np
import pytest
from derivation_loader import load_derivation
from extras import require

from bbdyn import Params
from bbdyn.core.billiard import chatter_sum
from bbdyn.core.flat import chatter_time
from bbdyn.core.plate import sin_cos

sp = require("sympy", "derivations")

N_ULP = 4  # the kernels and the derived forms order the same operations differently


@pytest.fixture(scope="module")
def derivation():
    return load_derivation("chattering")


def _within_ulp(got, want, scale):
    """|got - want| within N_ULP ulp of ``scale`` (the largest term, for sums that cancel)."""
    assert abs(got - want) <= N_ULP * np.spacing(abs(scale)), (got, want, scale)


def _accepted_samples(rng, draw, need=40, tries=4000):
    """Draw until ``need`` samples are accepted by the kernel's accuracy test (not inf)."""
    out = []
    for _ in range(tries):
        sample = draw(rng)
        if sample is not None:
            out.append(sample)
        if len(out) == need:
            return out
    raise AssertionError(f"only {len(out)} of {need} random chattering sums were accepted")


def test_derived_drift_is_the_form_in_the_kernel_docstring(derivation):
    assert sp.simplify(derivation.arc_drift_gt() - derivation.drift_model_form()) == 0


def test_derived_arc_gravity_and_series_terms(derivation):
    m = derivation
    g_n, g_t = m.arc_gravity()
    assert sp.simplify(g_n - (m.g_eff * m.S - m.v_t**2) / m.R) == 0
    assert sp.simplify(g_t - m.g_eff * m.xi / m.R) == 0
    # hop k: 2 v_n / g_n with beta^k v_t, i.e. alpha^k tau_0 / (1 - eps beta^(2k))
    g_0 = m.g_eff * m.S / m.R
    hop = 2 * m.v_n * m.alpha**m.k / g_n.subs(m.v_t, m.beta**m.k * m.v_t)
    values = {m.tau_0: 2 * m.v_n / g_0, m.eps: m.v_t**2 / (m.g_eff * m.S)}
    assert sp.simplify(hop - m.hop_time(m.k).subs(values)) == 0
    term = m.tau_0 * m.eps**m.m / (1 - m.alpha * m.beta ** (2 * m.m))
    assert sp.simplify(m.arc_stick_time_term() - term) == 0
    term = m.v_t * m.tau_0 * m.eps**m.m / (1 - m.alpha * m.beta ** (2 * m.m + 1))
    assert sp.simplify(m.arc_drift_vt_term() - term) == 0
    # no tangential motion (eps = 0): the flat sum with g_0
    flat = m.arc_stick_time_term().subs(m.m, 0).subs(m.tau_0, 2 * m.v / m.g_eff)
    assert sp.simplify(flat - m.flat_stick_time()) == 0


def test_flat_kernel_chatter_time_is_the_derived_sum(derivation):
    m = derivation
    tau_inf = sp.lambdify((m.v, m.g_eff, m.alpha), m.flat_stick_time(), "math")

    def draw(rng):
        p = Params(f=rng.uniform(45.0, 95.0), alpha=rng.uniform(0.05, 0.95))
        kp = p.kernel()
        phase = rng.uniform(0.0, 2 * math.pi)
        g_eff = kp.g + kp.A * kp.w * kp.w * sin_cos(phase)[0]
        vrel = g_eff * 10.0 ** rng.uniform(-16, -11)  # flights of 1e-16..1e-11 s
        got = chatter_time(phase, vrel, kp)
        if g_eff <= 0 or got == math.inf:
            return None
        # g_eff = g + A w^2 sin is a difference, rounded relative to its terms (the kernel
        # fuses it into one multiply-add, this test does not): want * cond is the scale
        cond = (kp.g + abs(g_eff - kp.g)) / g_eff
        want = tau_inf(vrel, g_eff, kp.alpha)
        return got, want, want * cond

    for got, want, scale in _accepted_samples(np.random.default_rng(1), draw):
        _within_ulp(got, want, scale)


def test_billiard_kernel_chatter_sum_is_the_derived_sum(derivation):
    m = derivation
    symbols = (m.tau_0, m.eps, m.v_t, m.alpha, m.beta)
    tau_inf = sp.lambdify(symbols, m.truncated(m.arc_stick_time_term(), 40), "math")
    from_vt = sp.lambdify(symbols, m.truncated(m.arc_drift_vt_term(), 40), "math")
    from_gt = sp.lambdify((m.g_t, m.tau_0, m.alpha, m.beta), m.arc_drift_gt(), "math")

    def draw(rng):
        p = Params(
            f=rng.uniform(45.0, 95.0), alpha=rng.uniform(0.05, 0.95), beta=rng.uniform(0.05, 0.95)
        )
        kp = p.kernel()
        phase = rng.uniform(0.0, 2 * math.pi)
        xi = rng.uniform(-kp.d / 2, kp.d / 2)
        S = math.sqrt((kp.R - xi) * (kp.R + xi))
        g_eff = kp.g + kp.A * kp.w * kp.w * math.sin(phase)
        if g_eff <= 0:
            return None
        tau_0 = 10.0 ** rng.uniform(-16, -11)
        vt = rng.uniform(-1.0, 1.0) * 0.3 * math.sqrt(g_eff * S)  # eps up to 0.09
        vn = g_eff * S / kp.R * tau_0 / 2
        got = chatter_sum(math.cos(phase), xi, S, vn, vt, g_eff, kp)
        if got[0] == math.inf:
            return None
        eps = vt * vt / (g_eff * S)
        a = from_vt(tau_0, eps, vt, kp.alpha, kp.beta)
        b = from_gt(g_eff * xi / kp.R, tau_0, kp.alpha, kp.beta)
        return got, (tau_inf(tau_0, eps, vt, kp.alpha, kp.beta), a + b), a, b

    for (tau_got, ds_got), (tau_want, ds_want), a, b in _accepted_samples(
        np.random.default_rng(2), draw
    ):
        _within_ulp(tau_got, tau_want, tau_want)
        _within_ulp(ds_got, ds_want, abs(a) + abs(b))


def _bounce_by_bounce(v_n, g_0, eps, v_t, g_t, alpha, beta):
    """Flights ``2 v / (g_0 (1 - eps beta^(2k)))`` (the centrifugal term of ``beta^k v_t``),
    restitution ``v -> alpha v`` and tangential motion ``u -> beta (u + g_t tau)``, one
    bounce at a time until the flights are below 1e-40 of the first; returns the summed
    time (s) and drift (mm)."""
    times, drifts = [], []
    u, v, shrink = v_t, v_n, 1.0
    while v > 1e-40 * v_n:
        tau = 2 * v / (g_0 * (1 - eps * shrink))
        times.append(tau)
        drifts.append(u * tau + g_t * tau * tau / 2)
        u, v, shrink = beta * (u + g_t * tau), alpha * v, shrink * beta * beta
    return math.fsum(times), math.fsum(drifts)


@pytest.mark.parametrize("seed", range(5))
def test_derived_sums_equal_the_bounce_by_bounce_sum(derivation, seed):
    """The series in eps against the flights added one by one; the drift of g_t, taken with
    the flat flights, is off by at most eps (2 - eps) / (1 - eps)^2 of its size (each of its
    terms is a product of two flights, each at most 1 / (1 - eps) times the flat one)."""
    m = derivation
    rng = np.random.default_rng(seed)
    alpha, beta = rng.uniform(0.05, 0.9, 2)
    v_n, g_0, g_t = rng.uniform(0.5, 2.0), rng.uniform(5e3, 2e4), rng.uniform(-500, 500)
    eps = rng.uniform(0.0, 0.3)
    tau_0 = 2 * v_n / g_0
    v_t = rng.choice([-1, 1]) * math.sqrt(eps * g_0 * 25.0)  # R = 25 mm, S = R
    t_sum, ds_sum = _bounce_by_bounce(v_n, g_0, eps, v_t, g_t, alpha, beta)
    values = {m.alpha: alpha, m.beta: beta, m.eps: eps, m.v_t: v_t, m.g_t: g_t, m.tau_0: tau_0}
    tau_inf = float(m.truncated(m.arc_stick_time_term(), 60).subs(values))
    assert tau_inf == pytest.approx(t_sum, rel=1e-13)
    from_vt = float(m.truncated(m.arc_drift_vt_term(), 60).subs(values))
    from_gt = float(m.arc_drift_gt().subs(values))
    scale = abs(from_vt) + abs(from_gt)
    neglected = eps * (2 - eps) / (1 - eps) ** 2 * abs(from_gt)
    assert abs(from_vt + from_gt - ds_sum) < 1e-13 * scale + neglected
