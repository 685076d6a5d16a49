"""The committed benchmark runs that docs/benchmarks.md states (tests of its numbers)."""

from derivation_loader import ROOT

from bbdyn.results import load_result


def bench_runs(name: str, before: str):
    """``(run, run before, docs/benchmarks.md)``: the results ``docs/bench/<name>.json`` and
    ``<before>.json`` and the page's text."""
    bench = ROOT / "docs" / "bench"
    raw = (ROOT / "docs" / "benchmarks.md").read_text()
    return load_result(bench / f"{name}.json"), load_result(bench / f"{before}.json"), raw
