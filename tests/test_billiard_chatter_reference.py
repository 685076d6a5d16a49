"""The billiard's closed-form chattering sum against the sequence solved bounce by bounce.

``reference_chatter`` (mpmath, 60 digits) resolves every hop of a chattering sequence on
an arc until the rest is below 1e-24 s; the kernel resolves hops one by one until its
closed-form sum (``chatter_sum``) is accurate to ``CHATTER_REL_TOL`` periods.  The time of
rest must agree to that tolerance plus the rounding of the kernel's hop-by-hop time, for
sequences with a fast tangential motion (the centrifugal term of every hop changes as
beta^(2k) v_t^2 / R) and a drive that changes during the sequence.
"""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.billiard import billiard_event
from bbdyn.core.floor import arc_root, from_normal_velocity
from bbdyn.core.status import IMPACT, OK, STICK
from bbdyn.core.tolerances import CHATTER_REL_TOL, EPS
from bbdyn.reference.billiard_mpmath import reference_chatter


def kernel_rest(kp, phase, xi, vx, vyrel):
    """(time to rest in s, xi at rest, hops) of the kernel's event loop from an IMPACT."""
    state = (0.0, phase, 0.0, xi, vx, vyrel, IMPACT)
    for hops in range(1, 10_000):
        *state, status = billiard_event(*state, kp)
        assert status == OK
        periods, ph, tile, xi_now, _, _, kind = state
        assert tile == 0.0
        if kind == STICK:
            return periods * kp.period + (ph - phase) / kp.w, xi_now, hops
    raise AssertionError("no stick")


def chatter_cases():
    """Sequences with v_n = 1e-2 mm/s and fast tangential motion at random drive phases
    where the floor holds the particle (g + A w^2 sin > g / 2)."""
    rng = np.random.default_rng(7)
    cases = []
    while len(cases) < 8:
        f, beta = rng.uniform(50.0, 95.0), rng.choice([0.5, 0.9, 0.99])
        phase = rng.uniform(0.0, 2 * math.pi)
        kp = Params(f=f, beta=beta).kernel()
        if kp.g + kp.A * kp.w**2 * math.sin(phase) < 0.5 * kp.g:
            continue
        xi, vt = rng.uniform(-0.4, 0.4) * kp.d, rng.choice([-1, 1]) * rng.uniform(5.0, 30.0)
        vx, vy = from_normal_velocity(xi, arc_root(xi, kp), 1e-2, vt, kp.R)
        cases.append(pytest.param(kp, phase, xi, vx, vy, id=f"f{f:.1f}-b{beta}-vt{vt:.0f}"))
    return cases


@pytest.mark.parametrize("kp, phase, xi, vx, vy", chatter_cases())
def test_chattering_comes_to_rest_when_the_bounce_by_bounce_sequence_does(kp, phase, xi, vx, vy):
    t_ref, xi_ref, hops_ref = reference_chatter(kp, phase, xi, vx, vy)
    t_kernel, xi_kernel, hops = kernel_rest(kp, phase, xi, vx, vy)
    assert hops < hops_ref  # the closed-form sum took over
    # each hop's time is rounded to a few ulp of the phase (< 2 pi) and of itself
    rounding = hops * 8 * EPS * 2 * math.pi / kp.w
    allowed = CHATTER_REL_TOL * kp.period + rounding
    assert abs(t_kernel - t_ref) <= allowed, (t_kernel - t_ref, allowed)
    speed = math.hypot(vx, vy)
    assert abs(xi_kernel - xi_ref) <= speed * allowed + 8 * EPS * kp.d
