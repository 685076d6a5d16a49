"""The chattering sums of the kernels are the series summed in derivations/chattering.py,
and both equal a bounce-by-bounce sum."""

import math

import numpy as np
import pytest
import sympy as sp
from derivation_loader import load_derivation

from bbdyn import Params
from bbdyn.core.billiard import chatter_sum
from bbdyn.core.flat import chatter_time
from bbdyn.core.plate import sin_cos

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
    assert sp.simplify(derivation.arc_drift() - derivation.drift_model_form()) == 0


def test_derived_arc_gravity_and_stick_time(derivation):
    m = derivation
    g_n, g_t = m.arc_gravity()
    assert sp.simplify(g_n - (m.g_eff * m.S - m.v_t**2) / m.R) == 0
    assert sp.simplify(g_t - m.g_eff * m.xi / m.R) == 0
    tau_inf = 2 * m.v_n / ((m.g_eff * m.S - m.v_t**2) / m.R) / (1 - m.alpha)
    assert sp.simplify(m.arc_stick_time() - tau_inf) == 0
    # flat limit: on the arc's top (xi = 0, S = R) without tangential motion
    flat = m.arc_stick_time().subs({m.S: m.R, m.v_t: 0}).subs(m.v_n, m.v)
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
        return None if g_eff <= 0 or got == math.inf else (got, tau_inf(vrel, g_eff, kp.alpha))

    for got, want in _accepted_samples(np.random.default_rng(1), draw):
        _within_ulp(got, want, want)


def test_billiard_kernel_chatter_sum_is_the_derived_sum(derivation):
    m = derivation
    g_n_t = sp.lambdify((m.g_eff, m.S, m.v_t, m.R, m.xi), m.arc_gravity(), "math")
    tau_inf = sp.lambdify((m.v_n, m.g_eff, m.S, m.v_t, m.R, m.alpha), m.arc_stick_time(), "math")
    drift = (
        m.v_t * m.tau_0 / (1 - m.alpha * m.beta),
        m.arc_drift() - m.v_t * m.tau_0 / (1 - m.alpha * m.beta),
    )
    drift = sp.lambdify((m.v_t, m.g_t, m.tau_0, m.alpha, m.beta), drift, "math")

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
        vt = rng.uniform(-2.0, 2.0) * g_eff * tau_0  # both drift terms matter
        g_n, g_t = g_n_t(g_eff, S, vt, kp.R, xi)
        vn = g_n * tau_0 / 2
        got = chatter_sum(phase, xi, S, vn, vt, g_eff, g_n, kp)
        if got[0] == math.inf:
            return None
        from_vt, from_gt = drift(vt, g_t, 2 * vn / g_n, kp.alpha, kp.beta)
        return got, (tau_inf(vn, g_eff, S, vt, kp.R, kp.alpha), from_vt + from_gt), from_vt, from_gt

    for (tau_got, ds_got), (tau_want, ds_want), a, b in _accepted_samples(
        np.random.default_rng(2), draw
    ):
        _within_ulp(tau_got, tau_want, tau_want)
        _within_ulp(ds_got, ds_want, abs(a) + abs(b))


def _bounce_by_bounce(v_n, g_n, v_t, g_t, alpha, beta):
    """Flights ``2 v / g_n``, restitution ``v -> alpha v`` and tangential motion
    ``u -> beta (u + g_t tau)``, one bounce at a time until the flights are below 1e-40 of
    the first; returns the summed time (s) and drift (mm)."""
    times, drifts = [], []
    u, v = v_t, v_n
    while v > 1e-40 * v_n:
        tau = 2 * v / g_n
        times.append(tau)
        drifts.append(u * tau + g_t * tau * tau / 2)
        u, v = beta * (u + g_t * tau), alpha * v
    return math.fsum(times), math.fsum(drifts)


@pytest.mark.parametrize("seed", range(5))
def test_derived_sums_equal_the_bounce_by_bounce_sum(derivation, seed):
    m = derivation
    rng = np.random.default_rng(seed)
    alpha, beta = rng.uniform(0.05, 0.9, 2)
    v_n, g_n, g_t = rng.uniform(0.5, 2.0), rng.uniform(5e3, 2e4), rng.uniform(-500, 500)
    v_t = rng.uniform(-1, 1) * g_t * 2 * v_n / g_n
    t_sum, ds_sum = _bounce_by_bounce(v_n, g_n, v_t, g_t, alpha, beta)
    values = {m.alpha: alpha, m.beta: beta, m.v: v_n, m.g_eff: g_n, m.v_t: v_t, m.g_t: g_t}
    values[m.tau_0] = 2 * v_n / g_n
    assert float(m.flat_stick_time().subs(values)) == pytest.approx(t_sum, rel=1e-13)
    scale = abs(v_t) * values[m.tau_0] + abs(g_t) * values[m.tau_0] ** 2
    assert abs(float(m.arc_drift().subs(values)) - ds_sum) < 1e-13 * scale
