"""k/1 orbits, the exact-map Jacobian, Newton k/m orbits and the Arnold tongue edges."""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.flat import FlatArrays, FlatState, flat_event, flat_flight, flat_run
from bbdyn.core.flat_jacobian import flat_map_jacobian
from bbdyn.core.status import IMPACT, OK, STICK
from bbdyn.core.tolerances import FD_AGREE_REL, FD_STEP_REL, ORBIT_NEWTON_TOL
from bbdyn.flat.tongues import (
    OrbitNotFound,
    find_periodic_orbit,
    gamma_hi_numeric,
    gamma_lo_numeric,
    k1_orbit,
    k1_orbit_numeric,
    k1_trace,
    map_jacobian,
    params_at_gamma,
    tongue_gamma_hi,
    tongue_gamma_lo,
    tongue_table,
)

#: issue 2: gamma_hi_numeric must agree with the closed form to 1e-8 relative
EDGE_AGREE_REL = 1e-8
ALPHA = 0.5


def _scaled(jac, kp):
    """Jacobian in (phase, vrel w / g): dimensionless, so entries are comparable."""
    s = kp.w / kp.g
    return np.array([[jac[0, 0], jac[0, 1] / s], [jac[1, 0] * s, jac[1, 1]]])


def _states():
    rng = np.random.default_rng(12345)
    p = Params(f=70.0)
    vscale = p.g / p.w
    states = [(p, rng.uniform(0, 2 * math.pi), vscale * rng.uniform(0.3, 8.0)) for _ in range(20)]
    # short flights: small vrel where the plate holds the ball (sin > 0)
    states += [(p, 0.7, 1e-3 * vscale), (p, 2.0, 1e-2 * vscale)]
    o = k1_orbit(p, 1)
    states.append((p, o.phase_stable, o.vrel))
    return states


def _lifted_map(phase, vrel, kp):
    dphase, vrel_new, _, status = flat_map_jacobian(phase, vrel, kp)
    assert status == OK
    return np.array([phase + dphase, vrel_new])


def test_jacobian_matches_central_finite_differences_of_the_kernel():
    for p, phase, vrel in _states():
        kp = p.kernel()
        jac = map_jacobian(p, phase, vrel)
        fd = np.empty((2, 2))
        for j, h in enumerate((FD_STEP_REL, FD_STEP_REL * vrel)):
            dz = np.array([h, 0.0]) if j == 0 else np.array([0.0, h])
            up = _lifted_map(phase + dz[0], vrel + dz[1], kp)
            down = _lifted_map(phase - dz[0], vrel - dz[1], kp)
            fd[:, j] = (up - down) / (2 * h)
        a, b = _scaled(jac, kp), _scaled(fd, kp)
        assert np.max(np.abs(a - b)) <= FD_AGREE_REL * max(1.0, np.max(np.abs(a))), (phase, vrel)


def test_jacobian_determinant_is_the_flux_ratio():
    # Liouville: the flight maps the flux measure |vrel| dt dv to itself, the
    # impact multiplies by -alpha: det = alpha vrel+ / (-vrel-), for any flight.
    for p, phase, vrel in _states():
        kp = p.kernel()
        _, vrel_minus, _ = flat_flight(phase, vrel, kp)
        det = np.linalg.det(map_jacobian(p, phase, vrel))
        assert det == pytest.approx(p.alpha * vrel / -vrel_minus, rel=1e-12)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_closed_form_k1_orbit_is_a_fixed_point_of_the_exact_kernel(k):
    p = params_at_gamma(0.5 * (tongue_gamma_lo(k, ALPHA) + tongue_gamma_hi(k, ALPHA)), alpha=ALPHA)
    o = k1_orbit(p, k)
    for phase in (o.phase_stable, o.phase_unstable):
        tau, vrel_minus, status = flat_flight(phase, o.vrel, p.kernel())
        assert status == OK
        assert p.w * tau == pytest.approx(2 * math.pi * k, rel=64 * ORBIT_NEWTON_TOL)
        assert -ALPHA * vrel_minus == pytest.approx(o.vrel, rel=64 * ORBIT_NEWTON_TOL)
    assert o.v == pytest.approx(p.g * o.tau / 2, rel=1e-15)  # same height at both impacts
    assert math.sin(o.phase_stable) < 0 < math.sin(o.phase_unstable)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_stable_root_is_stable_and_the_other_a_saddle_with_closed_form_trace(k):
    gamma = 0.5 * (tongue_gamma_lo(k, ALPHA) + tongue_gamma_hi(k, ALPHA))
    p = params_at_gamma(gamma, alpha=ALPHA)
    o = k1_orbit(p, k)
    stable = find_periodic_orbit(p, k, 1, o.phase_stable, o.vrel)
    saddle = find_periodic_orbit(p, k, 1, o.phase_unstable, o.vrel)
    assert stable.is_stable and not saddle.is_stable
    assert stable["phase"][0] == pytest.approx(o.phase_stable, abs=1e-12)
    assert saddle["phase"][0] == pytest.approx(o.phase_unstable, abs=1e-12)
    for orbit, phase in ((stable, o.phase_stable), (saddle, o.phase_unstable)):
        jac = orbit["jacobian"]
        assert np.linalg.det(jac) == pytest.approx(ALPHA**2, rel=1e-12)
        assert np.trace(jac) == pytest.approx(k1_trace(gamma, ALPHA, math.sin(phase)), rel=1e-12)
    assert max(abs(saddle.eigenvalues)) > 1.0


@pytest.mark.parametrize("k", [1, 2, 3])
def test_numeric_tongue_edges_agree_with_the_closed_form(k):
    hi, lo = tongue_gamma_hi(k, ALPHA), tongue_gamma_lo(k, ALPHA)
    assert abs(gamma_hi_numeric(k, ALPHA) / hi - 1) <= EDGE_AGREE_REL
    assert abs(gamma_lo_numeric(k, ALPHA) / lo - 1) <= EDGE_AGREE_REL


def _iterate(p, phase, vrel, n):
    """Events of flat_run from an impact state (phases, vrels, kinds, absolute phase)."""
    out = (np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64))
    start = FlatState(0.0, phase, vrel, IMPACT)
    _, n_done, status = flat_run(start, p.kernel(), n, FlatArrays(*out))
    assert status == OK and n_done == n
    periods, phases, vrels, kinds = out
    return phases, vrels, kinds, periods * 2 * math.pi + phases


N_ITER, N_TAIL, KICK, DELTA = 20_000, 200, 1e-6, 1e-3


@pytest.mark.parametrize("k", [1, 2, 3])
@pytest.mark.parametrize(
    "edge, side", [("hi", "inside"), ("hi", "outside"), ("lo", "inside"), ("lo", "outside")]
)
def test_direct_iteration_confirms_stability_at_each_edge(k, edge, side):
    lo, hi = tongue_gamma_lo(k, ALPHA), tongue_gamma_hi(k, ALPHA)
    sign = {("hi", "inside"): -1, ("hi", "outside"): 1, ("lo", "inside"): 1, ("lo", "outside"): -1}
    gamma = (hi if edge == "hi" else lo) * (1 + sign[edge, side] * DELTA)
    p = params_at_gamma(gamma, alpha=ALPHA)
    if (edge, side) == ("lo", "outside"):
        o = k1_orbit(params_at_gamma(lo, alpha=ALPHA), k)  # the orbit's ghost at the edge
        phase, vrel = o.phase_stable, o.vrel * params_at_gamma(lo, alpha=ALPHA).w / p.w
    else:
        orbit = k1_orbit_numeric(k, gamma, ALPHA)
        phase, vrel = orbit["phase"][0], orbit["vrel"][0]
    phases, vrels, kinds, lifted = _iterate(p, phase + KICK, vrel, N_ITER)
    tail = slice(-N_TAIL, None)
    locked = np.all(kinds[tail] == IMPACT) and np.allclose(
        np.diff(lifted[tail]), 2 * math.pi * k, rtol=0, atol=1e-9
    )
    converged = locked and np.max(np.abs(phases[tail] - phase)) < 1e-9
    if side == "inside":
        assert converged
    else:
        assert not converged
        # beyond gamma_hi: locked on average (period 2), beyond gamma_lo: not locked at all
        if edge == "hi":
            two_flights = lifted[tail][2:] - lifted[tail][:-2]
            assert np.all(kinds[tail] == IMPACT)
            assert np.allclose(two_flights, 4 * math.pi * k, rtol=0, atol=1e-9)
        else:
            assert not locked


@pytest.mark.parametrize("k", [1, 2, 3])
def test_gamma_exactly_at_the_upper_edge_has_multiplier_minus_one(k):
    hi = tongue_gamma_hi(k, ALPHA)
    orbit = k1_orbit_numeric(k, hi, ALPHA)
    lam = np.sort(orbit.eigenvalues.real)
    assert np.all(orbit.eigenvalues.imag == 0)
    assert lam[0] == pytest.approx(-1.0, abs=1e-9)
    assert lam[1] == pytest.approx(-(ALPHA**2), abs=1e-9)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_gamma_exactly_at_the_lower_edge_is_a_fold_with_multiplier_plus_one(k):
    p = params_at_gamma(tongue_gamma_lo(k, ALPHA), alpha=ALPHA)
    o = k1_orbit(p, k)
    assert o.phase_stable == pytest.approx(math.pi, abs=1e-7)  # cos = -1 up to rounding of Gamma
    lam = np.sort(np.linalg.eigvals(map_jacobian(p, o.phase_stable, o.vrel)).real)
    assert lam[1] == pytest.approx(1.0, abs=1e-7)
    assert lam[0] == pytest.approx(ALPHA**2, abs=1e-7)
    with pytest.raises(ValueError, match="Gamma must be >= Gamma_lo"):
        k1_orbit(params_at_gamma(tongue_gamma_lo(k, ALPHA) * (1 - 1e-9), alpha=ALPHA), k)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_alpha_one_elastic_edges_and_multipliers_on_the_unit_circle(k):
    assert tongue_gamma_lo(k, 1.0) == 0.0
    assert tongue_gamma_hi(k, 1.0) == 1.0
    assert math.isnan(gamma_lo_numeric(k, 1.0))
    assert gamma_hi_numeric(k, 1.0) == pytest.approx(1.0, rel=EDGE_AGREE_REL)
    orbit = k1_orbit_numeric(k, 0.5, 1.0)
    assert np.abs(orbit.eigenvalues) == pytest.approx(1.0, abs=1e-12)  # elliptic: det = 1
    assert orbit["phase"][0] == pytest.approx(1.5 * math.pi, abs=1e-12)  # cos theta* = 0


@pytest.mark.parametrize("k", [1, 2, 3])
def test_alpha_zero_edges_and_the_orbit_sticks(k):
    assert tongue_gamma_lo(k, 0.0) == pytest.approx(math.pi * k, rel=1e-15)
    assert tongue_gamma_hi(k, 0.0) == pytest.approx(math.sqrt(math.pi**2 * k**2 + 4), rel=1e-15)
    gamma = 0.5 * (tongue_gamma_lo(k, 0.0) + tongue_gamma_hi(k, 0.0))
    p = params_at_gamma(gamma, alpha=0.0)
    o = k1_orbit(p, k)
    assert o.vrel == 0.0
    with pytest.raises(ValueError, match="alpha must be in"):
        gamma_hi_numeric(k, 0.0)
    # arriving on the orbit, the ball stops relative to the plate; it sticks where g_eff > 0
    if 1 + gamma * math.sin(o.phase_stable) > 0:
        _, _, _, kind, status = flat_event(0.0, o.phase_stable, 1e-9, IMPACT, p.kernel())
        assert status == OK and kind == STICK


def test_period_doubled_orbit_born_at_gamma_hi_grows_like_a_square_root():
    k = 1
    hi = tongue_gamma_hi(k, ALPHA)
    amplitudes = []
    for delta in (1e-3, 4e-3):
        gamma = hi * (1 + delta)
        p = params_at_gamma(gamma, alpha=ALPHA)
        one = k1_orbit_numeric(k, gamma, ALPHA)
        assert not one.is_stable
        phases, vrels, _, _ = _iterate(p, one["phase"][0] + 1e-4, one["vrel"][0], 5000)
        two = find_periodic_orbit(p, 2 * k, 2, phases[-1], vrels[-1])
        assert two.is_stable  # supercritical flip
        assert np.sum(two["tau"]) * p.w == pytest.approx(4 * math.pi * k, rel=1e-13)
        amplitudes.append(abs(two["phase"][1] - two["phase"][0]))
    slope = math.log(amplitudes[1] / amplitudes[0]) / math.log(4.0)
    assert slope == pytest.approx(0.5, abs=0.02)


def test_newton_reports_failure_below_the_tongue_and_validates_input():
    p = params_at_gamma(0.9 * tongue_gamma_lo(1, ALPHA), alpha=ALPHA)
    with pytest.raises(OrbitNotFound, match="1/1 orbit at Gamma"):
        find_periodic_orbit(p, 1, 1, math.pi, 0.5 * p.g * math.pi / p.w)
    with pytest.raises(ValueError, match="m must be an integer >= 1, got 0"):
        find_periodic_orbit(p, 1, 0, 1.0, 1.0)
    with pytest.raises(ValueError, match="vrel must be > 0"):
        find_periodic_orbit(p, 1, 1, 1.0, -1.0)


def test_tongue_table_frequencies_match_model_md():
    table = tongue_table(ALPHA, 3, numeric=False)
    model_md = [(50.99, 61.56), (72.10, 76.72), (88.31, 90.95)]
    for row, (f_lo, f_hi) in zip(table.rows(), model_md, strict=True):
        assert row["f_lo_hz"] == pytest.approx(f_lo, abs=0.005)
        assert row["f_hi_hz"] == pytest.approx(f_hi, abs=0.005)
        assert row["gamma_hi_numeric"] is None


def test_cli_tongues_json_matches_closed_form_and_numeric_edges(capsys):
    import json

    from bbdyn.commands.cli import main

    assert main(["tongues", "--alpha", "0.5", "--kmax", "3", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["tongues"]
    assert [r["k"] for r in rows] == [1, 2, 3]
    for r in rows:
        assert r["gamma_lo"] == pytest.approx(tongue_gamma_lo(r["k"], 0.5), rel=1e-12)
        assert r["gamma_hi"] == pytest.approx(tongue_gamma_hi(r["k"], 0.5), rel=1e-12)
        assert abs(r["gamma_hi_numeric"] / r["gamma_hi"] - 1) <= EDGE_AGREE_REL
        assert abs(r["gamma_lo_numeric"] / r["gamma_lo"] - 1) <= EDGE_AGREE_REL
        assert r["f_lo"] == pytest.approx(math.sqrt(r["gamma_lo"] * 98000) / (2 * math.pi))


def test_scene_s1_quick_saves_numbers_and_redraws(tmp_path):
    from bbdyn.results import load_result
    from bbdyn.scenes import redraw_scene, run_scene
    from bbdyn.scenes.s1_tongues import SceneS1Result

    result, png = run_scene("S1", setting="quick", out_dir=tmp_path)
    assert png.exists() and result.kind == "scene_s1"
    assert result.meta["max_rel_dev_hi"] <= EDGE_AGREE_REL
    assert result.meta["max_rel_dev_lo"] <= EDGE_AGREE_REL
    loaded = load_result(tmp_path / "S1.json")
    assert isinstance(loaded, SceneS1Result)
    assert np.array_equal(loaded["gamma_hi_numeric"], result["gamma_hi_numeric"])
    assert redraw_scene(tmp_path / "S1.json").exists()


def test_stored_tongue_table_is_the_closed_form_and_the_numeric_edges_agree():
    """docs/data/flat_tables.json (the table of docs/tongues.md): the closed-form edges and
    their frequencies at alpha = 0.5, and numeric edges within a few ulp of them."""
    import json
    from pathlib import Path

    from bbdyn.flat.tongues import frequency_at_gamma, tongue_gamma_hi, tongue_gamma_lo

    path = Path(__file__).parents[1] / "docs" / "data" / "flat_tables.json"
    for row in json.loads(path.read_text())["tongues"]:
        k = row["k"]
        assert row["gamma_lo"] == pytest.approx(tongue_gamma_lo(k, 0.5), rel=1e-15)
        assert row["gamma_hi"] == pytest.approx(tongue_gamma_hi(k, 0.5), rel=1e-15)
        assert row["f_hi_hz"] == pytest.approx(frequency_at_gamma(row["gamma_hi"]), rel=1e-15)
        for edge in ("lo", "hi"):
            dev = (row[f"gamma_{edge}_numeric"] - row[f"gamma_{edge}"]) / row[f"gamma_{edge}"]
            assert dev == row[f"{edge}_rel_dev"] and abs(dev) < 8 * np.finfo(float).eps
