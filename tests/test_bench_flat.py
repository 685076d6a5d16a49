"""Flat-ball work-precision benchmark (B2): the compared methods and the command."""

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from bbdyn.commands import cli
from bbdyn.core.flat import FlatArrays, FlatState, flat_flight, flat_run
from bbdyn.core.search import flat_flight_tol
from bbdyn.core.status import IMPACT, OK
from bbdyn.core.tolerances import EPS, ROOT_STEP_REL
from bbdyn.reference.bench_kernels import flat_one_step
from bbdyn.reference.fixed_step import fixed_step_one_step, fixed_step_run
from bbdyn.reference.flat_ivp import ivp_flight
from bbdyn.reference.heyoka_flight import heyoka_available
from bbdyn.scenes import b2_flat
from bbdyn.scenes.b2_flat import (
    case_params,
    one_step_errors,
    start_states,
)

#: Stopping tolerances of the exact map compared in the benchmark, loosest first.
STEP_RELS = [1e-4, 1e-7, 1e-10, 1e-13, ROOT_STEP_REL]
STEP_REL_IDS = ["1e-4", "1e-7", "1e-10", "1e-13", "default"]


@pytest.fixture(scope="module")
def orbit():
    """Start states (phase, vrel) on the chaotic benchmark orbit, and the exact flights."""
    kp = case_params().kernel()
    last, _, status = flat_run(FlatState(0.0, 0.3, 50.0, IMPACT), kp, 10_000, None)
    assert status == OK
    n = 200
    out = [np.empty(n) for _ in range(3)] + [np.empty(n, dtype=np.int64)]
    _, n_done, status = flat_run(last, kp, n, FlatArrays(*out))
    assert status == OK and n_done == n
    keep = out[3] == IMPACT  # start only from impacts (a release starts with vrel = 0)
    phases, vrels = out[1][keep], out[2][keep]
    tau, vm = np.empty(phases.size), np.empty(phases.size)
    assert flat_one_step(phases, vrels, kp, ROOT_STEP_REL, tau, vm)[1] == OK
    return kp, phases, vrels, tau, vm


@pytest.fixture(scope="module")
def reference():
    """Start states on the orbit and the mpmath one-step reference from each (40 digits)."""
    params = case_params()
    return params.kernel(), start_states(params, 30)


def test_exact_one_step_at_the_default_tolerance_is_flat_flight(orbit):
    """The benchmark's default row measures exactly what flat_flight returns."""
    kp, phases, vrels, tau, vm = orbit
    for i in range(phases.size):
        assert flat_flight(phases[i], vrels[i], kp) == (tau[i], vm[i], OK)


@pytest.mark.parametrize("step_rel", STEP_RELS, ids=STEP_REL_IDS)
def test_exact_map_one_step_error_is_within_the_documented_bound(reference, step_rel):
    """Never late (beyond rounding), early by at most d (1 + M d / |G'|), d = step_rel tau.

    The bound is flat_flight_tol's for a transversal contact (all flights of the
    benchmark orbit are); v+ = -alpha vrel- + u then errs by at most
    (alpha M + A w^2) times the time error, |G''| <= M and |u'| <= A w^2.
    """
    kp, st = reference
    tau, vm = np.empty(st["tau"].size), np.empty(st["tau"].size)
    assert flat_one_step(st["phase"], st["vrel"], kp, step_rel, tau, vm)[1] == OK
    M, aw2 = kp.curv_bound, kp.A * kp.w**2
    d = step_rel * st["tau"]
    # a gap rounding error e (a few ulp of its terms) moves the contact by e / |G'|
    rounding = 8 * EPS * (st["vrel"] * tau + kp.g * tau**2 / 2 + 2 * kp.A) / np.abs(vm)
    early = st["tau"] - tau
    assert np.all(early >= -rounding)
    bound = d * (1 + 2 * M * d / np.abs(vm)) + rounding
    assert np.all(early <= bound)
    # the same bound on v+, plus the rounding of its terms (v, u, the phase of u)
    scale = np.abs(vm) + st["vrel"] + 2 * kp.A * kp.w + kp.g * tau
    scale += kp.A * kp.w * (st["phase"] + kp.w * tau)
    dv = np.abs(-kp.alpha * vm - kp.A * kp.w * np.cos(st["phase"] + kp.w * tau) - st["v"])
    assert np.all(dv <= (kp.alpha * M + aw2) * bound + 16 * EPS * scale)
    errors = one_step_errors(kp, st, tau, vm)
    assert errors["wrong_contacts"] == 0 and errors["max_time_error_s"] == np.max(np.abs(early))


def test_exact_map_cost_does_not_grow_as_the_tolerance_loosens(orbit):
    """The safe-step iterates do not depend on step_rel, only where they stop: per flight, a
    looser tolerance stops at an earlier iterate (tau no later) after no more gap evaluations.
    The default ends with the Taylor finish instead: at the contact the tightest safe-step
    iterate approaches from below, and in all cheaper."""
    kp, phases, vrels, _, _ = orbit
    taus, evals = [], []
    for step_rel in STEP_RELS:
        out = np.array(
            [flat_flight_tol(p, v, kp, step_rel) for p, v in zip(phases, vrels, strict=True)]
        )
        assert np.all(out[:, 2] == OK)
        taus.append(out[:, 0])
        evals.append(out[:, 3])
    for loose, tight in zip(range(len(STEP_RELS) - 2), range(1, len(STEP_RELS) - 1), strict=True):
        assert np.all(evals[loose] <= evals[tight]), STEP_REL_IDS[loose]
        assert np.all(taus[loose] <= taus[tight]), STEP_REL_IDS[loose]
    assert STEP_REL_IDS[-1] == "default"
    # the 1e-13 iterate is early by at most (1 + sqrt 2) 1e-13 of the flight, or it has reached
    # the contact within rounding (the finish's root is within a few ulp of it)
    assert np.all(taus[-2] <= taus[-1] * (1 + 4 * EPS))
    assert np.all(taus[-1] - taus[-2] <= 2.5e-13 * taus[-1])
    assert evals[-1].sum() < evals[-2].sum()
    # and the tolerance is used: the loosest saves evaluations over the tightest
    assert evals[0].sum() < evals[-2].sum()


def _tangent_flight(kp, theta_c, h):
    """Start (phase, vrel) of a flight whose gap has a minimum h (mm) at phase theta_c.

    The parabola with the plate's height + h and velocity at t_c = theta_c / w
    (sin theta_c < -1/Gamma, so G'' > 0 there: a minimum), followed back to its
    previous contact with the plate, the largest root of the gap before t_c.
    """
    A, w, g = kp.A, kp.w, kp.g
    t_c = theta_c / w

    def gap(t):
        y = -A * math.sin(theta_c) + h - A * w * math.cos(theta_c) * (t - t_c)
        return y - g * (t - t_c) ** 2 / 2 + A * math.sin(w * t)

    grid = t_c - np.linspace(1e-4, 2 * kp.period, 20_001)
    i = next(i for i in range(grid.size) if gap(grid[i]) <= 0)
    t0 = brentq(gap, grid[i], grid[i - 1], xtol=1e-300, rtol=4 * EPS)
    v0 = -A * w * math.cos(theta_c) + g * (t_c - t0)
    return (w * t0) % (2 * math.pi), v0 + A * w * math.cos(w * t0), t_c - t0


@pytest.mark.parametrize(
    ("h_over_bound", "step_rel"),
    [
        pytest.param(0.0, 1e-4, id="tangent_1e-4"),
        pytest.param(0.5, 1e-4, id="near_miss_below_bound_1e-4"),
        pytest.param(0.5, 1e-7, id="near_miss_below_bound_1e-7"),
    ],
)
def test_loose_tolerance_stops_near_a_tangency(h_over_bound, step_rel):
    """A gap minimum h below M d^2 / 2 (d = step_rel tau) is reported as a contact, early by
    at most (1 + sqrt 2) d (linear convergence e -> (2 - sqrt 2) e, stopped when the step
    (sqrt 2 - 1) e <= d; first order in w d = 4e-4 here), as documented; the default
    tolerance flies past a true near miss."""
    kp = case_params().kernel()
    theta_c = 1.5 * math.pi + 0.2  # sin = -0.98 < -1/Gamma = -0.37
    M = kp.curv_bound
    _, _, tau_c = _tangent_flight(kp, theta_c, 0.0)
    d = step_rel * tau_c
    h = h_over_bound * M * d * d / 2
    phase, vrel, tau_c = _tangent_flight(kp, theta_c, h)
    tau, _, status, _ = flat_flight_tol(phase, vrel, kp, step_rel)
    assert status == OK
    assert 0 <= tau_c - tau <= (1 + math.sqrt(2)) * d
    if h > 0:
        tau_default, _, status = flat_flight(phase, vrel, kp)
        assert status == OK and tau_default > tau_c + 0.01 * kp.period


def _fixed(kp, phases, vrels, dt, dt_min):
    tau, vm = np.empty(phases.size), np.empty(phases.size)
    _, status = fixed_step_one_step(phases, vrels, dt, dt_min, kp, tau, vm)
    assert status == OK
    return tau, vm


@pytest.mark.parametrize(
    ("dt", "halvings"),
    [
        # without refinement every flight costs tau / dt samples: stop at dt = 4e-7 s
        pytest.param(None, (2, 4, 6, 8), id="no_refinement_dt_shrinks"),
        pytest.param(1e-4, (3, 6, 9, 12), id="refinement_from_dt_1e-4"),
    ],
)
def test_fixed_step_impact_time_error_is_first_order(orbit, dt, halvings):
    """The impact is put at the first sample below the plate: late by [0, dt_min), order 1."""
    kp, phases, vrels, tau_exact, vm_exact = orbit
    steps, errors, v_errors = [], [], []
    for k in halvings:
        step, dt_min = (1e-4 / 2**k, 1e-4 / 2**k) if dt is None else (dt, dt / 2**k)
        tau, vm = _fixed(kp, phases, vrels, step, dt_min)
        late = tau - tau_exact
        # Never early, and late by less than the final bracket (up to rounding of tau).
        assert np.all(late >= -4 * EPS * tau_exact)
        assert np.all(late <= dt_min * (1 + 1e-9))
        steps.append(dt_min)
        errors.append(np.mean(late))
        v_errors.append(np.mean(np.abs(vm - vm_exact)))
    slope_t = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    slope_v = np.polyfit(np.log(steps), np.log(v_errors), 1)[0]
    assert slope_t == pytest.approx(1.0, abs=0.1)
    assert slope_v == pytest.approx(1.0, abs=0.1)


def test_fixed_step_turns_chattering_into_micro_bounces():
    """From rest on a holding plate the flights lock to m final brackets, never a stick."""
    kp = case_params().kernel()
    dt = 1e-4
    h = dt / 2**7  # the final bracket of the halving, 7.8e-7 s
    n = 60
    per, ph, vr = (np.empty(n) for _ in range(3))
    # phase 0: g_eff = g > 0, the plate holds the particle for a quarter period and more.
    n_done, status = fixed_step_run(0.0, 0.0, 0.0, dt, h, kp, per, ph, vr)
    assert status == OK and n_done == n
    flight = np.diff(per * 2 * math.pi + ph) / kp.w
    m = np.round(flight / h)
    np.testing.assert_allclose(flight, m * h, rtol=1e-6)
    assert np.all((m >= 1) & (m < (1 + kp.alpha) / (1 - kp.alpha)))
    # vrel+ tends to alpha g_eff m h / (1 + alpha), the fixed point of v -> alpha (g_eff m h - v).
    g_eff = kp.g + kp.A * kp.w**2 * np.sin(ph[-1])
    assert m[-1] == m[-2]
    assert vr[-1] == pytest.approx(kp.alpha * g_eff * m[-1] * h / (1 + kp.alpha), rel=1e-2)


@pytest.mark.parametrize(
    ("method", "frame", "rtol", "max_step"),
    [
        pytest.param("DOP853", "plate", 1e-13, math.inf, id="dop853_plate_frame"),
        pytest.param("RK45", "plate", 1e-10, math.inf, id="rk45_plate_frame"),
        pytest.param("RK45", "lab", 1e-6, 0.05, id="rk45_lab_frame_max_step"),
    ],
)
def test_solve_ivp_at_tight_rtol_agrees_with_exact_map(orbit, method, frame, rtol, max_step):
    kp, phases, vrels, tau_exact, vm_exact = orbit
    for i in range(0, phases.size, 10):
        tau, vm = ivp_flight(kp, float(phases[i]), float(vrels[i]), method, frame, rtol, max_step)
        # In the lab frame the solution is a parabola, integrated exactly: only the
        # event root finding (scipy's brentq, 4 eps) and rounding of y remain.
        tol = 10 * rtol if frame == "plate" else 64 * EPS
        assert tau == pytest.approx(tau_exact[i], rel=tol)
        # |d vrel / d tau| <= M = g + A w^2, so a time error moves vrel- by at most M times it.
        assert vm == pytest.approx(vm_exact[i], abs=tol * (kp.curv_bound * tau_exact[i] + abs(vm)))


def test_bench_flat_json_rows_have_finite_fields(tmp_path, capsys, monkeypatch):
    # Only this command is needed: isolate the test from the other subcommands.
    monkeypatch.setattr(cli, "COMMANDS", {"bench": "bench"})
    png = tmp_path / "bench.png"
    argv = ["bench", "flat", "--quick", "--json", "--impacts", "6", "--long-run", "200"]
    assert cli.main([*argv, "--out", str(png)]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    peers = {"heyoka"} if heyoka_available() else set()
    assert {r["method"] for r in rows} == {"exact", "fixed_step", "solve_ivp"} | peers
    for row in rows:
        for key in ("impacts_per_s", "max_time_error_s", "max_velocity_error"):
            assert math.isfinite(row[key]) and row[key] >= 0, (row["setting"], key)
        assert row["impacts_per_s"] > 0
        assert isinstance(row["setting"], str)
    assert png.exists() and png.with_suffix(".json").exists()
    saved = json.loads(png.with_suffix(".json").read_text())
    assert saved["kind"] == "bench_flat" and len(saved["meta"]["rows"]) == len(rows)


def test_without_heyoka_the_table_says_so(monkeypatch):
    """No heyoka row when heyoka is not importable, and the table says why."""
    monkeypatch.setattr(b2_flat, "heyoka_available", lambda: False)
    monkeypatch.setattr(b2_flat, "heyoka_version", lambda: None)
    settings = dict(b2_flat.QUICK, n_impacts=3, exact_tols=[], fixed=[], ivp=[], long_run=50)
    settings.update(long_run_fixed=[], continuous_events=100, repeats=1, min_time=0.0)
    res = b2_flat.compute(settings, log=lambda msg: None)
    assert "heyoka" not in {r["method"] for r in res.meta["rows"]}
    assert "heyoka not installed" in b2_flat.table(res)


def _committed_flat():
    """The committed run of ``bbdyn bench flat`` (docs/bench/bench_flat.json and .npz)."""
    from derivation_loader import ROOT

    from bbdyn.results import load_result

    return load_result(ROOT / "docs" / "bench" / "bench_flat.json")


def test_committed_run_exact_map_is_at_rounding_level_and_fixed_step_at_dt_min():
    """docs/benchmarks.md, flat ball: the exact map's one-step time error is a few ulp of the
    longest flight and its velocity error that time error times the relative acceleration;
    each fixed-step row is late by less than its dt_min (first order) and costs in proportion
    to 1/dt; the paper-like setting is ~1e10 less accurate than the exact map."""
    run = _committed_flat()
    rows, params = run.meta["rows"], run.meta["params"]
    exact = rows[0]
    assert exact["setting"].startswith("default")
    longest = float(np.max(run["ref_tau"]))
    assert exact["max_time_error_s"] <= 16 * EPS * longest
    accel = params["g"] + params["A"] * (2 * math.pi * params["f"]) ** 2
    rounding_v = 4 * EPS * float(np.max(np.abs(run["ref_v"])))
    # v+ = (1 + alpha) u - alpha v-: a time error dt moves u by at most A w^2 dt and v- by
    # g dt, so v+ by at most (1 + alpha) (g + A w^2) dt
    bound = (1 + params["alpha"]) * accel * exact["max_time_error_s"] + rounding_v
    assert exact["max_velocity_error"] <= bound
    fixed = [r for r in rows if r["method"] == "fixed_step"]
    for r in fixed:
        assert r["max_time_error_s"] < r["dt_min"] and r["wrong_contacts"] == 0
    by = {(r["dt"], r["dt_min"]): r for r in fixed}
    coarse, fine = by[1e-4, 1e-6], by[1e-5, 1e-6]
    assert 5 < fine["cost_ratio_to_exact"] / coarse["cost_ratio_to_exact"] < 20
    assert coarse["max_time_error_s"] / exact["max_time_error_s"] > 1e9


def test_committed_run_default_tolerance_is_nearly_the_cheapest():
    """The default (the Taylor finish) needs no more gap evaluations per impact than any
    stopping tolerance from 1e-4 to 1e-13; every tolerance's error is within its documented
    bound."""
    rows = _committed_flat().meta["rows"]
    loose = {r["step_rel"]: r for r in rows[2:6]}
    assert sorted(loose) == [1e-13, 1e-10, 1e-7, 1e-4]
    default = rows[0]["gap_evals_per_impact"]
    assert all(default <= r["gap_evals_per_impact"] for r in loose.values())
    for r in loose.values():
        assert r["wrong_contacts"] == 0 and r["max_early_per_step_rel"] <= 1 + math.sqrt(2)


def test_committed_run_solve_ivp_and_heyoka():
    """solve_ivp in the lab frame with scipy's defaults ends flights at wrong contacts at
    every rtol; with max_step it is right to rounding; in the plate frame its error falls
    with rtol and it finds every contact; heyoka is at rounding level."""
    rows = _committed_flat().meta["rows"]
    ivp = [r for r in rows if r["method"] == "solve_ivp"]
    lab = [r for r in ivp if r["frame"] == "lab"]
    assert all(r["wrong_contacts"] > 0 for r in lab if not math.isfinite(r["max_step_periods"]))
    capped = [r for r in lab if math.isfinite(r["max_step_periods"])]
    assert capped and all(r["wrong_contacts"] == 0 and r["max_time_error_s"] < 1e-15
                          for r in capped)  # fmt: skip
    for method in ("RK45", "DOP853"):
        plate = sorted((r for r in ivp if r["frame"] == "plate" and r["ivp_method"] == method),
                       key=lambda r: -r["rtol"])  # fmt: skip
        errors = [r["max_time_error_s"] for r in plate]
        assert errors == sorted(errors, reverse=True) and all(r["wrong_contacts"] == 0
                                                              for r in plate)  # fmt: skip
    heyoka = [r for r in rows if r["method"] == "heyoka"]
    assert all(r["max_time_error_s"] < 1e-16 for r in heyoka)


def test_committed_run_long_run_statistics():
    """The fixed step's impact phases lie on a lattice, so they repeat: over a hundred times
    as many repeated phases as the exact map has; the mean post-impact velocity agrees within
    3 combined standard errors."""
    long_run = _committed_flat().meta["long_run"]
    exact = long_run[0]
    assert exact["method"] == "exact"
    exact_repeats = exact["n_impacts"] - exact["distinct_phases"]
    for r in long_run[1:]:
        assert r["n_impacts"] - r["distinct_phases"] > 100 * max(exact_repeats, 1)
        z = (r["mean_v"] - exact["mean_v"]) / math.hypot(r["stderr_mean_v"],
                                                          exact["stderr_mean_v"])  # fmt: skip
        assert abs(z) < 3


def test_a_value_a_row_does_not_measure_prints_as_a_dash():
    """A benchmark row without a column (e.g. evaluations of a peer integrator) prints "-",
    never nan; a NaN value likewise; counts print 0."""
    from bbdyn.reference.timing import ERROR_COLUMNS, format_rows

    rows = [{"method": "exact", "setting": "s", "max_time_error_s": 1e-18,
             "median_time_error_s": math.nan}]  # fmt: skip
    head, line = format_rows(rows, ERROR_COLUMNS, 5)
    assert "nan" not in line.lower()
    cells = line.split()[2:]
    assert cells == ["1.00e-18", "-", "-", "0", "-"]
