"""benchmarks/bench_trees.py: medians per tree and their ratio from the rows of each run."""

import json

import pytest
from derivation_loader import load_benchmark

bt = load_benchmark("bench_trees")


def run(speed_one, speed_cont, dt):
    """The rows of one fake ``bbdyn bench billiard --json`` run."""
    return [
        {"method": "exact", "setting": "one flight", "collisions_per_s": speed_one,
         "max_time_error_s": dt, "max_velocity_error": 1e-13},
        {"method": "fixed_step", "setting": "dt=1e-4", "collisions_per_s": 1.0},
        {"method": "exact", "setting": "continuous", "collisions_per_s": speed_cont},
    ]  # fmt: skip


def test_medians_ratio_and_errors_per_tree():
    runs = {
        "old": [run(4.0, 2.0, 1e-17), run(6.0, 2.0, 1e-17), run(5.0, 9.0, 1e-17)],
        "new": [run(10.0, 3.0, 2e-17), run(1.0, 3.0, 2e-17), run(12.0, 3.0, 2e-17)],
    }
    rows = bt.summary(runs, "billiard")
    assert [r["setting"] for r in rows] == ["one flight", "continuous"]  # exact rows only
    assert rows[0]["old"]["speed"] == 5.0 and rows[0]["new"]["speed"] == 10.0
    assert rows[0]["ratio"] == 2.0
    assert rows[1]["old"]["speed"] == 2.0 and rows[1]["ratio"] == 1.5
    assert rows[0]["new"]["max_time_error_s"] == 2e-17
    assert rows[1]["old"]["max_time_error_s"] is None
    table = bt.doc_table({"trees": ["old", "new"], "billiard": rows}, "billiard")
    assert "| one flight | 5 | 10 | 2.000 | 1e-17 / 2e-17 | 1e-13 / 1e-13 |" in table
    assert "| continuous | 2 | 3 | 1.500 | - / - | - / - |" in table


def test_rows_found_after_progress_lines():
    rows = run(4.0, 2.0, 1e-17)
    obj = json.dumps({"version": "1", "target": "billiard", "rows": rows}, indent=2)
    progress = "[1/3] one flight\n{not json} 40%\n"
    assert bt.parse_rows(progress + obj + "\n") == rows
    assert bt.parse_rows(json.dumps(rows, indent=1)) == rows  # an older tree's bare list
    with pytest.raises(ValueError, match="no JSON rows"):
        bt.parse_rows("progress only\n")
