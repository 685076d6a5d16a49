"""The measured tables of docs/lyapunov.md, computed into ``docs/data/lyapunov.json``.

Run from the repository root (about two minutes on one core; ``--short`` leaves out the
longer billiard runs, about a minute of it):

    python docs/data/lyapunov_tables.py

Each table is ``{"columns": [...], "rows": [[cell, ...], ...]}`` with the cells as the page
shows them (``value ± se``; a spread at rounding level, identical particles, is written 0),
drawn by the ``data-table`` directive of ``docs/_ext/datavalue.py``:

* ``flat``: ``bbdyn lyapunov --flat --f F`` (n = 20, t = 20 s, transient 2 s, seed 0);
* ``flat_orbits``: the flat ball's 1/1 and 2/2 orbits, the Newton solver's multipliers
  against the exponents per impact of a 30-s tangent run from the orbit;
* ``billiard``: ``bbdyn lyapunov --f F`` per attractor (n = 20, t = 20 s, transient 2 s);
* ``billiard_long``: the same with n = 100, t = 50 s, transient 5 s;
* ``billiard_orbits``: the top orbits' closed-form exponent against a tangent run of 4000
  collisions started on the orbit.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

import bbdyn
from bbdyn.core.flat import FlatArrays, FlatState, flat_run
from bbdyn.core.status import IMPACT
from bbdyn.flat.tongues import (
    find_periodic_orbit,
    k1_orbit,
    k1_orbit_numeric,
    params_at_gamma,
    tongue_gamma_hi,
)
from bbdyn.lyapunov import (
    billiard_lyapunov,
    billiard_lyapunov_from,
    flat_lyapunov,
    flat_lyapunov_from,
    top_orbit_exponent,
)
from bbdyn.params import Params

OUT = Path(__file__).resolve().parent / "lyapunov.json"
COMMAND = "python docs/data/lyapunov_tables.py"
#: the frequencies of the measured tables (Hz) and the flat orbits' alpha
FREQUENCIES = (58.0, 70.0, 85.2, 88.4)
ALPHA = 0.5
BILLIARD_COLUMNS = ["f (Hz)", "regime", "attractor", "fraction", "lambda_1 (1/s)",
                    "lambda_1 / collision", "collisions / s", "windows (1/s)"]  # fmt: skip


def value_se(value: float, se: float) -> str:
    """``value ± se``; a spread at rounding level (identical particles) is written 0."""
    if value == -math.inf:
        return "-inf"
    return f"{value:.4g} ± {se if se > 1e-9 * abs(value) else 0:.2g}"


def flat_table() -> dict:
    """The flat ball's exponents at ``FREQUENCIES``."""
    rows = []
    for f in FREQUENCIES:
        s = flat_lyapunov(Params(f=f), 20, t=20.0, transient=2.0, seed=0).summary()
        rows.append([f"{f:g}", value_se(s["lam1_per_s"], s["lam1_per_s_se"]),
                     value_se(s["lam1_per_impact"], s["lam1_per_impact_se"]),
                     value_se(s["cond_lam1_per_s"], s["cond_lam1_per_s_se"]),
                     value_se(s["cond_lam1_per_impact"], s["cond_lam1_per_impact_se"]),
                     f"{s['stuck_fraction']:.2f}", f"{s['impacts_per_s']:.1f}"])  # fmt: skip
    columns = ["f (Hz)", "lambda_1 (1/s)", "lambda_1 / impact", "cond. lambda_1 (1/s)",
               "cond. lambda_1 / impact", "stuck", "impacts / s"]  # fmt: skip
    return {"columns": columns, "rows": rows}


def flat_orbit_table() -> dict:
    """The 1/1 orbit at 0.98 Gamma_hi and the 2/2 orbit at 1.004 Gamma_hi (alpha 0.5)."""
    gamma = tongue_gamma_hi(1, ALPHA) * 0.98
    p = params_at_gamma(gamma, alpha=ALPHA)
    orbits = [("1/1", p, k1_orbit_numeric(1, gamma, ALPHA), 1)]
    gamma = tongue_gamma_hi(1, ALPHA) * 1.004
    p2 = params_at_gamma(gamma, alpha=ALPHA)
    one = k1_orbit_numeric(1, gamma, ALPHA)
    out = (np.empty(3000), np.empty(3000), np.empty(3000), np.empty(3000, np.int64))
    start = FlatState(0.0, one["phase"][0] + 1e-4, one["vrel"][0], IMPACT)
    flat_run(start, p2.kernel(), 3000, FlatArrays(*out))
    orbits.append(("2/2", p2, find_periodic_orbit(p2, 2, 2, out[1][-1], out[2][-1]), 2))
    rows = []
    for name, pp, orbit, m in orbits:
        res = flat_lyapunov_from(pp, [orbit["phase"][0]], [orbit["vrel"][0]], t=30.0)
        mu = np.sort(np.log(np.abs(orbit.eigenvalues)))[::-1] / m
        lam = res.exponents("impact")[0]
        rows.append([name, f"{pp.f:.4f}", f"{mu[0]:.5f}, {mu[1]:.5f}",
                     f"{lam[0]:.5f}, {lam[1]:.5f}", f"{int(res['impacts'].sum())}"])  # fmt: skip
    columns = ["orbit", "f (Hz)", "log|mu| / m", "exponents / impact", "impacts"]
    return {"columns": columns, "rows": rows}


def billiard_groups(n: int = 20, t: float = 20.0, transient: float = 2.0) -> list:
    """``(f, regime, name, fraction, summary)`` of the whole ensemble and of each attractor,
    as ``bbdyn lyapunov --f F --n n --t t --transient transient`` (seed 0, classified)."""
    out = []
    for f in FREQUENCIES:
        res = billiard_lyapunov(Params(f=f), n, t=t, transient=transient, seed=0,
                                classify_attractors=True)  # fmt: skip
        cls = res.meta["classification"]
        out.append((f, cls["regime"], "all", 1.0, res.summary()))
        for a in res.by_attractor():
            name = f"{a['attractor']}: {cls['attractors'][a['attractor']]['character']}"
            out.append((f, cls["regime"], name, a["fraction"], a))
    return out


def billiard_table(groups: list) -> dict:
    """The billiard's exponents of ``billiard_groups``, one row per group."""
    rows = [[f"{f:g}", regime, name, f"{fraction:.2f}",
             value_se(g["lam1_per_s"], g["lam1_per_s_se"]),
             value_se(g["lam1_per_collision"], g["lam1_per_collision_se"]),
             f"{g['collisions_per_s']:.1f}",
             ", ".join(f"{x:.3g}" for x in g["window_cond_lam1_per_s"])]
            for f, regime, name, fraction, g in groups]  # fmt: skip
    return {"columns": BILLIARD_COLUMNS, "rows": rows}


def billiard_orbit_table() -> dict:
    """The k/1 top orbits at 58, 75 and 88.4 Hz: closed form against a tangent run."""
    rows, excess = [], []
    for f, k in ((58.0, 1), (75.0, 2), (88.4, 3)):
        p = Params(f=f)
        o = k1_orbit(p, k)
        n = 4000
        state = (0.0, o.phase_stable, 0.0, 0.0, 0.0, o.vrel, IMPACT)
        res = billiard_lyapunov_from(p, [state], t=(n * k + 0.5) / f, windows=1)
        log, collisions = res["log_growth"][0], res["collisions"][0]
        duration = res["duration"][0, 0]
        lam = top_orbit_exponent(p, k)
        excess.append(log[0] / collisions[0] - lam * k / f)
        rows.append([f"{k}/1", f"{f:g}", f"{math.exp(lam * k / f):.6f}", f"{lam * k / f:.5f}",
                     f"{log[0] / collisions[0]:.5f}", f"{lam:.4f}", f"{log[0] / duration:.4f}",
                     f"{int(collisions[0])}"])  # fmt: skip
    columns = ["orbit", "f (Hz)", "mu", "log mu", "per collision (run)", "1/s (closed form)",
               "1/s (run)", "collisions"]  # fmt: skip
    # the run's largest excess over the closed form, per collision
    return {"columns": columns, "rows": rows, "excess_per_collision": max(excess)}


def tables(long: bool = True) -> dict:
    """Every table of the page (``billiard_long`` only with ``long``)."""
    out = {"command": COMMAND, "bbdyn_version": bbdyn.__version__,
           "flat": flat_table(), "flat_orbits": flat_orbit_table(),
           "billiard": billiard_table(billiard_groups()),
           "billiard_orbits": billiard_orbit_table()}  # fmt: skip
    if long:
        out["billiard_long"] = billiard_table(billiard_groups(100, 50.0, 5.0))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short", action="store_true", help="without the longer billiard runs")
    args = parser.parse_args()
    data = tables(long=not args.short)
    if args.short and OUT.is_file():
        data["billiard_long"] = json.loads(OUT.read_text())["billiard_long"]
    OUT.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    print(f"saved {OUT.relative_to(Path.cwd()) if OUT.is_relative_to(Path.cwd()) else OUT}")


if __name__ == "__main__":
    main()
