"""The tilted billiard (docs/model.md, "Tilt"): symmetry, the untilted limit, closed forms."""

import math

import numpy as np
import pytest
from billiard_checks import run_arrays

from bbdyn import Params
from bbdyn.core.flat import flat_event
from bbdyn.core.status import IMPACT, OK, STICK, STUCK_FOREVER

TWO_PI = 2.0 * math.pi


def test_phi_range_and_overhang_refused():
    with pytest.raises(ValueError, match="phi must be in"):
        Params(f=58.0, phi=20.0)
    with pytest.raises(ValueError, match="overhang"):
        Params(f=58.0, phi=10.0, R=1.0001)  # arcs nearly semicircles: slope near 90 degrees


def test_phi_zero_selects_the_untilted_kernel():
    """phi = 0: the kernel's numbers are the untilted ones bit for bit (g_t = 0 selects
    the untilted code; benchmarks/bitwise_check.py compares whole runs)."""
    kp0, kp = Params(f=85.2).kernel(), Params(f=85.2, phi=0.0).kernel()
    assert kp.g_t == 0.0 and kp.tilt_curv == 0.0
    assert kp.g == 9800.0 and kp == kp0


def mirrored(state):
    """x -> -x: tile l -> -1 - l, xi -> -xi, vx -> -vx."""
    periods, phase, tile, xi, vx, vyrel, kind = state
    return periods, phase, -1.0 - tile, -xi, -vx, vyrel, kind


@pytest.mark.parametrize("f", [58.0, 85.2])
def test_mirror_symmetry_is_exact(f):
    """phi -> -phi with mirrored initial conditions gives the mirrored trajectory bit for
    bit (floor, wedge rule and search are symmetric), hence v_d(-phi) = -v_d(phi) exactly."""
    kp_p, kp_m = Params(f=f, phi=1.0).kernel(), Params(f=f, phi=-1.0).kernel()
    drift = []
    starts = [(0.3, 40.0, 60.0, IMPACT), (-0.7, -15.0, 120.0, IMPACT), (0.0, 0.0, 80.0, IMPACT),
              (1.0, 0.0, 0.0, STICK)]  # the last at rest in a wedge  # fmt: skip
    for xi0, vx0, vy0, kind in starts:
        state = (0.0, 0.5, 0.0, xi0, vx0, vy0, kind)
        a, sa = run_arrays(kp_p, state, 3000)
        b, sb = run_arrays(kp_m, mirrored(state), 3000)
        assert sa == sb == OK
        for name, i in (("periods", 0), ("phase", 1), ("vyrel", 5), ("kind", 6)):
            assert np.array_equal(a[i], b[i]), name
        assert np.array_equal(b[2], -1.0 - a[2]) and np.array_equal(b[3], -a[3])
        assert np.array_equal(b[4], -a[4])
        drift.append(((a[2][-1] - a[2][0]) * kp_p.d + a[3][-1] - a[3][0],
                      (b[2][-1] - b[2][0]) * kp_m.d + b[3][-1] - b[3][0]))  # fmt: skip
    drift = np.array(drift)
    assert np.array_equal(drift[:, 1], -drift[:, 0]) and np.any(drift[:, 0] != 0.0)


@pytest.mark.parametrize("f", [58.0, 85.2])
def test_tiny_tilt_follows_the_untilted_run(f):
    """phi = 1e-12 degrees takes the tilted search (no Taylor shortcuts, parabolic tile
    crossings, point-dependent release window) and must follow the untilted run: the
    first 40 events agree to 1e-8 (relative; the runs are chaotic further on)."""
    state = (0.0, 0.5, 0.0, 0.3, 40.0, 60.0, IMPACT)
    a, _ = run_arrays(Params(f=f).kernel(), state, 40)
    b, _ = run_arrays(Params(f=f, phi=1e-12).kernel(), state, 40)
    assert np.array_equal(a[6], b[6]) and np.array_equal(a[2], b[2])
    t_a, t_b = a[0] * TWO_PI + a[1], b[0] * TWO_PI + b[1]
    np.testing.assert_allclose(t_b, t_a, rtol=1e-8)
    np.testing.assert_allclose(b[3], a[3], rtol=0, atol=1e-8)
    np.testing.assert_allclose(b[4:6], a[4:6], rtol=0, atol=1e-8 * np.abs(a[4:6]).max())


@pytest.mark.parametrize("vx0", [-20.0, 0.0, 30.0], ids=["uphill", "at-rest", "downhill"])
def test_static_incline_chatters_to_rest_in_closed_form(vx0):
    """A = 0, R = 1e9 (a static flat incline): from a bounce with normal velocity vn0 and
    tangential u0 the hops last tau_k = alpha^k tau_0 (tau_0 = 2 vn0 / (g cos phi)); at each
    bounce u -> beta (u + g_t tau_k).  Summing the geometric series,

        T = tau_0 / (1 - alpha),
        x = u0 tau_0 / (1 - alpha beta)
            + g_t tau_0^2 [alpha beta / ((1 - alpha^2)(1 - alpha beta)) + 1 / (2 (1 - alpha^2))],

    then it rests for good (static friction, no drive).  Arc slopes <= d/2R = 1e-9."""
    p = Params(f=50.0, A=0.0, R=1e9, alpha=0.5, beta=0.9, phi=2.0)
    kp = p.kernel()
    vn0 = 50.0
    a, status = run_arrays(kp, (0.0, 0.0, 0.0, 0.0, vx0, vn0, IMPACT), 200)
    assert status == STUCK_FOREVER and a[6][-1] == STICK
    al, be, g_t = p.alpha, p.beta, p.g_t
    tau0 = 2.0 * vn0 / p.g_n
    T = tau0 / (1.0 - al)
    x = vx0 * tau0 / (1.0 - al * be) + g_t * tau0**2 * (
        al * be / ((1.0 - al * al) * (1.0 - al * be)) + 0.5 / (1.0 - al * al)
    )
    t_rest = (a[0][-1] * TWO_PI + a[1][-1]) / kp.w
    x_rest = a[2][-1] * p.d + a[3][-1]
    assert t_rest == pytest.approx(T, rel=1e-7)
    assert x_rest == pytest.approx(x, rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("vx0", [0.0, 100.0], ids=["vx-zero", "vx-nonzero"])
def test_tilted_flat_floor_normal_motion_is_the_flat_map(vx0):
    """R = 1e9 with phi = 3 degrees and A > 0: the motion along the normal is the flat
    ball's exact map with g -> g cos phi, and along the floor vx+ = beta (vx + g_t tau) at
    each impact (0 after a stick); at 58 Hz (stable 1/1 tongue) the arcs' slopes <= 1e-9
    do not grow, so the two agree to 1e3 d / 2R as in the untilted flat limit."""
    p = Params(f=58.0, R=1e9, phi=3.0)
    kp, kp_flat = p.kernel(), Params(f=58.0, R=1e9, g=p.g_n).kernel()
    tol = 1e3 * p.d / (2 * p.R)
    flat = (0.0, 0.0, 84.0, IMPACT)
    state = (0.0, 0.0, 0.0, 0.0, vx0, 84.0, IMPACT)
    a, status = run_arrays(kp, state, 200)
    assert status == OK
    vx_expected, tiles = vx0, set()
    for n in range(1, 201):
        t_prev = flat[0] * TWO_PI + flat[1]
        flat = flat_event(*flat[:4], kp_flat)
        assert flat[4] == OK
        t_flat = flat[0] * TWO_PI + flat[1]
        assert abs(t_flat - (a[0][n] * TWO_PI + a[1][n])) <= tol * (1 + t_flat), n
        assert a[6][n] == flat[3]
        assert abs(a[5][n] - flat[2]) <= tol * 50.0, n
        tau = (t_flat - t_prev) / kp.w
        if a[6][n] == IMPACT:
            vx_expected = p.beta * (vx_expected + p.g_t * tau)
        elif a[6][n] == STICK:
            vx_expected = 0.0
        assert abs(a[4][n] - vx_expected) <= tol * (1 + abs(vx0) + p.g_t), n
        tiles.add(a[2][n])
    assert len(tiles) > 20  # the flights do cross tiles


def test_pressed_tangent_chatter_sticks():
    """63 Hz, phi = 0.5: a particle chattering uphill near a left wedge just after the
    untilted release phase is still pressed onto the arc by the tilt; its hops shrink until
    the flight search would take the velocity for tangent.  It must stick there (it once
    ended in BAD_STATE, the tangent departure refused, after 905 events)."""
    from bbdyn.billiard import state_from_section

    p = Params(f=63.0, phi=0.5)
    state = state_from_section(p, 0.7913256621275528, 32.82046129728438, 17.543969297991083)
    a, status = run_arrays(p.kernel(), tuple(state), 1200)
    assert status == OK and np.count_nonzero(a[6] == STICK) > 0


def test_diffusion_about_the_drift():
    """Brownian paths with drift v and diffusion D: the MSD slope carries v^2 t, the variance
    about the mean does not; drift_velocity recovers v (both within 4 standard errors)."""
    from bbdyn.diffusion import drift_velocity, einstein_D

    rng = np.random.default_rng(1)
    t = np.linspace(0.05, 5.0, 100)
    v, D = 3.0, 0.7
    steps = rng.normal(0.0, np.sqrt(2 * D * 0.05), (3000, 100))
    x = v * t + np.cumsum(steps, axis=1)
    D_drift, se = einstein_D(t, x, drift=True)
    D_raw, _ = einstein_D(t, x)
    v_d, v_se = drift_velocity(t, x)
    assert abs(D_drift - D) < 4 * se and D_raw > D + 10 * se
    assert abs(v_d - v) < 4 * v_se


def test_tilt_refused_where_not_modelled():
    """The billiard's tangent dynamics is untilted: Lyapunov exponents refuse phi != 0."""
    from bbdyn.lyapunov import billiard_lyapunov

    with pytest.raises(ValueError, match="untilted floor only"):
        billiard_lyapunov(Params(f=85.2, phi=1.0), 2, t=1.0)
