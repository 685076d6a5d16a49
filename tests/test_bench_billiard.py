"""Billiard work-precision benchmark (B2): reference, fixed-step method, exact kernel, command."""

import json
import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.commands import cli
from bbdyn.core.billiard import EventArrays, EventState, billiard_run, tiny_hop
from bbdyn.core.plate import sin_cos
from bbdyn.core.status import IMPACT, OK, STICK
from bbdyn.core.tolerances import DEPARTURE_REL_TOL, EPS, IMPACT_TIME_TOL
from bbdyn.reference.bench_kernels import billiard_one_step, flight_profile
from bbdyn.reference.fixed_step_billiard import fixed_step_billiard_one_step
from bbdyn.scenes import b2_billiard as bench

N_FLIGHTS = 40


@pytest.fixture(scope="module")
def flights():
    """Start states on the 85.2 Hz attractor, the exact flights and the mpmath reference."""
    params = Params(f=bench.CASE["f"])
    kp = params.kernel()
    states = bench.attractor_states(params, N_FLIGHTS)
    starts = np.ascontiguousarray(bench._start_array(states))
    out = [np.empty(starts.shape[0]) for _ in range(5)]
    assert billiard_one_step(starts, kp, *out) == OK
    ref = bench._reference(kp, starts, out[1], out[0])
    return kp, starts, out, ref


def test_exact_kernel_impact_time_matches_mpmath(flights):
    """One flight of the exact kernel hits the mpmath root to IMPACT_TIME_TOL (<< 1e-12 s)."""
    kp, starts, (tau, _, _, vx, vy), ref = flights
    assert np.all(np.isfinite(ref))
    err = np.abs(tau - ref[:, 0])
    assert err.max() <= IMPACT_TIME_TOL
    # flights of more than a millisecond are right to a few ulp of the flight time
    # (tiny chattering hops lose more: V.n << |V| is rounded from vx and vyrel)
    long = ref[:, 0] > 1e-3
    assert np.count_nonzero(long) >= 5
    assert np.all(err[long] <= 4 * EPS * ref[long, 0])
    # the post-impact velocity follows: error ~ time error x acceleration bound
    dv = np.hypot(vx - ref[:, 1], vy - ref[:, 2])
    assert dv.max() <= 1e3 * EPS * kp.curv_bound * kp.period


def test_fixed_step_is_late_by_less_than_its_bracket(flights):
    """The fixed-step contact is never early and late by less than dt_min."""
    kp, starts, _, ref = flights
    n = starts.shape[0]
    for dt, dt_min in ((1e-4, 1e-6), (1e-5, 1e-8)):
        out = [np.empty(n) for _ in range(5)]
        _, status = fixed_step_billiard_one_step(starts, dt, dt_min, kp, *out)
        assert status == OK
        late = out[0] - ref[:, 0]
        assert np.all(late >= -IMPACT_TIME_TOL)
        assert np.all(late <= dt_min * (1 + 1e-9))


def test_fixed_step_error_is_first_order_in_dt_min(flights):
    """Halving the final bracket halves the mean lateness (fitted slope 1)."""
    kp, starts, _, ref = flights
    n = starts.shape[0]
    brackets = 1e-4 / 2.0 ** np.array([4, 7, 10, 13])
    mean_late = []
    for dt_min in brackets:
        out = [np.empty(n) for _ in range(5)]
        assert fixed_step_billiard_one_step(starts, 1e-4, dt_min, kp, *out)[1] == OK
        mean_late.append(np.mean(out[0] - ref[:, 0]))
    slope = np.polyfit(np.log(brackets), np.log(mean_late), 1)[0]
    assert abs(slope - 1.0) < 0.15


def test_profile_counts_agree_with_recorded_run():
    """flight_profile's collision and stick counts are those of a recorded run, and its tiny
    hops are the flights of that run that tiny_hop solves."""
    kp = Params(f=58.0).kernel()
    n = 5000
    state = np.array(bench.CASE["start"], dtype=float)
    _, flights_, tiny, collisions, sticks, status = flight_profile(state, kp, n)
    assert status == OK
    arrays = [np.empty(n) for _ in range(6)] + [np.empty(n, dtype=np.int64)]
    _, n_done, status = billiard_run(EventState(*bench.CASE["start"]), kp, n, EventArrays(*arrays))
    assert status == OK and n_done == n
    kind = arrays[6]
    assert collisions == np.count_nonzero(kind != 2)
    assert sticks == np.count_nonzero(kind == STICK)
    # a flight starts after every event but a STICK (the start is an IMPACT)
    assert flights_ == 1 + np.count_nonzero(kind[:-1] != STICK)
    assert bench.CASE["start"][6] == IMPACT
    start = bench.CASE["start"]
    starts = [(start[1], start[3], start[4], start[5])] + [
        (arrays[1][i], arrays[3][i], arrays[4][i], arrays[5][i]) for i in range(n - 1)
        if kind[i] != STICK
    ]  # fmt: skip
    solved = 0
    for phase, xi, vx, vyrel in starts:
        S0 = math.sqrt((kp.R - xi) * (kp.R + xi))
        Gp = vyrel + vx * xi / S0
        if Gp > DEPARTURE_REL_TOL * (abs(vyrel) + abs(vx * xi) / S0) and abs(xi) < kp.d / 2:
            solved += tiny_hop(*sin_cos(phase), xi, S0, vx, vyrel, Gp, kp)[3]
    assert tiny == solved > 0


TINY = {
    "n_impacts": 12,
    "fixed": [(1e-4, 1e-6)],
    "continuous_events": 5000,
    "ensemble": {"n": 8, "t": 0.5, "threads": 1},
    "observables": {"n": 4, "t": 0.5, "seed": 1, "fixed": [(1e-4, 1e-6)]},
    "profile_f": [58.0],
    "profile_events": 2000,
    "repeats": 1,
    "min_time": 0.0,
}


def test_compute_rows_and_table(tmp_path):
    """The benchmark's rows carry the flat benchmark's fields and collisions_per_s."""
    res = bench.compute(TINY, log=lambda msg: None)
    rows = res.meta["rows"]
    for row in rows:
        for key in ("method", "setting", "impacts_per_s", "collisions_per_s", "max_time_error_s"):
            assert key in row
        assert row["collisions_per_s"] > 0 and row["collisions_per_cpu_s"] > 0
    assert "coll/s wall" in bench.table(res) and "coll/CPU-s" in bench.table(res)
    assert all(p["collisions_per_cpu_s"] > 0 for p in res.meta["profile"])
    exact = rows[0]
    assert exact["max_time_error_s"] <= IMPACT_TIME_TOL and exact["wrong_contacts"] == 0
    fixed = [r for r in rows if r["method"] == "fixed_step"]
    assert all(r["max_time_error_s"] <= r["dt_min"] for r in fixed)
    obs = res.meta["observables"]
    assert [r["method"] for r in obs] == ["exact", "fixed_step"]
    assert all(
        math.isfinite(r["E"])
        and math.isclose(r["E"], r["E_x"] + r["E_y"] + r["E_pot"], rel_tol=1e-12)
        for r in obs
    )
    assert "profile" in bench.table(res)
    res.save(tmp_path / "b")
    fig = bench.draw(res)
    fig.savefig(tmp_path / "b.png")


@pytest.mark.slow
def test_bench_billiard_cli_json(tmp_path, capsys):
    """`bbdyn bench billiard --quick --json` prints rows with collisions_per_s."""
    assert (
        cli.main(["bench", "billiard", "--quick", "--json", "--out", str(tmp_path / "b.png")]) == 0
    )
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert rows[0]["method"] == "exact" and rows[0]["collisions_per_s"] > 0
    assert (tmp_path / "b.png").exists() and (tmp_path / "b.json").exists()


def _committed_billiard() -> dict:
    """``meta`` of the committed run of ``bbdyn bench billiard`` (docs/bench/bench_billiard)."""
    from derivation_loader import ROOT

    from bbdyn.results import load_result

    return load_result(ROOT / "docs" / "bench" / "bench_billiard.json").meta


def test_committed_run_errors_and_costs():
    """docs/benchmarks.md, billiard: the exact kernel's one-step time error is at rounding
    level (a few ulp of a flight of at most a period or so); each fixed-step row is late by
    less than its dt_min, finds the right contact and costs more than the exact kernel."""
    meta = _committed_billiard()
    period = 1.0 / meta["case"]["f"]
    exact = [r for r in meta["rows"] if r["method"] == "exact"]
    assert all(
        r["max_time_error_s"] <= 16 * EPS * 2 * period
        for r in exact
        if r["max_time_error_s"] is not None and math.isfinite(r["max_time_error_s"])
    )
    for r in meta["rows"]:
        if r["method"] == "fixed_step":
            assert r["max_time_error_s"] < r["dt_min"] and r["wrong_contacts"] == 0
            assert r["cost_ratio_to_exact"] > 1
        if r["method"] == "heyoka":
            assert r["max_time_error_s"] < 1e-16


def test_committed_run_fixed_step_observables():
    """The fixed step turns sticking into micro-bounces (over ten times the exact kernel's
    collisions per particle-second); its D agrees with the exact kernel's within 3 combined
    standard errors while an energy differs by more (the bias the page calls measurable)."""
    ref, *fixed = _committed_billiard()["observables"]
    assert ref["method"] == "exact" and fixed
    for r in fixed:
        assert r["collisions_per_particle_per_s"] > 10 * ref["collisions_per_particle_per_s"]
        assert abs(r["D_diff_in_se"]) < 3
        for key in ("D", "E", "E_y"):
            z = (r[key] - ref[key]) / math.hypot(r[key + "_se"], ref[key + "_se"])
            assert math.isclose(z, r[key + "_diff_in_se"], rel_tol=1e-9)
    assert max(max(r["E_diff_in_se"], r["E_y_diff_in_se"]) for r in fixed) > 3


def test_committed_run_tiny_hops_are_the_cheap_events():
    """In the profile, the frequency with the largest share of tiny hops has the cheapest
    events and the fewest safe steps per flight, the one with the smallest share the dearest."""
    profile = _committed_billiard()["profile"]
    by_tiny = sorted(profile, key=lambda p: p["tiny_share"])
    by_cost = sorted(profile, key=lambda p: p["ns_per_event"])
    assert by_tiny[-1] is by_cost[0] and by_tiny[0] is by_cost[-1]
    assert by_tiny[-1]["steps_per_flight"] == min(p["steps_per_flight"] for p in profile)


def test_compared_flights_start_from_the_fixed_attractor_state():
    """CASE["attractor"] is a state just after an impact on the floor, and the compared
    flights are the events of the kernel from it (not from a transient of its own)."""
    from bbdyn.core.billiard import billiard_event

    state = bench.CASE["attractor"]
    kp = Params(f=bench.CASE["f"]).kernel()
    assert state[6] == IMPACT and abs(state[3]) <= kp.d / 2 and state[5] > 0.0
    states = bench.attractor_states(Params(f=bench.CASE["f"]), 3)
    first = billiard_event(*state, kp)
    assert first[7] == OK and states["periods"][0] >= state[0]
    # the first event from it, up to the last bits in which the two event paths may differ
    assert states["tile"][0] == first[2] and states["kind"][0] == first[6]
    assert abs(states["phase"][0] - first[1]) < 1e-12 and abs(states["xi"][0] - first[3]) < 1e-12
    # then every STATE_STRIDE-th event of the same run
    stride = bench.STATE_STRIDE
    arrays = [np.empty(2 * stride) for _ in range(6)] + [np.empty(2 * stride, dtype=np.int64)]
    assert billiard_run(EventState(*state), kp, 2 * stride, EventArrays(*arrays))[1:] == (
        2 * stride,
        OK,
    )
    assert all(states[k][1] == arrays[i][stride] for i, k in enumerate(("periods", "phase")))
