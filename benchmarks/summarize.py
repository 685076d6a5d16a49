"""Derived numbers of the committed benchmark runs, for docs/benchmarks.md.

Reads the current run of each benchmark target (``docs/bench/bench_flat.json``,
``bench_billiard.json``, ``scan_cost.json``), the current full scan
(``docs/scan_compare/full_scan.json`` with its ``_wall.json``) and its comparison with
``docs/figures/S3_full`` (``full_scan_compare.json``), and writes what the page states
beyond the files' own fields: ratios, ranges, z-values of differences, the scan's time per
band beside the cost model's prediction, and the chattering sum's error on a creep cycle
(from ``docs/scan_compare/chatter_takeover.json``, for docs/billiard.md).  Recompute it
after replacing any of those files::

    python benchmarks/summarize.py            # writes docs/data/benchmarks.json

``tests/test_bench_summary.py`` checks that the committed JSON is what this script computes
from the committed files, and the statements of the page against the data.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
OUT = DOCS / "data" / "benchmarks.json"
#: the setting of the paper-like fixed-step method compared in the text
PAPER_SETTING = "dt=0.0001 s, dt_min=1e-06 s"
#: the performance targets (one core unless said): flat impacts/s, billiard collisions/s,
#: wall time of the full scan on two cores (s), one-step time error (s)
#: the creep cycle whose E_x shows the chattering sum's error (Hz)
CREEP_F = 56.8
TARGETS = {"flat_impacts_per_s": 1e7, "billiard_collisions_per_s": 8e6,
           "full_scan_wall_s": 600.0, "time_error_s": 1e-12}  # fmt: skip


def _load(relative: str) -> dict:
    return json.loads((DOCS / relative).read_text())


def _z(a: dict, b: dict, key: str) -> float:
    """Difference of two independent estimates in units of its standard error."""
    return (a[key] - b[key]) / math.hypot(a["stderr_" + key], b["stderr_" + key])


def _span(values) -> list[float]:
    values = list(values)
    return [float(min(values)), float(max(values))]


def flat(meta: dict) -> dict:
    """The flat ball: exact map against the paper's fixed step, scipy and heyoka."""
    rows = meta["rows"]
    exact, fixed = rows[0], next(r for r in rows if r["setting"] == PAPER_SETTING)
    ivp = [r for r in rows if r["method"] == "solve_ivp"]
    lab = [r for r in ivp if r["frame"] == "lab" and not math.isfinite(r["max_step_periods"])]
    lab_capped = [r for r in ivp if r["frame"] == "lab" and math.isfinite(r["max_step_periods"])]
    plate = [r for r in ivp if r["frame"] == "plate"]
    long_run = {r["setting"]: r for r in meta["long_run"]}
    ref = long_run["default"]
    others = [r for r in meta["long_run"] if r["method"] == "fixed_step"]
    return {
        "fixed_time_error_ratio": fixed["max_time_error_s"] / exact["max_time_error_s"],
        "fixed_cost_ratio": fixed["cost_ratio_to_exact"],
        "lab_default_wrong": _span(r["wrong_contacts"] for r in lab),
        "lab_capped_cost": _span(r["cost_ratio_to_exact"] for r in lab_capped),
        "lab_capped_time_error_s": max(r["max_time_error_s"] for r in lab_capped),
        "plate_cost": _span(r["cost_ratio_to_exact"] for r in plate),
        "ivp_right_cost": _span(r["cost_ratio_to_exact"] for r in ivp if r["wrong_contacts"] == 0),
        "long_run": [{"setting": r["setting"], "distinct_phases": r["distinct_phases"],
                      "mean_v_z": _z(r, ref, "mean_v"), "var_v_z": _z(r, ref, "var_v")}
                     for r in others],  # fmt: skip
        "exact_distinct_phases": ref["distinct_phases"],
    }


def billiard(meta: dict) -> dict:
    """The billiard: exact kernel against the paper's fixed step; the profile's range."""
    rows, profile = meta["rows"], meta["profile"]
    exact = [r for r in rows if r["method"] == "exact"]
    fixed = next(r for r in rows if r["setting"] == PAPER_SETTING)
    error = max(r["max_time_error_s"] for r in exact if r["max_time_error_s"] is not None
                and math.isfinite(r["max_time_error_s"]))  # fmt: skip
    by_tiny = sorted(profile, key=lambda p: p["tiny_share"])
    return {
        "exact_time_error_s": error,
        "fixed_time_error_ratio": fixed["max_time_error_s"] / error,
        "fixed_cost_ratio": fixed["cost_ratio_to_exact"],
        "profile_collisions_per_s": _span(p["collisions_per_s"] for p in profile),
        "profile_steps_per_flight": _span(p["steps_per_flight"] for p in profile),
        "fewest_tiny": by_tiny[0], "most_tiny": by_tiny[-1],
    }


def scan(points: list[dict], wall: dict, predicted: list[dict]) -> dict:
    """The full scan: wall and CPU time, per band beside the cost model's prediction."""
    from bbdyn.scenes.b2_scan_cost import measured_bands

    bands = measured_bands(points)
    for band, row in zip(bands, predicted, strict=True):
        band.update(predicted_cpu_s=row["predicted_cpu_s"], error_cpu_s=row["error_cpu_s"],
                    miss_in_errors=(row["predicted_cpu_s"] - band["cpu_s"]) / row["error_cpu_s"])
    return {"wall_s": wall["wall_s"], "cpu_s": float(sum(p["cpu_s"] for p in points)),
            "points": len(points), "bands": {b["band"]: b for b in bands}}  # fmt: skip


def compare(summary: dict, z: dict) -> dict:
    """The full scan against S3_full: the largest |z| per quantity, the points beyond 3 with
    their z, the agreement below 57 Hz (trapped and locked points) and the spread above 65 Hz."""
    f = z["f"]
    out = {"n_points": summary["n_points"]}
    for name in ("D", "E", "E_x"):
        values = z[name]["z"]
        beyond = np.abs(values) > 3.0
        out[name] = {
            "n_beyond_3": int(beyond.sum()), "chi2_per_dof": summary[name]["chi2_per_dof"],
            "mean_z": summary[name]["mean_z"], "std_z": summary[name]["std_z"],
            "max_abs_z": float(np.abs(values).max()),
            "beyond_3": [{"f": float(x), "z": float(v)} for x, v in zip(f[beyond], values[beyond],
                                                                        strict=True)],
            "max_abs_z_below_57_Hz": float(np.abs(values[f < 57.0]).max()),
            "std_z_above_65_Hz": float(values[f > 65.0].std(ddof=1)),
        }  # fmt: skip
    return out


def creep(report: dict) -> dict:
    """The chattering sum's error on a creep cycle (``benchmarks/chatter_takeover.py
    --simulate``): E_x at the default budget against the value the tightened budgets
    extrapolate to, and how the error shrinks per factor of the budget."""
    import chatter_takeover

    series = chatter_takeover.budget_series(report, "as is", CREEP_F)
    return {"f": CREEP_F, "E_x_rel_error": (series["E_x"][1.0] - series["limit"]) / series["limit"],
            "ratios": series["ratios"]}  # fmt: skip


def summarize() -> dict:
    """Everything docs/benchmarks.md states beyond the fields of the committed files."""
    import sys

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import scan_compare

    full = _load("scan_compare/full_scan.json")
    compared = _load("scan_compare/full_scan_compare.json")
    z = scan_compare.z_scores(scan_compare.load_old(ROOT / compared["provenance"]["old"]["file"]),
                              scan_compare.load_new(ROOT / compared["provenance"]["new"]["file"]))
    flat_meta = _load("bench/bench_flat.json")["meta"]
    billiard_meta = _load("bench/bench_billiard.json")["meta"]
    # per core: impacts (collisions) per second of the benchmark's CPU time
    measured = {"flat_impacts_per_s": flat_meta["rows"][0]["impacts_per_cpu_s"],
                "billiard_collisions_per_s": billiard_meta["rows"][0]["collisions_per_cpu_s"],
                "full_scan_wall_s": _load("scan_compare/full_scan_wall.json")["wall_s"],
                "time_error_s": max(flat_meta["rows"][0]["max_time_error_s"],
                                    billiard_meta["rows"][0]["max_time_error_s"])}  # fmt: skip
    below = {"full_scan_wall_s", "time_error_s"}  # targets that are upper bounds
    return {
        "command": "python benchmarks/summarize.py",
        "flat": flat(flat_meta),
        "billiard": billiard(billiard_meta),
        "scan": scan(full["points"], _load("scan_compare/full_scan_wall.json"),
                     _load("bench/scan_cost.json")["meta"]["rows"]),
        "compare": compare(compared, z),
        "creep": creep(_load("scan_compare/chatter_takeover.json")),
        "targets": {k: {"target": v, "measured": measured[k],
                        "met": "met" if (measured[k] <= v if k in below else measured[k] >= v)
                        else "missed"} for k, v in TARGETS.items()},  # fmt: skip
    }


def main() -> None:
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(json.dumps(summarize(), indent=1) + "\n")
    print(f"saved {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
