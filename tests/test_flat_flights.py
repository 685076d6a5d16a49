"""benchmarks/flat_flights.py: the same kernel in two trees gives bitwise the same flights and
gap evaluations; a kernel that searches differently (a committed variant, applied as a patch)
is told apart."""

from pathlib import Path

from derivation_loader import load_benchmark

ff = load_benchmark("flat_flights")
ROOT = Path(__file__).resolve().parents[1]
VARIANTS = ROOT / "docs" / "bench" / "flat_variants"


def test_same_tree_twice_is_bitwise_the_same_and_a_patched_search_is_not():
    # the variant whose Taylor finish reaches twice as far (to degree 20): fewer safe steps
    span = VARIANTS / "span1_degree20.diff"
    report = ff.compare([str(ROOT), str(ROOT)], rounds=1, patches=(str(span),))
    same, again, other = report["results"]
    assert other["tree"] == f"{same['tree']}+span1_degree20"
    assert report["patches"] == ["span1_degree20.diff"]
    assert again["bitwise_as_first"] and again["evals_per_flight"] == same["evals_per_flight"]
    assert not other["bitwise_as_first"]
    assert other["evals_per_flight"] < same["evals_per_flight"]
    for row in report["results"]:
        assert len(row["ns_per_flight"]) == 1 and row["median_ns_per_flight"] > 0
    table = ff.table(report)
    assert table.count("| yes |") == 2 and table.count("| no |") == 1
    assert f"| {same['median_ns_per_flight']:.2f} | 1.0000 |" in table


def test_every_committed_variant_applies_to_the_tree():
    import subprocess

    for diff in sorted(VARIANTS.glob("*.diff")):
        check = ["git", "apply", "--check", str(diff)]
        assert subprocess.run(check, cwd=ROOT, capture_output=True).returncode == 0, diff.name
