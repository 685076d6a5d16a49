"""The flat ball's one-flight kernel in several source trees, interleaved: ns per flight.

Times what ``bbdyn bench flat`` reports as its default row (``bench_kernels.flat_one_step`` at
``ROOT_STEP_REL`` on the start states of ``b2_flat.CASE``), but in a loop compiled around
it, so that the Python-to-numba call around each pass over the 300 flights is not counted,
and as the minimum over many short runs, repeated in rounds (the median over rounds is
reported).  Each tree gets a worker process (``PYTHONPATH`` = the tree, its own numba
cache) that compiles first; every round asks each worker once, the order reversed on every
round.  Reported per tree: the median over rounds of its minimum time per flight (ns), gap
evaluations per flight, and whether its flight times and velocities are bitwise those of
the first tree; the ratio of the medians (each tree / the first).

``--patch DIFF`` adds a tree: a copy of the first tree's ``bbdyn/`` with the unified diff
``DIFF`` applied (``git apply``; paths ``a/bbdyn/...``), named ``FIRST+STEM``.  A variant is
then one diff file instead of a source tree.

Usage::

    python benchmarks/flat_flights.py TREE [TREE ...] [--patch DIFF ...] [--rounds 4] [--json]
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import chatter_takeover  # noqa: E402  (tree_env: a run on a source tree, checked)
import kernel_buffers  # noqa: E402  (tree_label)

#: Tiled passes over the 300 flights per timed run, and timed runs per round (min taken).
PASSES = 300
RUNS = 25


def worker() -> None:
    """Answer each line on stdin with one round's timing of the one-flight kernel (JSON)."""
    import hashlib
    import time

    import numpy as np
    from numba import njit

    from bbdyn.core.tolerances import ROOT_STEP_REL
    from bbdyn.scenes import b2_flat

    params = b2_flat.case_params()
    kp = params.kernel()
    states = b2_flat.start_states(params, b2_flat.FULL["n_impacts"])
    phase, vrel = states["phase"], states["vrel"]
    tau, vm = np.empty_like(phase), np.empty_like(phase)

    try:
        from bbdyn.reference.bench_kernels import flat_one_step as one_step
    except ImportError:  # an older tree: the kernel lived in the scene
        one_step = b2_flat.exact_one_step

    @njit
    def passes(phase, vrel, kp, tau, vm, count):  # arguments, not constants frozen in
        n_evals = 0
        for _ in range(count):
            n_evals += one_step(phase, vrel, kp, ROOT_STEP_REL, tau, vm)[0]
        return n_evals

    n_evals = passes(phase, vrel, kp, tau, vm, 1)
    digest = hashlib.sha256(tau.tobytes() + vm.tobytes()).hexdigest()
    print(json.dumps({"evals_per_flight": n_evals / phase.size, "digest": digest}), flush=True)
    for _ in sys.stdin:
        best = float("inf")
        for _ in range(RUNS):
            start = time.perf_counter()
            passes(phase, vrel, kp, tau, vm, PASSES)
            best = min(best, time.perf_counter() - start)
        print(json.dumps({"ns_per_flight": best / (PASSES * phase.size) * 1e9}), flush=True)


def patched_tree(tree: str, diff: str, folder: str) -> str:
    """A copy of ``tree``'s ``bbdyn/`` in ``folder`` with the unified diff ``diff`` applied."""
    copy = os.path.join(folder, os.path.splitext(os.path.basename(diff))[0])
    ignore = shutil.ignore_patterns("__pycache__")
    shutil.copytree(os.path.join(tree, "bbdyn"), os.path.join(copy, "bbdyn"), ignore=ignore)
    subprocess.run(["git", "apply", os.path.abspath(diff)], cwd=copy, check=True)
    return copy


def start_worker(tree: str, cache: str, script: str, args: list[str]) -> subprocess.Popen:
    """``script args`` in a process on the source tree ``tree`` with the new numba cache
    ``cache``, talking through stdin and stdout."""
    os.mkdir(cache)
    env = chatter_takeover.tree_env(tree, cache)  # checks bbdyn comes from ``tree``
    cmd = [sys.executable, os.path.abspath(script), *args]
    return subprocess.Popen(cmd, env=env, cwd=cache, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)  # fmt: skip


def compare(trees: list[str], rounds: int, patches: tuple[str, ...] = ()) -> dict:
    """Interleaved timing of ``trees`` and of the first with each of ``patches`` applied; the
    report described in the module docstring."""
    with tempfile.TemporaryDirectory() as folder:
        labels = [kernel_buffers.tree_label(tree) for tree in trees]
        for diff in patches:
            trees = [*trees, patched_tree(trees[0], diff, folder)]
            labels.append(f"{labels[0]}+{os.path.splitext(os.path.basename(diff))[0]}")
        procs, first = [], []
        for i, tree in enumerate(trees):
            cache = os.path.join(folder, f"numba_{i}")
            procs.append(start_worker(tree, cache, __file__, ["--worker"]))
            first.append(json.loads(procs[-1].stdout.readline()))
        times = [[] for _ in trees]
        for r in range(rounds):
            order = range(len(trees)) if r % 2 == 0 else reversed(range(len(trees)))
            for i in order:
                procs[i].stdin.write("\n")
                procs[i].stdin.flush()
                times[i].append(json.loads(procs[i].stdout.readline())["ns_per_flight"])
        for proc in procs:
            proc.stdin.close()
            proc.wait()
    medians = [statistics.median(t) for t in times]
    return {
        "trees": labels,
        "patches": [os.path.basename(diff) for diff in patches],
        "rounds": rounds,
        "results": [
            {"tree": labels[i], "ns_per_flight": times[i],
             "median_ns_per_flight": medians[i], "ratio_to_first": medians[i] / medians[0],
             "evals_per_flight": first[i]["evals_per_flight"],
             "bitwise_as_first": first[i]["digest"] == first[0]["digest"]}
            for i in range(len(trees))
        ],
    }  # fmt: skip


def table(report: dict) -> str:
    """The report as a markdown table, one row per tree."""
    lines = ["| tree | ns / flight | ratio to the first | evaluations / flight | bitwise |",
             "|---|---:|---:|---:|---|"]  # fmt: skip
    for row in report["results"]:
        lines.append(f"| {row['tree']} | {row['median_ns_per_flight']:.2f} | "
                     f"{row['ratio_to_first']:.4f} | {row['evals_per_flight']:.3f} | "
                     f"{'yes' if row['bitwise_as_first'] else 'no'} |")  # fmt: skip
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trees", nargs="*", help="source trees; ratios are to the first")
    parser.add_argument("--patch", nargs="+", default=[], metavar="DIFF",
                        help="also time the first tree with each unified diff applied")  # fmt: skip
    parser.add_argument("--rounds", type=int, default=4, help="timed rounds per tree (>= 1)")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker()
        return
    if not args.trees or args.rounds < 1:
        parser.error("give at least one source tree and --rounds >= 1")
    report = compare(args.trees, args.rounds, tuple(args.patch))
    print(json.dumps(report, indent=1) if args.json else table(report))


if __name__ == "__main__":
    main()
