"""benchmarks/billiard_runs.py: every tree runs from the first tree's start states; the same
tree twice ends its runs in bitwise the same states."""

from pathlib import Path

from derivation_loader import load_benchmark

br = load_benchmark("billiard_runs")
ROOT = Path(__file__).resolve().parents[1]


def test_same_tree_twice_runs_from_the_same_start_to_the_same_end():
    report = br.compare([str(ROOT), str(ROOT)], [58.0, 85.2], events=20_000, rounds=2)
    assert [row["f"] for row in report["results"]] == [58.0, 85.2]
    for row in report["results"]:
        assert row["bitwise_as_first"] == [True, True]
        assert len(row["start"]) == 7 and row["start"][1] != 0.0  # after the transient
        assert all(len(runs) == 2 for runs in row["events_per_cpu_s"])
        assert row["ratio_to_first"][0] == 1.0 and row["median_events_per_cpu_s"][1] > 0
    table = br.table(report)
    assert table.splitlines()[2].startswith("| 58 | ")
    assert f"| {report['results'][1]['ratio_to_first'][1]:.3f} |" in table
