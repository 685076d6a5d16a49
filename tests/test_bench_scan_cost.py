"""Scan cost model: its arithmetic on fake timers with known cost, no timing."""

import math

import numpy as np
import pytest

from bbdyn.scans.frequency import frequency_grid
from bbdyn.scenes import b2_scan_cost as sc

SETTINGS = {"samples": 17, "n": 4, "t": 2.5, "repeats": 3}


def _band_linear_cost(f: float) -> float:
    """CPU s per particle-second, linear inside each band with a jump between bands."""
    for i, (lo, hi) in enumerate(sc.BANDS):
        if lo - 1e-9 <= f <= hi + 1e-9:
            return 1e-4 * (i + 1) + 3e-6 * (f - lo) * (-1) ** i
    raise AssertionError(f"{f} Hz is in no band")


def test_bands_tile_the_scan_grid():
    """The bands' grids are the S3-S5 grid (49.8-95 Hz, 0.2 Hz), each point once."""
    joined = np.concatenate([sc.band_grid(lo, hi) for lo, hi in sc.BANDS])
    np.testing.assert_array_equal(joined, frequency_grid(49.8, 95.0, sc.F_STEP))


@pytest.mark.parametrize("samples", [10, 14, 17, 20, 40])
def test_samples_per_band_include_both_ends(samples):
    """Every band is sampled at its ends, on the grid, and the count is the one asked for."""
    got = sc.sample_frequencies(samples)
    assert sum(len(s) for s in got) == samples
    for (lo, hi), f_s in zip(sc.BANDS, got, strict=True):
        assert f_s[0] == lo and f_s[-1] == hi and np.all(np.diff(f_s) > 0)
        assert set(f_s) <= set(sc.band_grid(lo, hi))


def test_prediction_is_exact_for_a_cost_linear_in_each_band():
    """With c linear in each band the model is exact: n t sum c(f) over the full grid."""
    calls = []

    def timer(f, n, t, seed):
        calls.append((f, n, t, seed))
        return n * t * _band_linear_cost(f)

    res = sc.compute(SETTINGS, timer=timer)
    assert len(calls) == 1 + SETTINGS["samples"] * SETTINGS["repeats"]  # warm-up + runs
    timed = calls[1:]
    assert all(n == SETTINGS["n"] and t == SETTINGS["t"] for _, n, t, _ in timed)
    assert [seed for *_, seed in timed[: SETTINGS["repeats"]]] == list(range(SETTINGS["repeats"]))
    grid = frequency_grid(49.8, 95.0, sc.F_STEP)
    exact = sc.FULL_N * sc.FULL_T * sum(_band_linear_cost(f) for f in grid)
    rows = res.meta["rows"]
    assert rows[-1]["setting"] == "total"
    assert rows[-1]["predicted_cpu_s"] == pytest.approx(exact, rel=1e-12)
    for (lo, hi), row in zip(sc.BANDS, rows[:-1], strict=True):
        want = sc.FULL_N * sc.FULL_T * sum(_band_linear_cost(f) for f in sc.band_grid(lo, hi))
        assert row["predicted_cpu_s"] == pytest.approx(want, rel=1e-12)
    # no timing noise and no interpolation miss: the error estimate is zero
    assert res.meta["interp_rel_error"] == pytest.approx(0.0, abs=1e-12)
    assert rows[-1]["error_cpu_s"] == pytest.approx(0.0, abs=1e-9 * exact)
    assert math.fsum(r["share"] for r in rows[:-1]) == pytest.approx(1.0)


def test_error_estimate_sees_curvature_and_the_spread_of_seeds():
    """A cost quadratic in f is missed by the linear model; leave-one-out and the spread
    over seeds (a timer off by -10, 0, +10 % for seeds 0, 1, 2) both show up in the error
    estimate."""

    def timer(f, n, t, seed):
        return n * t * 1e-4 * (1.0 + 0.01 * (f - 70.0) ** 2) * (0.9, 1.0, 1.1)[seed]

    res = sc.compute(SETTINGS, timer=timer)
    samples = sc.sample_frequencies(SETTINGS["samples"])
    costs = [1e-4 * (1.0 + 0.01 * (f - 70.0) ** 2) for f in samples]  # medians: exact
    loo = sc.loo_rel_errors(samples, costs)
    assert np.all(loo > 0)  # chords of a convex function lie above it
    assert res.meta["interp_rel_error"] == pytest.approx(np.sqrt(np.mean(loo**2)))
    grid = frequency_grid(49.8, 95.0, sc.F_STEP)
    exact = sc.FULL_N * sc.FULL_T * 1e-4 * float(np.sum(1.0 + 0.01 * (grid - 70.0) ** 2))
    total = res.meta["rows"][-1]
    assert total["predicted_cpu_s"] > exact  # linear interpolation of a convex cost
    assert abs(total["predicted_cpu_s"] - exact) <= total["error_cpu_s"]
    band_rel = [r["error_cpu_s"] / r["predicted_cpu_s"] for r in res.meta["rows"][:-1]]
    assert min(band_rel) >= 0.2 * (1 - 1e-9)  # the seeds' spread (1.1 - 0.9) is included


def test_too_few_samples_is_refused():
    with pytest.raises(ValueError, match="samples must be >= 10"):
        sc.sample_frequencies(9)


def test_unknown_setting_is_refused():
    """--impacts (n_impacts) means nothing to the cost model: refused, not ignored."""
    with pytest.raises(ValueError, match="n_impacts"):
        sc.compute({**SETTINGS, "n_impacts": 5}, timer=lambda f, n, t, seed: 1.0)


def test_measured_table_sums_each_band_of_a_real_scan():
    """Per-point times of a scan grid with a known cost (1 s per point, 5 s at 50 Hz): every
    band sums its points, the shares add to 100 %, a band without points says so."""
    grid = frequency_grid(49.8, 95.0, 0.2)
    points = [{"f": float(f), "cpu_s": 5.0 if abs(f - 50.0) < 1e-9 else 1.0} for f in grid]
    rows = sc.measured_table(points).splitlines()
    assert rows[2] == "| 49.8-53 | 21 | 9% | 17 | 5.0 s at 50 Hz |"  # 16 x 1 s + 5 s, of 231 s
    assert rows[-1] == f"| all | {grid.size + 4} | 100% | {grid.size} | |"
    counts = [int(r.split("|")[4]) for r in rows[2:-1]]
    assert sum(counts) == grid.size
    empty = sc.measured_table(points[:3]).splitlines()
    assert empty[3] == "| 53.2-57.4 | 0 | 0% | 0 | - |"


def test_measured_speedup_table_compares_two_scans_band_by_band():
    """Two grids of known cost (the second twice as fast, four times at 50 Hz): each band's
    sums and ratio; grids that differ are refused."""
    grid = frequency_grid(49.8, 95.0, 0.2)
    before = [{"f": float(f), "cpu_s": 2.0} for f in grid]
    after = [{"f": float(f), "cpu_s": 0.5 if abs(f - 50.0) < 1e-9 else 1.0} for f in grid]
    rows = sc.measured_speedup_table(before, after[::-1]).splitlines()
    assert rows[2] == "| 49.8-53 | 34 | 16 | 2.06 |"  # 17 points: 34 s against 16.5 s
    assert rows[3] == "| 53.2-57.4 | 44 | 22 | 2.00 |"
    assert rows[-1] == f"| all | {2 * grid.size} | {grid.size - 0.5:.0f} | 2.00 |"
    with pytest.raises(ValueError, match="same frequency grid"):
        sc.measured_speedup_table(before, after[1:])


def test_predicted_vs_measured_table_lines_up_bands_and_ratios():
    """Predictions of known rows beside grids of known cost (1 s per point, then 0.5 s)."""
    grid = frequency_grid(49.8, 95.0, 0.2)
    slow = [{"f": float(f), "cpu_s": 1.0} for f in grid]
    fast = [{"f": float(f), "cpu_s": 0.5} for f in grid]
    rows = [{"predicted_cpu_s": 10.0 * (i + 1), "error_cpu_s": 2.0} for i in range(6)]
    half = [dict(r, predicted_cpu_s=r["predicted_cpu_s"] / 4) for r in rows]
    lines = sc.predicted_vs_measured_table([rows, half], [slow, fast], ["a", "b"]).splitlines()
    assert lines[0].startswith("| band (Hz) | predicted, a | measured, a | predicted, b |")
    assert lines[2] == "| 49.8-53 | 10 +- 2 | 17 | 2 +- 2 | 8 | 4.00 | 2.00 |"  # 17 points
    total = f"| all | 60 +- 2 | {grid.size} | 15 +- 2 | {grid.size / 2:.0f} | 4.00 | 2.00 |"
    assert lines[-1] == total


def test_committed_prediction_holds_for_the_committed_full_scan():
    """docs/benchmarks.md: the committed cost model's prediction (docs/bench/scan_cost.json)
    lies within its stated error of the committed full scan's CPU time in every band and in
    total, and its error is not so wide that it could not miss (under 100 % in total)."""
    import json

    from derivation_loader import ROOT

    rows = json.loads((ROOT / "docs" / "bench" / "scan_cost.json").read_text())["meta"]["rows"]
    scan = json.loads((ROOT / "docs" / "scan_compare" / "full_scan.json").read_text())
    measured = sc.band_sums(scan["points"])
    assert len(rows) == len(measured) == len(sc.BANDS) + 1
    for row, cpu in zip(rows, measured, strict=True):
        assert abs(row["predicted_cpu_s"] - cpu) <= row["error_cpu_s"]
    assert rows[-1]["error_cpu_s"] < rows[-1]["predicted_cpu_s"]
