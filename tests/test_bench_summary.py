"""docs/data/benchmarks.json: the derived numbers of docs/benchmarks.md are those that
``benchmarks/summarize.py`` computes from the committed runs, and the targets' verdicts
follow from the numbers."""

import json
import math

from derivation_loader import ROOT, load_benchmark
from json_trees import json_close


def _committed() -> dict:
    return json.loads((ROOT / "docs" / "data" / "benchmarks.json").read_text())


def test_committed_summary_is_what_the_script_computes():
    fresh = json.loads(json.dumps(load_benchmark("summarize").summarize()))
    assert json_close(_committed(), fresh), "run python benchmarks/summarize.py"


def test_target_verdicts_follow_from_the_numbers():
    for name, t in _committed()["targets"].items():
        upper = name in ("full_scan_wall_s", "time_error_s")
        holds = t["measured"] <= t["target"] if upper else t["measured"] >= t["target"]
        assert t["met"] == ("met" if holds else "missed"), name


def test_band_rows_add_up_to_the_scan():
    """The scan's bands cover every point once, their CPU times add up to the total, and the
    costliest point of all is the costliest of some band."""
    scan = _committed()["scan"]
    bands = [b for name, b in scan["bands"].items() if name != "all"]
    assert sum(b["points"] for b in bands) == scan["bands"]["all"]["points"] == scan["points"]
    assert math.isclose(sum(b["cpu_s"] for b in bands), scan["cpu_s"], rel_tol=1e-12)
    assert scan["bands"]["all"]["costliest_cpu_s"] == max(b["costliest_cpu_s"] for b in bands)
