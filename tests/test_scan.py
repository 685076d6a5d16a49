"""Resumable, parallel scans (bbdyn.scans.runner): seeds, storage, interruption, dask.

The compute functions are cheap stand-ins (a synthetic random draw, and an
ensemble of flat balls from bbdyn.core.flat); the facts checked are the scan's:
identical numbers whatever the order, the worker count, an interruption or the
executor, and physical facts of the flat-ball compute (Gamma < 1 traps everything).
"""

import functools
import io
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from extras import require

from bbdyn import Params
from bbdyn.core.flat import FlatState, flat_run
from bbdyn.core.status import IMPACT, STICK, STUCK_FOREVER, raise_for_status
from bbdyn.scans.progress import Progress
from bbdyn.scans.runner import (
    KEY_SCALE,
    ScanResult,
    SourceChangedWarning,
    load_scan,
    point_key,
    point_seed,
    run_scan,
)

VALUES = [50.0, 58.0, 60.2, 72.4, 95.0]


# ---- compute functions (top level: workers import them by name) ---------------------------
def synthetic(value, seed_sequence, *, n=64, stop_file=None, hang_file=None):
    """Draws from the point's own stream.

    For interruption tests, while ``stop_file`` exists the points above 60 raise,
    and while ``hang_file`` exists they hang (for a minute).
    """
    if stop_file is not None and os.path.exists(stop_file) and value > 60.0:
        raise RuntimeError(f"stopped at {value}")
    if hang_file is not None and os.path.exists(hang_file) and value > 60.0:
        time.sleep(60.0)
    rng = np.random.default_rng(seed_sequence)
    x = rng.normal(value, 1.0, n)
    return {"mean": x.mean(), "mean_se": x.std(ddof=1) / math.sqrt(n), "draws": x}


def flat_ensemble(f, seed_sequence, *, n=16, events=400):
    """Flat balls from random impacts (phase, vrel up to the floor's speed) after ``events``."""
    kp = Params(f=f).kernel()
    rng = np.random.default_rng(seed_sequence)
    vrel_end = np.empty(n)
    stuck = 0
    for i in range(n):
        phase = rng.uniform(0.0, 2.0 * math.pi)
        vrel = rng.uniform(0.1, 2.0) * kp.A * kp.w
        (_, _, vrel_i, kind), _, status = flat_run(
            FlatState(0.0, phase, vrel, IMPACT), kp, events, None
        )
        raise_for_status(status, f"flat_ensemble(f={f})")
        vrel_end[i] = vrel_i
        stuck += kind == STICK and status == STUCK_FOREVER
    return {"stuck_fraction": stuck / n, "vrel_end": vrel_end}


def not_numeric(value, seed_sequence):
    return {"label": np.array(["a", "b"])}


def _same(a: ScanResult, b: ScanResult) -> None:
    assert list(a.arrays) == list(b.arrays)
    for k in a.arrays:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


@pytest.fixture(scope="module")
def reference_dir(tmp_path_factory) -> Path:
    """Folder of an uninterrupted scan of ``synthetic`` with 2 workers."""
    out = tmp_path_factory.mktemp("reference")
    run_scan(VALUES, synthetic, out_dir=out, seed=3, workers=2, progress=False)
    return out


@pytest.fixture(scope="module")
def reference(reference_dir) -> ScanResult:
    return load_scan(reference_dir)


# ---- seeds ----------------------------------------------------------------------------------
def test_point_seed_depends_on_seed_and_value_at_stated_resolution():
    state = point_seed(1, 58.0).generate_state(4)
    assert (point_seed(1, 58.0 + 0.4 / KEY_SCALE).generate_state(4) == state).all()
    assert not (point_seed(1, 58.0 + 1.0 / KEY_SCALE).generate_state(4) == state).all()
    assert not (point_seed(2, 58.0).generate_state(4) == state).all()
    assert point_key(95.2) == 95_200_000_000


def test_values_closer_than_resolution_are_refused(tmp_path):
    with pytest.raises(ValueError, match="differ by more than 1e-9"):
        run_scan([58.0, 58.0 + 1e-11], synthetic, out_dir=tmp_path, seed=0, progress=False)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        pytest.param({"values": []}, "must not be empty", id="empty"),
        pytest.param({"values": [-1.0]}, "finite and >= 0", id="negative"),
        pytest.param({"values": [math.nan]}, "finite and >= 0", id="nan"),
        pytest.param({"seed": -1}, "seed must be", id="negative_seed"),
        pytest.param({"seed": 1.5}, "seed must be", id="float_seed"),
        pytest.param({"workers": 0}, "workers must be", id="zero_workers"),
        pytest.param({"compute": lambda v, s: {}}, "top-level function", id="lambda"),
        pytest.param({"progress": 3}, "progress must be", id="bad_progress"),
    ],
)
def test_bad_arguments_are_named(tmp_path, kwargs, match):
    args = {"values": VALUES, "compute": synthetic, "seed": 0, "progress": False}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        run_scan(args.pop("values"), args.pop("compute"), out_dir=tmp_path, **args)


# ---- results independent of order and workers; storage -------------------------------------
def test_order_and_worker_count_do_not_change_numbers(tmp_path, reference):
    reverse = run_scan(VALUES[::-1], synthetic, out_dir=tmp_path, seed=3, workers=1, progress=False)
    order = np.argsort(reverse.values)
    assert (reverse.values[order] == reference.values).all()
    for k in ("mean", "mean_se", "draws"):
        np.testing.assert_array_equal(reverse[k][order], reference[k])


def test_stacking_shapes_and_values_order(reference):
    n = len(VALUES)
    assert reference.values.tolist() == VALUES
    # the documented seed rule, applied by hand in this process
    for i, v in enumerate(VALUES):
        np.testing.assert_array_equal(
            reference["draws"][i], synthetic(v, point_seed(3, v))["draws"]
        )
    assert reference["mean"].shape == (n,) and reference["draws"].shape == (n, 64)
    # each point's mean is its own draws' mean: rows stay with their value
    np.testing.assert_array_equal(reference["mean"], reference["draws"].mean(axis=1))
    # and the draws are centred on the value (normal, sd 1, n = 64: |error| < 6 sd)
    assert np.all(np.abs(reference["mean"] - reference.values) < 6 * reference["mean_se"])


def test_points_load_without_pickle_and_carry_metadata(reference_dir, reference):
    out = reference_dir
    files = sorted((out / "points").glob("*.npz"))
    assert len(files) == len(VALUES)
    assert not list((out / "points").glob("*.tmp"))
    for path in files:
        with np.load(path, allow_pickle=False) as data:
            assert set(data.files) == {"mean", "mean_se", "draws"}
        meta = json.loads(path.with_suffix(".json").read_text())["meta"]
        assert meta["key"] == point_key(meta["value"]) and meta["seed"] == 3
        assert meta["compute"]["function"].endswith(":synthetic")
        assert {"bbdyn_version", "wall_s", "host", "pid"} <= set(meta)
    _same(load_scan(out), reference)


def test_saved_scan_result_round_trips(tmp_path, reference):
    reference.save(tmp_path / "scan")
    again = ScanResult.load(tmp_path / "scan")
    _same(again, reference)
    assert again.meta["values"] == VALUES


def test_output_must_be_numeric(tmp_path):
    with pytest.raises(TypeError, match="must be numeric"):
        run_scan([58.0], not_numeric, out_dir=tmp_path, seed=0, workers=1, progress=False)


# ---- interruption and resume ----------------------------------------------------------------
def test_crash_keeps_finished_points_and_resume_matches(tmp_path, reference):
    stop = tmp_path / "stop"
    stop.touch()
    compute = functools.partial(synthetic, stop_file=str(stop))
    with pytest.raises(RuntimeError, match="stopped at") as info:
        run_scan(VALUES, compute, out_dir=tmp_path / "scan", seed=3, workers=1, progress=False)
    assert "resume=True" in "".join(info.value.__notes__)
    part = load_scan(tmp_path / "scan", partial=True)
    assert part.values.tolist() == [v for v in VALUES if v <= 60.0]
    with pytest.raises(FileNotFoundError, match="missing"):
        load_scan(tmp_path / "scan")
    stop.unlink()
    mtimes = {p: p.stat().st_mtime_ns for p in (tmp_path / "scan/points").glob("*.json")}
    resumed = run_scan(VALUES, compute, out_dir=tmp_path / "scan", seed=3, progress=False)
    _same(resumed, reference)
    # the finished points were not computed again
    assert all(p.stat().st_mtime_ns == t for p, t in mtimes.items())


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.parametrize(
    "signum, whole_group",
    [
        pytest.param(signal.SIGKILL, True, id="killed"),
        pytest.param(signal.SIGINT, True, id="ctrl_c"),
        pytest.param(signal.SIGINT, False, id="sigint_to_main_process_only"),
        pytest.param(signal.SIGTERM, False, id="sigterm_to_main_process_only"),
    ],
)
def test_interrupted_process_keeps_points_and_resume_matches(
    tmp_path, reference, signum, whole_group
):
    out, hang = tmp_path / "scan", tmp_path / "hang"
    hang.touch()
    compute = functools.partial(synthetic, hang_file=str(hang))
    code = (
        "import sys, functools; sys.path.insert(0, sys.argv[1]);"
        "from test_scan import synthetic, VALUES; from bbdyn.scans.runner import run_scan;"
        "run_scan(VALUES, functools.partial(synthetic, hang_file=sys.argv[3]),"
        " out_dir=sys.argv[2], seed=3, workers=1, progress=False)"
    )
    argv = [sys.executable, "-c", code, str(Path(__file__).parent), str(out), str(hang)]
    proc = subprocess.Popen(argv, start_new_session=True, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 30
        # 50 and 58 Hz finish, then the worker hangs at 60.2 Hz
        while len(list(out.glob("points/*.json"))) < 2:
            assert time.monotonic() < deadline, "the scan did not store two points in 30 s"
            assert proc.poll() is None, "the scan ended before it was interrupted"
            time.sleep(0.05)
        if whole_group:
            os.killpg(proc.pid, signum)
        else:
            os.kill(proc.pid, signum)
        assert proc.wait(timeout=15) != 0
        # no worker is left running the hanging point
        deadline = time.monotonic() + 10
        while _group_alive(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _group_alive(proc.pid), "worker processes outlived the interrupted scan"
    finally:
        if _group_alive(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)  # only the processes this test started
        proc.wait()
    assert len(list(out.glob("points/*.json"))) == 2
    hang.unlink()
    _same(run_scan(VALUES, compute, out_dir=out, seed=3, progress=False), reference)


@pytest.mark.parametrize(
    "change, match",
    [
        pytest.param({"seed": 4}, "seed", id="seed"),
        pytest.param({"values": VALUES[:-1]}, "values", id="values"),
        pytest.param({"compute": functools.partial(synthetic, n=8)}, "compute", id="kwargs"),
        pytest.param({"compute": flat_ensemble}, "compute", id="function"),
    ],
)
def test_resume_with_a_different_scan_is_refused(reference_dir, change, match):
    out = reference_dir
    args = {"values": VALUES, "compute": synthetic, "seed": 3}
    args.update(change)
    with pytest.raises(ValueError, match=f"differs in: .*{match}"):
        run_scan(args["values"], args["compute"], out_dir=out, seed=args["seed"], progress=False)


def test_fresh_scan_into_existing_folder_is_refused(reference_dir):
    with pytest.raises(FileExistsError, match="resume=True"):
        run_scan(VALUES, synthetic, out_dir=reference_dir, seed=3, resume=False)


def test_complete_scan_resumes_without_computing(reference_dir, reference):
    again = run_scan(VALUES, synthetic, out_dir=reference_dir, seed=3, progress=False)
    _same(again, reference)


def test_resume_by_other_source_warns(tmp_path, reference):
    """Points computed by two versions of the code are not mixed silently."""
    import warnings

    out = tmp_path / "scan"
    run_scan(VALUES[:2], synthetic, out_dir=out, seed=3, workers=1, progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the same source: resumed without a word
        run_scan(VALUES[:2], synthetic, out_dir=out, seed=3, workers=1, progress=False)
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["bbdyn_source"] = "0" * 64  # as if begun before an edit of bbdyn
    (out / "manifest.json").write_text(json.dumps(manifest))
    with pytest.warns(SourceChangedWarning, match="begun by other bbdyn source"):
        again = run_scan(VALUES[:2], synthetic, out_dir=out, seed=3, workers=1, progress=False)
    np.testing.assert_array_equal(again["draws"], reference["draws"][:2])


def test_half_written_point_is_computed_again(tmp_path, reference):
    out = tmp_path / "scan"
    run_scan(VALUES[:2], synthetic, out_dir=out, seed=3, workers=1, progress=False)
    # a crash between the .npz and the .json (the .json marks a point done)
    victim = sorted(out.glob("points/*.json"))[0]
    victim.unlink()
    (out / "points" / "leftover.npz.tmp").write_bytes(b"partial")
    again = run_scan(VALUES[:2], synthetic, out_dir=out, seed=3, workers=1, progress=False)
    np.testing.assert_array_equal(again["draws"], reference["draws"][:2])
    assert not list(out.glob("points/*.tmp"))


# ---- a physical compute: the flat ball ------------------------------------------------------
def test_flat_ball_scan_traps_everything_below_gamma_one(tmp_path):
    f1 = Params(f=50.0).f_gamma_one  # 49.8 Hz
    freqs = [0.8 * f1, 0.95 * f1, 1.2 * f1, 1.4 * f1]
    compute = functools.partial(flat_ensemble, n=8, events=300)
    res = run_scan(freqs, compute, out_dir=tmp_path / "a", seed=1, workers=2, progress=False)
    below = res.values < f1
    assert (res["stuck_fraction"][below] == 1.0).all()
    assert (res["vrel_end"][below] == 0.0).all()
    # above Gamma = 1 the floor throws the ball again: nothing is stuck for good
    assert (res["stuck_fraction"][~below] == 0.0).all()
    again = run_scan(
        freqs[::-1], compute, out_dir=tmp_path / "b", seed=1, workers=1, progress=False
    )
    np.testing.assert_array_equal(again["vrel_end"][::-1], res["vrel_end"])


# ---- progress and plotting ------------------------------------------------------------------
def test_progress_reports_done_rate_and_time_left(tmp_path):
    stream = io.StringIO()
    run_scan(VALUES[:3], synthetic, out_dir=tmp_path, seed=0, workers=1, progress=stream)
    lines = stream.getvalue().splitlines()
    assert lines[0].startswith("f: 0/3") and lines[-1].startswith("f: 3/3")
    assert "/s" in lines[-1] and "0s left" in lines[-1]


def test_progress_counts_rate_from_resumed_points_only():
    bar = Progress(10, done=8, stream=io.StringIO())
    assert bar.line() == "8/10 | -/s | - left"


def test_plot_draws_errorbars_of_a_scalar(reference):
    ax = reference.plot(key="mean")
    # labels with the schema's unit, where the key has one (f in Hz; "mean" is the test's)
    assert ax.get_xlabel() == "f (Hz)" and ax.get_ylabel() == "mean"
    assert len(ax.containers) == 1  # the errorbar container from mean_se
    with pytest.raises(ValueError, match="scalar outputs"):
        reference.plot(key="draws")


# ---- dask -----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def cluster():
    distributed = require("distributed", "dask")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        yield cluster


@pytest.mark.parametrize("how", ["client", "address"])
def test_dask_local_cluster_gives_the_local_numbers(tmp_path, reference, cluster, how):
    import distributed

    if how == "client":
        with distributed.Client(cluster) as client:
            res = run_scan(VALUES, synthetic, out_dir=tmp_path, seed=3, scheduler=client)
    else:
        res = run_scan(
            VALUES, synthetic, out_dir=tmp_path, seed=3, scheduler=cluster.scheduler_address
        )
    _same(res, reference)
    assert os.getpid() not in {p["pid"] for p in res.meta["points"]}


def test_dask_crash_keeps_points_and_local_resume_matches(tmp_path, reference, cluster):
    stop = tmp_path / "stop"
    stop.touch()
    compute = functools.partial(synthetic, stop_file=str(stop))
    out = tmp_path / "scan"
    with pytest.raises(RuntimeError, match="stopped at"):
        run_scan(VALUES, compute, out_dir=out, seed=3, scheduler=cluster.scheduler_address)
    assert load_scan(out, partial=True).values.tolist() == [v for v in VALUES if v <= 60.0]
    stop.unlink()
    _same(run_scan(VALUES, compute, out_dir=out, seed=3, workers=1, progress=False), reference)
