"""The device check (benchmarks/gpu_check.py) and the GPU page's report (docs/_ext/devicereport.py).

The check itself needs a GPU; ``--smoke`` runs it at a tiny size in numba's CUDA simulator
(slow: it compiles the kernels it calls for the CPU).  The page draws every number about
the device from the committed report; a report of the expected shape renders to tables
that carry its numbers.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import devicereport  # docs/_ext, on the path by conftest.py
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _z(n_points, beyond, max_z, chi2, exact=0):
    return {"z": [0.0] * n_points, "max_abs_z": max_z, "n_beyond": beyond, "chi2_per_dof": chi2,
            "chi2_per_dof_scatter": (2 / (n_points - exact)) ** 0.5, "mean_z": 0.1,
            "n_exact": exact, "passed": beyond == 0 and 0.7 <= chi2 <= 1.3}  # fmt: skip


def fake_report() -> dict:
    """A report as gpu_check writes it, with made-up numbers."""
    table = {"n_points": 20, "f": [50.0 + k for k in range(20)], "passed": True,
             "D": _z(20, 0, 2.1, 0.93), "E": _z(20, 0, 1.7, 1.12, exact=3),
             "E_x": _z(20, 1, 3.9, 1.41)}  # fmt: skip
    full = {"points": 227, "n": 1000, "t": 200.0, "done": True, "gpu_wall_s": 12.34,
            "events": 2.2e10, "events_per_s": 1.78e9, "state_bytes": 500_000_000,
            "cpu": {"cpu_s": 7353.7}, "cpu_over_gpu_wall": 595.9,
            "agreement": {**table, "n_points": 227}}  # fmt: skip
    b6 = {"centres": [{"centre": 85.2, "points": 69, "n": 40000, "done": True,
                       "gpu_wall_s": 61.5, "events_per_s": 2.0e9}],
          "complete": False, "extrapolated_gpu_s": 246.0}  # fmt: skip
    return {"kind": "gpu_report", "smoke": False, "command": "python benchmarks/gpu_check.py",
            "created_utc": "2026-01-01T00:00:00+00:00", "bbdyn_version": "0.1.0",
            "gpu": {"name": "NVIDIA H200", "compute_capability": [9, 0],
                    "memory_total_bytes": 150 * 2**30, "driver": "12.8", "runtime": "12.9"},
            "compile_s": 41.2, "total_s": 399.0, "agreement": {**table, "done": True},
            "full_scan": full, "b6": b6}  # fmt: skip


def _rows(lines, first_cell):
    return [[c.strip() for c in line.strip("|").split("|")] for line in lines
            if line.startswith(f"| {first_cell}")]  # fmt: skip


def test_a_report_renders_its_numbers(tmp_path):
    path = tmp_path / "gpu_report.json"
    path.write_text(json.dumps(fake_report()))
    report = json.loads(path.read_text())
    lines = devicereport.report_markdown(report)
    assert _rows(lines, "NVIDIA H200") == [["NVIDIA H200", "9.0", "150", "12.8", "12.9",
                                            "41.2", "399"]]  # fmt: skip
    agreement = _rows(lines, "20 frequencies")
    assert [r[1] for r in agreement] == ["D", "E", "E_x"]
    assert agreement[2][3:5] == ["1", "3.90"] and agreement[2][-1] == "no"
    assert agreement[1][6] == "3"  # points equal within rounding
    speed = _rows(lines, "full scan")
    assert speed[-1] == ["full scan", "227 x 1000", "200", "12.3", "2.2e+10", "1.78e+09", "7354",
                         "596"]  # fmt: skip
    assert _rows(lines, "85.2") == [["85.2", "69", "40000", "61.5", "2e+09"]]
    assert any("246 s of GPU time" in line and "extrapolated" in line for line in lines)


def test_a_part_cut_short_says_so():
    report = fake_report()
    report["full_scan"] = {"done": False, "fraction": 0.25, "wall_s": 100.0,
                           "extrapolated_s": 400.0}  # fmt: skip
    text = "\n".join(devicereport.report_markdown(report))
    assert "cut short at 25 % after 100 s (extrapolated: 400 s)" in text


@pytest.mark.slow  # about 10 s warm, a minute or more with a cold numba cache
def test_smoke_check_runs_in_the_simulator_and_renders(tmp_path):
    pytest.importorskip("numba_cuda", reason="numba-cuda is not installed (pip install bbdyn[gpu])")
    out = tmp_path / "report.json"
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1")
    env.pop("PYTHONPATH", None)  # the script puts its own checkout first
    run = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "gpu_check.py"), "--smoke",
                          "--out", str(out)], env=env, capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    report = json.loads(out.read_text())
    assert report["smoke"] and report["gpu"]["name"] == "CUDA simulator"
    assert report["agreement"]["done"] and report["full_scan"]["done"]
    assert report["b6"]["complete"] and "error" not in report
    assert report["total_s"] < 60
    assert devicereport.report_markdown(report)
