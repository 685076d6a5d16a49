"""Speed of the ensemble kernel: events per CPU-second, one thread, two source trees interleaved.

Times ``bbdyn.ensemble.ensemble`` (the ``core.ensemble.run_ensemble`` kernel and the few
array allocations around it) through the public API, so that it runs unchanged on two
versions of the code.  Each tree gets a worker process (``PYTHONPATH`` = the tree,
``NUMBA_NUM_THREADS=1``) that compiles and runs once first; then every repeat runs each
frequency once in each worker, alternating which goes first, so that load on the machine
hits both alike.  Reported per tree and frequency: the median over the repeats of simulated
events (fast-forwarded ones excluded) per CPU-second of the worker process, and the ratio
of the medians (second tree / first).

Usage::

    python benchmarks/kernel_buffers.py OLD_TREE NEW_TREE [--f 85.2 58] [--n 64] [--t 20]
        [--repeats 7] [--fast-forward] [--json]
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time


def worker(n: int, t: float, fast_forward: bool) -> None:
    """Answer each frequency (Hz) read from stdin with one timed run, as a JSON line."""
    import bbdyn
    from bbdyn import Params
    from bbdyn.ensemble import ensemble

    print(json.dumps({"bbdyn": bbdyn.__file__}), flush=True)
    for line in sys.stdin:
        f = float(line)
        cpu = time.process_time()
        res = ensemble(Params(f=f), t=t, n=n, seed=1, threads=1, fast_forward=fast_forward)
        cpu = time.process_time() - cpu
        events = int(res["events"].sum() - res["skipped_events"].sum())
        print(json.dumps({"f": f, "events": events, "cpu_s": cpu}), flush=True)


def start(tree: str, args, cache: str | None = None) -> subprocess.Popen:
    """A worker process on the source tree ``tree`` (with its own numba cache ``cache``)."""
    env = dict(os.environ, PYTHONPATH=os.path.abspath(tree), NUMBA_NUM_THREADS="1")
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--n", str(args.n)]
    cmd += ["--t", str(args.t)] + (["--fast-forward"] if args.fast_forward else [])
    proc = subprocess.Popen(cmd, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    loaded = json.loads(proc.stdout.readline())["bbdyn"]
    if not loaded.startswith(os.path.abspath(tree)):
        raise RuntimeError(f"worker for {tree} imported bbdyn from {loaded}")
    return proc


def ask(proc: subprocess.Popen, f: float) -> dict:
    """One timed run at ``f`` (Hz) in the worker ``proc``."""
    proc.stdin.write(f"{f}\n")
    proc.stdin.flush()
    return json.loads(proc.stdout.readline())


def compare(args) -> dict:
    """Interleaved repeats on both trees; medians of events per CPU-second and their ratio."""
    # a new numba cache per tree: a tree's own __pycache__ may hold a kernel compiled before an
    # edit to a module it calls (numba checks only the defining file), and would time that
    folder = tempfile.mkdtemp(prefix="kernel_buffers_")
    procs = [
        start(tree, args, os.path.join(folder, f"cache{i}")) for i, tree in enumerate(args.trees)
    ]
    rates = {(tree, f): [] for tree in args.trees for f in args.f}
    events = {}
    for proc in procs:  # compile (or load the cache) and warm up
        for f in args.f:
            ask(proc, f)
    for r in range(args.repeats):
        order = list(zip(args.trees, procs, strict=True))[:: 1 if r % 2 == 0 else -1]
        for f in args.f:
            for tree, proc in order:
                out = ask(proc, f)
                rates[tree, f].append(out["events"] / out["cpu_s"])
                if events.setdefault((tree, f), out["events"]) != out["events"]:
                    raise RuntimeError(f"{tree} at {f} Hz: event count changed between repeats")
    for proc in procs:
        proc.stdin.close()
        proc.wait()
    shutil.rmtree(folder)
    report = {"n": args.n, "t": args.t, "repeats": args.repeats, "fast_forward": args.fast_forward}
    report["trees"] = [tree_label(tree) for tree in args.trees]
    report["results"] = []
    for f in args.f:
        med = [statistics.median(rates[tree, f]) for tree in args.trees]
        report["results"].append({
            "f": f,
            "events": [events[tree, f] for tree in args.trees],
            "median_events_per_cpu_s": med,
            "min_max": [[min(rates[tree, f]), max(rates[tree, f])] for tree in args.trees],
            "ratio": med[1] / med[0],
        })  # fmt: skip
    return report


def tree_label(tree: str) -> str:
    """The tree's git commit (short hash; ``+dirty`` with uncommitted changes), else its path."""

    def git(*args):
        out = subprocess.run(["git", "-C", tree, *args], capture_output=True, text=True, check=True)
        return out.stdout.strip()

    try:
        head = git("rev-parse", "--short", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.CalledProcessError):
        return os.path.abspath(tree)
    return head + ("+dirty" if dirty else "")


def doc_table(report: dict) -> str:
    """The report as a markdown table: per frequency, events per CPU-second of each tree
    (median over the repeats) and their ratio."""
    old, new = report["trees"]
    lines = [f"| f (Hz) | events / CPU-s, {old} | events / CPU-s, {new} | ratio |",
             "|---:|---:|---:|---:|"]  # fmt: skip
    for row in report["results"]:
        a, b = row["median_events_per_cpu_s"]
        lines.append(f"| {row['f']:g} | {a:.3g} | {b:.3g} | {row['ratio']:.2f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trees", nargs="*", help="two source trees: reference, then candidate")
    parser.add_argument("--f", type=float, nargs="+", default=[85.2, 58.0], help="Hz")
    parser.add_argument("--n", type=int, default=64, help="particles")
    parser.add_argument("--t", type=float, default=20.0, help="simulated time (s)")
    parser.add_argument("--repeats", type=int, default=7, help="timed runs per tree and f (>= 5)")
    parser.add_argument("--fast-forward", action="store_true", help="with fast-forward")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.n, args.t, args.fast_forward)
        return
    if len(args.trees) != 2 or args.repeats < 5:
        parser.error("give two source trees and --repeats >= 5")
    report = compare(args)
    if args.json:
        print(json.dumps(report, indent=1))
        return
    print(f"n = {args.n}, t = {args.t} s, {args.repeats} repeats, one thread; events per CPU-s:")
    for row in report["results"]:
        old, new = row["median_events_per_cpu_s"]
        print(f"  f = {row['f']} Hz: {old:.4g} ({args.trees[0]}), {new:.4g} ({args.trees[1]}), "
              f"ratio {row['ratio']:.3f}; events {row['events']}")  # fmt: skip


if __name__ == "__main__":
    main()
