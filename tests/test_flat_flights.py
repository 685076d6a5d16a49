"""benchmarks/flat_flights.py: the same kernel in two trees gives bitwise the same flights and
gap evaluations; a kernel that searches differently (a variant, applied as a patch) is told
apart."""

from pathlib import Path

import pytest
from derivation_loader import load_benchmark

ff = load_benchmark("flat_flights")
ROOT = Path(__file__).resolve().parents[1]
VARIANTS = ROOT / "docs" / "bench" / "flat_variants"


def no_finish_patch(folder: Path) -> Path:
    """A unified diff of the tree's own ``core/flat.py`` that switches the Taylor finish off
    (safe steps to the end: more gap evaluations per flight), written into ``folder``."""
    import difflib

    path = "bbdyn/core/flat.py"
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


@pytest.mark.parametrize(
    ("folder", "report_name"),
    [("flat_variants", "flat_flights_e7de300.json"),
     ("flat_variants_e56e7ce", "flat_flights_e56e7ce_variants.json")],
)  # fmt: skip
def test_every_committed_variant_applies_to_the_tree_it_was_measured_on(
    tmp_path, folder, report_name
):
    """The variants of a folder of docs/bench/ are edits of the source at the commit of their
    measurement (the report's first tree), and the report timed each of them; later changes
    to the same lines need not leave them applicable to today's tree."""
    import json
    import subprocess

    report = json.loads((ROOT / "docs" / "bench" / report_name).read_text())
    variants = ROOT / "docs" / "bench" / folder
    assert sorted(report["patches"]) == sorted(p.name for p in variants.glob("*.diff"))
    base = report["trees"][0]
    if subprocess.run(["git", "cat-file", "-e", f"{base}^{{commit}}"], cwd=ROOT).returncode:
        pytest.skip(f"commit {base} is not in this clone (a shallow checkout)")
    archive = subprocess.run(["git", "archive", base, "bbdyn"], cwd=ROOT, capture_output=True,
                             check=True).stdout  # fmt: skip
    subprocess.run(["tar", "-x", "-C", str(tmp_path)], input=archive, check=True)
    for diff in sorted(variants.glob("*.diff")):
        check = ["git", "apply", "--check", str(diff)]
        assert subprocess.run(check, cwd=tmp_path, capture_output=True).returncode == 0, diff.name


def test_docs_section_states_the_committed_run():
    """docs/benchmarks.md's "Where the flat flight's time goes": its table and every ratio,
    count and speed it states, from docs/bench/flat_flights_e7de300.json."""
    import json

    text = (ROOT / "docs" / "benchmarks.md").read_text()
    flat = " ".join(text.split())
    report = json.loads((ROOT / "docs" / "bench" / "flat_flights_e7de300.json").read_text())
    assert ff.table(report) in text
    assert report["patches"] == sorted(p.name for p in VARIANTS.glob("*.diff"))
    rows = {r["tree"].partition("+")[2] or "base": r for r in report["results"]}
    spread = max(max(r["ns_per_flight"]) / min(r["ns_per_flight"]) for r in rows.values())
    assert f"rounds of one tree differ by up to {100 * (spread - 1):.1f} %" in flat
    assert all(len(r["ns_per_flight"]) == report["rounds"] == 5 for r in rows.values())
    for name, row in rows.items():
        if name != "base":
            assert f"{row['ratio_to_first']:.3f}" in flat, name
    # the two wrong-on-purpose variants, and "none [correct one] comes near the 9 % needed"
    assert (
        rows["no_taylor_finish"]["ratio_to_first"] < 0.55
        and not rows["no_taylor_finish"]["bitwise_as_first"]
    )
    assert 0.94 < rows["no_series_rate"]["ratio_to_first"] < 0.96
    correct = ("quartic_prestep", "degree16_fixed", "span1_degree20", "sincos_branchless",
               "time_above_serial")  # fmt: skip
    assert min(rows[n]["ratio_to_first"] for n in correct) > 0.97
    for name in ("span1_degree20", "sincos_branchless"):  # "slower"
        assert rows[name]["ratio_to_first"] > 1.01
    for name in ("degree16_fixed", "sincos_branchless", "time_above_serial"):  # bitwise
        assert rows[name]["bitwise_as_first"]
    span, base = rows["span1_degree20"], rows["base"]
    assert (f"{span['evals_per_flight']:.3f} evaluations per flight against "
            f"{base['evals_per_flight']:.3f}") in flat  # fmt: skip
    ns = base["median_ns_per_flight"]
    assert f"{ns:.1f} ns per flight is {1e9 / ns:.3g} flights per second" in flat
    # "still about 9 % short of its target of 1e7": the last bench run of the flat row
    bench = json.loads((ROOT / "docs" / "bench" / "bench_trees_92c6887_67c51b6.json").read_text())
    assert round(100 * (1 - bench["flat"][0]["67c51b6"]["speed"] / 1e7)) == 9
