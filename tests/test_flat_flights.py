"""benchmarks/flat_flights.py: the same kernel in two trees gives bitwise the same flights and
gap evaluations; a kernel that searches differently is told apart."""

import shutil
from pathlib import Path

from derivation_loader import load_benchmark

ff = load_benchmark("flat_flights")
ROOT = Path(__file__).resolve().parents[1]


def test_same_tree_twice_is_bitwise_the_same_and_a_changed_search_is_not(tmp_path):
    # a copy whose Taylor finish reaches twice as far (to degree 20): fewer safe steps
    changed = tmp_path / "changed"
    shutil.copytree(ROOT / "bbdyn", changed / "bbdyn", ignore=shutil.ignore_patterns("__pycache__"))
    tol = changed / "bbdyn" / "core" / "tolerances.py"
    source = tol.read_text()
    assert "TAYLOR_MAX_SPAN = 0.5\n" in source and "TAYLOR_MAX_DEGREE = 16\n" in source
    tol.write_text(
        source.replace("TAYLOR_MAX_SPAN = 0.5\n", "TAYLOR_MAX_SPAN = 1.0\n").replace(
            "TAYLOR_MAX_DEGREE = 16\n", "TAYLOR_MAX_DEGREE = 20\n"
        )
    )
    report = ff.compare([str(ROOT), str(ROOT), str(changed)], rounds=1)
    same, again, other = report["results"]
    assert again["bitwise_as_first"] and again["evals_per_flight"] == same["evals_per_flight"]
    assert not other["bitwise_as_first"]
    assert other["evals_per_flight"] < same["evals_per_flight"]
    for row in report["results"]:
        assert len(row["ns_per_flight"]) == 1 and row["median_ns_per_flight"] > 0
    table = ff.table(report)
    assert table.count("| yes |") == 2 and table.count("| no |") == 1
    assert f"| {same['median_ns_per_flight']:.2f} | 1.0000 |" in table
