"""What a chattering sum accepted earlier could save at most: run times with an oracle sum.

A faster scan could accept the closed-form chattering sum (``chatter_sum`` in
``bbdyn/core/billiard.py``) at a larger normal velocity than today's error bound allows, so
that the bounces before each stick need not be computed one by one.  This benchmark bounds
its gain from above: for each velocity V (mm/s) a copy of the source tree is patched so that
``chatter_sum`` accepts its sum whenever ``V.n < V`` *without its error budget* (only its
conditions that the effective gravity stays positive remain; the physics is then wrong at
the level the budget guards, and only the timing means anything).  Each copy
runs in its own worker process (those of ``kernel_buffers.py``: one numba thread, the
default fast-forward, seed 1; its own numba cache), interleaved with the unpatched tree.

Reported per sampled frequency: the median over the repeats of the CPU time of one run and
its ratio unpatched / patched.  Applied to the points of a measured full scan (each point's
``cpu_s`` divided by the ratio interpolated linearly in f within its band; the band's
ends take the nearest sample), they predict the scan's CPU time per band for each V.

Usage::

    python benchmarks/chatter_oracle.py [--tree .] [--v 1e-4 1e-3 1e-2] [--f 50.2 55 ...]
        [--n 16] [--t 200] [--repeats 3] [--scan docs/scan_compare/full_scan.json]
        [--json]
"""

import argparse
import json
import os
import shutil
import statistics
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import kernel_buffers  # noqa: E402  (the worker processes and their protocol)

from bbdyn.scenes.b2_scan_cost import BANDS, band_masks, band_sums  # noqa: E402

#: ``chatter_sum``'s error budget (periods of rounding the neglected terms may cost) ...
ANCHOR = "    budget = CHATTER_REL_TOL * kp.period * g_n\n"
#: ... lifted below V: the sum is then accepted whenever the effective gravity stays positive.
ORACLE = "    budget = math.inf if vn < {v!r} else CHATTER_REL_TOL * kp.period * g_n  # oracle\n"
F_DEFAULT = [50.2, 51.0, 52.0, 55.0, 57.0, 60.0, 63.0, 64.0, 67.0, 70.0, 73.6, 75.0, 79.4,
             80.4, 83.6, 85.2, 90.0, 95.0]  # fmt: skip


def patched_source(source: str, v: float) -> str:
    """``billiard.py``'s source with the error budget lifted below ``v`` (mm/s)."""
    if source.count(ANCHOR) != 1:
        raise RuntimeError("chatter_sum changed: the oracle's anchor line is not found once")
    return source.replace(ANCHOR, ORACLE.format(v=float(v)))


def copy_with_patch(tree: str, dest: str, relpath: str, patch) -> str:
    """A copy of ``tree``'s package at ``dest`` with the file ``relpath`` (under ``bbdyn/``)
    replaced by ``patch(its source)``; returns ``dest``."""
    shutil.copytree(os.path.join(tree, "bbdyn"), os.path.join(dest, "bbdyn"),
                    ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    path = os.path.join(dest, "bbdyn", relpath)
    with open(path) as fh:
        source = fh.read()
    with open(path, "w") as fh:
        fh.write(patch(source))
    return dest


def patched_tree(tree: str, v: float, folder: str) -> str:
    """A copy of ``tree``'s package in ``folder`` with the oracle at ``v``; returns its path."""
    return copy_with_patch(tree, os.path.join(folder, f"v{v:g}"), "core/billiard.py",
                           lambda source: patched_source(source, v))  # fmt: skip


def timed_runs(trees: list[str], args, folder: str) -> dict:
    """CPU s of the scan's runs (``args.n`` particles, ``args.t`` s) at each ``args.f``, on
    every tree in its own worker (numba cache in ``folder``), compiled first, then
    ``args.repeats`` rounds interleaved in alternating order: ``{(tree index, f): [s, ...]}``."""
    worker = argparse.Namespace(n=args.n, t=args.t, fast_forward=True)
    procs = [kernel_buffers.start(tree, worker, os.path.join(folder, f"cache{i}"))
             for i, tree in enumerate(trees)]  # fmt: skip
    for proc in procs:  # compile and warm up
        kernel_buffers.ask(proc, args.f[0])
    cpu = {(i, f): [] for i in range(len(trees)) for f in args.f}
    for r in range(args.repeats):
        for f in args.f:
            order = list(enumerate(procs))[:: 1 if r % 2 == 0 else -1]
            for i, proc in order:
                cpu[i, f].append(kernel_buffers.ask(proc, f)["cpu_s"])
    for proc in procs:
        proc.stdin.close()
        proc.wait()
    return cpu


def measure(args) -> dict:
    """Interleaved repeats of every frequency in the unpatched tree and each oracle copy."""
    with tempfile.TemporaryDirectory() as folder:
        trees = [os.path.abspath(args.tree)]
        trees += [patched_tree(args.tree, v, folder) for v in args.v]
        cpu = timed_runs(trees, args, folder)
    rows = []
    for f in args.f:
        base = statistics.median(cpu[0, f])
        ratio = [base / statistics.median(cpu[i + 1, f]) for i in range(len(args.v))]
        rows.append({"f": f, "cpu_s": base, "ratio": ratio})
    return {"tree": kernel_buffers.tree_label(args.tree), "n": args.n, "t": args.t,
            "repeats": args.repeats, "v": list(args.v), "rows": rows}  # fmt: skip


def predict(report: dict, points: list[dict]) -> list[list[float]]:
    """Per V of ``report``: the CPU s of ``points`` (a scan's ``f``, ``cpu_s``) per band, then
    all, with each point divided by the ratio interpolated within its band."""
    f_s = np.array([row["f"] for row in report["rows"]])
    f, cpu, masks = band_masks(points)
    samples = band_masks([{"f": x, "cpu_s": 0.0} for x in f_s])[2]
    out = []
    for j in range(len(report["v"])):
        ratio = np.array([row["ratio"][j] for row in report["rows"]])
        sums = [float((cpu[m] / np.interp(f[m], f_s[ms], ratio[ms])).sum())
                for m, ms in zip(masks, samples, strict=True)]  # fmt: skip
        out.append(sums + [sum(sums)])
    return out


def band_table(points: list[dict], pred: list[list[float]], labels: list[str]) -> str:
    """Markdown: the measured CPU s of the scan ``points`` per band and all, then each
    prediction of ``pred`` (as ``predict`` returns) under its label."""
    measured = band_sums(points)
    head = "| band (Hz) | measured | " + " | ".join(labels) + " |"
    lines = [head, "|---|" + "---:|" * (1 + len(labels))]
    names = [f"{lo:g}-{hi:g}" for lo, hi in BANDS] + ["all"]
    for k, name in enumerate(names):
        cells = " | ".join(f"{p[k]:.0f}" for p in pred)
        lines.append(f"| {name} | {measured[k]:.0f} | {cells} |")
    return "\n".join(lines)


def doc_table(report: dict, points: list[dict]) -> str:
    """Measured CPU s of the scan per band, and predicted with the oracle at each V."""
    labels = [f"V = {v:g} mm/s" for v in report["v"]]
    return band_table(points, predict(report, points), labels)


def add_prediction(report: dict, scan: str, predictor) -> list[dict]:
    """Store in ``report`` the scan file ``scan`` and ``predictor(report, its points)`` as
    ``predicted_cpu_s``; returns the points."""
    with open(scan) as fh:
        points = json.load(fh)["points"]
    report["scan"] = scan
    report["predicted_cpu_s"] = predictor(report, points)
    return points


def save_report(report: dict, path: str | None) -> None:
    """Write ``report`` as JSON to ``path`` (nothing if None)."""
    if path:
        with open(path, "w") as fh:
            json.dump(report, fh, indent=1)


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """``--tree``, ``--repeats``, ``--scan`` and ``--json`` (shared with chatter_takeover.py)."""
    parser.add_argument("--tree", default=".", help="source tree (default: .)")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per tree and f")
    scan = "docs/scan_compare/full_scan.json"
    parser.add_argument("--scan", default=scan, help="a full scan's JSON (its points)")
    parser.add_argument("--json", default=None, help="save the report here")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_common_arguments(parser)
    parser.add_argument("--v", type=float, nargs="+", default=[1e-4, 1e-3, 1e-2], help="mm/s")
    parser.add_argument("--f", type=float, nargs="+", default=F_DEFAULT, help="Hz")
    parser.add_argument("--n", type=int, default=16, help="particles")
    parser.add_argument("--t", type=float, default=200.0, help="simulated time (s)")
    args = parser.parse_args()
    report = measure(args)
    points = add_prediction(report, args.scan, predict)
    for row in report["rows"]:
        ratios = "  ".join(f"{r:5.2f}" for r in row["ratio"])
        print(f"f = {row['f']:5.1f} Hz: {row['cpu_s']:.3f} CPU-s, unpatched / oracle: {ratios}")
    print(doc_table(report, points))
    save_report(report, args.json)


if __name__ == "__main__":
    main()
