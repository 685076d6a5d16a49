"""Per-attractor D of ``bbdyn classify`` next to ``bbdyn simulate`` on the same ensemble.

Writes the numbers of docs/classification.md ("Per-attractor D, measured") into
``docs/data/classification_d_table.json`` and the page's table, whose cells are ``{data}``
references to that file, between the page's markers; run from the repository root:

    python docs/classification_d_table.py            # compute, print the table
    python docs/classification_d_table.py --write    # and write the JSON and the page's table

For each setting (f, n, t, seed) it runs ``classify`` and ``ensemble`` (what ``bbdyn
simulate`` runs: same seed, same particles, default sample times) and, per attractor,
gives the classifier's D (Einstein), the Einstein D computed here directly from the
``ensemble`` displacements of the attractor's own particles, and the block estimate
(mean over the attractor's particles and the 16 blocks of the window of
``dx^2 / (2 L T)``), from a second ``ensemble`` run sampled at the block boundaries.
One numba thread.

The statements of docs/classification.md about the table are asserted here: the
classifier's D is the Einstein D of its particles (and simulate's D when the attractor
holds every particle), to within what the converged fast-forward allows: the classifier's
run and the ensemble's stop at different times (block edges, sample times), so they skip
converged stick-release cycles at different points, and positions may differ by up to
``FF_DRIFT_TOL`` per skipped cycle (``d_bound``; equal bit for bit when nothing is
skipped), and for every diffusive attractor (D > 3 standard errors) the block estimate is
never above D by more than two combined standard errors (how often it is below is counted
in the JSON's ``shortfall``).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from bbdyn import Params, __version__
from bbdyn.classify import classify_features, trajectory_features
from bbdyn.core.tolerances import FF_DRIFT_TOL
from bbdyn.diffusion import einstein_D
from bbdyn.ensemble import ensemble

#: (f in Hz, n, t in s, seed): 58, 62 and 85.2 Hz at n = 1000, t = 50 s, and 85.2 Hz at
#: n = 200, t = 20 s with three seeds (how D and its error scatter between ensembles).
SETTINGS = [(58.0, 1000, 50.0, 0), (62.0, 1000, 50.0, 0), (85.2, 1000, 50.0, 0)] + [
    (85.2, 200, 20.0, s) for s in (0, 1, 2)
]
DOC = Path(__file__).resolve().parent / "classification.md"
DATA = DOC.parent / "data" / "classification_d_table.json"
START, END = "<!-- D table: start -->", "<!-- D table: end -->"


def block_estimate(params, c, members, n, t, seed):
    """The block estimate of an attractor's D: block ``dx^2 / (2 L T)`` averaged, and its error."""
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


def _pair(value, se) -> dict:
    return {"value": float(value), "se": float(se)}


def rows() -> list[dict]:
    """One record per attractor and setting: the setting, the attractor's fraction,
    character, collisions and jumps per driving period, the classifier's D, the Einstein D
    of its particles, the block estimate and ``block_z = (D - block) / combined se``,
    and for attractor 0 simulate's D over all particles (mm^2/s, ``{value, se}``)."""
    out = []
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
            character = att["character"]
            if att["locking_k"]:
                character += f" (k = {att['locking_k']})"
            out.append({
                "f": f, "n": n, "t": t, "seed": seed, "attractor": a,
                "fraction": float(att["fraction"]), "character": character,
                "collisions_per_period": float(att["collision_rate"]) / f,
                "jumps_per_period": float(att["jump_rate"]) / f,
                "D": _pair(att["D"], att["D_se"]), "D_own": _pair(D_own, se_own),
                "D_block": _pair(D_blk, se_blk),
                "block_z": float((att["D"] - D_blk) / math.hypot(att["D_se"], se_blk)),
                "diffusive": bool(att["D"] > 3 * att["D_se"]),
                "D_simulate": _pair(D_sim, se_sim) if a == 0 else None,
            })  # fmt: skip
        print(f"f = {f} Hz, n = {n}, t = {t} s, seed {seed}: {time.perf_counter() - start:.0f} s")
    return out


def shortfall(records: list[dict]) -> dict:
    """How the block estimate stands against D in the diffusive attractors (D > 3 standard
    errors); asserts that it is never above D by more than two combined standard errors."""
    z = [r["block_z"] for r in records if r["diffusive"]]
    assert min(z) > -2.0, "the block estimate is above D"
    return {"diffusive": len(z), "below": sum(v > 0 for v in z), "far_below": sum(v > 2 for v in z)}


def table(records: list[dict]) -> str:
    """The page's table: every cell a ``{data}`` reference into ``DATA``."""
    head = [
        "f (Hz)",
        "n",
        "t (s)",
        "seed",
        "attractor",
        "fraction",
        "character",
        "collisions per period",
        "classify D (mm^2/s)",
        "Einstein D of its particles",
        "block estimate",
        "(D - block) / combined se",
        "simulate D (all particles)",
    ]
    cells = [("f", "g"), ("n", ""), ("t", "g"), ("seed", ""), ("attractor", ""),
             ("fraction", ".3f"), ("character", ""), ("collisions_per_period", ".1f"),
             ("D", ".3g"), ("D_own", ".3g"), ("D_block", ".3g"), ("block_z", "+.1f")]  # fmt: skip
    ref = DATA.relative_to(DOC.parent).as_posix()

    def cell(i, key, fmt):  # the "|" before FMT escaped: it would end the table cell
        return f"{{data}}`{ref}:rows/{i}/{key}" + (f"\\|{fmt}`" if fmt else "`")

    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for i, r in enumerate(records):
        row = [cell(i, k, fmt) for k, fmt in cells]
        row.append(cell(i, "D_simulate", ".3g") if r["D_simulate"] else "")
        lines.append("| " + " | ".join(row) + " |")
    count = f"{{data}}`{ref}:shortfall"
    lines += [
        "",
        f"In {count}/below` of the {count}/diffusive` diffusive attractors (D > 3 standard "
        f"errors) the block estimate is below D, in {count}/far_below` by more than two "
        "combined standard errors; in none is it above D by more than two.",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--write",
        action="store_true",
        help="write docs/data/classification_d_table.json and the page's table",
    )
    args = parser.parse_args()
    records = rows()
    data = {
        "command": "python docs/classification_d_table.py --write",
        "bbdyn_version": __version__,
        "settings": [dict(zip(("f", "n", "t", "seed"), s, strict=True)) for s in SETTINGS],
        "rows": records,
        "shortfall": shortfall(records),
    }
    print(json.dumps(data, indent=1))
    if args.write:
        DATA.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
        doc = DOC.read_text(encoding="utf-8")
        i, j = doc.index(START) + len(START), doc.index(END)
        DOC.write_text(doc[:i] + "\n" + table(records) + "\n" + doc[j:], encoding="utf-8")


if __name__ == "__main__":
    main()
