"""The billiard kernel: geometry, collision law, first contact, invariants, API."""

import math
import os
import shutil

import numpy as np
import pytest
from billiard_checks import flight_violations, late_sticks, run_arrays, window_sticks
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from bbdyn import Params
from bbdyn.billiard import BilliardTrajectory, simulate, state_from_section
from bbdyn.core.billiard import billiard_event, billiard_flight, flight_gap
from bbdyn.core.floor import (
    arc_length,
    bounce,
    floor_height_rel,
    floor_slope,
    xi_from_arc_length,
)
from bbdyn.core.status import IMPACT, OK, RELEASE, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import EPS, ROOT_STEP_REL
from bbdyn.results import load_result

P = Params(f=85.2)
KP = P.kernel()


# ---- geometry -------------------------------------------------------------------------


def test_floor_height_wedges_top_and_closed_form():
    half = P.d / 2
    assert floor_height_rel(half, KP) == 0.0 and floor_height_rel(-half, KP) == 0.0
    # h = R - sqrt(R^2 - d^2/4), written without cancellation
    h = (P.d**2 / 4) / (P.R + math.sqrt(P.R**2 - P.d**2 / 4))
    assert math.isclose(floor_height_rel(0.0, KP), h, rel_tol=4 * EPS)
    for xi in np.linspace(-half, half, 7):
        direct = math.sqrt(P.R**2 - xi**2) - math.sqrt(P.R**2 - half**2)
        assert abs(floor_height_rel(xi, KP) - direct) <= 8 * EPS * P.R


def test_slope_is_derivative_of_height():
    for xi in (-0.9, -0.3, 0.0, 0.5, 0.99):
        dx = 1e-6
        fd = (floor_height_rel(xi + dx, KP) - floor_height_rel(xi - dx, KP)) / (2 * dx)
        assert math.isclose(floor_slope(xi, KP), fd, rel_tol=1e-8, abs_tol=1e-12)


def test_arc_length_ends_top_and_inverse():
    half = P.d / 2
    assert arc_length(-half, KP) == 0.0
    assert math.isclose(arc_length(half, KP), P.s_max, rel_tol=4 * EPS)
    assert math.isclose(arc_length(0.0, KP), P.s_max / 2, rel_tol=4 * EPS)
    for s in np.linspace(0.0, P.s_max, 9):
        assert abs(arc_length(xi_from_arc_length(s, KP), KP) - s) <= 16 * EPS * P.s_max


@pytest.mark.parametrize("xi", [-1.0, -0.4, 0.0, 0.7, 1.0])
def test_bounce_components(xi):
    """V_n+ = -alpha V_n-, V_t+ = beta V_t-, and |V| is kept for alpha = beta = 1."""
    vx, vy = 13.0, -41.0
    S = math.sqrt(P.R**2 - xi**2)
    n = np.array([xi, S]) / P.R
    t = np.array([S, -xi]) / P.R
    v = np.array([vx, vy])
    vx2, vy2, vn, vt = bounce(xi, vx, vy, KP)
    v2 = np.array([vx2, vy2])
    assert math.isclose(v2 @ n, -P.alpha * (v @ n), rel_tol=1e-14)
    assert math.isclose(v2 @ t, P.beta * (v @ t), rel_tol=1e-14)
    assert math.isclose(vn, v2 @ n, rel_tol=1e-14) and math.isclose(vt, v2 @ t, rel_tol=1e-14)
    kp1 = P.replace(alpha=1.0, beta=1.0).kernel()
    vx3, vy3, _, _ = bounce(xi, vx, vy, kp1)
    assert math.isclose(math.hypot(vx3, vy3), math.hypot(vx, vy), rel_tol=1e-15)


# ---- first contact --------------------------------------------------------------------


def _first_root_bruteforce(phase, xi, vx, vyrel, kp, t_max, n_grid=200_000):
    """First sign change of the gap on a fine grid, polished by Brent (an independent search)."""
    taus = np.linspace(0.0, t_max, n_grid + 1)[1:]
    gaps = np.array([flight_gap(phase, xi, vx, vyrel, t, kp) for t in taus])
    i = int(np.argmax(gaps <= 0.0))
    assert gaps[i] <= 0.0, "no contact in the grid"
    lo = taus[i - 1] if i > 0 else taus[0] * 1e-9
    return brentq(lambda t: flight_gap(phase, xi, vx, vyrel, t, kp), lo, taus[i], xtol=1e-16)


@pytest.mark.parametrize(
    "phase, xi, vx, vyrel",
    [
        (0.3, 0.2, 15.0, 40.0),
        (2.0, -0.9, -35.0, 120.0),
        (4.0, 0.95, 3.0, 5.0),
        (5.5, 0.0, 80.0, 300.0),
    ],
    ids=["short", "leftward", "near-wedge-slow", "many-tiles"],
)
def test_first_contact_matches_bruteforce(phase, xi, vx, vyrel):
    """The safe-step search finds the same first root as a dense grid + Brent."""
    tau, k, xi_c, _, _, status = billiard_flight(phase, xi, vx, vyrel, KP)
    assert status == OK
    ref = _first_root_bruteforce(phase, xi, vx, vyrel, KP, 1.5 * tau + 1e-3)
    assert abs(tau - ref) <= 1e-12 + 8 * ROOT_STEP_REL * tau
    x_c = k * P.d + xi_c
    assert abs(x_c - (xi + vx * tau)) <= 1e-12 * (1 + abs(vx * tau))


def test_release_then_flight():
    """STICK -> RELEASE at theta_r = pi + asin(1/Gamma) with zero relative velocity; a stick
    after theta_e = 2 pi - asin(1/Gamma) waits for theta_r of the next period."""
    theta_r = math.pi + math.asin(1.0 / P.gamma)
    theta_e = 2 * math.pi - math.asin(1.0 / P.gamma)
    ev = billiard_event(3.0, 1.0, 7.0, 0.4, 0.0, 0.0, STICK, KP)
    assert ev[6] == RELEASE and ev[7] == OK
    assert ev[0] == 3.0 and math.isclose(ev[1], theta_r, rel_tol=4 * EPS)
    assert ev[2:6] == (7.0, 0.4, 0.0, 0.0)
    late = billiard_event(3.0, 0.5 * (theta_e + 2 * math.pi), 7.0, 0.4, 0.0, 0.0, STICK, KP)
    assert late[0] == 4.0 and late[1] == ev[1]
    nxt = billiard_event(*ev[:7], KP)
    assert nxt[7] == OK and nxt[6] in (IMPACT, STICK)
    assert (nxt[0] - ev[0]) * 2 * math.pi + nxt[1] - ev[1] > 0.0


def test_far_time_and_tile_lose_nothing():
    """Started at 1e7 periods and tile 1e6 the run is the same up to the offsets."""
    s0 = (0.0, 0.7, 0.0, 0.3, 12.0, 60.0, IMPACT)
    s1 = (1e7, 0.7, 1e6, 0.3, 12.0, 60.0, IMPACT)
    a, st0 = run_arrays(KP, s0, 2000)
    b, st1 = run_arrays(KP, s1, 2000)
    assert st0 == st1 == OK
    np.testing.assert_array_equal(a[1], b[1])  # phase
    np.testing.assert_array_equal(a[3], b[3])  # xi
    np.testing.assert_array_equal(b[0] - a[0], 1e7)
    np.testing.assert_array_equal(b[2] - a[2], 1e6)


# ---- invariants over random parameters and initial conditions --------------------------


def radius(d, u):
    """R = (d/2)(1 + 10^u) (mm): u in [-3, 2.3] spans steep wedges (R = 1.001 d/2, walls
    2.6 degrees from vertical) to nearly flat arcs (R = 100 d), log-uniform in R - d/2."""
    return 0.5 * d * (1.0 + 10.0**u)


@st.composite
def billiard_cases(draw):
    d = draw(st.floats(0.5, 4.0))
    params = Params(
        f=draw(st.floats(30.0, 120.0)),
        A=draw(st.floats(0.0, 0.3)),
        alpha=draw(st.floats(0.0, 1.0)),
        beta=draw(st.floats(0.0, 0.999)),
        d=d,
        R=radius(d, draw(st.floats(-3.0, 2.3))),
    )
    s = draw(st.floats(0.0, 1.0)) * params.s_max
    vx = draw(st.floats(-60.0, 60.0))
    vy = draw(st.floats(1.0, 80.0))
    return params, s, vx, vy


#: Named hard cases, run first by every property test whatever hypothesis draws
#: (``(params, s, vx, vy)``, the post-collision state of ``state_from_section``).
_STATIC = Params(f=50.0, A=0.0)
HARD_CASES = {
    # a parabola flatter than the arc (vx^2 > g R) from a bump top: grazes the next top
    "grazing": (_STATIC.replace(R=100.0), 100.0 * math.asin(0.01), 1500.0, 1e-9),
    "wedge": (Params(f=85.2), 0.0, 3.0, 40.0),
    "chatter": (Params(f=58.0), 0.7, 0.5, 1.0),
    # issue 10: a wedge collapse inside the release window
    "steep_wedge": (
        Params(f=58.0, R=1.01),
        1.7775522733060598,
        -9.305795659049323,
        39.89118749577923,
    ),
    "steepest_wedge": (Params(f=70.0, R=1.001), 0.3, 5.0, 30.0),
    # falls onto a 120-degree wedge and leaves along the neighbour's wall (R = d)
    "wedge_tangent": (Params(f=30.0, A=0.0, alpha=0.1875, beta=0.1875, R=1.0, d=1.0), 0, 0, 1),
    # alpha = 1, beta = 0 in that wedge: the bounces accumulate (Zeno)
    "wedge_zeno": (Params(f=30.0, A=0.25, alpha=1.0, beta=0.0, R=1.0, d=1.0), 0, 0, 1),
    "gamma_below_one": (Params(f=40.0), 1.0, 3.0, 10.0),
    "tiny_velocity": (Params(f=85.2), 0.9, 1e-9, 1e-9),
    "huge_velocity": (Params(f=85.2), 0.9, 4000.0, 3e4),
}


def _check_run(params, s, vx, vy, n_events, n_samples):
    kp = params.kernel()
    try:
        state0 = state_from_section(params, s, vx, vy)
    except ValueError:
        return 0  # the velocity does not leave the floor there: not a valid start
    arrays, status = run_arrays(kp, state0, n_events)
    assert status in (OK, STUCK_FOREVER)
    for a in arrays:
        assert np.all(np.isfinite(a))
    periods, phase, tile, xi, vxs, vyrel, kind = arrays
    assert np.all(np.abs(xi) <= params.d / 2)
    worst_in, worst_end, back = flight_violations(
        periods, phase, xi, vxs, vyrel, kind, kp, n_samples
    )
    assert back == 0, "time went backwards"
    assert worst_in <= 1.0, f"particle below the floor by {worst_in} tolerances"
    assert worst_end <= 1.0, f"contact off the floor by {worst_end} tolerances"
    assert late_sticks(periods, phase, kind, params.gamma) == 0, "held inside the release window"
    # only a wedge collapse can stick inside the window: chattering and V_n = 0 need g_eff > 0
    in_window = window_sticks(phase, kind, params.gamma)
    assert np.all(np.abs(xi[in_window]) == params.d / 2), "chattering ended in the window"
    return len(kind) - 1


def hard_examples(test):
    """Decorate a property test with every named hard case as an explicit example."""
    for case in HARD_CASES.values():
        test = example(case)(test)
    return test


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@hard_examples
@given(billiard_cases())
def test_never_below_the_floor(case):
    """Property: the gap is never negative, times do not go backwards, nothing is NaN, and
    a stick inside the release window lasts zero time."""
    _check_run(*case, n_events=300, n_samples=6)


@pytest.mark.parametrize("name", HARD_CASES)
def test_hard_cases_are_valid_starts(name):
    """Every named hard case starts validly and runs (else the example would check nothing)."""
    assert _check_run(*HARD_CASES[name], n_events=300, n_samples=6) >= 1


@pytest.mark.slow
@settings(max_examples=1000, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@hard_examples
@given(billiard_cases())
def test_never_below_the_floor_explored(case):
    """The property over 1000 drawn cases of 2000 events (``HYPOTHESIS_PROFILE=explore``
    draws new ones on every run; ``--hypothesis-show-statistics`` counts the kinds)."""
    n = _check_run(*case, n_events=2000, n_samples=4)
    event("valid start" if n else "refused start (enters the floor)")
    if case[0].R < 0.6 * case[0].d:
        event("steep wedge (R < 0.6 d)")


@pytest.mark.slow
def test_never_below_the_floor_million_collisions():
    """>= 1e6 collisions over random parameters, the same invariants."""
    rng = np.random.default_rng(20040101)
    total = 0
    while total < 1_000_000:
        d = rng.uniform(0.5, 4.0)
        params = Params(
            f=rng.uniform(30.0, 120.0),
            A=rng.uniform(0.0, 0.3),
            alpha=rng.uniform(0.0, 1.0),
            beta=rng.uniform(0.0, 0.999),
            d=d,
            R=radius(d, rng.uniform(-3.0, 2.3)),
        )
        s = rng.uniform(0, params.s_max)
        total += _check_run(
            params, s, rng.uniform(-60, 60), rng.uniform(1, 80), n_events=50_000, n_samples=3
        )


# ---- the user-facing API --------------------------------------------------------------


def test_simulate_record_and_roundtrip(tmp_path):
    traj = simulate(P, n_events=500, s0=0.5, vx0=10.0, vy0=30.0)
    assert isinstance(traj, BilliardTrajectory)
    assert traj["kind"].shape == (501,)
    assert np.all(np.diff(traj["t"]) >= 0)
    assert np.all((traj["s"] >= 0) & (traj["s"] <= P.s_max + 1e-12))
    # row 0 is the initial state: s and absolute velocity as given
    assert math.isclose(traj["s"][0], 0.5, rel_tol=1e-14)
    assert math.isclose(traj["vy"][0], 30.0, rel_tol=1e-14)
    # y is the floor height under the particle at each event
    y_floor = -P.A * np.sin(traj["phase"]) + np.sqrt(P.R**2 - traj["xi"] ** 2)
    y_floor -= math.sqrt(P.R**2 - P.d**2 / 4)
    np.testing.assert_allclose(traj["y"], y_floor, rtol=0, atol=1e-12)
    traj.save(tmp_path / "traj")
    back = load_result(tmp_path / "traj")
    assert isinstance(back, BilliardTrajectory)
    np.testing.assert_array_equal(back["xi"], traj["xi"])
    assert traj.plot() is not None


def test_simulate_gamma_below_one_ends():
    traj = simulate(Params(f=40.0), n_events=100_000, s0=0.7, vx0=1.0, vy0=5.0)
    assert traj.meta["status"].startswith("stuck")
    assert traj["kind"][-1] == STICK and len(traj["kind"]) < 100_001


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"s0": -0.1, "vx0": 1.0, "vy0": 1.0}, "s must be in"),
        ({"s0": 0.5, "vx0": 1.0, "vy0": -100.0}, "must leave the floor"),
        ({"s0": 0.5, "vx0": 1.0}, "give either"),
        ({"s0": 0.5, "vx0": 1.0, "vy0": float("nan")}, "vy must be finite"),
    ],
    ids=["s-out-of-range", "into-floor", "missing-vy", "nan"],
)
def test_simulate_refuses_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        simulate(P, n_events=10, **kwargs)


def _offset_run(periods, tile):
    """Event times (periods from the start, with the phase) and tiles moved from the start of
    a run begun ``periods`` periods and ``tile`` tiles on."""
    state = state_from_section(P, 0.7, 10.0, 30.0)
    run = simulate(P, n_events=200, state0=(periods, state[1], tile, *state[3:]))
    return (run["periods"] - periods, run["phase"], run["tile"] - tile, run["xi"])


@pytest.mark.parametrize("offset", [2.0**40, 2.0**52 - 2.0**10, -(2.0**52) + 2.0**10])
def test_offsets_below_2_to_the_52_give_the_same_run(offset):
    """Time and space are homogeneous: a run begun any whole number of periods and tiles on
    (below 2^52) has the same event times and tile changes, bit for bit."""
    for got, want in zip(_offset_run(offset, offset), _offset_run(0.0, 0.0), strict=True):
        np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("name", ["periods", "tile"])
@pytest.mark.parametrize("offset", [2.0**52, -(2.0**52), 2.0**53, 1e300])
def test_offsets_beyond_2_to_the_52_are_refused(name, offset):
    """At 2^53 a period more is no longer a float (the times above come out wrong with status
    ok); from 2^52 sums of the offset and a fraction are inexact: refused, naming the offset."""
    state = list(state_from_section(P, 0.7, 10.0, 30.0))
    state[0 if name == "periods" else 2] = offset
    with pytest.raises(ValueError, match=f"{name} must be an integer of magnitude < 2\\^52"):
        simulate(P, n_events=10, state0=tuple(state))
    if name == "tile":
        with pytest.raises(ValueError, match="tile must be an integer of magnitude < 2\\^52"):
            state_from_section(P, 0.7, 10.0, 30.0, tile=offset)


def test_simulate_refuses_bad_n_events():
    with pytest.raises(ValueError, match="n_events must be"):
        simulate(P, n_events=0, s0=0.5, vx0=1.0, vy0=10.0)


# ---- the numba cache of the test run ---------------------------------------------------


def test_numba_cache_is_keyed_on_the_kernel_sources(tmp_path):
    """The test run's numba cache directory changes whenever a kernel source changes (numba
    would not see a change in a function inlined from another module)."""
    import numba
    from conftest import REPO, numba_source_key

    key = numba_source_key(REPO)
    assert os.environ["NUMBA_CACHE_DIR"].endswith(key)
    assert numba.config.CACHE_DIR == os.environ["NUMBA_CACHE_DIR"]
    copy = tmp_path / "repo"
    shutil.copytree(REPO / "bbdyn", copy / "bbdyn", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(REPO / "tests", copy / "tests", ignore=shutil.ignore_patterns("__pycache__"))
    assert numba_source_key(copy) == key
    plate = copy / "bbdyn" / "core" / "plate.py"
    text = plate.read_text()
    plate.write_text(text.replace("_KS6 = ", "_KS6 = 0.0 + "))
    assert numba_source_key(copy) != key
    plate.write_text(text)
    assert numba_source_key(copy) == key
    checks = copy / "tests" / "billiard_checks.py"  # a kernel outside bbdyn/core
    checks.write_text(checks.read_text() + "\n")
    assert numba_source_key(copy) != key
