"""How many events a chattering sum accepted earlier would remove: per frequency, the share
of all events that are bounces of a chattering sequence, ending in a STICK, whose normal
velocity after the bounce is below a threshold.

A STICK reached by the closed-form chattering sum (``core.billiard.chatter_sum``) follows a
run of IMPACTs on the same tile whose normal velocities ``V.n = (vyrel S + vx xi) / R``
shrink by alpha per bounce; the sum is accepted once its neglected terms are below
``CHATTER_REL_TOL`` of a period (a normal velocity of ~1e-5 mm/s).  A sum accepted at ``V.n
< X`` would replace the IMPACTs of that run with ``V.n < X``: this script counts them
(``absorbed``).  Event by event from ``n`` particles of the reference box after a transient
(one thread, seed 1), ``events`` events each.

Usage::

    python benchmarks/chatter_events.py [--f 50.2 55 60 64 70 75 80 85.2 90] [--n 8]
        [--events 200000] [--json OUT.json]
"""

import argparse
import json

import numpy as np


def absorbed(tile, xi, vx, vyrel, kind, R, threshold, stick, impact):
    """Events absorbed by a chattering sum accepted at ``V.n < threshold`` (mm/s): for every
    STICK, the IMPACTs just before it on its tile with ``V.n`` below the threshold."""
    S = np.sqrt((R - xi) * (R + xi))
    vn = (vyrel * S + vx * xi) / R
    count = 0
    for i in np.flatnonzero(kind == stick):
        j = i - 1
        while j >= 0 and kind[j] == impact and vn[j] < threshold and tile[j] == tile[i]:
            j -= 1
        count += i - 1 - j
    return count


def measure(f: float, n: int, n_events: int, thresholds) -> dict:
    """Shares of absorbed events at ``f`` (Hz) for each threshold (mm/s)."""
    from bbdyn import Params
    from bbdyn.core.billiard import EventArrays, EventState, billiard_run
    from bbdyn.core.status import IMPACT, OK, STICK
    from bbdyn.ensemble import ensemble

    params = Params(f=f)
    kp = params.kernel()
    finals = np.asarray(ensemble(params, t=5.0, n=n, seed=1, threads=1)["final"])
    counts = np.zeros(len(thresholds), dtype=np.int64)
    for state in finals:
        out = [np.empty(n_events) for _ in range(6)] + [np.empty(n_events, dtype=np.int64)]
        _, done, status = billiard_run(EventState(*state), kp, n_events, EventArrays(*out))
        if status != OK:
            raise RuntimeError(f"{f} Hz: kernel status {status}")
        rows = [a[:done] for a in out]
        for c, x in enumerate(thresholds):
            counts[c] += absorbed(*rows[2:], kp.R, x, STICK, IMPACT)
    total = n * n_events
    return {"f": f, "events": total, "share": [float(c / total) for c in counts]}


def doc_table(report: dict) -> str:
    """The report as a markdown table: share of events absorbed per threshold."""
    xs = report["thresholds"]
    lines = ["| f (Hz) | " + " | ".join(f"V.n < {x:g} mm/s" for x in xs) + " |",
             "|---:|" + "---:|" * len(xs)]  # fmt: skip
    for row in report["rows"]:
        lines.append(f"| {row['f']:g} | " + " | ".join(f"{s:.0%}" for s in row["share"]) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--f", type=float, nargs="+", default=[50.2, 55, 60, 64, 70, 75, 80, 85.2, 90]
    )
    parser.add_argument("--n", type=int, default=8, help="particles")
    parser.add_argument("--events", type=int, default=200_000, help="events per particle")
    parser.add_argument("--json", help="save the report here")
    args = parser.parse_args()
    thresholds = [1e-4, 1e-3, 1e-2]
    report = {"n": args.n, "events": args.events, "thresholds": thresholds}
    report["rows"] = [measure(f, args.n, args.events, thresholds) for f in args.f]
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1)
    print(doc_table(report))


if __name__ == "__main__":
    main()
