"""The billiard's closed-form chattering sum against the sequence solved bounce by bounce.

``reference_chatter`` (mpmath, 60 digits) resolves every hop of a chattering sequence on
an arc until the rest is below 1e-24 s; the kernel resolves hops one by one until its
closed-form sum (``chatter_sum``) is accurate to ``CHATTER_REL_TOL`` periods.  The time of
rest must agree to that tolerance plus the rounding of the kernel's hop-by-hop time, for
sequences with a fast tangential motion (the centrifugal term of every hop changes as
beta^(2k) v_t^2 / R) and a drive that changes during the sequence (the sum corrects for it
to first order; the second order's coefficients, which bound what is left, are measured
here in mpmath on a flat floor whose pull changes at a constant rate).
"""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.billiard import billiard_event
from bbdyn.core.floor import arc_root, from_normal_velocity
from bbdyn.core.status import IMPACT, OK, STICK
from bbdyn.core.tolerances import (
    CHATTER_DRIVE_MAX,
    CHATTER_REL_TOL,
    CHATTER_SECOND_Q,
    CHATTER_SECOND_RR,
    EPS,
)
from bbdyn.reference.billiard_mpmath import reference_chatter


def kernel_rest(kp, phase, xi, vx, vyrel):
    """(time to rest in s, xi at rest, hops, the last impact's state) of the kernel's event
    loop from an IMPACT."""
    state = last = (0.0, phase, 0.0, xi, vx, vyrel, IMPACT)
    for hops in range(1, 10_000):
        *state, status = billiard_event(*state, kp)
        assert status == OK
        periods, ph, tile, xi_now, _, _, kind = state
        assert tile == 0.0
        if kind == STICK:
            return periods * kp.period + (ph - phase) / kp.w, xi_now, hops, last
        last = tuple(state)
    raise AssertionError("no stick")


def drive_shift(kp, state):
    """The first-order drive shift ``r tau_inf^2 / (3 g_n)`` (s) of a sum started at
    ``state``, with the flat sum ``tau_inf = 2 V_n / (g_n (1 - alpha))`` (to its eps order)."""
    _, phase, _, xi, vx, vyrel, _ = state
    S = arc_root(xi, kp)
    vn = (vx * xi + vyrel * S) / kp.R
    vt = (vx * S - vyrel * xi) / kp.R
    g_n = ((kp.g + kp.A * kp.w**2 * math.sin(phase)) * S - vt * vt) / kp.R
    r = kp.A * kp.w**3 * math.cos(phase) * S / kp.R
    tau_inf = 2 * vn / (g_n * (1 - kp.alpha))
    return r * tau_inf**2 / (3 * g_n)


def chatter_cases():
    """Sequences with v_n = 1e-3..1e-1 mm/s and fast tangential motion at random drive phases
    where the floor holds the particle (g + A w^2 sin > g / 5), for three alphas."""
    rng = np.random.default_rng(7)
    cases = []
    while len(cases) < 16:
        f, beta = rng.uniform(50.0, 95.0), rng.choice([0.5, 0.9, 0.99])
        alpha = rng.choice([0.2, 0.5, 0.8])
        phase = rng.uniform(0.0, 2 * math.pi)
        kp = Params(f=f, alpha=alpha, beta=beta).kernel()
        if kp.g + kp.A * kp.w**2 * math.sin(phase) < 0.2 * kp.g:
            continue
        xi, vt = rng.uniform(-0.45, 0.45) * kp.d, rng.choice([-1, 1]) * 10 ** rng.uniform(-2, 1.5)
        vn = 10 ** rng.uniform(-3, -1)
        vx, vy = from_normal_velocity(xi, arc_root(xi, kp), vn, vt, kp.R)
        label = f"f{f:.1f}-a{alpha}-b{beta}-vt{vt:.2g}-vn{vn:.1g}"
        cases.append(pytest.param(kp, phase, xi, vx, vy, id=label))
    return cases


@pytest.fixture(scope="module")
def shifts():
    """The drive shift of every case's sum and that case's tolerance, filled by the test."""
    return []


@pytest.mark.parametrize("kp, phase, xi, vx, vy", chatter_cases())
def test_chattering_comes_to_rest_when_the_bounce_by_bounce_sequence_does(
    kp, phase, xi, vx, vy, shifts
):
    t_ref, xi_ref, hops_ref = reference_chatter(kp, phase, xi, vx, vy)
    t_kernel, xi_kernel, hops, last = kernel_rest(kp, phase, xi, vx, vy)
    assert hops < hops_ref  # the closed-form sum took over
    # each hop's time is rounded to a few ulp of the phase (< 2 pi) and of itself
    rounding = hops * 8 * EPS * 2 * math.pi / kp.w
    allowed = CHATTER_REL_TOL * kp.period + rounding
    assert abs(t_kernel - t_ref) <= allowed, (t_kernel - t_ref, allowed)
    speed = math.hypot(vx, vy)
    assert abs(xi_kernel - xi_ref) <= speed * allowed + 8 * EPS * kp.d
    shifts.append(abs(drive_shift(kp, last)) / allowed)


def test_the_drive_shift_was_needed(shifts):
    """Without its first-order drive shift the sum would have missed the tolerance: in most
    cases above the shift is larger than the whole error allowed."""
    assert len(shifts) == 16
    assert sum(s > 1 for s in shifts) >= 8, sorted(shifts)


def flat_rest(v0, g, r, q, alpha):
    """Time (s) to rest of a chattering sequence on a flat floor whose pull is ``g + r t + q
    t^2 / 2`` (mm/s^2; t from the first impact), from speed ``v0`` (mm/s), hop by hop in
    mpmath (40 digits; the hops after the last are summed as flat ones)."""
    import mpmath as mp

    with mp.workdps(40):
        g, r, q, v, s = (mp.mpf(x) for x in (g, r, q, v0, 0))
        while True:
            a, b = g + r * s + q * s * s / 2, r + q * s

            # v t - a t^2 / 2 - b t^3 / 6 - q t^4 / 24 = 0, t > 0
            def rate(t, v=v, a=a, b=b):
                return v - a * t / 2 - b * t * t / 6 - q * t**3 / 24

            t = mp.findroot(rate, 2 * v / a)
            v_in = v - a * t - b * t * t / 2 - q * t**3 / 6
            s += t
            v = -alpha * v_in
            if t < mp.mpf(10) ** -36 * s:
                return s + 2 * v / (a * (1 - alpha))


@pytest.mark.parametrize("alpha", [0.05, 0.3, 0.5, 0.8, 0.95])
def test_second_order_of_the_drive_is_within_the_bound(alpha):
    """``T = tau_inf - r tau_inf^2 / (3 g) + (c_rr (r/g)^2 + c_q q / g) tau_inf^3 + ...``: the
    second-order coefficients, measured at small r and q, are within the kernel's bounds, and
    the whole rest after the first order is within the bound up to ``CHATTER_DRIVE_MAX``."""
    g, tau_inf = 1.0, 1.0
    v0 = g * tau_inf * (1 - alpha) / 2

    def rest(r, q):
        return flat_rest(v0, g, r, q, alpha) - (tau_inf - r * tau_inf**2 / (3 * g))

    c_rr = float(rest(1e-4, 0.0)) / 1e-8
    c_q = float(rest(0.0, 1e-4)) / 1e-4
    assert 0.2 < c_rr <= CHATTER_SECOND_RR / 1.1
    assert -CHATTER_SECOND_Q / 1.1 <= c_q < -0.08
    x = CHATTER_DRIVE_MAX
    for r, q in [(x, x), (-x, x), (x, -x), (-x, -x)]:
        bound = (CHATTER_SECOND_RR * r * r + CHATTER_SECOND_Q * abs(q)) * tau_inf**3
        assert abs(float(rest(r, q))) <= bound


def test_the_docs_state_the_kernel_s_bounds():
    """docs/billiard.md states the second-order bounds the kernel uses."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "billiard.md").read_text()
    flat = " ".join(text.split())
    assert f"`({CHATTER_SECOND_RR:g} (r / g_n)^2 + {CHATTER_SECOND_Q:g} q / g_n) tau_inf^3`" in flat
