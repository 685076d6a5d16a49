"""Named hard cases of the flat bouncing ball (issue 2)."""

import math

import mpmath
import numpy as np
import pytest
from billiard_checks import STICK_PHASES, release_window_phases, stick_phase

from bbdyn import Params
from bbdyn.core.flat import FlatArrays, FlatState, flat_event, flat_flight, flat_run
from bbdyn.core.status import IMPACT, OK, RELEASE, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import (
    CHATTER_REL_TOL,
    EPS,
    IMPACT_GAP_REL,
    IMPACT_TIME_TOL,
    ROOT_STEP_REL,
)
from bbdyn.flat.flatball import flat_ensemble, simulate_flat
from bbdyn.reference.flat_mpmath import reference_impacts

# ---- grazing -------------------------------------------------------------------------


def _grazing_start(p, theta0):
    """(tau*, vrel*) of a flight from phase theta0 whose parabola touches the plate at tau*.

    With F(tau) = g tau^2 / 2 + rise(tau) the gap is vrel tau - F(tau), linear in
    vrel; it touches zero tangentially where q = F / tau is stationary, with
    vrel* = q(tau*).  We take the first local maximum of q above all earlier
    values (so the gap is positive before tau*), polished in mpmath.
    """
    A, w, g = p.A, p.w, p.g

    def F(t, sin=np.sin, cos=np.cos):
        return g * t * t / 2 - A * sin(theta0 + w * t) + A * sin(theta0) + A * w * cos(theta0) * t

    tau = np.linspace(1e-6, 3 / p.f, 200_001)
    q = F(tau) / tau
    is_max = (q[1:-1] > q[:-2]) & (q[1:-1] > q[2:]) & (q[1:-1] >= np.maximum.accumulate(q)[:-2])
    i = int(np.flatnonzero(is_max)[0]) + 1
    with mpmath.workdps(40):

        def h(t):  # F'(t) t - F(t): zero where q' = 0
            dF = g * t + A * w * (mpmath.cos(theta0) - mpmath.cos(theta0 + w * t))
            return dF * t - F(t, mpmath.sin, mpmath.cos)

        t_star = mpmath.findroot(h, mpmath.mpf(tau[i]))
        return float(t_star), float(F(t_star, mpmath.sin, mpmath.cos) / t_star)


def _gap_abs(p, theta0, vrel, tau):
    """Gap (mm) from the absolute formulas (independent of plate.py), float64."""
    v0 = vrel - p.A * p.w * math.cos(theta0)
    return -p.A * math.sin(theta0) + v0 * tau - p.g * tau**2 / 2 + p.A * np.sin(theta0 + p.w * tau)


@pytest.mark.parametrize("delta", [1e-6, 1e-9], ids=["rel_1e-6", "rel_1e-9"])
@pytest.mark.parametrize("case", ["just_hit", "just_miss"])
def test_grazing(case, delta):
    """A parabola nearly tangent to the plate: hit just before the touch, or fly past it.

    The first-root guarantee is checked by dense sampling of the gap (no sign
    change before the kernel's contact, including a fine grid around the touch)
    and against the mpmath reference.  At a near-tangency the contact time is
    ill conditioned: a gap rounding error e moves it by e / |G'|, so the allowed
    difference is IMPACT_TIME_TOL plus that.
    """
    p = Params(f=85.2)
    kp = p.kernel()
    theta0 = 0.5
    t_star, v_star = _grazing_start(p, theta0)
    vrel = v_star * (1 - delta if case == "just_hit" else 1 + delta)
    tau, vrel_minus, status = flat_flight(theta0, vrel, kp)
    assert status == OK
    if case == "just_hit":
        # the dip below zero has half-width sqrt(2 depth / G''), G'' <= M
        half_width = math.sqrt(2 * delta * v_star * t_star / (kp.A * kp.w**2 - kp.g))
        assert t_star - 2 * half_width < tau < t_star
    else:
        assert tau > t_star + 1e-3 / p.f
    grid = np.concatenate(
        [np.linspace(0, tau, 200_001)[1:-1], np.linspace(t_star - 1e-5, t_star + 1e-5, 20_001)]
    )
    grid = grid[grid < tau * (1 - 1e-9)]
    rounding = 8 * EPS * (vrel * tau + kp.g * tau**2 / 2 + 2 * kp.A)
    assert np.all(_gap_abs(p, theta0, vrel, grid) > -rounding)
    ref = reference_impacts(p, theta0, vrel, 1)
    tau_ref = ref["t"][0] - theta0 / kp.w
    assert abs(tau - tau_ref) <= IMPACT_TIME_TOL + rounding / abs(vrel_minus)


# ---- chattering, sticking, release ---------------------------------------------------


def _brute_force_chatter(kp, phase, vrel, vrel_end=1e-13):
    """Sum the flight times of every tiny bounce (no closed-form sum) until vrel < vrel_end."""
    total = 0.0
    while vrel > vrel_end:
        tau, vrel_minus, status = flat_flight(phase, vrel, kp)
        assert status == OK
        total += tau
        phase = (phase + kp.w * tau) % (2 * math.pi)
        vrel = -kp.alpha * vrel_minus
    return total


@pytest.mark.parametrize("phase", [0.3, 1.5, 3.0], ids=["phase_0.3", "phase_1.5", "phase_3.0"])
def test_chattering_matches_brute_force_bounces(phase):
    """The kernel's closed-form accumulation time agrees with summing ~40 explicit bounces.

    Start the sequence with vrel+ = 1e-3 mm/s; the brute force stops at
    1e-13 mm/s, whose remaining tail (< 2 vrel / (g_eff (1 - alpha))) is ~1e-17 s.
    """
    kp = Params(f=85.2).kernel()
    vrel = 1e-3
    periods, stick_phase, _, kind, status = flat_event(0.0, phase, vrel, IMPACT, kp)
    n_impacts = 0
    while kind == IMPACT:  # the kernel bounces explicitly until the sum is accurate
        periods, stick_phase, _, kind, status = flat_event(periods, stick_phase, _, kind, kp)
        n_impacts += 1
    assert (kind, status) == (STICK, OK)
    t_kernel = (periods * 2 * math.pi + stick_phase - phase) / kp.w
    t_brute = _brute_force_chatter(kp, phase, vrel)
    assert abs(t_kernel - t_brute) <= CHATTER_REL_TOL * kp.period + 1e-16


def test_chattering_on_a_static_plate_is_the_geometric_series():
    """A = 0: bounce flights 2 v alpha^k / g; the kernel sticks at 2 v / (g (1 - alpha)).

    On a static plate the closed-form sum is exact, so the kernel sticks at the
    first landing; the individual flights are checked by iterating the flight search.
    """
    p = Params(f=50.0, A=0.0, alpha=0.5)
    kp = p.kernel()
    v = 100.0
    traj = simulate_flat(p, n_events=10, vrel0=v)
    assert traj.meta["status"] == "stuck_forever"  # Gamma = 0: it never leaves
    assert list(traj["kind"]) == [IMPACT, STICK]
    total = 2 * v / (kp.g * (1 - kp.alpha))
    assert abs(traj.t[-1] - total) <= CHATTER_REL_TOL * kp.period + 4 * EPS * total
    vrel, phase = v, 0.0
    for k in range(60):
        tau, vrel_minus, status = flat_flight(phase, vrel, kp)
        assert status == OK
        expected = 2 * v * kp.alpha**k / kp.g
        assert abs(tau - expected) <= (ROOT_STEP_REL + 4 * EPS) * expected
        phase = (phase + kp.w * tau) % (2 * math.pi)
        vrel = -kp.alpha * vrel_minus


@pytest.mark.parametrize("f", [58.0, 85.2], ids=["58Hz", "85.2Hz"])
def test_release_exactly_at_theta_r(f):
    """A stuck particle leaves where sin(w t) = -1/Gamma, theta_r = pi + asin(1/Gamma)."""
    p = Params(f=f)
    traj = simulate_flat(p, n_events=2000, phase0=0.0, stuck=True)
    theta_r = math.pi + math.asin(1 / p.gamma)
    rel = traj["kind"] == RELEASE
    assert rel.sum() >= 1 and traj["kind"][1] == RELEASE
    np.testing.assert_allclose(traj["phase"][rel], theta_r, rtol=0, atol=4 * EPS * theta_r)
    assert np.all(traj["vrel"][rel] == 0.0)
    # each release follows a stick, in the same or the next period
    idx = np.flatnonzero(rel)[1:]
    assert np.all(traj["kind"][idx - 1] == STICK)


@pytest.mark.parametrize("where", STICK_PHASES)
def test_stuck_start_releases_at_once_inside_the_window(where):
    """Issue 10: a particle resting on the plate while sin(w t) < -1/Gamma (theta_r <= theta <
    theta_e, the plate falls faster than g) leaves at once, with the plate's velocity; from
    theta_e on the plate holds it until theta_r of the next period."""
    p = Params(f=58.0)
    theta_r, theta_e = release_window_phases(p.gamma)
    theta = stick_phase(p.gamma, where)
    traj = simulate_flat(p, n_events=3, phase0=theta, stuck=True)
    assert traj["kind"][1] == RELEASE and traj["vrel"][1] == 0.0
    if where == "theta_e":
        assert traj["periods"][1] == 1.0
        assert math.isclose(traj["phase"][1], theta_r, rel_tol=4 * EPS)
    else:
        assert (traj["periods"][1], traj["phase"][1]) == (0.0, theta)
        # the flight from there is the release flight: no contact before theta_e
        t2 = traj["periods"][2] * 2 * math.pi + traj["phase"][2]
        assert traj["kind"][2] in (IMPACT, STICK) and t2 > theta_e


def test_gamma_below_one_terminates_stuck_forever():
    p = Params(f=40.0)  # Gamma = 0.64
    traj = simulate_flat(p, n_events=100_000, vrel0=10.0)
    assert traj.meta["status"] == "stuck_forever"
    assert traj["kind"][-1] == STICK
    assert len(traj["phase"]) < 100_001


def test_alpha_zero_sticks_at_every_landing():
    """alpha = 0: no bounce; the particle sticks at each landing (or, where the plate
    falls faster than g, leaves it at once with vrel = 0)."""
    p = Params(f=85.2, alpha=0.0)
    traj = simulate_flat(p, n_events=500, vrel0=100.0)
    after = traj["kind"][1:]
    assert np.all(traj["vrel"][1:][after != RELEASE] == 0.0)
    g_eff = p.g + p.A * p.w**2 * np.sin(traj["phase"][1:])
    assert np.all(after[(after != RELEASE) & (g_eff > 0)] == STICK)


def test_alpha_one_static_plate_conserves_energy_over_1e5_bounces():
    """alpha = 1, A = 0: every bounce returns vrel exactly (to a few ulp, no accumulation:
    a random walk of rounding would reach ~sqrt(1e5) ulp)."""
    p = Params(f=50.0, A=0.0, alpha=1.0)
    v = 100.0
    traj = simulate_flat(p, n_events=100_000, vrel0=v)
    assert np.all(traj["kind"] == IMPACT)
    assert np.max(np.abs(traj["vrel"] - v)) <= 16 * EPS * v
    flights = np.diff(traj["periods"] * 2 * math.pi + traj["phase"]) / p.w
    np.testing.assert_allclose(flights, 2 * v / p.g, rtol=1e-9)


# ---- time origin, seeds, extreme velocities ------------------------------------------


def test_start_at_t0_and_at_1e6_periods_gives_the_same_phases():
    p = Params(f=85.2)
    a = simulate_flat(p, n_events=2000, phase0=0.5, vrel0=100.0)
    b = simulate_flat(p, n_events=2000, phase0=0.5, vrel0=100.0, periods0=1_000_000)
    np.testing.assert_array_equal(a["phase"], b["phase"])
    np.testing.assert_array_equal(a["vrel"], b["vrel"])
    np.testing.assert_array_equal(b["periods"] - a["periods"], 1_000_000)


def test_same_seed_same_numbers():
    p = Params(f=85.2)
    a = flat_ensemble(p, 6, n_events=50, seed=7)
    b = flat_ensemble(p, 6, n_events=50, seed=7)
    c = flat_ensemble(p, 3, n_events=50, seed=7)
    d = flat_ensemble(p, 6, n_events=50, seed=8)
    for key in ("phase0", "vrel0", "phase", "vrel", "periods"):
        np.testing.assert_array_equal(a[key], b[key])
        np.testing.assert_array_equal(a[key][:3], c[key])  # member i depends on (seed, i) only
    assert not np.any(a["phase0"] == d["phase0"])
    assert np.all((a["vrel0"] > 0) & (a["vrel0"] <= 40))


def test_tiny_velocity_sticks_after_the_closed_form_time():
    """vrel = 1e-9 mm/s: one closed-form chattering sum, 2 vrel / (g_eff (1 - alpha))."""
    p = Params(f=85.2)
    kp = p.kernel()
    phase = 1.0
    periods, ph, vrel, kind, status = flat_event(0.0, phase, 1e-9, IMPACT, kp)
    assert (kind, status) == (STICK, OK)
    tau = (periods * 2 * math.pi + ph - phase) / kp.w
    g_eff = kp.g + kp.A * kp.w**2 * math.sin(phase)
    expected = 2e-9 / (g_eff * (1 - kp.alpha))
    assert abs(tau - expected) <= CHATTER_REL_TOL * kp.period + 4 * EPS * phase / kp.w


@pytest.mark.parametrize("phase", [0.5, 4.0], ids=["phase_0.5", "phase_4.0"])
def test_huge_velocity_flight_matches_reference(phase):
    """vrel = 1e5 mm/s: a 20 s flight over ~1700 periods, checked against mpmath."""
    p = Params(f=85.2)
    kp = p.kernel()
    tau, vrel_minus, status = flat_flight(phase, 1e5, kp)
    assert status == OK
    ref = reference_impacts(p, phase, 1e5, 1)
    tau_ref = ref["t"][0] - phase / kp.w
    # relative accuracy: the gap's terms are ~v tau = 2e6 mm, rounded to eps each
    assert abs(tau - tau_ref) <= ROOT_STEP_REL * tau + 8 * EPS * 1e5 * tau / abs(vrel_minus)
    assert abs(-kp.alpha * vrel_minus - ref["vrel"][0]) <= 1e-9 * 1e5


# ---- invariants over long chaotic runs -----------------------------------------------


def _check_invariants(f, n):
    p = Params(f=f)
    kp = p.kernel()
    out = (np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64))
    _, n_done, status = flat_run(FlatState(0.0, 0.5, 100.0, IMPACT), kp, n, FlatArrays(*out))
    assert (n_done, status) == (n, OK)
    periods, phase, vrel, kind = out
    for arr in (periods, phase, vrel):
        assert np.all(np.isfinite(arr))
    assert np.all((phase >= 0) & (phase < 2 * math.pi))
    assert np.all(np.diff(periods) >= 0)
    # flights end in an impact: positive duration and gap zero at the recorded impact
    sel = np.flatnonzero((kind[:-1] != STICK) & (kind[1:] == IMPACT))
    tau = ((periods[sel + 1] - periods[sel]) * 2 * math.pi + phase[sel + 1] - phase[sel]) / kp.w
    assert np.all(tau > 0)
    v0 = vrel[sel] - kp.A * kp.w * np.cos(phase[sel])
    y_particle = -kp.A * np.sin(phase[sel]) + v0 * tau - kp.g * tau**2 / 2
    y_plate = -kp.A * np.sin(phase[sel + 1])
    vminus = vrel[sel + 1] / kp.alpha
    scale = np.abs(v0 * tau) + kp.g * tau**2 / 2 + 2 * kp.A + np.abs(vminus) * kp.period
    assert np.all(np.abs(y_particle - y_plate) <= IMPACT_GAP_REL * scale)
    # no double hits: every impact leaves the plate (vrel+ > 0) unless it sticks
    assert np.all(vrel[kind == IMPACT] >= 0)
    # chattering ends where the plate holds the particle (g_eff > 0 over the summed sequence),
    # never inside the release window
    theta_r, theta_e = release_window_phases(p.gamma)
    stick = phase[kind == STICK]
    assert stick.size > 0 and not np.any((theta_r <= stick) & (stick < theta_e))
    return kind


def test_invariants_over_1e5_events_chaotic():
    kind = _check_invariants(85.2, 100_000)
    assert np.sum(kind == STICK) > 100  # the run does pass through chattering and release


@pytest.mark.slow
def test_invariants_over_1e6_events_chaotic():
    _check_invariants(85.2, 1_000_000)


def test_stuck_forever_leaves_state_unchanged():
    kp = Params(f=40.0).kernel()
    assert flat_event(3.0, 1.0, 0.0, STICK, kp) == (3.0, 1.0, 0.0, STICK, STUCK_FOREVER)
