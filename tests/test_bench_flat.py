"""Flat-ball work-precision benchmark (B2): the compared methods and the command."""

import json
import math

import numpy as np
import pytest

from bbdyn import cli
from bbdyn.benchmarking.fixed_step import fixed_step_one_step, fixed_step_run
from bbdyn.benchmarking.flat import case_params, exact_one_step, ivp_flight
from bbdyn.core.flat import flat_run, flat_run_count
from bbdyn.core.status import IMPACT, OK
from bbdyn.core.tolerances import EPS


@pytest.fixture(scope="module")
def orbit():
    """Start states (phase, vrel) on the chaotic benchmark orbit, and the exact flights."""
    kp = case_params().kernel()
    periods, phase, vrel, kind, _, status = flat_run_count(0.0, 0.3, 50.0, IMPACT, kp, 10_000)
    assert status == OK
    n = 200
    out = [np.empty(n) for _ in range(3)] + [np.empty(n, dtype=np.int64)]
    n_done, status = flat_run(periods, phase, vrel, kind, kp, *out)
    assert status == OK and n_done == n
    keep = out[3] == IMPACT  # start only from impacts (a release starts with vrel = 0)
    phases, vrels = out[1][keep], out[2][keep]
    tau, vm = np.empty(phases.size), np.empty(phases.size)
    assert exact_one_step(phases, vrels, kp, tau, vm) == OK
    return kp, phases, vrels, tau, vm


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
    rows = json.loads(capsys.readouterr().out)
    assert {r["method"] for r in rows} == {"exact", "fixed_step", "solve_ivp"}
    for row in rows:
        for key in ("impacts_per_s", "max_time_error_s", "max_velocity_error"):
            assert math.isfinite(row[key]) and row[key] >= 0, (row["setting"], key)
        assert row["impacts_per_s"] > 0
        assert isinstance(row["setting"], str)
    assert png.exists() and png.with_suffix(".json").exists()
    saved = json.loads(png.with_suffix(".json").read_text())
    assert saved["kind"] == "bench_flat" and len(saved["meta"]["rows"]) == len(rows)
