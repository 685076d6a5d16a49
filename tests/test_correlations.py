"""Velocity autocorrelation, Green-Kubo D and distributions (bbdyn.correlations).

Independent facts: the exact piecewise C(tau) against a brute-force sum of the kernel's own
event velocities on a fine grid; C(0) against the kernel's integral of 2 E_x; the grid's
displacements against the collision record; the Green-Kubo integral of a telegraph walk
(known D) and of the billiard against the Einstein D of an independent ensemble; P(x, tau)
normalised with the ensemble's <dx^2> as its variance; the tiles crossed per flight against
a trajectory's event arrays.
"""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.billiard import simulate, xi_at_arc_length
from bbdyn.core.status import IMPACT, STICK
from bbdyn.correlations import (
    CorrelationResult,
    bin_velocities,
    binned_correlation,
    correlations,
    exact_correlation,
    excess_kurtosis,
    gk_running,
    grid_times,
    lag_moments,
)
from bbdyn.ensemble import ensemble, initial_conditions
from bbdyn.results import load_result

F = 85.2


@pytest.fixture(scope="module")
def small():
    """A cheap run: 12 particles, 6 s, GK cutoff 1 s, every particle's collisions recorded."""
    return correlations(Params(f=F), n=12, t=6.0, seed=5, cutoff=1.0, times=(0.05, 0.5),
                        record_particles=12)  # fmt: skip


def trajectory_knots(f=F, n_events=400):
    """Times (s), positions (mm) and post-event vx (mm/s) of one trajectory's events."""
    traj = simulate(Params(f=f), n_events=n_events, s0=0.7, vx0=12.0, vy0=35.0)
    return traj["t"], traj["x"], traj["vx"], traj["kind"]


def test_exact_correlation_equals_a_brute_force_sum_on_a_fine_grid():
    """The exact piecewise form (slopes of x between events) against the average of
    v(s) v(s + tau) on a fine grid, v being the kernel's post-event vx (0 while stuck)."""
    t, x, vx, kind = trajectory_knots(n_events=200)
    t0, t1 = t[20], t[-1] - 0.2
    lags = np.array([0.0, 0.0031, 0.017, 0.05, 0.11, 0.2])
    exact = exact_correlation(t, x, lags, t0, t1)
    v = np.where(kind == STICK, 0.0, vx)  # constant from each event to the next
    dt = 5e-6
    s = np.arange(t0, t1, dt) + 0.5 * dt  # midpoints
    vel = lambda u: v[np.searchsorted(t, u, side="right") - 1]  # noqa: E731
    brute = np.array([np.mean(vel(s) * vel(s + lag)) for lag in lags])
    # a jump of v inside a grid cell misplaces at most dt of |v v'| per jump, in each factor
    jumps = np.count_nonzero((t > t0) & (t < t[-1]))
    bound = 2 * jumps * dt * np.max(v**2) / (t1 - t0)
    assert np.all(np.abs(brute - exact) <= bound), (brute - exact, bound)
    assert bound < 1e-2 * exact[0]  # the check is tight against C itself
    assert exact[0] == pytest.approx(np.sum(np.diff(t)[20:] * v[20:-1] ** 2) / (t1 - t0), rel=0.1)


def test_binned_correlation_equals_direct_sums():
    rng = np.random.default_rng(1)
    V = rng.normal(size=(3, 500)) + np.sin(np.arange(500) / 7.0)
    n_lags = 40
    got = binned_correlation(V, n_lags)
    n_orig = V.shape[1] - n_lags + 1
    for m in range(n_lags):
        direct = np.mean(V[:, :n_orig] * V[:, m : m + n_orig], axis=1)
        np.testing.assert_allclose(got[:, m], direct, rtol=1e-12, atol=1e-12)


def telegraph_knots(v, rate, t_end, rng):
    """x(t) of a velocity +-v flipping at Poisson times of ``rate``: C = v^2 exp(-2 rate tau),
    D = v^2 / (2 rate)."""
    flips = np.cumsum(rng.exponential(1.0 / rate, int(3 * rate * t_end) + 10))
    t = np.concatenate(([0.0], flips[flips < t_end], [t_end]))
    sign = rng.choice((-1.0, 1.0)) * (-1.0) ** np.arange(t.size - 1)
    return t, np.concatenate(([0.0], np.cumsum(v * sign * np.diff(t))))


def test_green_kubo_of_a_telegraph_walk_is_its_known_D():
    """The binned estimator on a walk whose D is known, with bins as long as a third of the
    correlation time: c_0 is C smoothed by the bin triangle, yet the GK integral (weights
    h (c_0 / 2 + c_1 + ... + c_M)) has no bias; each particle an independent estimate."""
    rng = np.random.default_rng(7)
    v, rate, t_end, h, cutoff = 30.0, 20.0, 40.0, 0.01, 0.5
    grid = np.arange(0.0, t_end + h / 2, h)
    M = int(round(cutoff / h))
    c = np.array([binned_correlation(bin_velocities(*telegraph_knots(v, rate, t_end, rng), grid),
                                     M + 1)[0] for _ in range(40)])  # fmt: skip
    ah = 2 * rate * h  # int v^2 e^{-2 r |tau|} Lambda_h(tau) dtau
    assert c[:, 0].mean() == pytest.approx(v * v * 2 * (ah - 1 + math.exp(-ah)) / ah**2, rel=0.02)
    per_particle = gk_running(c, h)[:, -1]
    D = v * v / (2 * rate) * (1 - math.exp(-2 * rate * cutoff))
    est, se = per_particle.mean(), per_particle.std(ddof=1) / math.sqrt(40)
    assert abs(est - D) < 3 * se, (est, D, se)
    assert se < 0.05 * D


def test_kurtosis_of_a_telegraph_walk():
    """Over a lag much shorter than the time between flips the displacement is +-v tau (a
    two-point law, excess kurtosis -2); over a lag much longer, nearly Gaussian (0)."""
    rng = np.random.default_rng(3)
    v, rate, t_end, h = 30.0, 20.0, 40.0, 1e-3
    grid = np.arange(0.0, t_end + h / 2, h)
    X = np.array([np.interp(grid, *telegraph_knots(v, rate, t_end, rng)) for _ in range(30)])
    k_short, _ = excess_kurtosis(*lag_moments(X, 1))
    assert k_short == pytest.approx(-2.0, abs=0.03)  # a flip in 2 % of the bins: +0.01
    k_long, se = excess_kurtosis(*lag_moments(X, 2000))
    assert abs(k_long) < 3 * se and se < 0.2


def test_c0_exact_is_twice_the_kernels_E_x():
    """From t = 0 (no transient) the collision record and the initial state fix x(t) on the
    whole window: the exact C(0) = <vx^2> equals 2 E_x, the kernel's own integral."""
    params = Params(f=F)
    ics = initial_conditions(params, 3, 11)
    t_end = 40 / params.f  # whole periods: the window is [0, t_end]
    ens = ensemble(params, initial=ics, t=t_end, transient=0.0, observables=("energy", "record"),
                   record_particles=3, record_capacity=5000)  # fmt: skip
    for i, s0 in enumerate(ics[:, 0]):
        rec = ens["record"][i, : ens["record_n"][i]]
        t = rec[:, 0] / params.f + rec[:, 1] / params.w
        x = (rec[:, 2] + 0.5) * params.d + rec[:, 3]
        x_start = 0.5 * params.d + xi_at_arc_length(params, s0)
        v_last = rec[-1, 4] if rec[-1, 6] == IMPACT else 0.0
        t = np.concatenate(([0.0], t, [t_end]))
        x = np.concatenate(([x_start], x, [x[-1] + v_last * (t_end - t[-2])]))
        c0 = exact_correlation(t, x, [0.0], 0.0, t_end)[0]
        assert c0 == pytest.approx(2 * ens["E_x"][i], rel=1e-9)


def test_grid_displacements_follow_the_collision_record(small):
    """The ensemble kernel's displacements at the grid times lie on the piecewise linear
    x(t) through the recorded collisions (flights straight, stuck intervals flat)."""
    params = Params(f=F)
    ics = initial_conditions(params, 2, [5, 1])
    grid = grid_times(params, *small.meta["window_periods"], 16)
    ens = ensemble(params, initial=ics, t=6.0, transient=1.2, sample_times=grid,
                   observables=("displacement", "record"), record_particles=2,
                   record_window=(grid[0], grid[-1]), record_capacity=20000)  # fmt: skip
    for i in range(2):
        rec = ens["record"][i, : ens["record_n"][i]]
        t = rec[:, 0] / params.f + rec[:, 1] / params.w
        x = (rec[:, 2] + 0.5) * params.d + rec[:, 3]
        inside = (grid >= t[0]) & (grid <= t[-1])
        disp = ens["displacement"][i, inside]
        x_grid = np.interp(grid[inside], t, x)
        np.testing.assert_allclose(disp - disp[0], x_grid - x_grid[0], atol=1e-9)


def test_P_is_normalised_with_the_ensembles_msd_as_its_variance(small):
    params = Params(f=F)
    h = small.meta["h"]
    grid = grid_times(params, *small.meta["window_periods"], 16)
    ens = ensemble(params, initial=initial_conditions(params, 12, [5, 1]), t=6.0,
                   transient=1.2, sample_times=grid, observables=("displacement",))  # fmt: skip
    X = ens["displacement"]
    for j, tau in enumerate(small["P_times"]):
        edges = small["P_edges"][j]
        width = np.diff(edges)
        dens = small["P_density"][j]
        assert np.sum(dens * width) + small["P_outside"][j] == pytest.approx(1.0, abs=1e-12)
        lag = int(round(tau / h))
        msd = np.mean([np.mean((X[i, lag:] - X[i, :-lag]) ** 2) for i in range(X.shape[0])])
        assert small["P_var"][j] == pytest.approx(msd, rel=1e-12)
        # the histogram's variance: each sample moved by at most half a bin
        mid = 0.5 * (edges[1:] + edges[:-1])
        var_hist = np.sum(mid**2 * dens * width)
        dx = width.max()
        assert small["P_outside"][j] == 0.0
        assert abs(var_hist - msd) <= dx * math.sqrt(msd) + dx * dx / 4


def test_tiles_per_flight_from_the_event_arrays(small):
    """The histogram of tiles crossed per flight counts every flight between the recorded
    collisions, and its mean is the mean |tile change| of a trajectory run from the same
    initial condition (event arrays of ``billiard_run``)."""
    params = Params(f=F)
    p0, p1 = small.meta["window_periods"]
    one = correlations(params, n=2, t=6.0, seed=5, cutoff=1.0, times=(0.05,),
                       record_particles=1)  # fmt: skip
    s0, vx0, vy0 = initial_conditions(params, 2, [5, 1])[0]
    traj = simulate(params, n_events=20000, s0=s0, vx0=vx0, vy0=vy0)
    t = traj["periods"] + traj["phase"] / (2 * np.pi)
    hit = np.isin(traj["kind"], (IMPACT, STICK)) & (t >= p0) & (t <= p1)
    assert t[-1] > p1
    dl = np.abs(np.diff(traj["tile"][hit]))
    counts = one["jump_counts"]
    assert counts.sum() == dl.size == one.meta["flights"]
    assert np.sum(np.arange(counts.size) * counts) / counts.sum() == pytest.approx(dl.mean())
    assert np.sum(small["jump_counts"]) == small.meta["flights"]
    assert np.sum(small["tile_density_impacts"] * np.diff(small["tile_edges"])) == pytest.approx(1)


def test_green_kubo_against_einstein_cheap(small):
    """At 77.2 Hz (diffusive, C decays within about 1.5 s) the GK integral of one
    ensemble and the Einstein D of another agree within their errors."""
    res = correlations(Params(f=77.2), n=60, t=20.0, seed=2, cutoff=3.0, times=(1.0,))
    assert abs(res.meta["z"]) < 3, res.meta
    assert res.meta["D_GK_se"] < 0.2 * res.meta["D_GK"]


def test_result_saves_loads_and_plots(small, tmp_path):
    small.save(tmp_path / "c")
    back = load_result(tmp_path / "c")
    assert isinstance(back, CorrelationResult)
    np.testing.assert_array_equal(back["C"], small["C"])
    assert back.meta["D_GK"] == small.meta["D_GK"]
    import matplotlib

    matplotlib.use("Agg")
    assert back.plot() is not None


def test_bad_cutoff_and_times_are_refused():
    with pytest.raises(ValueError, match="cutoff must be in"):
        correlations(Params(f=F), n=2, t=3.0, cutoff=2.0)
    with pytest.raises(ValueError, match="times must lie in"):
        correlations(Params(f=F), n=2, t=3.0, cutoff=0.1, times=(5.0,))


@pytest.mark.slow
@pytest.mark.parametrize("f", [58.0, 77.2, 85.2, 88.4])
def test_green_kubo_equals_einstein_at_the_scene_frequencies(f):
    """The scene's diffusive frequencies at a medium size (5-10 s each on an idle core)."""
    res = correlations(Params(f=f), n=300, t=60.0, seed=1, cutoff=15.0, times=(1.0,))
    assert abs(res.meta["z"]) < 3, res.meta


def test_scene_b9_table_and_drawing(tmp_path):
    """Scene B9 at a tiny size: the Green-Kubo table from the stored numbers, one row of five
    panels (and the C axis' twin) per frequency, drawn from the saved data."""
    from bbdyn.scenes import b9_distributions as b9

    tiny = {"f": (88.4,), "n": 4, "t": 4.0, "cutoff": 0.5, "times": (0.1,),
            "record_particles": 2, "record_capacity": 2000}  # fmt: skip
    b9.compute(tiny, seed=3).save(tmp_path / "b9")
    back = load_result(tmp_path / "b9")
    (row,) = back.meta["rows"]
    assert back.meta["table"]["rows"][0][0] == "88.4"
    assert row["z"] == pytest.approx((row["D_GK"] - row["D"]) / math.hypot(row["D_GK_se"],
                                                                          row["D_se"]))  # fmt: skip
    counts = back["jump_counts_0"]
    assert row["jump_tail"]["1"] == pytest.approx(counts[1:].sum() / counts.sum())
    import matplotlib

    matplotlib.use("Agg")
    assert len(b9.draw(back).axes) == 6


def test_the_documented_b9_figure_backs_docs_distributions():
    """What docs/distributions.md says of the committed B9 figure, checked on its data."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "docs" / "figures" / "B9_full.json"
    meta = load_result(path).meta
    rows = {r["f"]: r for r in meta["rows"]}
    for f in (58.0, 77.2, 85.2, 88.4):  # Green-Kubo equals Einstein within the errors
        assert abs(rows[f]["z"]) < 3, (f, rows[f]["z"])
    trapped = rows[70.2]  # no limit: the integral swings; Cesaro mean and D far below it
    assert trapped["D_GK_se"] < 1e-9 * trapped["D_GK_swing"]
    assert max(abs(trapped["D_GK_mean"]), abs(trapped["D"])) < 0.01 * trapped["D_GK_swing"]
    for f in (77.2, 85.2, 88.4):  # the kurtosis peaks and falls back towards 0
        peak, last = rows[f]["kurtosis_max"], rows[f]["kurtosis_last"]
        assert peak["value"] - 3 * peak["se"] > 1 and last["value"] < 0.2 * peak["value"]
    assert meta["jump_max"] == max(r["jump_max"] for r in meta["rows"]) == 1
