"""Work-precision benchmark of the billiard (scene B2, docs/model.md §6).

Speed: collisions per second of the exact kernel (``bbdyn.core.billiard``), single
thread, median over repeats after compilation: one flight at a time from a set of
start states on the attractor, a continuous run (``billiard_run`` storing nothing, all event
kinds), and the ensemble (``bbdyn.ensemble.ensemble``) on 2 threads.  A
*collision* is an IMPACT or a STICK event (a STICK is the impact that starts a
summed chattering sequence); RELEASE events are not collisions.

Accuracy: *one-step* impact-time errors, as for the flat ball.  Start states are
the exact kernel's post-event states on the attractor (float64); from each, the
exact kernel and the fixed-step method (``fixed_step_billiard``) find the next
contact, and both are compared with an mpmath root (``bbdyn.reference.billiard_mpmath``) of the
same flight's gap on the tile of the exact contact
(``reference_flight``).  The reference refines the contact; that it is the
*first* one is the exact kernel's guarantee (tested in tests/test_billiard_*.py),
and a fixed-step contact more than ``WRONG_CONTACT_REL`` of the flight away from
it is counted as a wrong contact (missed or spurious).

Peer: ``heyoka`` (only if the optional package is installed, extra ``peers``), a
generic high-order integrator with event detection (adaptive Taylor method at a
tolerance of machine epsilon, ``bbdyn.reference.heyoka_flight.BilliardTaylor``: the
flight relative to the floor level, one tile at a time, the gap to the tile's arc
as terminal event), from the same start states, then the same impact law; its
integrator is built once and reused for every flight.

Observables: D and the period-averaged energies of the same small ensemble with
the exact kernel and with the fixed-step method at one frequency, with standard
errors (independent chaotic runs: the difference's error is the quadrature sum).

Profile: per frequency, collisions per second of a continuous run, safe steps
per flight and the share of STICK events (summed chattering sequences).
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any

import numpy as np

from bbdyn.core.billiard import (
    EventArrays,
    EventState,
    billiard_run,
)
from bbdyn.core.floor import bounce
from bbdyn.core.status import IMPACT, STICK, raise_for_status
from bbdyn.core.tolerances import EPS, ROOT_STEP_REL
from bbdyn.ensemble import ensemble
from bbdyn.params import Params
from bbdyn.reference.bench_kernels import billiard_continuous, billiard_one_step, flight_profile
from bbdyn.reference.billiard_mpmath import reference_flight
from bbdyn.reference.fixed_step_billiard import (
    fixed_step_billiard_one_step,
    fixed_step_ensemble,
)
from bbdyn.reference.heyoka_flight import (
    BilliardTaylor,
    heyoka_available,
    heyoka_version,
    missing_note,
)
from bbdyn.reference.timing import (
    ERROR_COLUMNS,
    format_rows,
    measure,
    rate_columns,
    rate_key,
    single_thread,
)
from bbdyn.results import Result, make_meta
from bbdyn.scenes.b2_flat import describe, draw_point_key, number_points

__all__ = [
    "CASE",
    "QUICK",
    "FULL",
    "BilliardBenchResult",
    "attractor_states",
    "compute",
    "draw",
    "table",
]

#: The benchmark case: default parameters (docs/model.md) at f = 85.2 Hz (the S7 frequency,
#: ergodic intermittent regime).  The profile's runs go through ``transient`` events from
#: ``start`` first; ``attractor`` is where that transient ended at 85.2 Hz at 8ec5687, fixed
#: here (as ``b2_flat.CASE`` fixes its start) so that the compared flights and the continuous
#: run start from the same state whatever the last bits of the kernel under test; the
#: flights after it still part where two kernels' trajectories do.
CASE = {
    "f": 85.2,
    "start": (0.0, 0.0, 0.0, 0.3, 10.0, 40.0, IMPACT),
    "transient": 20_000,
    "attractor": (15712.0, 2.261969079070793, -3.0, 0.9480824546283221, 17.674941010553013,
                  45.212141092401936, IMPACT),
}  # fmt: skip


#: The compared flights start at every STATE_STRIDE-th event from ``CASE["attractor"]``:
#: consecutive events are correlated (a chattering sequence, a stretch of long flights), and
#: a stretch of them is a poor sample.
STATE_STRIDE = 50

#: A flight whose time differs from the reference by more than this fraction of
#: it, and by more than the method's final bracket ``dt_min`` (a fixed-step
#: contact is late by less than that), ended at a different contact.
WRONG_CONTACT_REL = 0.01

TITLE = (
    "Billiard work-precision: impact-time error against cost per collision "
    "(exact, fixed step, heyoka)"
)
QUICK: dict[str, Any] = {
    "n_impacts": 60,
    "fixed": [(1e-4, 1e-6), (1e-4, 1e-8)],
    "continuous_events": 200_000,
    "ensemble": {"n": 200, "t": 5.0, "threads": 2},
    "observables": {"n": 24, "t": 4.0, "seed": 1, "fixed": [(1e-4, 1e-6)]},
    "profile_f": [58.0, 85.2],
    "profile_events": 100_000,
    "repeats": 3,
    "min_time": 0.02,
}
FULL: dict[str, Any] = {
    "n_impacts": 400,
    "fixed": [(1e-4, 1e-6), (1e-5, 1e-6), (1e-4, 1e-7), (1e-4, 1e-8), (1e-4, 1e-10)],
    "continuous_events": 2_000_000,
    "ensemble": {"n": 1000, "t": 20.0, "threads": 2},
    "observables": {"n": 200, "t": 40.0, "seed": 1, "fixed": [(1e-4, 1e-6), (1e-5, 1e-6)]},
    "profile_f": [58.0, 70.0, 85.2, 88.4, 95.0],
    "profile_events": 1_000_000,
    "repeats": 5,
    "min_time": 0.2,
}


def attractor_states(params: Params, n_events: int) -> dict[str, np.ndarray]:
    """``n_events`` events of the exact kernel from ``CASE["attractor"]``, every
    ``STATE_STRIDE``-th: a sample spread over the intermittent attractor, not one stretch.

    Returns arrays ``periods, phase, tile, xi, vx, vyrel, kind`` (shape ``(n_events,)``).
    """
    kp = params.kernel()
    names = ("periods", "phase", "tile", "xi", "vx", "vyrel", "kind")
    total = n_events * STATE_STRIDE
    arrays = {k: np.empty(total) for k in names[:-1]}
    arrays["kind"] = np.empty(total, dtype=np.int64)
    start = EventState(*CASE["attractor"])
    _, n_done, status = billiard_run(start, kp, total, EventArrays(*arrays.values()))
    raise_for_status(status, "billiard benchmark states")
    return {k: v[:n_done:STATE_STRIDE] for k, v in arrays.items()}


def _start_array(states) -> np.ndarray:
    """Rows ``(phase, xi, vx, vyrel)`` of the flights that start at the states (not STICKs)."""
    keep = states["kind"] != STICK
    return np.column_stack([states[k][keep] for k in ("phase", "xi", "vx", "vyrel")])


def _reference(kp, starts, k, tau) -> np.ndarray:
    """mpmath reference ``(tau, vx+, vy+)`` for every start, on the exact contact's tile."""
    ref = np.empty((starts.shape[0], 3))
    for i in range(starts.shape[0]):
        ref[i] = reference_flight(kp, *starts[i], k[i], tau[i])
    return ref


def _errors(ref, tau, vx, vy, dt_min=0.0) -> dict[str, Any]:
    dt = np.abs(tau - ref[:, 0])
    dv = np.hypot(vx - ref[:, 1], vy - ref[:, 2])
    wrong = dt > np.maximum(WRONG_CONTACT_REL * ref[:, 0], dt_min)
    return {
        "wrong_contacts": int(np.count_nonzero(wrong)),
        "max_time_error_s": float(dt[~wrong].max()) if np.any(~wrong) else math.nan,
        "median_time_error_s": float(np.median(dt[~wrong])) if np.any(~wrong) else math.nan,
        "max_velocity_error": float(dv[~wrong].max()) if np.any(~wrong) else math.nan,
    }


#: Flights per timed call of the one-step loops.
_TILE = 20_000


def _bench_exact(kp, states, starts, ref, settings) -> list[dict[str, Any]]:
    n = starts.shape[0]
    out = [np.empty(n) for _ in range(5)]
    raise_for_status(billiard_one_step(starts, kp, *out), "exact one-step")
    tau, _, _, vx, vy = out
    errors = _errors(ref, tau, vx, vy)
    reps = -(-_TILE // n)
    tiled = np.ascontiguousarray(np.tile(starts, (reps, 1)))
    scratch = [np.empty(n * reps) for _ in range(5)]
    timing = measure(
        lambda: billiard_one_step(tiled, kp, *scratch),
        repeats=settings["repeats"],
        min_time=settings["min_time"],
    )
    rows = [
        {
            "method": "exact",
            "setting": f"one flight + impact law (ROOT_STEP_REL = {ROOT_STEP_REL / EPS:g} eps)",
            **timing.rates("impacts", n * reps),
            **timing.rates("collisions", n * reps),
            **errors,
        }
    ]
    n_events = int(settings["continuous_events"])
    state = np.array([states[k][0] for k in ("periods", "phase", "tile", "xi", "vx", "vyrel")])
    state = np.append(state, states["kind"][0])
    steps, flights, _, collisions, sticks, status = flight_profile(state, kp, n_events)
    raise_for_status(status, "exact continuous run")
    timing = measure(
        lambda: raise_for_status(billiard_continuous(state, kp, n_events), "exact continuous run"),
        repeats=settings["repeats"],
        min_time=settings["min_time"],
    )
    rows.append(
        {
            "method": "exact",
            "setting": f"continuous run, {n_events} events, 1 thread",
            **timing.rates("impacts", collisions),
            **timing.rates("collisions", collisions),
            **timing.rates("events", n_events),
            "steps_per_flight": steps / flights,
            "stick_share": sticks / collisions,
            "max_time_error_s": errors["max_time_error_s"],
            "max_velocity_error": errors["max_velocity_error"],
        }
    )
    return rows


def _bench_ensemble(params, settings) -> dict[str, Any]:
    """Collisions per second of ``bbdyn.ensemble.ensemble`` (reference box, no transient)."""
    cfg = settings["ensemble"]
    # t f whole periods, transient 0: the collision count covers the whole run.
    t = math.floor(cfg["t"] * params.f) / params.f
    counts = []

    def run():
        res = ensemble(
            params, t=t, n=cfg["n"], seed=0, transient=0.0, threads=cfg["threads"], observables=()
        )
        counts.append(int(res["collisions"].sum()))

    timing = measure(run, repeats=settings["repeats"], min_time=0.0)
    threads = int(cfg["threads"])
    rate = timing.per_second(counts[-1])
    return {
        "method": "exact",
        "setting": f"ensemble n={cfg['n']}, t={cfg['t']:g} s, {threads} threads",
        **timing.rates("impacts", counts[-1]),
        **timing.rates("collisions", counts[-1]),
        "collisions_per_s_per_core": rate / threads,
        "threads": threads,
        "max_time_error_s": math.nan,
        "max_velocity_error": math.nan,
    }


def _bench_fixed(kp, starts, ref, settings) -> list[dict[str, Any]]:
    n = starts.shape[0]
    rows = []
    for dt, dt_min in settings["fixed"]:
        out = [np.empty(n) for _ in range(5)]
        evals = [0]

        def run(dt=dt, dt_min=dt_min, out=out, evals=evals):
            evals[0], status = fixed_step_billiard_one_step(starts, dt, dt_min, kp, *out)
            raise_for_status(status, "fixed-step one-step")

        timing = measure(run, repeats=settings["repeats"], min_time=settings["min_time"])
        tau, _, _, vx, vy = out
        row = {"method": "fixed_step", "setting": f"dt={dt:g} s, dt_min={dt_min:g} s"}
        row.update(dt=dt, dt_min=dt_min, gap_evals_per_impact=evals[0] / n)
        row.update(timing.rates("impacts", n), **timing.rates("collisions", n))
        row.update(_errors(ref, tau, vx, vy, dt_min))
        rows.append(row)
    return rows


def _bench_heyoka(kp, starts, ref, settings) -> list[dict[str, Any]]:
    """The heyoka row (Taylor method, tolerance eps); none if heyoka is not installed."""
    if not heyoka_available():
        return []
    n = starts.shape[0]
    tau, vx, vy = np.empty(n), np.empty(n), np.empty(n)
    taylor = BilliardTaylor(kp)

    def run():
        for i in range(n):
            phase, xi0, vx0, vyrel = (float(v) for v in starts[i])
            tau[i], _, xi, vym = taylor.flight(phase, xi0, vx0, vyrel)
            vx[i], vyr, _, _ = bounce(xi, vx0, vym, kp)
            vy[i] = vyr - kp.A * kp.w * math.cos(phase + kp.w * tau[i])

    timing = measure(run, repeats=settings["repeats"], min_time=settings["min_time"])
    row = {"method": "heyoka", "setting": f"Taylor order {taylor.ta.order}, tol=eps, + impact law"}
    row.update(tol=taylor.ta.tol, **timing.rates("impacts", n), **timing.rates("collisions", n))
    row.update(_errors(ref, tau, vx, vy))
    return [row]


def _observables(params, settings) -> list[dict[str, Any]]:
    """D and energies of the same ensemble (seed, box) with the exact and fixed-step methods."""
    cfg = settings["observables"]
    res = ensemble(params, t=cfg["t"], n=cfg["n"], seed=cfg["seed"])
    exact = {"method": "exact", "setting": "default", **res.summary()}
    exact["wall_s"] = res.meta["wall_s"]
    rows = [exact]
    for dt, dt_min in cfg["fixed"]:
        row = {"method": "fixed_step", "setting": f"dt={dt:g} s, dt_min={dt_min:g} s"}
        row.update(
            fixed_step_ensemble(
                params, t=cfg["t"], n=cfg["n"], seed=cfg["seed"], dt=dt, dt_min=dt_min
            )
        )
        for name in ("D", "E", "E_x", "E_y", "E_pot"):
            diff = row[name] - exact[name]
            se = math.hypot(row[name + "_se"], exact[name + "_se"])
            row[name + "_diff_in_se"] = diff / se
        rows.append(row)
    return rows


def _profile(settings) -> list[dict[str, Any]]:
    """Continuous-run collisions per second, steps per flight, tiny-hop and stick shares and
    time per event, per frequency."""
    rows = []
    n_events = int(settings["profile_events"])
    for f in settings["profile_f"]:
        kp = Params(f=f).kernel()
        last, _, status = billiard_run(EventState(*CASE["start"]), kp, CASE["transient"], None)
        raise_for_status(status, f"profile transient at {f} Hz")
        state = np.array(last, dtype=float)
        steps, flights, tiny, collisions, sticks, status = flight_profile(state, kp, n_events)
        raise_for_status(status, f"profile at {f} Hz")
        timing = measure(
            lambda kp=kp, state=state: billiard_continuous(state, kp, n_events),
            repeats=settings["repeats"],
            min_time=settings["min_time"],
        )
        rows.append(
            {
                "f": f,
                **timing.rates("collisions", collisions),
                **timing.rates("events", n_events),
                "steps_per_flight": steps / flights,
                "tiny_share": tiny / flights,
                "stick_share": sticks / collisions,
                "ns_per_event": 1e9 * timing.median_s / n_events,
            }
        )
    return rows


class BilliardBenchResult(Result):
    """Rows of the billiard work-precision benchmark (B2).

    ``meta["rows"]``: one dict per method and setting (``method``, ``setting``,
    ``collisions_per_s``, ``impacts_per_s`` (the same), ``max_time_error_s`` (s),
    ``max_velocity_error`` (mm/s), ``cost_ratio_to_exact``, ``wrong_contacts``, ...);
    ``meta["observables"]``: D and energies, exact vs fixed step; ``meta["profile"]``:
    per-frequency cost.  Arrays: the one-step start states ``starts`` (rows ``phase,
    xi, vx, vyrel``) and the mpmath reference ``reference`` (rows ``tau, vx+, vy+``).
    """

    kind = "bench_billiard"

    def plot(self, ax=None):
        """Work-precision: max one-step impact-time error vs cost per collision, each point
        numbered as in ``point_key``."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        floor = 1e-19
        number = 1
        speed, clock = rate_key(self.meta["rows"], "collisions")
        for method, marker, rows in self.drawn_rows():
            cost = np.array([1e6 / r[speed] for r in rows])
            err = np.array([max(r["max_time_error_s"], floor) for r in rows])
            ax.loglog(cost, err, marker, label=method.replace("_", " "))
            number = number_points(ax, cost, err, number)
        ax.axhline(1e-12, color="0.6", lw=0.8, ls="--", label="target: 1e-12 s")
        ax.set_xlabel(f"cost per collision (µs of {clock}, single core)")
        ax.set_ylabel("max one-step error of impact time (s)")
        ax.legend(fontsize=8)
        return ax

    def drawn_rows(self) -> list[tuple[str, str, list[dict[str, Any]]]]:
        """``(method, marker, rows)`` of the work-precision panel (rows with a measured
        error), in the order drawn."""
        drawn = []
        for method, marker in (("exact", "o"), ("fixed_step", "s"), ("heyoka", "D")):
            rows = [r for r in self.meta["rows"]
                    if r["method"] == method and math.isfinite(r["max_time_error_s"])]  # fmt: skip
            if rows:
                drawn.append((method, marker, rows))
        return drawn

    def point_key(self) -> list[str]:
        """The points of the panel in words, in the order of their numbers."""

        return [describe(r) for _, _, rows in self.drawn_rows() for r in rows]


def compute(settings: dict[str, Any], *, log=None) -> BilliardBenchResult:
    """Run the benchmark with ``settings`` (``QUICK``, ``FULL`` or a modified copy)."""
    log = log or (lambda msg: print(msg, file=sys.stderr))
    start = time.perf_counter()
    params = Params(f=CASE["f"])
    kp = params.kernel()
    n = int(settings["n_impacts"])
    if n < 1:
        raise ValueError(f"n_impacts must be >= 1, got {n}")
    log("bench billiard: ensemble on 2 threads")
    ens_row = _bench_ensemble(params, settings)
    single_thread()
    states = attractor_states(params, n)
    starts = np.ascontiguousarray(_start_array(states))
    tau, k = np.empty(starts.shape[0]), np.empty(starts.shape[0])
    scratch = [np.empty(starts.shape[0]) for _ in range(3)]
    raise_for_status(billiard_one_step(starts, kp, tau, k, *scratch), "exact one-step")
    log(f"bench billiard: mpmath reference for {starts.shape[0]} flights")
    ref = _reference(kp, starts, k, tau)
    log("bench billiard: exact kernel")
    rows = _bench_exact(kp, states, starts, ref, settings) + [ens_row]
    log("bench billiard: fixed step")
    rows += _bench_fixed(kp, starts, ref, settings)
    log("bench billiard: heyoka" if heyoka_available() else "bench billiard: heyoka not installed")
    rows += _bench_heyoka(kp, starts, ref, settings)
    speed, _ = rate_key(rows, "collisions")  # CPU time: not inflated by the machine's load
    for row in rows:
        row["cost_ratio_to_exact"] = rows[0][speed] / row[speed]
    log("bench billiard: D and energies, exact vs fixed step")
    observables = _observables(params, settings)
    log("bench billiard: profile over frequencies")
    profile = _profile(settings)
    keys = ("collisions_per_s", "max_time_error_s", "max_velocity_error", "cost_ratio_to_exact")
    arrays = {key: np.array([r[key] for r in rows]) for key in keys}
    arrays.update(starts=starts, reference=ref)
    meta = make_meta(
        params,
        wall_s=time.perf_counter() - start,
        case={
            "f": CASE["f"],
            "start": list(CASE["start"]),
            "transient": CASE["transient"],
            "attractor": list(CASE["attractor"]),
        },  # fmt: skip
        settings=settings,
        rows=rows,
        observables=observables,
        profile=profile,
        peers={"heyoka": heyoka_version()},
        errors="one-step: every method restarts from the same float64 state on the attractor",
    )
    return BilliardBenchResult(arrays, meta)


def draw(result: BilliardBenchResult):
    """Figure: work-precision panel and the per-frequency cost profile."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    result.plot(axes[0])
    prof = result.meta["profile"]
    f = [r["f"] for r in prof]
    axes[1].plot(f, [r["collisions_per_s"] / 1e6 for r in prof], "o-", label="collisions/s (1e6)")
    axes[1].plot(f, [r["steps_per_flight"] for r in prof], "s-", label="safe steps / flight")
    axes[1].set(xlabel="f (Hz)", ylabel="collisions/s (1e6); safe steps per flight (1)")
    axes[1].legend(fontsize=8)
    axes[1].set_title("exact kernel cost, continuous run, 1 thread", fontsize=9)
    fig.suptitle(f"billiard work-precision (f = {result.meta['case']['f']} Hz, default parameters, "
                 f"{result['starts'].shape[0]} one-step flights per point)")  # fmt: skip
    fig.tight_layout()
    draw_point_key(fig, result.point_key())
    return fig


def table(result: BilliardBenchResult) -> str:
    """The rows, the observables comparison and the profile as plain text."""
    columns = (*rate_columns(result.meta["rows"], "collisions", "coll", 9), *ERROR_COLUMNS)
    lines = format_rows(result.meta["rows"], columns, 48)
    lines += missing_note(result.meta.get("peers"))
    cfg = result.meta["settings"]["observables"]
    lines += ["", f"observables at {result.meta['case']['f']} Hz, n={cfg['n']}, t={cfg['t']} s:"]
    for r in result.meta["observables"]:
        text = f"{r['method']:<11} {r['setting']:<24}"
        for name in ("D", "E", "E_x", "E_y"):
            text += f" {name} {r[name]:.4g} +- {r[name + '_se']:.2g}"
            if name + "_diff_in_se" in r:
                text += f" ({r[name + '_diff_in_se']:+.1f} se)"
        text += f"  coll/particle/s {r['collisions_per_particle_per_s']:.4g}"
        lines.append(text)
    lines += ["", "profile (continuous run, 1 thread):"]
    profile = result.meta["profile"]
    rates = rate_columns(profile, "collisions", "coll", 9)
    lines.append(
        f"{'f (Hz)':>7}"
        + "".join(f" {head:>{width}}" for _, head, width, _ in rates)
        + f" {'steps/flight':>12} {'tiny hops':>9} {'stick share':>11} {'ns/event':>8}"
    )
    for r in profile:
        lines.append(
            f"{r['f']:>7g}"
            + "".join(f" {r[key]:>{width}{spec}}" for key, _, width, spec in rates)
            + f" {r['steps_per_flight']:>12.2f} {r['tiny_share']:>9.3f} {r['stick_share']:>11.3f}"
            f" {r['ns_per_event']:>8.1f}"
        )
    return "\n".join(lines)
