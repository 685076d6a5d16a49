"""What depends on where the chattering sum takes over: the classifier's creep label, and time.

The event kernel computes the first bounces of a chattering sequence one by one and sums
the rest in closed form (``chatter_sum`` in ``bbdyn/core/billiard.py``) once the sum's
neglected terms are below ``CHATTER_REL_TOL`` of a period.  Each bounce computed is an
impact; the classifier calls an attractor *creeping* (regime c) when at least ``creep_min``
= 0.5 of its collisions are tiny hops, and leaves out of its collisions the impacts after
flights shorter than ``hop_floor`` periods (``bbdyn classify --hop-floor``; 0 counts every
impact).  This benchmark varies where the sum takes over:

* the tree as it is (``--tree``) and other source trees (``--other``), e.g. a worktree of
  another kernel;
* copies of each with ``CHATTER_REL_TOL`` multiplied by every ``--scale`` (the same sum,
  accepted with a looser or tighter budget);

and classifies each with every ``--hop-floor``.  For every tree, floor and frequency
``bbdyn classify --f F --n N --t T --seed 0 --threads 1 --hop-floor H`` (its own numba cache)
gives the regime and each attractor's tiny-hop fraction, collision rate and D.  With
``--simulate F``, ``bbdyn simulate --f F --n 1000 --t 200`` on every tree gives D, E and E_x:
how far they move with the take-over, and whether two kernels converge to the same values as
the budget is tightened.  With ``--time`` the scan's runs on the ``--other`` trees are also
timed against the tree (the workers of ``kernel_buffers.py``, medians of ``--repeats``), and
the ratios applied to a measured full scan as in ``chatter_oracle.py``.

Usage::

    python benchmarks/chatter_takeover.py [--tree .] [--scale 0.25 4 64] [--other TREE ...]
        [--hop-floor 1e-4 0] [--f 70 71.4 74.8 78.4 81.6] [--n 20] [--t 20] [--simulate F ...]
        [--time] [--repeats 3] [--json OUT]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import chatter_oracle  # noqa: E402  (the patched copies, the timed runs, the scan prediction)
import kernel_buffers  # noqa: E402  (tree_label)

#: The line of ``bbdyn/core/tolerances.py`` that sets the sum's budget.
ANCHOR = "CHATTER_REL_TOL = 64.0 * EPS\n"
F_CLASSIFY = [70.0, 71.4, 74.8, 78.4, 81.6]


def scaled_source(source: str, scale: float) -> str:
    """``tolerances.py``'s source with ``CHATTER_REL_TOL`` multiplied by ``scale``."""
    if source.count(ANCHOR) != 1:
        raise RuntimeError("tolerances.py changed: the CHATTER_REL_TOL line is not found once")
    return source.replace(ANCHOR, f"CHATTER_REL_TOL = {64.0 * scale!r} * EPS\n")


def scaled_tree(tree: str, scale: float, folder: str) -> str:
    """A copy of ``tree``'s package in ``folder`` with the scaled budget; returns its path."""
    return chatter_oracle.copy_with_patch(tree, os.path.join(folder, f"scale{scale:g}"),
                                          "core/tolerances.py",
                                          lambda source: scaled_source(source, scale))  # fmt: skip


def tree_env(tree: str, cache: str) -> dict:
    """Environment of a run on ``tree`` with the numba cache ``cache``; checks that bbdyn is
    imported from ``tree`` when run with ``cache`` as the working directory."""
    env = dict(os.environ, PYTHONPATH=os.path.abspath(tree), NUMBA_CACHE_DIR=cache)
    cmd = [sys.executable, "-c", "import bbdyn; print(bbdyn.__file__)"]
    loaded = subprocess.run(cmd, env=env, cwd=cache, capture_output=True, text=True, check=True)
    if not loaded.stdout.strip().startswith(os.path.abspath(tree)):
        raise RuntimeError(f"a run on {tree} imported bbdyn from {loaded.stdout.strip()}")
    return env


def classify(env: dict, f: float, n: int, t: float, hop_floor: float) -> dict:
    """``bbdyn classify`` at ``f`` with ``hop_floor`` (periods) in the environment ``env`` of
    ``tree_env`` (working directory its numba cache): regime and, per attractor, its share of
    the particles, character, tiny-hop fraction, collision rate and D."""
    cache = env["NUMBA_CACHE_DIR"]
    cmd = [sys.executable, "-m", "bbdyn", "classify", "--f", str(f), "--n", str(n),
           "--t", str(t), "--seed", "0", "--threads", "1", "--hop-floor", repr(hop_floor),
           "--json"]  # fmt: skip
    # run outside any source tree: ``python -m`` puts the working directory first on the path
    out = subprocess.run(cmd, env=env, cwd=cache, capture_output=True, text=True, check=True)
    res = json.loads(out.stdout)
    keys = ("fraction", "character", "tiny_fraction", "collision_rate", "D", "D_se")
    return {"f": f, "regime": res["regime"],
            "attractors": [{k: a[k] for k in keys} for a in res["attractors"]]}  # fmt: skip


def time_trees(trees: list[str], args, folder: str) -> list[dict]:
    """Median CPU s of the scan's runs (16 particles, 200 s, ``chatter_oracle.F_DEFAULT``) per
    frequency on each tree, interleaved (``chatter_oracle.timed_runs``)."""
    runs = argparse.Namespace(n=16, t=200.0, f=chatter_oracle.F_DEFAULT, repeats=args.repeats)
    timing = os.path.join(folder, "timing")  # numba caches apart from the classify runs
    os.makedirs(timing)
    cpu = chatter_oracle.timed_runs(trees, runs, timing)
    return [{"f": f, "cpu_s": [statistics.median(cpu[i, f]) for i in range(len(trees))]}
            for f in chatter_oracle.F_DEFAULT]  # fmt: skip


def simulate(env: dict, f: float, n: int, t: float) -> dict:
    """``bbdyn simulate`` at ``f`` in the environment ``env`` of ``tree_env``: D (mm^2/s), the
    energies E and E_x (kg mm^2/s^2) with their standard errors, and the collision rate."""
    cmd = [sys.executable, "-m", "bbdyn", "simulate", "--f", str(f), "--n", str(n),
           "--t", str(t), "--seed", "0", "--json"]  # fmt: skip
    out = subprocess.run(cmd, env=env, cwd=env["NUMBA_CACHE_DIR"], capture_output=True,
                         text=True, check=True)  # fmt: skip
    from bbdyn.schema import standardise

    res = standardise(json.loads(out.stdout))  # older trees print older keys
    keys = ("D", "D_se", "E", "E_se", "E_x", "E_x_se")
    return {"f": f, **{k: res[k] for k in keys},
            "collisions_per_particle_per_s": res["collision_rate"]}  # fmt: skip


def variant_trees(args, folder: str) -> tuple[list[str], list[str]]:
    """The tree and each ``--other`` tree, each followed by its copies with the budget scaled
    by every ``--scale``: ``(paths, names)``."""
    paths, names = [], []
    bases = [(args.tree, "as is")] + [(o, kernel_buffers.tree_label(o)) for o in args.other]
    for j, (base, name) in enumerate(bases):
        paths.append(base)
        names.append(name)
        for s in args.scale:
            paths.append(scaled_tree(base, s, os.path.join(folder, f"base{j}")))
            scaled = f"CHATTER_REL_TOL x {s:g}"
            names.append(scaled if j == 0 else f"{name}, {scaled}")
    return paths, names


def measure(args) -> dict:
    """Classification of every variant tree with every hop floor, ``bbdyn simulate`` on each
    at the ``--simulate`` frequencies and, with ``--time``, timing of the ``--other`` trees
    against the tree."""
    with tempfile.TemporaryDirectory() as folder:
        trees, names = variant_trees(args, folder)
        envs = []
        for i, tree in enumerate(trees):
            os.makedirs(os.path.join(folder, f"cache{i}"))
            envs.append(tree_env(tree, os.path.join(folder, f"cache{i}")))
        floors = args.hop_floor
        jobs = [(i, h, f) for h in floors for i in range(len(trees)) for f in args.f]
        sims = [(i, f) for i in range(len(trees)) for f in args.simulate]
        with ThreadPoolExecutor(max_workers=args.workers) as pool:
            runs = list(pool.map(lambda job: classify(envs[job[0]], job[2], args.n, args.t,
                                                      job[1]), jobs))  # fmt: skip
            simulated = list(pool.map(lambda job: simulate(envs[job[0]], job[1], 1000, 200.0),
                                      sims))  # fmt: skip
        timing = time_trees([args.tree, *args.other], args, folder) if args.time else []
    variants = [{"label": f"{name}, hop_floor {h:g}", "tree": name, "hop_floor": h,
                 "runs": [r for (k, hk, _), r in zip(jobs, runs, strict=True)
                          if k == i and hk == h]}
                for h in floors for i, name in enumerate(names)]  # fmt: skip
    return {"tree": kernel_buffers.tree_label(args.tree), "n": args.n, "t": args.t,
            "seed": 0, "hop_floors": floors, "variants": variants, "timing": timing,
            "simulate": [{"tree": names[i], **r}
                         for (i, _), r in zip(sims, simulated, strict=True)],
            "timed": [kernel_buffers.tree_label(o) for o in args.other if args.time]}  # fmt: skip


def main_tiny_fraction(run: dict) -> float:
    """Tiny-hop fraction of the attractor holding most particles."""
    return max(run["attractors"], key=lambda a: a["fraction"])["tiny_fraction"]


def doc_table(report: dict) -> str:
    """Per frequency and variant: regime and the main attractor's tiny-hop fraction."""
    freqs = [r["f"] for r in report["variants"][0]["runs"]]
    head = "| variant | " + " | ".join(f"{f:g} Hz" for f in freqs) + " |"
    lines = [head, "|---|" + "---:|" * len(freqs)]
    for v in report["variants"]:
        cells = " | ".join(f"{r['regime']} ({main_tiny_fraction(r):.3f})" for r in v["runs"])
        lines.append(f"| {v['label']} | {cells} |")
    return "\n".join(lines)


def simulate_table(report: dict) -> str:
    """Per ``--simulate`` run: the variant, E_x and E (kg mm^2/s^2, to 10 and 13 significant
    digits, with their standard errors over particles) and the collision rate."""
    lines = ["| variant | f (Hz) | E_x | E | collisions per particle per s |",
             "|---|---:|---:|---:|---:|"]  # fmt: skip
    for r in report["simulate"]:
        lines.append(f"| {r['tree']} | {r['f']:g} | {r['E_x']:.10g} ± {r['E_x_se']:.1g} "
                     f"| {r['E']:.13g} ± {r['E_se']:.1g} "
                     f"| {r['collisions_per_particle_per_s']:.1f} |")  # fmt: skip
    return "\n".join(lines)


def budget_series(report: dict, kernel: str, f: float) -> dict:
    """E_x of ``kernel``'s ``--simulate`` runs at ``f`` with the budget tightened: ``{scale:
    E_x}`` for the kernel as is (scale 1) and its copies scaled below 1, the ratios of
    successive differences (one per two factors of the budget), and the value the last
    difference's ratio extrapolates to (geometric series)."""
    runs = {r["tree"]: r["E_x"] for r in report["simulate"] if r["f"] == f}
    prefix = "" if kernel == "as is" else f"{kernel}, "
    ex = {1.0: runs[kernel]}
    for name, value in runs.items():
        if name.startswith(prefix + "CHATTER_REL_TOL x "):
            scale = float(name.rsplit(" ", 1)[1])
            if scale < 1.0:
                ex[scale] = value
    scales = sorted(ex, reverse=True)
    diffs = [ex[a] - ex[b] for a, b in zip(scales, scales[1:], strict=False)]
    ratios = [b / a for a, b in zip(diffs, diffs[1:], strict=False)]
    r = ratios[-1]
    limit = ex[scales[-1]] - diffs[-1] * r / (1.0 - r)
    return {"E_x": ex, "ratios": ratios, "limit": limit}


def predicted_scan(report: dict, points: list[dict]) -> list[list[float]]:
    """Per timed tree: the scan's CPU s per band and all, from the measured ratios."""
    rows = [{"f": r["f"], "ratio": [r["cpu_s"][0] / c for c in r["cpu_s"][1:]]}
            for r in report["timing"]]  # fmt: skip
    return chatter_oracle.predict({"v": report["timed"], "rows": rows}, points)


def scan_table(report: dict, points: list[dict]) -> str:
    """Measured CPU s of the scan per band, and predicted on each timed tree."""
    return chatter_oracle.band_table(points, predicted_scan(report, points), report["timed"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    chatter_oracle.add_common_arguments(parser)
    parser.add_argument("--scale", type=float, nargs="*", default=[0.25, 4.0, 64.0],
                        help="factors of CHATTER_REL_TOL")  # fmt: skip
    parser.add_argument("--other", nargs="*", default=[], help="other source trees")
    parser.add_argument("--f", type=float, nargs="+", default=F_CLASSIFY, help="Hz")
    parser.add_argument("--n", type=int, default=20, help="particles")
    parser.add_argument("--t", type=float, default=20.0, help="simulated time (s)")
    parser.add_argument("--hop-floor", type=float, nargs="+", default=[1e-4, 0.0],
                        help="classify with each of these hop floors (periods)")  # fmt: skip
    parser.add_argument("--simulate", type=float, nargs="*", default=[],
                        help="also run bbdyn simulate (n 1000, t 200 s) on every variant at these "
                        "frequencies (Hz)")  # fmt: skip
    parser.add_argument("--time", action="store_true",
                        help="time the scan's runs on the --other trees against the tree")
    parser.add_argument("--workers", type=int, default=2, help="classify runs at once")
    args = parser.parse_args()
    report = measure(args)
    print(doc_table(report))
    if report["simulate"]:
        print(simulate_table(report))
    if report["timing"]:
        points = chatter_oracle.add_prediction(report, args.scan, predicted_scan)
        print(scan_table(report, points))
    chatter_oracle.save_report(report, args.json)


if __name__ == "__main__":
    main()
