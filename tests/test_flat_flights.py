"""benchmarks/flat_flights.py: the same kernel in two trees gives bitwise the same flights and
gap evaluations; a kernel that searches differently (a variant, applied as a patch) is told
apart."""

from pathlib import Path

from derivation_loader import load_benchmark

ff = load_benchmark("flat_flights")
ROOT = Path(__file__).resolve().parents[1]


def no_finish_patch(folder: Path) -> Path:
    """A unified diff of the tree's own ``core/search.py`` that switches the Taylor finish off
    (safe steps to the end: more gap evaluations per flight), written into ``folder``."""
    import difflib

    path = "bbdyn/core/search.py"  # flat_flight_tol: the flat search and its Taylor finish
    old = (ROOT / path).read_text().splitlines(keepends=True)
    line = "    finish = step_rel <= ROOT_STEP_REL\n"
    assert line in old
    new = [("    finish = False\n" if x == line else x) for x in old]
    diff = folder / "no_finish.diff"
    diff.write_text("".join(difflib.unified_diff(old, new, f"a/{path}", f"b/{path}")))
    return diff


def test_same_tree_twice_is_bitwise_the_same_and_a_patched_search_is_not(tmp_path):
    # the search without its Taylor finish: more safe steps, other last bits
    patch = no_finish_patch(tmp_path)
    report = ff.compare([str(ROOT), str(ROOT)], rounds=1, patches=(str(patch),))
    same, again, other = report["results"]
    assert other["tree"] == f"{same['tree']}+no_finish"
    assert report["patches"] == ["no_finish.diff"]
    assert again["bitwise_as_first"] and again["evals_per_flight"] == same["evals_per_flight"]
    assert not other["bitwise_as_first"]
    assert other["evals_per_flight"] > same["evals_per_flight"]
    for row in report["results"]:
        assert len(row["ns_per_flight"]) == 1 and row["median_ns_per_flight"] > 0
    table = ff.table(report)
    assert table.count("| yes |") == 2 and table.count("| no |") == 1
    assert f"| {same['median_ns_per_flight']:.2f} | 1.0000 |" in table
