"""Billiard work-precision benchmark (B2): reference, fixed-step method, exact kernel, command."""

import json
import math

import numpy as np
import pytest

from bbdyn import Params, cli
from bbdyn.core.billiard import billiard_run, tiny_hop
from bbdyn.core.plate import sin_cos
from bbdyn.core.status import IMPACT, OK, STICK
from bbdyn.core.tolerances import DEPARTURE_REL_TOL, EPS, IMPACT_TIME_TOL
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
    assert bench.exact_one_step(starts, kp, *out) == OK
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
    _, flights_, tiny, collisions, sticks, status = bench.flight_profile(state, kp, n)
    assert status == OK
    arrays = [np.empty(n) for _ in range(6)] + [np.empty(n, dtype=np.int64)]
    n_done, status = billiard_run(*bench.CASE["start"], kp, *arrays)
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
        assert row["collisions_per_s"] > 0
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


def test_the_docs_numbers_are_those_of_the_committed_run():
    """docs/benchmarks.md shows the table of docs/bench/billiard_7c21b69.json and states its
    numbers in the findings below it, and those of the previous run (bd1e3d6) it cites."""
    from committed_runs import bench_runs

    result, before, raw = bench_runs("billiard_7c21b69", "billiard_bd1e3d6")
    assert bench.table(result) in raw
    text = " ".join(raw.split())
    rows, prof = result.meta["rows"], result.meta["profile"]
    exact = [r for r in rows if r["method"] == "exact"]
    fixed = {r["setting"]: r for r in rows if r["method"] == "fixed_step"}
    paper = fixed["dt=0.0001 s, dt_min=1e-06 s"]
    cps = [p["collisions_per_s"] / 1e6 for p in prof]
    steps = [p["steps_per_flight"] for p in prof]
    by_f = {p["f"]: p for p in prof}
    ensemble = next(r for r in exact if "ensemble" in r["setting"])
    err = max(r["max_time_error_s"] for r in exact if np.isfinite(r["max_time_error_s"]))
    obs = result.meta["observables"]
    ref, fs = obs[0], obs[1:]
    expected = [
        f"max {err:.1e} s",
        f"{min(cps):.1f}e6 to {max(cps):.1f}e6 collisions/s per core",
        f"{ensemble['collisions_per_s'] / 1e6:.1f}e6 on the two threads",
        f"({min(steps):.1f} to {max(steps):.1f} per flight",
        f"where {100 * by_f[58.0]['tiny_share']:.0f} % of the flights are tiny hops",
        f"an event costs {by_f[58.0]['ns_per_event']:.0f} ns; at 88.4 Hz, where "
        f"{100 * by_f[88.4]['tiny_share']:.0f} % are, {by_f[88.4]['ns_per_event']:.0f} ns",
        f"1e{round(math.log10(paper['max_time_error_s'] / err))} times less accurate",
        f"{paper['cost_ratio_to_exact']:.1f} times slower",
        f"{fs[0]['collisions_per_particle_per_s']:.0f} collisions per particle per second "
        f"instead of {ref['collisions_per_particle_per_s']:.0f}",
        f"({fs[0]['D_diff_in_se']:+.1f} and {fs[1]['D_diff_in_se']:+.1f} se)",
        f"E by {fs[0]['E'] - ref['E']:.0f} +- {math.hypot(fs[0]['E_se'], ref['E_se']):.0f} and "
        f"{fs[1]['E'] - ref['E']:.0f} +- {math.hypot(fs[1]['E_se'], ref['E_se']):.0f} "
        f"({fs[0]['E_diff_in_se']:.1f} and {fs[1]['E_diff_in_se']:.1f} se)",
        f"E_y by {fs[0]['E_y'] - ref['E_y']:.0f} and {fs[1]['E_y'] - ref['E_y']:.0f} +- "
        f"{math.hypot(fs[0]['E_y_se'], ref['E_y_se']):.1f} ({fs[0]['E_y_diff_in_se']:.1f} and "
        f"{fs[1]['E_y_diff_in_se']:.1f} se)",
        f"{100 * (fs[0]['E'] - ref['E']) / ref['E']:.1f} % of E",
    ]
    # "above 8e6 at 58 Hz only"; the fixed-step D "within 3 se"
    assert [p["f"] for p in prof if p["collisions_per_s"] > 8e6] == [58.0]
    assert all(abs(r["D_diff_in_se"]) < 3 for r in fs)
    # the steps per flight before and after, cited under the full scan's kernel table
    steps0 = {p["f"]: p["steps_per_flight"] for p in before.meta["profile"]}
    expected.append(
        f"from {steps0[70.0]:.2f} to {by_f[70.0]['steps_per_flight']:.2f} at 70 Hz, from "
        f"{steps0[85.2]:.2f} to {by_f[85.2]['steps_per_flight']:.2f} at 85.2 Hz and from "
        f"{steps0[88.4]:.2f} to {by_f[88.4]['steps_per_flight']:.2f} at 88.4 Hz"
    )
    # the previous run, cited: its one-flight and ensemble speeds and its exact D at 85.2 Hz
    rows0, ref0 = before.meta["rows"], before.meta["observables"][0]
    ens0 = next(r for r in rows0 if "ensemble" in r["setting"])
    se = math.hypot(ref["D_se"], ref0["D_se"])
    expected += [
        f"gave {rows0[0]['collisions_per_s'] / 1e6:.2f}e6 collisions/s for one flight and "
        f"{ens0['collisions_per_s'] / 1e6:.2f}e6 for the ensemble",
        f"moved from {ref0['D']:.1f} +- {ref0['D_se']:.1f} (bd1e3d6) to {ref['D']:.2f} +- "
        f"{ref['D_se']:.1f} mm^2/s (7c21b69), {abs(ref['D'] - ref0['D']) / se:.1f} combined se",
    ]
    for sentence in expected:
        assert sentence in text, sentence
    assert all(r["wrong_contacts"] == 0 for r in fixed.values())  # "no wrong contact"


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
    assert billiard_run(*state, kp, *arrays) == (2 * stride, OK)
    assert all(states[k][1] == arrays[i][stride] for i, k in enumerate(("periods", "phase")))
