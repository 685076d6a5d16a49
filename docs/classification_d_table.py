"""Per-attractor D of ``bbdyn classify`` next to ``bbdyn simulate`` on the same ensemble.

Writes the table of docs/classification.md ("Per-attractor D, measured") between its
markers; run from the repository root:

    python docs/classification_d_table.py            # print the table
    python docs/classification_d_table.py --write    # and put it into docs/classification.md

For each setting (f, n, t, seed) it runs ``classify`` and ``ensemble`` (what ``bbdyn
simulate`` runs: same seed, same particles, default sample times) and, per attractor,
gives the classifier's D (Einstein), the Einstein D computed here directly from the
``ensemble`` displacements of the attractor's own particles, and the block estimate the
classifier reported before (mean over the attractor's particles and the blocks of
``dx^2 / (2 L T)``, displacements over the 16 blocks of the window), from a second
``ensemble`` run sampled at the block boundaries.  One numba thread.

The statements of docs/classification.md about the table are asserted here: the
classifier's D is the Einstein D of its particles (and simulate's D when the attractor
holds every particle), to within what the converged fast-forward allows: the classifier's
run and the ensemble's stop at different times (block edges, sample times), so they skip
converged stick-release cycles at different points, and positions may differ by up to
``FF_DRIFT_TOL`` per skipped cycle (``d_bound``; equal bit for bit when nothing is
skipped), and for every diffusive attractor (D > 3 standard
errors) the block estimate is never above D by more than two combined standard errors (how
often it is below is stated under the table, from the numbers).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from bbdyn import Params
from bbdyn.classify import classify_features, trajectory_features
from bbdyn.core.tolerances import FF_DRIFT_TOL
from bbdyn.diffusion import einstein_D
from bbdyn.ensemble import ensemble

#: (f in Hz, n, t in s, seed): 58, 62 and 85.2 Hz at n = 1000, t = 50 s, and the 85.2 Hz
#: settings of the original report (n = 200, t = 20 s, seeds 0, 1, 2).
SETTINGS = [(58.0, 1000, 50.0, 0), (62.0, 1000, 50.0, 0), (85.2, 1000, 50.0, 0)] + [
    (85.2, 200, 20.0, s) for s in (0, 1, 2)
]
DOC = Path(__file__).resolve().parent / "classification.md"
START, END = "<!-- D table: start -->", "<!-- D table: end -->"


def block_estimate(params, c, members, n, t, seed):
    """The previous per-attractor D: block ``dx^2 / (2 L T)`` averaged, and its error."""
    s = c.summary
    p0 = math.ceil(s["transient"] * params.f)
    L = math.floor((math.floor(t * params.f) - p0) / 16)
    bounds = (p0 + L * np.arange(17)) / params.f
    run = ensemble(params, n=n, t=t, seed=seed, sample_times=bounds, threads=1,
                   observables=("displacement",))  # fmt: skip
    per = (np.diff(run["displacement"][members], axis=1) ** 2 / (2 * L / params.f)).mean(axis=1)
    return per.mean(), per.std(ddof=1) / math.sqrt(per.size)


def d_bound(x_max, dx, t):
    """Bound (mm^2/s) of the change of the Einstein D over the window [t/2, t] when positions
    up to ``x_max`` (mm) move by at most ``dx`` (mm): x^2 moves by at most ``E = 2 x_max dx +
    dx^2``, a least-squares slope over a window of width t/2 by at most ``3 E / (t/2)``, D by
    half that.  Zero when the two runs agree bit for bit."""
    return 3.0 * (2.0 * x_max * dx + dx * dx) / t


def rows():
    """One table row per attractor and setting, as strings, and the shortfalls ``(D - block
    estimate) / combined standard error`` of the diffusive attractors (D > 3 standard errors)."""
    out, shortfalls = [], []
    for f, n, t, seed in SETTINGS:
        params = Params(f=f)
        start = time.perf_counter()
        feat = trajectory_features(params, n=n, t=t, seed=seed, threads=1)
        c = classify_features(feat)
        sim = ensemble(params, n=n, t=t, seed=seed, threads=1)
        D_sim, se_sim = sim.D()
        dx = np.abs(feat["displacement"] - sim["displacement"]).max()
        assert dx <= FF_DRIFT_TOL * f * t, f"displacements differ by {dx} mm at {f} Hz"
        for a, att in enumerate(c.summary["attractors"]):
            mem = np.flatnonzero(c["labels"] == a)
            D_own, se_own = einstein_D(sim["sample_times"], sim["displacement"][mem])
            bound = d_bound(np.abs(sim["displacement"][mem]).max(), dx, t)
            assert abs(D_own - att["D"]) <= bound, "classify D is not Einstein's"
            if mem.size == n:
                assert abs(D_sim - att["D"]) <= bound, "not simulate's D"
            D_blk, se_blk = block_estimate(params, c, mem, n, t, seed)
            z = (att["D"] - D_blk) / math.hypot(att["D_se"], se_blk)
            if att["D"] > 3 * att["D_se"]:  # diffusive
                shortfalls.append(z)
            out.append([
                f"{f:g}", f"{n}", f"{t:g}", f"{seed}", f"{a}", f"{att['fraction']:.3f}",
                f"{att['character']} (k = {att['locking_k']})" if att["locking_k"] else
                att["character"],
                f"{att['D']:.3g} ± {att['D_se']:.2g}", f"{D_own:.3g} ± {se_own:.2g}",
                f"{D_blk:.3g} ± {se_blk:.2g}", f"{z:+.1f}",
                f"{D_sim:.3g} ± {se_sim:.2g}" if a == 0 else "",
            ])  # fmt: skip
        print(f"f = {f} Hz, n = {n}, t = {t} s, seed {seed}: {time.perf_counter() - start:.0f} s")
    return out, shortfalls


def shortfall_sentence(shortfalls) -> str:
    """What the table shows of the block estimate in the diffusive attractors; asserts that it
    is never above D by more than two combined standard errors."""
    assert min(shortfalls) > -2.0, "the block estimate is above D"
    below = sum(z > 0 for z in shortfalls)
    far = sum(z > 2 for z in shortfalls)
    return (f"In {below} of the {len(shortfalls)} diffusive attractors (D > 3 standard errors) "
            f"the block estimate is below D, in {far} by more than two combined standard "
            "errors; in none is it above D by more than two.")


def table(rs) -> str:
    head = ["f (Hz)", "n", "t (s)", "seed", "attractor", "fraction", "character",
            "classify D (mm^2/s)", "Einstein D of its particles", "block estimate (before)",
            "(D - block) / combined se", "simulate D (all particles)"]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rs])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write into docs/classification.md")
    args = parser.parse_args()
    rs, shortfalls = rows()
    text = table(rs) + "\n\n" + shortfall_sentence(shortfalls)
    print(text)
    if args.write:
        doc = DOC.read_text(encoding="utf-8")
        i, j = doc.index(START) + len(START), doc.index(END)
        DOC.write_text(doc[:i] + "\n" + text + "\n" + doc[j:], encoding="utf-8")


if __name__ == "__main__":
    main()
