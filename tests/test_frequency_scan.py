"""D and energies across frequency (bbdyn.scans.frequency, bbdyn.diffusion checks).

Facts checked: the Einstein D of synthetic random walks covers the truth at the
nominal rate, and its bootstrap error agrees with the analytic one; the window
test keeps its size and detects a drifting D; a particle stuck to the floor
(Gamma < 1) has the harmonic energies; the energy drift of every particle is
its late minus early half, as two separate runs give, 0 when stuck and flagged during
a transient; scans are the same resumed, on dask, and trapped below Gamma = 1.
"""

import functools
import math
import shutil

import numpy as np
import pytest
from extras import require

from bbdyn import Params
from bbdyn.core.floor import floor_height_rel
from bbdyn.core.status import STUCK_FOREVER
from bbdyn.diffusion import (
    einstein_D,
    einstein_D_bootstrap,
    per_particle_slopes,
    window_consistency,
)
from bbdyn.ensemble import ensemble
from bbdyn.flat.tongues import tongue_intervals
from bbdyn.scans.frequency import (
    diffusion_point,
    frequency_grid,
    frequency_scan,
)
from bbdyn.scans.runner import load_scan

D_TRUE = 2.5  # mm^2/s
TINY = {"n": 6, "t": 1.0}


def random_walks(rng, n, m=40, t_max=4.0, D=D_TRUE, drift_factor=0.0):
    """Brownian paths x(t_k) with diffusion D (times (m,), positions (n, m)).

    With ``drift_factor`` c the local diffusion grows as D (1 + c t / t_max).
    """
    t = np.linspace(t_max / m, t_max, m)
    dt = np.diff(t, prepend=0.0)
    local = D * (1.0 + drift_factor * t / t_max)
    return t, np.cumsum(rng.normal(0.0, np.sqrt(2 * local * dt), (n, m)), axis=1)


# ---- the estimator on synthetic data ----------------------------------------------------------
def test_einstein_D_errors_cover_the_truth_at_the_nominal_rate():
    rng = np.random.default_rng(11)
    reps = 400
    hits = 0
    for _ in range(reps):
        t, x = random_walks(rng, 200)
        D, se = einstein_D(t, x)
        hits += abs(D - D_TRUE) <= 1.959964 * se
    # 95 % nominal; binomial sd sqrt(reps 0.95 0.05) = 4.4: accept 4 sd either side
    sd = math.sqrt(reps * 0.95 * 0.05)
    assert abs(hits - 0.95 * reps) <= 4 * sd


def test_bootstrap_error_agrees_with_the_analytic_error():
    rng = np.random.default_rng(12)
    t, x = random_walks(rng, 2000)
    D, se = einstein_D(t, x)
    n_boot = 2000
    se_boot, lo, hi = einstein_D_bootstrap(t, x, n_boot=n_boot, seed=3)
    # the bootstrap se estimates the same quantity with relative sd ~ 1/sqrt(2 n_boot)
    assert abs(se_boot / se - 1) < 5 / math.sqrt(2 * n_boot)
    assert lo < D < hi
    # percentile interval of a near-normal mean: about +-1.96 se
    assert abs((hi - lo) / (2 * 1.959964 * se) - 1) < 0.1


def test_per_particle_slopes_average_to_the_einstein_D():
    rng = np.random.default_rng(13)
    t, x = random_walks(rng, 50)
    D, _ = einstein_D(t, x, window=(0.3, 1.0))
    assert 0.5 * per_particle_slopes(t, x, (0.3, 1.0)).mean() == pytest.approx(D, rel=1e-12)


def test_window_consistency_keeps_its_size():
    rng = np.random.default_rng(14)
    reps = 300
    rejected = sum(window_consistency(*random_walks(rng, 300))[2] < 0.05 for _ in range(reps))
    sd = math.sqrt(reps * 0.05 * 0.95)
    assert abs(rejected - 0.05 * reps) <= 4 * sd


def test_window_consistency_detects_a_growing_D():
    rng = np.random.default_rng(15)
    t2, dof, p = window_consistency(*random_walks(rng, 2000, drift_factor=2.0))
    assert dof == 3
    assert p < 1e-6


def test_window_consistency_of_frozen_particles():
    t = np.linspace(0.1, 1.0, 20)
    x = np.tile(np.arange(5.0)[:, None], (1, 20))
    assert window_consistency(t, x) == (0.0, 0, 1.0)


# ---- physics of one frequency ----------------------------------------------------------------
def test_gamma_below_one_stuck_particles_have_harmonic_energies():
    params = Params(f=45.0)
    assert params.gamma < 1
    res = ensemble(params, n=12, t=3.0, seed=5, transient=1.5)
    assert np.all(res["status"] == STUCK_FOREVER)
    kp = params.kernel()
    # riding the floor at xi: vx = 0, vy = u(t), y = y_p(t) + b(xi); whole periods average
    # <u^2 / 2> = A^2 w^2 / 4 and <y_p> = 0
    b = np.array([floor_height_rel(xi, kp) for xi in res["final"][:, 3]])
    harmonic = 0.25 * (params.A * params.w) ** 2
    np.testing.assert_array_equal(res["E_x"], 0.0)
    np.testing.assert_allclose(res["E_y"], harmonic, rtol=1e-12)
    np.testing.assert_allclose(res["E_pot"], params.g * b, rtol=1e-9, atol=1e-12 * params.g)
    out = diffusion_point(45.0, np.random.SeedSequence(5), n=12, t=3.0, transient=1.5)
    assert out["E_y"] == pytest.approx(harmonic, rel=1e-12)
    assert out["E_x"] == 0.0
    assert out["trapped"] == 1 and out["D"] == 0.0 and out["D_se"] == 0.0


@pytest.mark.parametrize("f", [58.0, 85.2])
def test_energy_drift_is_late_minus_early_half_for_every_particle(f):
    """The drift of every particle equals that of two separate runs, one per half window."""
    params = Params(f=f)
    seq = np.random.SeedSequence(8)
    out = diffusion_point(f, seq, n=10, t=2.0, n_boot=10)
    seed = np.random.SeedSequence(8).spawn(2)[0].generate_state(4).tolist()
    p0, p1 = math.ceil(0.4 * f), math.floor(2.0 * f)
    mid = (p0 + p1) // 2
    early = ensemble(params, n=10, t=(mid + 0.5) / f, seed=seed, transient=(p0 - 0.5) / f)
    late = ensemble(params, n=10, t=(p1 + 0.5) / f, seed=seed, transient=(mid - 0.5) / f)
    assert early.meta["window_periods"] == [p0, mid] and late.meta["window_periods"] == [mid, p1]
    for name in ("E", "E_x"):
        drift = late[name] - early[name]
        scale = 1e-9 * late[name].max()
        assert out[name + "_drift"] == pytest.approx(drift.mean(), rel=1e-9, abs=scale)
        err = drift.std(ddof=1) / math.sqrt(drift.size)
        assert out[name + "_drift_se"] == pytest.approx(err, rel=1e-6, abs=scale)


def test_energy_drift_zero_when_stuck_and_flagged_in_a_transient():
    """Stuck for good before the window: the same energy in both halves (drift 0 to
    rounding, not flagged however small its scatter); from the box with no transient at
    50.2 Hz the energy relaxes for seconds (docs/results.md), so the halves differ."""
    stuck = diffusion_point(45.0, np.random.SeedSequence(5), n=12, t=3.0, transient=1.5)
    assert stuck["E_x_drift"] == 0.0
    assert abs(stuck["E_drift"]) <= 1e-12 * stuck["E"]
    assert stuck["energy_stationary"] == 1  # a rounding difference is no drift
    relaxing = diffusion_point(50.2, np.random.SeedSequence(0), n=20, t=2.0, transient=0.0)
    assert relaxing["energy_stationary"] == 0
    assert abs(relaxing["E_drift"]) > 5 * relaxing["E_drift_se"]


def test_diffusion_point_reports_every_number_with_its_error():
    out = diffusion_point(85.2, np.random.SeedSequence(2), **TINY)
    for name in ("D", "E", "E_x", "E_y", "E_pot", "stuck_fraction", "collision_rate"):
        assert name + "_se" in out and math.isfinite(out[name + "_se"])
    assert out["E_reference"] == pytest.approx(0.5 * (0.1 * 2 * math.pi * 85.2) ** 2)
    assert out["E"] == pytest.approx(out["E_x"] + out["E_y"] + out["E_pot"])
    assert out["D_windows"].shape == out["D_windows_se"].shape == (4,)


@pytest.mark.parametrize(
    "kwargs, match",
    [({"n": 1}, "n must"), ({"n_samples": 5}, "n_samples")],
    ids=["one-particle", "few-samples"],
)
def test_diffusion_point_refuses_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        diffusion_point(60.0, np.random.SeedSequence(0), **({"t": 1.0} | kwargs))


def test_frequency_grid_includes_the_end_and_refuses_bad_steps():
    assert frequency_grid(49.8, 95.0, 0.2).size == 227
    assert frequency_grid(50.0, 50.0, 1.0).tolist() == [50.0]
    with pytest.raises(ValueError, match="f_step"):
        frequency_grid(50.0, 60.0, 0.0)
    with pytest.raises(ValueError, match="f_stop"):
        frequency_grid(50.0, 40.0, 1.0)


def test_tongue_intervals_are_the_model_md_ones():
    rows = tongue_intervals(Params(f=60.0), 49.77, 95.0)
    np.testing.assert_array_equal(rows[:, 0], [1, 2, 3])
    np.testing.assert_allclose(rows[:, 1:], [[50.99, 61.56], [72.10, 76.72], [88.31, 90.95]],
                               atol=0.005)  # fmt: skip


# ---- scans -------------------------------------------------------------------------------
FREQS = [48.0, 60.0, 85.2]


def _arrays_equal(a, b):
    assert a.arrays.keys() == b.arrays.keys()
    for k in a.arrays:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_scan_interrupted_and_resumed_equals_uninterrupted(tmp_path):
    whole = frequency_scan(FREQS, out_dir=tmp_path / "whole", seed=4, workers=2, **TINY)
    part = frequency_scan(FREQS[:1], out_dir=tmp_path / "cut", seed=4, workers=1, **TINY)
    # the interrupted scan: the same manifest, one point finished
    shutil.copy(tmp_path / "whole" / "manifest.json", tmp_path / "cut" / "manifest.json")
    resumed = frequency_scan(FREQS, out_dir=tmp_path / "cut", seed=4, workers=2, **TINY)
    assert part.values.tolist() == FREQS[:1]
    _arrays_equal(whole, resumed)


def test_scan_on_dask_equals_local(tmp_path):
    distributed = require("distributed", "dask")
    local = frequency_scan(FREQS[1:], out_dir=tmp_path / "local", seed=9, workers=1, **TINY)
    with (
        distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False) as cluster,
        distributed.Client(cluster) as client,
    ):
        remote = frequency_scan(FREQS[1:], out_dir=tmp_path / "dask", seed=9, scheduler=client,
                                **TINY)  # fmt: skip
    _arrays_equal(local, remote)


def test_scan_below_gamma_one_finishes_trapped(tmp_path):
    freqs = [40.0, 45.0, 49.5]
    assert all(Params(f=f).gamma < 1 for f in freqs)
    scan = frequency_scan(freqs, out_dir=tmp_path / "s", seed=1, workers=2, n=8, t=2.0)
    np.testing.assert_array_equal(scan["trapped"], 1)
    np.testing.assert_array_equal(scan["D"], 0.0)
    np.testing.assert_array_equal(scan["D_se"], 0.0)
    np.testing.assert_array_equal(scan["collision_rate"], 0.0)
    assert load_scan(tmp_path / "s").values.tolist() == freqs


def test_partial_of_diffusion_point_is_recorded_in_the_manifest(tmp_path):
    scan = frequency_scan([60.0], out_dir=tmp_path / "m", seed=0, workers=1, **TINY)
    compute = scan.meta["compute"]
    assert compute["function"] == "bbdyn.scans.frequency:diffusion_point"
    assert compute["kwargs"] == {"n": 6, "t": 1.0}
    assert functools.partial(diffusion_point, n=6, t=1.0)(60.0, np.random.SeedSequence(0))


def test_scan_on_a_fine_grid_keeps_every_point(tmp_path):
    freqs = [85.0, 85.2]
    scan = frequency_scan(freqs, out_dir=tmp_path / "fine", seed=2, workers=1, **TINY)
    one = [diffusion_point(f, np.random.SeedSequence(2, spawn_key=(round(f * 10**9),)), **TINY)
           for f in freqs]  # fmt: skip
    np.testing.assert_array_equal(scan["E"], [o["E"] for o in one])


# ---- arguments checked before anything is written (issue 10) ---------------------------------
def test_transient_zero_averages_from_the_start(tmp_path):
    """transient = 0 is allowed (ensemble: [0, t)); the energy drift check then splits
    [0, floor(t f)] periods like any other window (it used to ask for a negative transient)."""
    scan = frequency_scan([85.2], out_dir=tmp_path / "s", seed=1, workers=1, transient=0.0,
                          **TINY)  # fmt: skip
    assert math.isfinite(scan["E_drift"][0])
    res = ensemble(Params(f=85.2), n=6, t=1.0, seed=0, transient=0.0, observables=("energy",))
    assert res.meta["window_periods"] == [0, math.floor(85.2)]


@pytest.mark.parametrize(
    "option, value, match",
    [
        ("--transient", "2", "transient"),
        ("--transient", "-1", "transient"),
        ("--n", "1", "n must"),
        ("--t", "0", "t must"),
        ("--t", "nan", "t must"),
        ("--f-step", "1e-12", "f_step"),
        ("--n", "1000000000", "n="),
        ("--t", "1e12", "t="),
        ("--workers", "0", "workers"),
    ],
    ids=[
        "transient>t",
        "negative-transient",
        "n=1",
        "t=0",
        "t=nan",
        "tiny-step",
        "huge-n",
        "huge-t",
        "workers=0",
    ],  # fmt: skip
)
def test_refused_scan_writes_nothing(tmp_path, capsys, option, value, match):
    from bbdyn.commands.cli import main

    out = tmp_path / "scan"
    args = ["scan", "--f-start", "60", "--f-stop", "61", "--n", "4", "--t", "1", "--out", str(out)]
    try:
        code = main([*args, option, value])
    except SystemExit as stop:
        code = stop.code
    assert code != 0
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err, err
    assert not out.exists(), "a refused scan left files behind"


def test_absurd_grid_is_refused_with_its_cost_before_allocating():
    from bbdyn.scans.frequency import MAX_POINTS, check_scan_size

    with pytest.raises(ValueError, match="f_step") as info:
        frequency_grid(49.8, 95.0, 1e-12)
    assert "4.52e+13 frequencies" in str(info.value)
    # the largest allowed grid is fine
    assert frequency_grid(0.5, 0.5 + (MAX_POINTS - 1) * 0.001, 0.001).size == MAX_POINTS
    with pytest.raises(ValueError, match="CPU") as info:
        check_scan_size(49.8, 95.0, 227, n=10**4, t=1e7)
    assert "disk" in str(info.value)


def test_disk_estimate_matches_a_stored_point(tmp_path):
    """The estimate of the disk a scan needs is the size of the points it writes (+-50 %)."""
    from bbdyn.scans.frequency import point_bytes

    frequency_scan([85.2], out_dir=tmp_path / "s", seed=1, workers=1, **TINY)
    size = sum(p.stat().st_size for p in (tmp_path / "s" / "points").iterdir())
    assert 0.5 < point_bytes() / size < 1.5
