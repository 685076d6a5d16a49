"""Ensembles with on-the-fly observables (bbdyn/ensemble.py, bbdyn/core/ensemble.py).

Independent facts only: energy conservation on an elastic static floor, the
harmonic averages of a particle glued to the floor, identities between counts,
jumps, the collision record and the displacements, thread independence, and
array sizes that do not grow with the run length.
"""

import math

import numba
import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.status import IMPACT, STICK, STUCK_FOREVER
from bbdyn.core.tolerances import OBS_INTEGRAL_REL_TOL
from bbdyn.ensemble import EnsembleResult, ensemble, initial_conditions, reference_box
from bbdyn.results import load_result

ALL = ("displacement", "energy", "jumps", "record")


def _xi_and_b(p, s):
    """Independent geometry: contact point and arc height above the wedges (docs/model.md §2)."""
    xi = p.R * np.sin(s / p.R - math.asin(p.d / (2 * p.R)))
    return xi, np.sqrt(p.R**2 - xi**2) - math.sqrt(p.R**2 - p.d**2 / 4)


def _trap(tile, xi):
    return tile + (xi >= 0)


@pytest.fixture(scope="module")
def run85():
    """A quick run at 85.2 Hz with every observable, from t = 0 (no transient)."""
    p = Params(f=85.2)
    return ensemble(
        p,
        n=40,
        t=3.0,
        seed=7,
        transient=0.0,
        observables=ALL,
        jump_capacity=4096,
        record_particles=40,
        record_capacity=20000,
    )


def test_initial_conditions_depend_only_on_seed_and_index():
    p = Params(f=85.2)
    few, many = initial_conditions(p, 10, 3), initial_conditions(p, 1000, 3)
    assert np.array_equal(few, many[:10])
    box = reference_box(p)
    assert box.s == (0.0, p.s_max)
    assert np.all((many[:, 0] >= 0) & (many[:, 0] <= p.s_max))
    assert np.all(np.abs(many[:, 1]) <= 40) and np.all((many[:, 2] > 0) & (many[:, 2] <= 40))
    assert not np.array_equal(many, initial_conditions(p, 1000, 4))


# ---- steep wedges: a box draws only the states that leave the floor -------------------------
def _box_draw(p, seed, n):
    """The reference box scaled from the seed's uniforms, written out independently."""
    u = np.random.default_rng(np.random.SeedSequence(seed)).random((n, 3))
    return np.column_stack([p.s_max * u[:, 0], -40.0 + 80.0 * u[:, 1], 40.0 - 40.0 * u[:, 2]])


def _leaves_floor(p, ics):
    """Normal velocity relative to the floor (at t = 0, velocity -A w) > 0, from the arc's
    outward normal (xi, sqrt(R^2 - xi^2)) / R."""
    xi, _ = _xi_and_b(p, ics[:, 0])
    return ics[:, 1] * xi + (ics[:, 2] + p.A * p.w) * np.sqrt(p.R**2 - xi**2) > 0


def test_reference_box_at_the_default_R_is_the_plain_uniform_draw():
    """At R = 25 mm every state of the reference box leaves the floor: the initial conditions
    are the seed's uniforms scaled to the box, bit for bit, and so are the runs from them."""
    p = Params(f=85.2)
    expected = _box_draw(p, 7, 5000)
    assert np.all(_leaves_floor(p, expected))
    np.testing.assert_array_equal(initial_conditions(p, 5000, 7), expected)
    drawn = ensemble(p, n=8, t=2.0, seed=7, threads=1)
    given = ensemble(p, initial=expected[:8], t=2.0, threads=1)
    assert drawn.D() == given.D()


def test_steep_wedge_box_draws_uniformly_from_the_states_that_leave_the_floor():
    """R = 1.001 d/2: some states of the reference box move into the arc near the wedges.
    Those are drawn again (the others are the plain draw's), every state leaves the floor,
    the redrawn ones are uniform on the part of the box that does (means of a large
    independent accepted sample), and a particle depends only on the seed and its index."""
    from bbdyn.billiard import state_from_section

    p = Params(f=85.2, R=1.001)
    ics, plain = initial_conditions(p, 20000, 5), _box_draw(p, 5, 20000)
    kept = _leaves_floor(p, plain)
    assert 0.01 < np.mean(~kept) < 0.5
    np.testing.assert_array_equal(ics[kept], plain[kept])
    assert np.all(_leaves_floor(p, ics))
    for s, vx, vy in ics[~kept][:100]:  # the single-trajectory API's own check agrees
        state_from_section(p, s, vx, vy)
    reference = _box_draw(p, 6, 400_000)
    reference = reference[_leaves_floor(p, reference)]
    redrawn = ics[~kept]
    for c in range(3):
        err = np.hypot(reference[:, c].std() / math.sqrt(redrawn.shape[0]),
                       reference[:, c].std() / math.sqrt(reference.shape[0]))  # fmt: skip
        assert abs(redrawn[:, c].mean() - reference[:, c].mean()) < 4 * err, c
    np.testing.assert_array_equal(initial_conditions(p, 300, 5), ics[:300])


def test_steep_wedge_trajectories_stay_above_the_floor():
    """Trajectories from the steep-wedge box (R = 1.001 d/2) never cross the floor between
    their recorded contacts (tests/billiard_checks.py), and time runs forward."""
    from billiard_checks import flight_violations

    from bbdyn.billiard import simulate

    p = Params(f=85.2, R=1.001)
    for s, vx, vy in initial_conditions(p, 6, 2):
        run = simulate(p, n_events=400, s0=s, vx0=vx, vy0=vy)
        worst_in, worst_end, back = flight_violations(
            *(run[k] for k in ("periods", "phase", "xi", "vx", "vyrel", "kind")), p.kernel(), 16
        )
        assert worst_in <= 1.0 and worst_end <= 1.0 and back == 0


def test_a_box_that_moves_into_the_floor_is_refused():
    from bbdyn.ensemble import Box

    into = Box(s=(0.0, 1.0), vx=(-1.0, 1.0), vy=(-100.0, -60.0))  # slower than the floor
    with pytest.raises(ValueError, match="no post-collision states"):
        initial_conditions(Params(f=85.2), 4, 0, into)


def test_same_numbers_at_one_and_two_threads():
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs two numba threads")
    kwargs = {"n": 64, "t": 1.5, "seed": 5, "observables": ALL, "record_particles": 3}
    one = ensemble(Params(f=85.2), threads=1, **kwargs)
    two = ensemble(Params(f=85.2), threads=2, **kwargs)
    assert one.meta["threads"] == 1 and two.meta["threads"] == 2
    assert one.arrays.keys() == two.arrays.keys()
    for name in one.arrays:
        assert np.array_equal(one[name], two[name], equal_nan=True), name


def test_memory_does_not_grow_with_run_length():
    kwargs = {"n": 16, "seed": 2, "observables": ALL, "jump_capacity": 8, "record_particles": 2}
    short = ensemble(Params(f=85.2), t=0.5, record_capacity=50, **kwargs)
    long = ensemble(Params(f=85.2), t=4.0, record_capacity=50, **kwargs)
    assert long["events"].sum() > 6 * short["events"].sum()
    for name in short.arrays:
        assert short[name].shape == long[name].shape, name
    # what does not fit is counted, not stored
    assert np.any(long["jumps"] > 8) and np.any(long["record_n"] > 50)


@pytest.mark.parametrize("transient", [0.0, 0.2537], ids=["from_start", "window_cut_mid_flight"])
def test_elastic_static_floor_conserves_energy_in_every_average(transient):
    # alpha = beta = 1, A = 0: E = (vx^2 + vy^2)/2 + g y is conserved along the whole orbit,
    # so its time average over any window is the initial E, whatever the cut points.
    p = Params(f=50.0, A=0.0, alpha=1.0, beta=1.0)
    t = 2.0
    res = ensemble(p, n=24, t=t, seed=1, transient=transient, observables=ALL, record_particles=24,
                   record_capacity=10000)  # fmt: skip
    s, vx, vy = res["initial"].T
    _, b = _xi_and_b(p, s)
    E0 = 0.5 * (vx**2 + vy**2) + p.g * b
    assert res["E"] == pytest.approx(E0, rel=1e-10)
    for half in (0, 1):  # the early and late half of the window
        assert res["E_halves"][:, half] == pytest.approx(E0, rel=1e-10)
    assert np.all(res["stuck_fraction"] == 0) and np.all(res["sticks"] == 0)
    assert np.all(res["record_n"] <= 10000)
    # E_x from the collision record (post-collision vx times flight durations, clipped to the
    # window by hand): the kernel's clipped integrals must say the same
    t0 = math.ceil(transient * p.f) / p.f
    t1 = math.floor(t * p.f) / p.f
    for i in range(24):
        rec = res["record"][i, : res["record_n"][i]]
        times = np.concatenate([[0.0], (rec[:, 0] + rec[:, 1] / (2 * math.pi)) / p.f, [t]])
        vxs = np.concatenate([[vx[i]], rec[:, 4]])
        lo, hi = np.clip(times[:-1], t0, t1), np.clip(times[1:], t0, t1)
        Ex = np.sum(0.5 * vxs**2 * (hi - lo)) / (t1 - t0)
        assert res["E_x"][i] == pytest.approx(Ex, rel=1e-9)


@pytest.mark.parametrize("samples", [41, 0], ids=["samples", "no_samples"])
@pytest.mark.parametrize(("f", "t"), [(58.0, 20.0), (85.2, 2.0)])
def test_energy_halves_are_those_of_runs_over_each_half(f, t, samples):
    # Independent: the old construction, a second run of the same particles (same seed and
    # indices, the same trajectories) whose window ends at the split / starts there.  At
    # 58 Hz most particles are on fast-forwarded stick-release cycles by then; with no
    # samples a skip runs to the end of the window, over the split.
    p = Params(f=f)
    n, seed = 12, 3
    obs = ("displacement", "energy") if samples else ("energy",)
    res = ensemble(p, n=n, t=t, seed=seed, sample_times=np.linspace(0, t, max(samples, 1)),
                   observables=obs)  # fmt: skip
    p0, p1 = res.meta["window_periods"]
    mid = math.floor((p0 + p1) / 2)
    assert res.meta["halves_periods"] == [p0, mid, p1]
    skipping = np.count_nonzero(res["skipped_events"])
    assert skipping >= n // 2 if f == 58.0 else skipping == 0
    kw = {"n": n, "seed": seed, "observables": ("energy",)}
    early = ensemble(p, t=(mid + 0.5) / f, transient=(p0 - 0.5) / f, **kw)
    late = ensemble(p, t=(p1 + 0.5) / f, transient=(mid - 0.5) / f, **kw)
    assert early.meta["window_periods"] == [p0, mid] and late.meta["window_periods"] == [mid, p1]
    for name in ("E", "E_x", "E_y", "E_pot"):
        halves = res[name + "_halves"]
        assert halves.shape == (n, 2)
        np.testing.assert_allclose(halves[:, 0], early[name], rtol=1e-12)
        # the late half is the whole minus the early half: rounding of the larger whole
        scale = 1e-12 * (p1 - p0) / (p1 - mid) * np.abs(res[name])
        assert np.all(np.abs(halves[:, 1] - late[name]) <= scale + 1e-12 * np.abs(late[name]))


def test_particle_glued_to_the_floor_has_the_harmonic_averages():
    # Gamma < 1 (40 Hz): every particle chatters, sticks and rides the floor for good.
    # Over whole periods <u^2/2> = A^2 w^2 / 4 and <g y> = g b(xi) (the mean of -g A sin is 0).
    p = Params(f=40.0)
    res = ensemble(p, n=30, t=3.0, seed=3, transient=1.0, observables=ALL)
    assert np.all(res["status"] == STUCK_FOREVER)
    assert np.all(res["final"][:, 6] == STICK)
    tol = 4 * OBS_INTEGRAL_REL_TOL * p.f * 3.0  # a few roundings per period of the window
    assert res["stuck_fraction"] == pytest.approx(1.0, rel=tol)
    assert np.all(res["E_x"] == 0)
    assert res["E_y"] == pytest.approx((p.A * p.w) ** 2 / 4, rel=tol)
    _, b = _xi_and_b(p, np.zeros(1))
    final_xi = res["final"][:, 3]
    b_final = np.sqrt(p.R**2 - final_xi**2) - math.sqrt(p.R**2 - p.d**2 / 4)
    assert np.all(np.abs(res["E_pot"] - p.g * b_final) <= tol * p.g * (p.A + p.h))
    # it no longer moves: displacement constant after the transient
    late = res["sample_times"] >= 1.0
    assert np.all(res["displacement"][:, late] == res["displacement"][:, late][:, :1])
    assert np.all(res["collisions"] == 0) and np.all(res["jumps"] == 0)


def test_jumps_are_the_trap_changes_of_the_collision_record(run85):
    res, p = run85, Params(f=85.2)
    xi0, _ = _xi_and_b(p, res["initial"][:, 0])
    p_end = res.meta["window_periods"][1]
    for i in range(res["status"].size):
        rec = res["record"][i, : res["record_n"][i]]
        # the record runs to t, the counts to the last whole period before it
        assert res["collisions"][i] == np.count_nonzero(rec[:, 0] < p_end)
        rec = rec[rec[:, 0] < p_end]
        traps = np.concatenate([[_trap(0.0, xi0[i])], _trap(rec[:, 2], rec[:, 3])])
        steps = np.diff(traps)
        n_j = res["jumps"][i]
        assert n_j <= 4096
        assert np.array_equal(res["jump_len"][i, :n_j], steps[steps != 0])
        times = (rec[:, 0] + rec[:, 1] / (2 * math.pi)) / p.f
        assert np.allclose(res["jump_time"][i, :n_j], times[steps != 0], rtol=1e-14, atol=0)
        assert res["sticks"][i] == np.count_nonzero(rec[:, 6] == STICK)


def test_displacements_agree_with_the_final_state(run85):
    res, p = run85, Params(f=85.2)
    xi0, _ = _xi_and_b(p, res["initial"][:, 0])
    assert np.all(res["displacement"][:, 0] == 0.0)  # sample at t = 0
    periods, phase, tile, xi, vx, _, kind = res["final"].T
    t_last = (periods + phase / (2 * math.pi)) / p.f
    flying = kind != STICK
    x_end = tile * p.d + xi + np.where(flying, vx * (res.meta["t"] - t_last), 0.0) - xi0
    assert res["displacement"][:, -1] == pytest.approx(x_end, rel=1e-12, abs=1e-12)


def test_end_to_end_at_85_2_hz_quick(run85, tmp_path):
    res = run85
    assert res["status"].tolist() == [0] * 40
    summary = res.summary()
    # 40 particles over 3 s from t = 0 cannot pin D down (its error is larger than D); check
    # instead that the summary's D is half the least-squares slope of these particles' MSD
    # over the late half of the run
    t, disp = res["sample_times"], res["displacement"]
    late = t >= 0.5 * t[-1]
    slope = np.polyfit(t[late], np.mean(disp[:, late] ** 2, axis=0), 1)[0]
    assert summary["D"] == pytest.approx(slope / 2, rel=1e-9) and summary["D_se"] > 0
    assert 0 <= summary["stuck_fraction"] < 1
    assert summary["collisions_per_particle_per_s"] > 0
    assert np.allclose(res["E"], res["E_x"] + res["E_y"] + res["E_pot"], rtol=1e-14)
    # flights dominate at Gamma = 2.9: a parabola spends twice as much in g y as in vy^2/2
    # (relative to its launch height), so E_pot exceeds E_y
    assert summary["E_pot"] > summary["E_y"] > 0 and summary["E_x"] > 0
    path = res.save(tmp_path / "ens")
    back = load_result(path)
    assert isinstance(back, EnsembleResult)
    assert back.D() == res.D()
    assert back.plot() is not None


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"params": Params(f=85.2, beta=1.0)}, "sliding"),
        ({"initial": [[1.0, 0.0, -100.0]]}, "must leave the floor"),
        ({"initial": [[5.0, 0.0, 1.0]]}, "initial s must be in"),
        ({"t": -1.0}, "t must be"),
        ({"transient": 2.0}, "transient must be in"),
        ({"observables": ("msd",)}, "observables must be among"),
        ({"sample_times": [0.5, 0.1]}, "sample_times must be"),
        ({"t": 0.01, "transient": 0.005}, "no room for 1 whole driving period"),
    ],
    ids=[
        "beta_one_alpha_below_one",
        "into_the_floor",
        "s_outside_arc",
        "negative_t",
        "transient_beyond_t",
        "unknown_observable",
        "unsorted_samples",
        "window_too_short",
    ],
)
def test_bad_input_is_refused_with_a_clear_message(kwargs, message):
    args = {"params": Params(f=85.2), "t": 1.0, "seed": 0}
    args.update(kwargs)
    if "initial" not in args:
        args["n"] = 4
    with pytest.raises(ValueError, match=message):
        ensemble(args.pop("params"), **args)


def _integrands(p, stuck, te, phase, b, vx, vyrel):
    """E_x, E_y and g y as functions of t (s) on a stuck interval or a flight from time te."""
    A, w, g = p.A, p.w, p.g
    if stuck:
        return (
            lambda t: 0.0,
            lambda t: 0.5 * (A * w * math.cos(w * t)) ** 2,
            lambda t: g * (b - A * math.sin(w * t)),
        )
    y0, vy0 = -A * math.sin(phase) + b, vyrel - A * w * math.cos(phase)
    return (
        lambda t: 0.5 * vx**2,
        lambda t: 0.5 * (vy0 - g * (t - te)) ** 2,
        lambda t: g * (y0 + vy0 * (t - te) - 0.5 * g * (t - te) ** 2),
    )


def test_energy_averages_agree_with_quadrature_along_the_recorded_orbit():
    # Rebuild one dissipative orbit (flights, sticks, releases) from its collision record and
    # integrate E_x, E_y and g y over the window by adaptive quadrature of the same motion.
    from scipy.integrate import quad

    p = Params(f=85.2)
    res = ensemble(p, n=3, t=0.6, seed=4, transient=0.1, observables=ALL, record_particles=3)
    theta_r = math.pi + math.asin(1 / p.gamma)
    t0, t1 = (np.array(res.meta["window_periods"]) / p.f).tolist()
    for i in range(3):
        assert res["sticks"][i] > 0  # the orbit must contain stuck intervals to test them
        s, vx, vy = res["initial"][i]
        xi, _ = _xi_and_b(p, np.array([s]))
        events = [(0.0, 0.0, xi[0], vx, vy + p.A * p.w, IMPACT)]
        for periods, phase, _, xi_k, vx_k, vyrel_k, kind in res["record"][i, : res["record_n"][i]]:
            events.append(
                ((periods + phase / (2 * math.pi)) / p.f, phase, xi_k, vx_k, vyrel_k, kind)
            )
            if kind == STICK:
                n_rel = periods + (phase > theta_r)
                events.append(
                    ((n_rel + theta_r / (2 * math.pi)) / p.f, theta_r, xi_k, 0.0, 0.0, -1)
                )
        events.append((res.meta["t"], 0, 0, 0, 0, 0))
        total = np.zeros(3)
        for (te, ph, xi_e, vx_e, vyrel_e, kind), nxt in zip(events[:-1], events[1:], strict=True):
            lo, hi = max(te, t0), min(nxt[0], t1)
            if hi <= lo:
                continue
            b = math.sqrt(p.R**2 - xi_e**2) - math.sqrt(p.R**2 - p.d**2 / 4)
            integrands = _integrands(p, kind == STICK, te, ph, b, vx_e, vyrel_e)
            total += [quad(f, lo, hi, epsabs=0, epsrel=1e-12)[0] for f in integrands]
        averages = total / (t1 - t0)
        got = [res["E_x"][i], res["E_y"][i], res["E_pot"][i]]
        assert got == pytest.approx(averages, rel=1e-9)


def test_jump_data_hands_the_window_jumps_to_the_random_walk_analysis(run85):
    data = run85.jump_data()
    assert data.n_particles == 40
    assert np.array_equal(data.counts, run85["jumps"])
    assert np.all((data.times >= 0) & (data.times <= run85.meta["window_s"]))
    small = ensemble(Params(f=85.2), n=8, t=2.0, seed=1, observables=ALL, jump_capacity=1)
    with pytest.raises(ValueError, match="larger jump_capacity"):
        small.jump_data()


def test_simulate_command_prints_the_required_fields(capsys):
    import argparse
    import json

    from bbdyn.commands import simulate

    parser = argparse.ArgumentParser()
    simulate.add_arguments(parser)
    args = parser.parse_args(["--f", "85.2", "--n", "20", "--t", "1", "--seed", "3", "--json"])
    assert simulate.run(args) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("D", "D_se", "E", "E_x", "E_y", "stuck_fraction", "collision_rate",
                "cpu_s", "wall_s", "params", "seed", "version"):  # fmt: skip
        assert key in out, key
    assert out["params"]["f"] == 85.2 and out["seed"] == 3
    args = parser.parse_args(["--f", "85.2", "--n", "20", "--t", "1", "--seed", "3"])
    assert simulate.run(args) == 0
    assert "D " in capsys.readouterr().out
