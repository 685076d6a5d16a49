"""The full scan's points in two source trees, interleaved: CPU time per point and per band.

Runs what one point of ``bbdyn scan`` runs (``bbdyn.scans.frequency.diffusion_point`` with
the scan's seed for that frequency and its defaults: 201 sample times, fast-forward of
converged cycles), with fewer particles, on every frequency of the full grid.  Each tree
gets a worker process (``PYTHONPATH`` = the tree, its own new numba cache, one numba thread)
that compiles first; the frequencies go to both workers in turn, the order alternating.
Reported: the CPU seconds of each point in each tree, their sums per band of
``bbdyn bench scan-cost`` and their ratio (first / second tree: > 1 means the second is
faster), and how far D, E and E_x of the second tree are from the first's (the points
where all three are equal; elsewhere the largest difference of D in units of its standard
error and of E, E_x relative to their values).  CPU time scales with the particles, so a
band's sum times ``1000 / n`` estimates the full scan's.

Usage::

    python benchmarks/scan_points.py OLD_TREE NEW_TREE [--n 100] [--t 200] [--json OUT]
"""

import argparse
import json
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import flat_flights  # noqa: E402  (start_worker: a worker on a source tree)
import kernel_buffers  # noqa: E402  (tree_label)


def worker(n: int, t: float) -> None:
    """Answer each frequency (Hz) read from stdin with one timed scan point, as a JSON line."""
    import numba

    from bbdyn.scans.frequency import diffusion_point
    from bbdyn.scans.runner import point_seed

    numba.set_num_threads(1)
    diffusion_point(60.0, point_seed(0, 60.0), n=4, t=1.0)  # compile
    print(json.dumps({"ready": True}), flush=True)
    for line in sys.stdin:
        f = float(line)
        cpu = time.process_time()
        out = diffusion_point(f, point_seed(0, f), n=n, t=t)
        cpu = time.process_time() - cpu
        row = {"f": f, "cpu_s": cpu}
        row.update({key: float(out[key]) for key in ("D", "E", "E_x")})
        row["D_err"] = float(out["D_se"] if "D_se" in out else out["D_err"])  # older trees
        print(json.dumps(row), flush=True)


def compare(trees: list[str], freqs: list[float], n: int, t: float) -> dict:
    """Both trees on every frequency, interleaved; the report of the module docstring."""
    from bbdyn.scenes.b2_scan_cost import BANDS, agreement_sentence, band_sums

    with tempfile.TemporaryDirectory() as folder:
        procs = []
        for j, tree in enumerate(trees):
            args = ["--worker", "--n", str(n), "--t", str(t)]
            procs.append(flat_flights.start_worker(tree, os.path.join(folder, f"numba_{j}"),
                                                   __file__, args))  # fmt: skip
            json.loads(procs[-1].stdout.readline())
        points = [[], []]
        for m, f in enumerate(freqs):
            for j in (0, 1) if m % 2 == 0 else (1, 0):
                procs[j].stdin.write(f"{f!r}\n")
                procs[j].stdin.flush()
                points[j].append(json.loads(procs[j].stdout.readline()))
        for proc in procs:
            proc.stdin.close()
            proc.wait()
    for rows in points:  # the names agreement_sentence reads
        for row in rows:
            row["D_se"] = row["D_err"]
    sums = [band_sums(rows, BANDS) for rows in points]
    names = [f"{lo:g}-{hi:g}" for lo, hi in BANDS] + ["all"]
    return {
        "trees": [kernel_buffers.tree_label(tree) for tree in trees],
        "n": n,
        "t": t,
        "bands": [
            {"band": name, "cpu_s": [a, b], "ratio": a / b}
            for name, a, b in zip(names, *sums, strict=True)
        ],  # fmt: skip
        "agreement": agreement_sentence(points[0], points[1]),
        "points": points,
    }


def table(report: dict) -> str:
    """The per-band sums and ratios (markdown) and the agreement sentence."""
    old, new = report["trees"]
    lines = [f"| band (Hz) | CPU s {old} | CPU s {new} | {old} / {new} |", "|---|---:|---:|---:|"]
    for row in report["bands"]:
        a, b = row["cpu_s"]
        lines.append(f"| {row['band']} | {a:.1f} | {b:.1f} | {row['ratio']:.2f} |")
    return "\n".join(lines) + "\n\n" + report["agreement"] + "."


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("trees", nargs="*", help="two source trees: reference, then candidate")
    parser.add_argument("--n", type=int, default=100, help="particles per point")
    parser.add_argument("--t", type=float, default=200.0, help="simulated time (s)")
    parser.add_argument("--json", metavar="OUT", help="also save the report as JSON")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        worker(args.n, args.t)
        return
    if len(args.trees) != 2:
        parser.error("give two source trees")
    from bbdyn.scans.frequency import frequency_grid
    from bbdyn.scenes.b2_scan_cost import F_STEP

    freqs = [float(f) for f in frequency_grid(49.8, 95.0, F_STEP)]
    report = compare(args.trees, freqs, args.n, args.t)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1)
    print(table(report))


if __name__ == "__main__":
    main()
