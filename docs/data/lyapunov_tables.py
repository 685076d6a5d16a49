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
  collisions started on the orbit;
* ``billiard_spectrum``, ``billiard_spectrum_free``: the whole spectrum of the ``billiard``
  runs (``--spectrum``), and its growth between sticks; ``..._long`` of ``billiard_long``;
* ``billiard_orbit_spectrum``: the top orbits' four closed-form multipliers against a
  spectrum run of 4000 collisions;
* ``spectrum_cost``: CPU time per event of the event kernel, with one tangent vector and
  with four (measured on the machine that runs the script).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import bbdyn
from bbdyn.core.billiard import billiard_run
from bbdyn.core.flat import FlatArrays, FlatState, flat_run
from bbdyn.core.status import IMPACT
from bbdyn.ensemble import initial_conditions, kernel_states
from bbdyn.flat.tongues import (
    find_periodic_orbit,
    k1_orbit,
    k1_orbit_numeric,
    map_jacobian,
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
#: the tables of the longer runs (left as they are with ``--short``)
LONG_KEYS = ("billiard_long", "billiard_spectrum_long", "billiard_spectrum_free_long",
             "spectrum_convergence")
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
    as ``bbdyn lyapunov --f F --n n --t t --transient transient --spectrum`` (seed 0,
    classified; the largest exponent is bitwise that of the run without ``--spectrum``)."""
    out = []
    for f in FREQUENCIES:
        res = billiard_lyapunov(Params(f=f), n, t=t, transient=transient, seed=0,
                                classify_attractors=True, spectrum=True)  # fmt: skip
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


def spectrum_table(groups: list) -> dict:
    """The whole spectrum of ``billiard_groups`` (1/s; -inf where a particle stuck), with the
    sum of the exponents per impact-to-impact event against the closed-form log |det J|."""
    rows = [[f"{f:g}", name, f"{fraction:.2f}", f"{g['stuck_fraction']:.2f}",
             f"{g['stick_event_fraction']:.2g}",
             *(value_se(v, e) for v, e in zip(g["spectrum_per_s"], g["spectrum_per_s_se"],
                                              strict=True)),
             value_se(g["spectrum_sum_per_event"], g["spectrum_sum_per_event_se"]),
             value_se(g["log_det_per_event"], g["log_det_per_event_se"]),
             f"{g['spectrum_sum_deviation']:.1e}"]
            for f, _, name, fraction, g in groups]  # fmt: skip
    columns = ["f (Hz)", "attractor", "fraction", "stuck", "sticks / collision",
               "lambda_1 (1/s)", "lambda_2 (1/s)", "lambda_3 (1/s)", "lambda_4 (1/s)",
               "sum / event (QR)", "log det J / event (closed form)",
               "largest difference"]  # fmt: skip
    deviation = max(g["spectrum_sum_deviation"] for *_, g in groups)
    return {"columns": columns, "rows": rows, "sum_deviation_max": deviation}


def free_spectrum_table(groups: list) -> dict:
    """The four exponents from the growth between sticks (1/s of the impact-to-impact
    events, and per event), and the impact-to-impact events per stick."""
    rows = []
    for f, _, name, _, g in groups:
        per_stick = g["carried_fraction"] / g["stick_event_fraction"] \
            if g["stick_event_fraction"] > 0 else math.inf
        rows.append([f"{f:g}", name,
                     *(value_se(v, e) for v, e in zip(g["free_spectrum_per_s"],
                                                      g["free_spectrum_per_s_se"], strict=True)),
                     ", ".join(f"{x:.3g}" for x in g["free_spectrum_per_event"]),
                     "no stick" if per_stick == math.inf else f"{per_stick:.3g}"])  # fmt: skip
    columns = ["f (Hz)", "attractor", "lambda_1 (1/s)", "lambda_2 (1/s)", "lambda_3 (1/s)",
               "lambda_4 (1/s)", "per event", "events per stick"]  # fmt: skip
    return {"columns": columns, "rows": rows}


def orbit_spectrum_table() -> dict:
    """The k/1 top orbits: the four closed-form log |mu| (flat block, curvature block)
    against the four exponents per collision of a spectrum run of 4000 collisions."""
    rows, errors = [], []
    for f, k in ((58.0, 1), (88.4, 3)):
        p = Params(f=f)
        o = k1_orbit(p, k)
        n = 4000
        state = (0.0, o.phase_stable, 0.0, 0.0, 0.0, o.vrel, IMPACT)
        res = billiard_lyapunov_from(p, [state], t=(n * k + 0.5) / f, windows=1, spectrum=True)
        lam = res.spectrum("collision")[0]
        mu = top_orbit_log_multipliers(p, k, math.sin(o.phase_stable))
        errors.append(float(np.max(np.abs(lam - mu))))
        rows.append([f"{k}/1", f"{f:g}", ", ".join(f"{x:.5f}" for x in mu),
                     ", ".join(f"{x:.5f}" for x in lam),
                     f"{int(res['collisions'].sum())}"])  # fmt: skip
    columns = ["orbit", "f (Hz)", "log of abs(mu) (closed form)", "exponents / collision (run)",
               "collisions"]  # fmt: skip
    return {"columns": columns, "rows": rows, "error_max": max(errors)}


def top_orbit_log_multipliers(p: Params, k: int, sin_star: float) -> np.ndarray:
    """log |mu| of the four multipliers of the k/1 top orbit, largest first: the flat k/1
    orbit's pair (eigenvalues of the flat ball's exact map, ``bbdyn.flat.tongues.map_jacobian``)
    and the curvature block's ``(T +- sqrt(T^2 - 4 beta)) / 2`` (``top_orbit_exponent``)."""
    o = k1_orbit(p, k)
    flat = np.linalg.eigvals(map_jacobian(p, o.phase_stable, o.vrel))
    mu_plus = math.exp(top_orbit_exponent(p, k) * k / p.f)
    return np.sort(np.log(np.abs(np.concatenate([flat, [mu_plus, p.beta / mu_plus]]))))[::-1]


def cost_table() -> dict:
    """CPU time per event (microseconds) of the event kernel alone, with one tangent vector
    and with the whole frame, on the same particles (n = 20, 20 s after 2 s, seed 0; the
    best of three runs, kernels compiled before)."""
    rows = []
    for f in FREQUENCIES:
        p = Params(f=f)
        states = kernel_states(p, initial_conditions(p, 20, 0))
        times = {}
        for key, spectrum in (("largest", False), ("spectrum", True)):
            billiard_lyapunov_from(p, states[:1], t=0.1, windows=1, spectrum=spectrum)
            best = math.inf
            for _ in range(3):
                start = time.process_time()
                res = billiard_lyapunov_from(p, states, t=20.0, transient=2.0, spectrum=spectrum)
                best = min(best, time.process_time() - start)
            times[key] = best
        events = int(res["collisions"].sum())
        kp = p.kernel()
        best = math.inf
        for _ in range(3):
            start = time.process_time()
            for s in states:
                billiard_run((*s[:6], int(s[6])), kp, events // states.shape[0], None)
            best = min(best, time.process_time() - start)
        rows.append([f"{f:g}", f"{events}", f"{best / events * 1e6:.3f}",
                     f"{times['largest'] / events * 1e6:.3f}",
                     f"{times['spectrum'] / events * 1e6:.3f}",
                     f"{times['spectrum'] / times['largest']:.2f}"])  # fmt: skip
    columns = ["f (Hz)", "collisions measured", "event kernel (us / event)",
               "largest exponent (us / event)", "spectrum (us / event)",
               "spectrum / largest"]  # fmt: skip
    return {"columns": columns, "rows": rows}


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


def tables(long: bool = True, cost: bool = True) -> dict:
    """Every table of the page (``billiard_long`` and the spectrum's long tables only with
    ``long``, ``spectrum_cost`` only with ``cost``)."""
    groups = billiard_groups()
    out = {"command": COMMAND, "bbdyn_version": bbdyn.__version__,
           "flat": flat_table(), "flat_orbits": flat_orbit_table(),
           "billiard": billiard_table(groups),
           "billiard_orbits": billiard_orbit_table(),
           "billiard_spectrum": spectrum_table(groups),
           "billiard_spectrum_free": free_spectrum_table(groups),
           "billiard_orbit_spectrum": orbit_spectrum_table()}  # fmt: skip
    if cost:
        out["spectrum_cost"] = cost_table()
    if long:
        long_groups = billiard_groups(100, 50.0, 5.0)
        out["billiard_long"] = billiard_table(long_groups)
        out["billiard_spectrum_long"] = spectrum_table(long_groups)
        out["billiard_spectrum_free_long"] = free_spectrum_table(long_groups)
        out["spectrum_convergence"] = spectrum_convergence(groups, long_groups)
    return out


def _z(a: float, a_se: float, b: float, b_se: float) -> float:
    """The difference of two estimates over their combined standard error."""
    return abs(a - b) / math.hypot(a_se, b_se)


def spectrum_convergence(short: list, long: list) -> dict:
    """Short against long runs, per attractor: the z-value (difference over the combined
    standard error) of ``lambda_1`` and the largest of the four exponents between sticks."""
    short_by = {(f, name): g for f, _, name, _, g in short}
    rows = []
    for f, _, name, _, g in long:
        if name == "all" or (f, name) not in short_by:
            continue
        s = short_by[(f, name)]
        z1 = _z(g["lam1_per_s"], g["lam1_per_s_se"], s["lam1_per_s"], s["lam1_per_s_se"])
        free = max(_z(g["free_spectrum_per_s"][i], g["free_spectrum_per_s_se"][i],
                      s["free_spectrum_per_s"][i], s["free_spectrum_per_s_se"][i])
                   for i in range(4))  # fmt: skip
        rows.append([f"{f:g}", name, f"{z1:.2f}", f"{free:.2f}"])
    columns = ["f (Hz)", "attractor", "z of lambda_1", "largest z between sticks"]
    return {"columns": columns, "rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short", action="store_true", help="without the longer billiard runs")
    args = parser.parse_args()
    data = tables(long=not args.short)
    if args.short and OUT.is_file():
        old = json.loads(OUT.read_text())
        for key in LONG_KEYS:
            if key in old:
                data[key] = old[key]
    OUT.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    print(f"saved {OUT.relative_to(Path.cwd()) if OUT.is_relative_to(Path.cwd()) else OUT}")


if __name__ == "__main__":
    main()
