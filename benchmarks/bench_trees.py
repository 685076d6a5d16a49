"""``bbdyn bench TARGET`` on two source trees in one run: speed before and after, errors beside.

Each tree runs the benchmark in its own process (``PYTHONPATH`` = the tree, its own numba
cache), the trees alternating and the order reversed on every repeat, so that load on the
machine hits both alike.  Reported for each row of the exact kernel (flat: ``impacts_per_s``;
billiard: ``collisions_per_s``): the median speed over the repeats in each tree, their ratio
(second tree / first), and each tree's largest one-step time and velocity errors against the
mpmath reference (deterministic).

Usage::

    python benchmarks/bench_trees.py OLD_TREE NEW_TREE --target flat billiard [--repeats 2]
        [--quick] [--json OUT]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import chatter_takeover  # noqa: E402  (tree_env: a run on a source tree, checked)
import kernel_buffers  # noqa: E402  (tree_label)

SPEED = {"flat": "impacts_per_s", "billiard": "collisions_per_s"}


def bench_rows(tree: str, target: str, quick: bool, folder: Path) -> list[dict]:
    """The rows of one ``bbdyn bench TARGET --json`` run on ``tree``."""
    cache = folder / f"numba_{Path(tree).name}"
    cache.mkdir(exist_ok=True)
    env = chatter_takeover.tree_env(tree, str(cache))  # checks bbdyn comes from ``tree``
    png = folder / f"{target}_{Path(tree).name}.png"
    cmd = [sys.executable, "-m", "bbdyn", "bench", target, "--json", "--out", str(png)]
    out = subprocess.run(cmd + (["--quick"] if quick else []), env=env, cwd=cache,
                         capture_output=True, text=True, check=True)  # fmt: skip
    return parse_rows(out.stdout)


def parse_rows(stdout: str) -> list[dict]:
    """The rows in the stdout of ``bbdyn bench --json``: the JSON object with ``rows`` (a bare
    list of rows from older trees), found after any progress lines printed before it."""
    offset = 0
    for line in stdout.splitlines(keepends=True):
        if line[:1] in "{[":
            try:
                data, _ = json.JSONDecoder().raw_decode(stdout, offset)
            except json.JSONDecodeError:
                data = None
            if isinstance(data, dict) and "rows" in data:
                return data["rows"]
            if isinstance(data, list) and all(isinstance(r, dict) for r in data):
                return data
        offset += len(line)
    raise ValueError(f"no JSON rows in the bench output: {stdout[:200]!r}")


def exact_rows(run: list[dict], speed: str) -> list[dict]:
    """The rows of the exact kernel that report a speed (one flight, continuous, ensemble)."""
    return [r for r in run if r["method"] == "exact" and speed in r]


def summary(runs: dict[str, list[list[dict]]], target: str) -> list[dict]:
    """Per exact row: median speed per tree, the ratio, and each tree's largest errors."""
    speed = SPEED[target]
    trees = list(runs)
    rows = []
    for i, row in enumerate(exact_rows(runs[trees[0]][0], speed)):
        out = {"setting": row["setting"]}
        for tree in trees:
            same = [exact_rows(run, speed)[i] for run in runs[tree]]
            out[tree] = {
                "speed": statistics.median(r[speed] for r in same),
                "max_time_error_s": same[0].get("max_time_error_s"),
                "max_velocity_error": same[0].get("max_velocity_error"),
            }
        out["ratio"] = out[trees[1]]["speed"] / out[trees[0]]["speed"]
        rows.append(out)
    return rows


def doc_table(report: dict, target: str) -> str:
    """Markdown table of one target's rows: speed in each tree, ratio, largest errors."""
    old, new = report["trees"]
    unit = "impacts/s" if target == "flat" else "collisions/s"
    lines = [
        f"| exact kernel | {unit}, {old} | {unit}, {new} | ratio | max dt (s), {old} / {new} "
        f"| max dv (mm/s), {old} / {new} |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for row in report[target]:
        a, b = row[old], row[new]
        errors = []
        for key in ("max_time_error_s", "max_velocity_error"):
            vals = [x[key] for x in (a, b)]
            pair = " / ".join("-" if v is None or v != v else f"{v:.2g}" for v in vals)
            errors.append(pair)
        lines.append(f"| {row['setting']} | {a['speed']:.3g} | {b['speed']:.3g} "
                     f"| {row['ratio']:.3f} | {errors[0]} | {errors[1]} |")  # fmt: skip
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("--target", nargs="+", choices=sorted(SPEED), default=["flat"])
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json", help="save the report here")
    args = parser.parse_args(argv)
    names = {tree: kernel_buffers.tree_label(tree) for tree in (args.old, args.new)}
    report = {"trees": list(names.values()), "repeats": args.repeats, "quick": args.quick}
    with tempfile.TemporaryDirectory() as tmp:
        for target in args.target:
            runs = {names[t]: [] for t in (args.old, args.new)}
            for rep in range(args.repeats):
                order = (args.old, args.new) if rep % 2 == 0 else (args.new, args.old)
                for tree in order:
                    runs[names[tree]].append(bench_rows(tree, target, args.quick, Path(tmp)))
            report[target] = summary(runs, target)
            for row in report[target]:
                a, b = (row[n]["speed"] for n in names.values())
                print(
                    f"{target:9s} {row['setting'][:48]:48s} {a:10.3g} {b:10.3g} {row['ratio']:6.3f}"
                )
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
