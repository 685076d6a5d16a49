"""The billiard's continuous event loop in several source trees, from the same start states.

Times ``bbdyn.core.billiard.billiard_run`` storing nothing (the loop of ``bbdyn bench
billiard``'s continuous row; ``billiard_run_count`` in trees without ``EventState``) at each
frequency from one start state per frequency: the state after a transient of 20000 events
from ``b2_billiard.CASE``'s start, computed by the *first* tree and handed to every tree, so
that no tree's transient decides where its run starts (the attractors are intermittent: a
run's cost depends on where it starts).  Each tree gets a worker process (``PYTHONPATH`` =
the tree, its own numba cache); every round asks each worker once, the order reversed on
every round.  Reported per tree and frequency: events per CPU-second of the worker (median
over rounds), the ratio to the first tree, and whether the run ends in bitwise the state of
the first tree's.

Usage::

    python benchmarks/billiard_runs.py TREE [TREE ...] [--f 58 70 85.2 90] [--events 2000000]
        [--rounds 3] [--json]
"""

import argparse
import json
import os
import statistics
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import flat_flights  # noqa: E402  (start_worker: a worker process on a source tree)
import kernel_buffers  # noqa: E402  (tree_label)

#: Events of the transient before the timed runs, as in ``b2_billiard.CASE``.
TRANSIENT = 20_000


def worker(events: int) -> None:
    """Print the start states of the requested frequencies (one JSON line), then answer
    each JSON line of start states with events per CPU-second and the final state at each
    frequency."""
    import time

    from bbdyn.core import billiard
    from bbdyn.core.status import OK

    if hasattr(billiard, "EventState"):  # one run loop; count mode: out = None

        def billiard_run_count(*args):
            *state, kp, n = args
            last, n_done, status = billiard.billiard_run(billiard.EventState(*state), kp, n, None)
            return (*last, n_done, status)

    else:
        billiard_run_count = billiard.billiard_run_count
    from bbdyn.params import Params
    from bbdyn.scenes.b2_billiard import CASE

    frequencies = json.loads(sys.stdin.readline())
    starts = {}
    for f in frequencies:
        out = billiard_run_count(*CASE["start"], Params(f=f).kernel(), TRANSIENT)
        starts[str(f)] = [float(x) for x in out[:7]]
    print(json.dumps(starts), flush=True)
    for line in sys.stdin:
        rates, final = {}, {}
        for f, s in json.loads(line).items():
            kp = Params(f=float(f)).kernel()
            cpu = time.process_time()
            out = billiard_run_count(*s[:6], int(s[6]), kp, events)
            rates[f] = events / (time.process_time() - cpu) if out[8] == OK else float("nan")
            final[f] = [float(x) for x in out[:7]]
        print(json.dumps({"rates": rates, "final": final}), flush=True)


def compare(trees: list[str], frequencies: list[float], events: int, rounds: int) -> dict:
    """Interleaved timing of ``trees``; the report described in the module docstring."""
    with tempfile.TemporaryDirectory() as folder:
        args = ["--worker", "--events", str(events)]
        procs = [flat_flights.start_worker(tree, os.path.join(folder, f"numba_{i}"), __file__,
                                           args) for i, tree in enumerate(trees)]  # fmt: skip
        starts = None
        for proc in procs:
            proc.stdin.write(json.dumps(frequencies) + "\n")
            proc.stdin.flush()
            own = json.loads(proc.stdout.readline())
            starts = starts or own  # the first tree's
        answers = [[] for _ in trees]
        for r in range(rounds):
            for i in range(len(trees)) if r % 2 == 0 else reversed(range(len(trees))):
                procs[i].stdin.write(json.dumps(starts) + "\n")
                procs[i].stdin.flush()
                answers[i].append(json.loads(procs[i].stdout.readline()))
        for proc in procs:
            proc.stdin.close()
            proc.wait()
    labels = [kernel_buffers.tree_label(tree) for tree in trees]
    results = []
    for f in starts:
        medians = [statistics.median(run["rates"][f] for run in answers[i])
                   for i in range(len(trees))]  # fmt: skip
        final = [r[0]["final"][f] for r in answers]
        results.append({"f": float(f), "start": starts[f],
                        "events_per_cpu_s": [[run["rates"][f] for run in r] for r in answers],
                        "median_events_per_cpu_s": medians,
                        "ratio_to_first": [m / medians[0] for m in medians],
                        "bitwise_as_first": [end == final[0] for end in final]})  # fmt: skip
    return {"trees": labels, "events": events, "rounds": rounds, "results": results}


def table(report: dict) -> str:
    """The report as a markdown table: per frequency, events per CPU-second of each tree and
    the ratio of each to the first."""
    head = " | ".join(f"events / CPU-s, {t}" for t in report["trees"])
    ratios = " | ".join(f"ratio, {t}" for t in report["trees"][1:])
    lines = [f"| f (Hz) | {head} | {ratios} |", "|---:" * (2 * len(report["trees"])) + "|"]
    for row in report["results"]:
        speeds = " | ".join(f"{v:.3g}" for v in row["median_events_per_cpu_s"])
        ratio = " | ".join(f"{v:.3f}" for v in row["ratio_to_first"][1:])
        lines.append(f"| {row['f']:g} | {speeds} | {ratio} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trees", nargs="*", help="source trees; ratios are to the first")
    parser.add_argument("--f", type=float, nargs="+", default=[58.0, 70.0, 85.2, 90.0])
    parser.add_argument("--events", type=int, default=2_000_000, help="events per timed run")
    parser.add_argument("--rounds", type=int, default=3, help="timed rounds per tree (>= 1)")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.events)
        return
    if len(args.trees) < 2 or args.rounds < 1 or args.events < 1:
        parser.error("give at least two source trees, --rounds >= 1 and --events >= 1")
    report = compare(args.trees, args.f, args.events, args.rounds)
    print(json.dumps(report, indent=1) if args.json else table(report))


if __name__ == "__main__":
    main()
