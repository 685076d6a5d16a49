"""The CPU-time forecast of scans (``bbdyn.scans.frequency.scan_cpu_forecast``) that
``bbdyn reproduce`` prints before it runs the scan scenes.

The forecast counts the work (particles x driving periods) at a measured CPU cost per
particle and period, plus the start-up of each worker process; compilation is a separate
number.  It is checked against CPU time measured independently: the full S3 scan committed
in docs/scan_compare (measured on an idle machine) and a small scan run here (process
time, kernels compiled beforehand).  The old bound (50 events per period at 0.5 us each)
is 30-60 times these measurements and fails both.
"""

import json
import time

import numpy as np
import pytest
from derivation_loader import ROOT

from bbdyn.scans.frequency import (
    POINT_PERIOD_CPU_S,
    WORKER_COMPILE_CPU_S,
    WORKER_START_CPU_S,
    diffusion_point,
    frequency_grid,
    scan_cpu_forecast,
)
from bbdyn.scans.runner import local_workers, point_seed
from bbdyn.scenes import SCENES, scene_module, scene_settings
from bbdyn.scenes.reproduce import cost_lines

#: the full S3 scan measured on the idle machine (docs/benchmarks.md, "The full scan and its
#: cost model"): per-point CPU times of its two workers
FULL_SCAN = ROOT / "docs" / "scan_compare" / "full_scan.json"
FACTOR = 2.0


def test_forecast_of_the_full_scan_is_within_a_factor_2_of_its_measured_cpu_time():
    record = json.loads(FULL_SCAN.read_text())
    wall = json.loads(FULL_SCAN.with_name(FULL_SCAN.stem + "_wall.json").read_text())
    settings = scene_settings("S3", "full")
    assert "otherwise idle" in wall["machine"] and "--n 1000 --t 200" in wall["command"]
    assert (settings["n"], settings["t"]) == (1000, 200.0)
    f = np.array([p["f"] for p in record["points"]])
    assert np.allclose(f, frequency_grid(settings["f_start"], settings["f_stop"], 0.2))
    measured = sum(p["cpu_s"] for p in record["points"])
    forecast = scene_module("S3").cost({**settings, "workers": 2})
    assert 1 / FACTOR < forecast["cpu_s"] / measured < FACTOR, (forecast, measured)


def test_forecast_of_a_small_scan_is_within_a_factor_3_of_its_measured_cpu_time():
    """Three points run here, one numba thread, kernels compiled by a first call: the points'
    process time against the forecast without the workers' start-up (generous factor 3: CPU
    time on a loaded machine grows a little with cache contention)."""
    import numba

    freqs, n, t = (60.0, 75.0, 90.0), 40, 10.0
    old = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        diffusion_point(freqs[0], point_seed(1, freqs[0]), n=2, t=2.0)  # compile
        start = time.process_time()
        for f in freqs:
            diffusion_point(f, point_seed(0, f), n=n, t=t)
        measured = time.process_time() - start
    finally:
        numba.set_num_threads(old)
    forecast = scan_cpu_forecast(sum(freqs), len(freqs), n, t, workers=1)
    points = forecast["cpu_s"] - WORKER_START_CPU_S
    assert points == pytest.approx(sum(freqs) * n * t * POINT_PERIOD_CPU_S, rel=1e-12)
    assert 1 / 3 < points / measured < 3, (points, measured)


def test_forecast_counts_workers_once_per_process_and_compilation_apart():
    one = scan_cpu_forecast(100.0, 1, 10, 2.0, workers=4)  # one point: one worker
    four = scan_cpu_forecast(100.0, 8, 10, 2.0, workers=4)
    assert local_workers(4, 1) == 1 and local_workers(4, 8) == 4 and local_workers(None, 1) == 1
    assert four["cpu_s"] - one["cpu_s"] == pytest.approx(3 * WORKER_START_CPU_S)
    assert four["compile_cpu_s"] == 4 * WORKER_COMPILE_CPU_S
    twice = scan_cpu_forecast(200.0, 8, 10, 2.0, workers=4)
    assert twice["cpu_s"] - four["cpu_s"] == pytest.approx(100.0 * 10 * 2.0 * POINT_PERIOD_CPU_S)


def test_every_scene_cost_follows_the_protocol():
    """``bbdyn reproduce`` asks every scene with a ``cost`` for its forecast: each returns
    the forecast CPU time and the compile time (a scene whose ``cost`` means something else
    stops the main job)."""
    for setting in ("quick", "full"):
        lines = cost_lines(list(SCENES), setting)
        costed = [i for i in SCENES if hasattr(scene_module(i), "cost")]
        assert [line.split(":")[0] for line in lines] == costed


def test_reproduce_cost_lines_say_what_they_include():
    lines = cost_lines(["S3", "B1", "S1"], "quick")
    assert [line.split(":")[0] for line in lines] == ["S3", "B1"]  # S1 runs no scan
    for line in lines:
        assert "with compiled kernels" in line and "to compile them" in line, line
