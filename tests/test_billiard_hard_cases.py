"""Named hard cases of the billiard kernel (issue 3)."""

import math

import numpy as np
import pytest
from billiard_checks import STICK_PHASES, release_window_phases, stick_phase
from scipy.optimize import brentq

from bbdyn import Params
from bbdyn.billiard import simulate, state_from_section
from bbdyn.core.billiard import billiard_event, billiard_flight, collide, flight_gap
from bbdyn.core.flat import flat_flight
from bbdyn.core.floor import bounce, floor_height_rel
from bbdyn.core.plate import sin_cos
from bbdyn.core.status import IMPACT, OK, RELEASE, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import EPS, WEDGE_TOL

TWO_PI = 2.0 * math.pi
STATIC = Params(f=50.0, A=0.0)  # a floor at rest: parabolas are exact, answers analytic
SKP = STATIC.kernel()


def collide_at(periods, phase, tile, xi, vx, vyrel, kp):
    """``collide`` at a contact given by its phase alone: ``(periods, phase, tile, xi, vx,
    vyrel, kind, status)`` after it."""
    state, status, _ = collide(periods, phase, *sin_cos(phase), tile, xi, vx, vyrel, kp)
    return (*state, status)


def _b_global(x):
    """Floor height at global x (tile 0 starts at x = 0)."""
    tile = math.floor(x / STATIC.d)
    return floor_height_rel(x - (tile + 0.5) * STATIC.d, SKP)


@pytest.mark.parametrize(
    "delta",
    [1e-9, -1e-9, 1e-12, -1e-12],
    ids=["miss-1e-9", "touch-1e-9", "miss-1e-12", "touch-1e-12"],
)
def test_grazing_bump_top(delta):
    """A parabola flatter than the arc (vx^2 > g R) with its apex delta above the top of tile 1.

    Near the top the gap is ``delta + (x - x_t)^2 (1/R - g/vx^2) / 2``: for delta > 0 the
    particle passes tile 1 untouched; for delta < 0 it hits tile 1 first at
    ``x_t - sqrt(2 |delta| / (1/R - g/vx^2))``.
    """
    p, kp = STATIC, SKP
    vx = 1500.0
    x_top = 1.5 * p.d
    apex = floor_height_rel(0.0, kp) + delta  # h without the cancellation of R - c0

    def parabola_minus_floor(x):
        return apex - p.g * (x - x_top) ** 2 / (2 * vx**2) - _b_global(x)

    x0 = brentq(parabola_minus_floor, 0.5 * p.d, p.d, xtol=1e-15)  # launch on tile 0
    vy0 = p.g * (x_top - x0) / vx
    tau, k, xi, _, _, status = billiard_flight(0.0, x0 - 0.5 * p.d, vx, vy0, kp)
    assert status == OK
    if delta > 0:
        assert k >= 2, "touched the bump it should just miss"
    else:
        assert k == 1
        curv = 1 / p.R - p.g / vx**2
        expected = -math.sqrt(2 * abs(delta) / curv)
        assert math.isclose(xi, expected, rel_tol=1e-4), (xi, expected)


@pytest.mark.parametrize("side", [-1.0, 1.0], ids=["left-of-wedge", "right-of-wedge"])
def test_impact_within_1e12_of_wedge(side):
    """A parabola aimed 1e-12 mm beside the wedge at x = 2d lands there, on the right arc."""
    p, kp = STATIC, SKP
    x1 = 2 * p.d + side * 1e-12
    xi0 = -0.3
    x0 = 0.5 * p.d + xi0
    T = 0.05
    vx = (x1 - x0) / T
    vy = (_b_global(x1) - floor_height_rel(xi0, kp) + 0.5 * p.g * T * T) / T
    tau, k, xi, _, _, status = billiard_flight(0.0, xi0, vx, vy, kp)
    assert status == OK
    assert k == (1.0 if side < 0 else 2.0)
    assert abs((k + 0.5) * p.d + xi - x1) <= 1e-14
    assert abs(xi) < p.d / 2 - WEDGE_TOL * p.d  # not snapped: it is beside the wedge
    assert math.isclose(tau, T, rel_tol=1e-12)


@pytest.mark.parametrize("side", [1.0, -1.0], ids=["right-wedge", "left-wedge"])
def test_wedge_rule_reflects_on_neighbour(side):
    """At the wedge, a velocity sent into the neighbouring arc is reflected there too.

    Incoming (100, -5) mm/s at the right wedge of tile 0: the arc of tile 0 turns it
    into (99, -3.5), which points into tile 1's arc; the final velocity is the
    composition of both reflections and leaves both arcs.  The left wedge is its
    mirror image: (-100, -5) ends on tile -1 with the mirrored velocity.
    """
    kp = Params(f=85.2).kernel()
    half = kp.d / 2
    out = collide_at(0.0, 1.0, 0.0, side * half * (1 - EPS), side * 100.0, -5.0, kp)
    assert out[7] == OK and out[6] == IMPACT
    vx1, vy1, _, _ = bounce(half, 100.0, -5.0, kp)
    vx2, vy2, _, _ = bounce(-half, vx1, vy1, kp)
    assert out[2] == side and out[3] == -side * half
    assert math.isclose(out[4], side * vx2, rel_tol=1e-15)
    assert math.isclose(out[5], vy2, rel_tol=1e-15)
    assert vx2 * half + vy2 * kp.c0 > 0 and -vx2 * half + vy2 * kp.c0 > 0
    nxt = billiard_event(*out[:7], kp)
    assert nxt[7] == OK and nxt[0] * TWO_PI + nxt[1] > 1.0


def test_flight_over_1000_tiles_is_cheap():
    """A 2000 mm flight: the envelope steps cross the tiles, a few dozen steps in all."""
    kp = Params(f=85.2).kernel()
    vx, vy = 24000.0, 500.0
    tau, k, xi, _, n_steps, status = billiard_flight(0.3, 0.1, vx, vy, kp)
    assert status == OK
    assert k >= 1000
    assert n_steps <= 60, n_steps
    assert abs(flight_gap(0.3, 0.1, vx, vy, tau, kp)) <= 1e-12
    # no earlier contact: the gap is positive on a grid finer than a tile crossing
    m = 40_000
    assert all(flight_gap(0.3, 0.1, vx, vy, tau * j / m, kp) > 0 for j in range(1, m))


@pytest.mark.parametrize("vt0", [0.0, 1.0, -1.0])
def test_chattering_on_a_slope_matches_incline_closed_form(vt0):
    """Explicit tiny bounces + closed-form tail on the slope at xi = 0.5 (static floor).

    On an incline of normal n with gravity g the sequence from (V_n0, V_t0) lasts
    ``2 V_n0 / (g_n (1 - alpha))`` and drifts by ``V_t0 tau_0 / (1 - alpha beta) + g_t
    tau_0^2 [alpha beta / ((1 - alpha^2)(1 - alpha beta)) + 1/(2 (1 - alpha^2))]`` along
    the tangent.  The arc differs from the incline by relative O(ds / R) = O(1e-5) and by
    the centrifugal V_t^2 / (g_n R) = O(1e-6), so the kernel's event-by-event sequence
    must match the time to 1e-5 and the drift to 1e-4.  Gamma = 0: then stuck forever.
    """
    p, kp = STATIC, SKP
    xi0, vn0 = 0.5, 1.0
    S = math.sqrt(p.R**2 - xi0**2)
    vx0 = (vn0 * xi0 + vt0 * S) / p.R
    vy0 = (vn0 * S - vt0 * xi0) / p.R
    state = (0.0, 0.0, 0.0, xi0, vx0, vy0, IMPACT)
    n_impacts = 0
    while state[6] == IMPACT:
        out = billiard_event(*state, kp)
        assert out[7] == OK
        state = out[:7]
        n_impacts += state[6] == IMPACT
    assert state[6] == STICK and n_impacts >= 3  # bounces explicitly before the closed form
    g_n, g_t = p.g * S / p.R, p.g * xi0 / p.R
    a, b = p.alpha, p.beta
    tau0 = 2 * vn0 / g_n
    t_expected = tau0 / (1 - a)
    ds = vt0 * tau0 / (1 - a * b)
    ds += g_t * tau0**2 * (a * b / ((1 - a * a) * (1 - a * b)) + 0.5 / (1 - a * a))
    t_stick = (state[0] * TWO_PI + state[1]) / kp.w
    xi_expected = p.R * math.sin(math.asin(xi0 / p.R) + ds / p.R)
    assert math.isclose(t_stick, t_expected, rel_tol=1e-5)
    assert math.isclose(state[3] - xi0, xi_expected - xi0, rel_tol=1e-4)
    assert billiard_event(*state, kp)[7] == STUCK_FOREVER


@pytest.mark.parametrize("alpha", [0.5, 0.0], ids=["chatter-sum", "alpha-0"])
@pytest.mark.parametrize("ratio", [0.9, 1.1], ids=["below", "above"])
@pytest.mark.parametrize("phase", [0.0, 1.0], ids=["static", "moving"])
def test_fast_particle_at_a_bump_top_flies_off(phase, alpha, ratio):
    """A grazing contact at the top (xi = 0) with tangential speed v_t: the floor holds the
    particle only if the arc's centripetal acceleration v_t^2 / R is below the effective
    gravity g_eff = g + A w^2 sin(phase) (effective normal gravity g_n = (g_eff R - v_t^2) /
    R > 0).  Below the threshold the tiny bounces sum to a STICK; above it the particle
    leaves the arc after the impact and flies for a finite time."""
    p = (STATIC if phase == 0.0 else Params(f=85.2)).replace(alpha=alpha)
    kp = p.kernel()
    g_eff = p.g + p.A * p.w**2 * math.sin(phase)
    vt_after = ratio * math.sqrt(g_eff * p.R)
    vx = vt_after / p.beta  # the tangent at the top is (1, 0): vt = beta vx after
    out = collide_at(0.0, phase, 0.0, 0.0, vx, -1e-6, kp)
    assert out[7] == OK
    if ratio < 1:
        assert out[6] == STICK
        return
    assert out[6] == IMPACT and math.isclose(out[4], vt_after, rel_tol=1e-15)
    nxt = billiard_event(*out[:7], kp)
    assert nxt[7] == OK
    tau = ((nxt[0] - out[0]) * TWO_PI + nxt[1] - out[1]) / kp.w
    # it leaves: the parabola's curvature g_eff / v_t^2 is below the arc's 1 / R
    assert tau > 1e-3 / p.f
    assert all(flight_gap(out[1], 0.0, out[4], out[5], tau * j / 50, kp) > 0 for j in range(1, 50))


def test_release_phase():
    """Every release is at theta_r = pi + asin(1/Gamma), with zero relative velocity."""
    params = Params(f=85.2)
    theta_r = math.pi + math.asin(1 / params.gamma)
    traj = simulate(params, n_events=20_000, s0=0.6, vx0=5.0, vy0=20.0)
    rel = traj["kind"] == RELEASE
    assert rel.sum() > 10
    assert max(abs(traj["phase"][rel] - theta_r)) <= 4 * EPS * theta_r
    assert (traj["vx"][rel] == 0).all() and (traj["vyrel"][rel] == 0).all()


def test_gamma_below_one_terminates():
    """Gamma < 1: the first stick is final; the run ends with a status, it does not hang."""
    params = Params(f=45.0)
    assert params.gamma < 1
    traj = simulate(params, n_events=10**7, s0=1.0, vx0=3.0, vy0=10.0)
    assert (
        traj.meta["status"] == "stuck on the floor for good: Gamma <= 1, the floor never pulls away"
    )
    assert traj["kind"][-1] == STICK


def test_beta_one_refused():
    with pytest.raises(ValueError, match="beta = 1 with alpha < 1 is not supported"):
        simulate(Params(f=85.2, beta=1.0), n_events=10, s0=1.0, vx0=3.0, vy0=10.0)
    # elastic (alpha = beta = 1) has no chattering and is allowed
    simulate(Params(f=85.2, alpha=1.0, beta=1.0), n_events=10, s0=1.0, vx0=3.0, vy0=10.0)


@pytest.mark.parametrize("s_at", ["left_wedge", "right_wedge"])
def test_start_on_a_wedge_must_leave_both_arcs(s_at):
    """Found by the property test: s = 0 with (vx, vy) = (-2, 1) leaves tile 0's arc but
    enters its neighbour's (slope 30 degrees at R = d = 1); such a start is refused."""
    params = Params(f=30.0, A=0.0, alpha=0.0, beta=0.0, R=1.0, d=1.0)
    s, vx = (0.0, -2.0) if s_at == "left_wedge" else (params.s_max, 2.0)
    with pytest.raises(ValueError, match="must leave both arcs"):
        state_from_section(params, s, vx, 1.0)
    # steeper than the neighbour's slope: accepted, and the run is valid
    state = state_from_section(params, s, vx, 4.0)
    nxt = billiard_event(*state, params.kernel())
    assert nxt[7] in (OK, STUCK_FOREVER)


def test_wedge_collapse_inside_release_window_leaves_at_once():
    """Issue 10: a wedge collapse (R = 1.01 mm, d = 2 mm) at phase 4.333, inside the release
    window (3.97, 5.45) where the floor falls faster than g, is a stick of zero duration: the
    next event is the RELEASE at the same time and point, not one period later.  The flight
    that follows falls straight onto the wedge (vx = 0): its gap, from the absolute positions
    of particle and floor, is positive before the contact, after theta_e, and zero there."""
    params = Params(f=58.0, R=1.01)
    kp = params.kernel()
    theta_r, theta_e = release_window_phases(params.gamma)
    traj = simulate(
        params, n_events=5000, s0=1.7775522733060598, vx0=-9.305795659049323, vy0=39.89118749577923
    )
    kind, periods, phase = traj["kind"], traj["periods"], traj["phase"]
    inside = np.flatnonzero((kind[:-1] == STICK) & (theta_r < phase[:-1]) & (phase[:-1] < theta_e))
    assert inside.size >= 1
    for i in inside:
        assert kind[i + 1] == RELEASE
        assert (periods[i + 1], phase[i + 1]) == (periods[i], phase[i])
        assert (traj["tile"][i + 1], traj["xi"][i + 1]) == (traj["tile"][i], traj["xi"][i])
        assert traj["vx"][i + 1] == 0.0 and traj["vyrel"][i + 1] == 0.0
    i = inside[0] + 1
    assert abs(traj["xi"][i]) == kp.d / 2  # on the wedge
    tau = ((periods[i + 1] - periods[i]) * TWO_PI + phase[i + 1] - phase[i]) / kp.w
    assert kind[i + 1] in (IMPACT, STICK) and phase[i] + kp.w * tau > theta_e

    def gap(t):  # particle leaving with the floor's velocity minus the floor, absolute (mm)
        th = phase[i]
        y = -kp.A * math.sin(th) - kp.A * kp.w * math.cos(th) * t - 0.5 * kp.g * t * t
        return y + kp.A * math.sin(th + kp.w * t)

    scale = kp.A * kp.w * tau + kp.g * tau * tau + kp.A
    assert abs(gap(tau)) <= 1e-13 * scale
    assert all(gap(tau * j / 200) > 0 for j in range(1, 200))


@pytest.mark.parametrize("where", STICK_PHASES)
def test_stick_release_time(where):
    """A stick at theta in [theta_r, theta_e) releases at once; before theta_r it waits for
    theta_r of its period, from theta_e on for theta_r of the next."""
    kp = Params(f=85.2).kernel()
    theta_r, theta_e = release_window_phases(kp.gamma)
    theta = stick_phase(kp.gamma, where)
    ev = billiard_event(5.0, theta, 2.0, 0.25, 0.0, 0.0, STICK, kp)
    assert ev[6] == RELEASE and ev[7] == OK and ev[2:6] == (2.0, 0.25, 0.0, 0.0)
    if where == "theta_e":
        assert ev[0] == 6.0 and math.isclose(ev[1], theta_r, rel_tol=4 * EPS)
    else:
        assert (ev[0], ev[1]) == (5.0, theta)
        nxt = billiard_event(*ev[:7], kp)  # the flight from the release is valid
        assert nxt[7] == OK and (nxt[0] - 5.0) * TWO_PI + nxt[1] > theta_e


@pytest.mark.parametrize("f", [30.0, 33.0], ids=["gamma-0.91", "gamma-1.10"])
def test_zeno_collapse_into_a_wedge(f):
    """Found by the explored property test: alpha = 1, beta = 0 in a 60-degree wedge (R = d)
    loses the tangential velocity at each bounce, so the bounces between the two walls shrink
    geometrically and accumulate (Zeno).  The particle collapses into the wedge: once a
    bounce lands within the rounding of the time the run records a STICK on the wedge (it
    used to repeat zero-time events until the gap underflowed and the state went bad)."""
    params = Params(f=f, A=0.25, alpha=1.0, beta=0.0, R=1.0, d=1.0)
    traj = simulate(params, n_events=2000, s0=0.0, vx0=0.0, vy0=1.0)
    kind, xi = traj["kind"], traj["xi"]
    stick = np.flatnonzero(kind == STICK)
    assert stick.size >= 1 and np.all(np.abs(xi[stick]) == params.d / 2)
    t = traj["periods"] * TWO_PI + traj["phase"]
    assert np.all(np.diff(t) >= 0.0)
    if params.gamma < 1:
        assert traj.meta["status"].startswith("stuck on the floor for good")
    else:
        assert traj.meta["status"] == "ok" and len(kind) == 2001
        assert np.count_nonzero(kind == RELEASE) >= 1


@pytest.mark.parametrize("side", ["left", "right"])
def test_wedge_bounce_tangent_to_the_neighbour(side):
    """Found by the explored property test: at R = d the walls of a wedge lean 30 degrees
    (asin(d / 2R)), so a vertical fall onto it, reflected with alpha = beta, leaves at 60
    degrees: along the neighbour's wall, tangent to it within rounding.  It cannot fly off
    the neighbour (gravity presses it on), so it touches it: with the static floor the
    normal velocity vanishes and the particle stays in the wedge for good (it used to end
    with BAD_STATE)."""
    params = Params(f=30.0, A=0.0, alpha=0.1875, beta=0.1875, R=1.0, d=1.0)
    s0 = 0.0 if side == "left" else params.s_max
    traj = simulate(params, n_events=10, s0=s0, vx0=0.0, vy0=1.0)
    assert traj.meta["status"].startswith("stuck on the floor for good")
    assert traj["kind"][-1] == STICK and abs(traj["xi"][-1]) == params.d / 2
    # it fell straight down onto the wedge: the stick is at the time of that fall
    t = (traj["periods"][-1] * TWO_PI + traj["phase"][-1]) / params.w
    assert math.isclose(t, 2.0 / params.g, rel_tol=1e-12)


@pytest.mark.parametrize("vx", [-2.225073858507203e-309, -1e-20, 1e-20], ids=str)
def test_flight_from_a_wedge_with_a_tiny_vx(vx):
    """Found by the explored property test: from a wedge with |vx| below the rounding of the
    position the particle rises and falls back onto that wedge, like the flat ball (the gap
    differs by the floor's drop over |vx| tau, below 1e-20 mm).  Leftwards it lands on the
    left tile (it used to be put on the right one and the search did not converge)."""
    kp = Params(f=43.0, A=0.125, alpha=0.0, beta=0.0, R=5.5, d=1.0).kernel()
    half = kp.d / 2
    xi0 = -half if vx < 0 else half
    tau, k, xi, vminus, _, status = billiard_flight(0.0, xi0, vx, 100.0, kp)
    tau_flat, vminus_flat, status_flat = flat_flight(0.0, 100.0, kp)
    assert status == status_flat == OK
    assert k == (-1.0 if vx < 0 else 1.0) and xi == -xi0
    assert math.isclose(tau, tau_flat, rel_tol=1e-12)
    assert math.isclose(vminus, vminus_flat, rel_tol=1e-9)
