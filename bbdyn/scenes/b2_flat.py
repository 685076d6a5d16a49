"""Work-precision benchmark of the flat ball (scene B2, docs/model.md §6).

Three ways to find the next impact are compared against the mpmath reference
``bbdyn.reference.flat_mpmath.reference_impacts``:

* ``exact``: bbdyn's first-contact search ``bbdyn.core.search.flat_flight_tol``,
  at the default stopping tolerance ``ROOT_STEP_REL`` (that of ``flat_flight``)
  and at looser ones (``step_rel``: the contact time is then early by up to
  about ``step_rel`` times the flight);
* ``fixed_step``: the paper-like sampler of ``bbdyn.reference.fixed_step``
  (flight sampled at ``dt``, the crossing halved down to ``dt_min``);
* ``solve_ivp``: scipy's RK45 / DOP853 with a terminal event, either in the lab
  frame (state ``y, v``, ``y'' = -g``, event ``y - y_p(t)``: the solution is a
  parabola, which Runge-Kutta methods reproduce exactly, so only the event
  location and missed contacts matter) or in the plate frame (state ``G, G'``,
  ``G'' = -g - A w^2 sin(w t)``, event ``G``: here the tolerance matters);
* ``heyoka`` (only if the optional package is installed, extra ``peers``): a
  generic high-order integrator with event detection, heyoka's adaptive Taylor
  method at a tolerance of machine epsilon, plate frame as for ``solve_ivp``
  (``bbdyn.reference.heyoka_flight.FlatTaylor``, built once, reused per flight).

The case is chaotic and has no chattering in the compared window (``CASE``).
Chaos amplifies any difference by about e^1.4 per impact, so errors are
*one-step* errors: every method restarts from the same float64 start state
(the reference trajectory's states, rounded) and its next impact is compared
with the reference computed from exactly that start state.  Speeds are
impacts per second on that same set of flights, single core, median over
repeats after compilation; the exact map's speed over a long continuous run
(all event kinds) is reported as its own row.

Long-run statistics compare the fixed-step method with the exact map over many
impacts of the same chaotic case: these are not one-step quantities, so they
measure what the method's errors do to the attractor.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any

import numpy as np

from bbdyn.core.flat import FlatArrays, FlatState, flat_run
from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import IMPACT, STICK, raise_for_status
from bbdyn.core.tolerances import EPS, ROOT_STEP_REL
from bbdyn.params import Params
from bbdyn.reference.bench_kernels import flat_one_step
from bbdyn.reference.fixed_step import fixed_step_one_step, fixed_step_run
from bbdyn.reference.flat_ivp import ivp_flight
from bbdyn.reference.flat_mpmath import reference_impacts
from bbdyn.reference.heyoka_flight import (
    FlatTaylor,
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

__all__ = [
    "CASE",
    "QUICK",
    "FULL",
    "FlatBenchResult",
    "compute",
    "draw",
    "table",
    "start_states",
    "one_step_errors",
    "long_run_stats",
]

#: A chaotic case: at f = 82 Hz (Gamma = 2.71) and alpha = 0.8 the attractor is
#: chaotic (nearby orbits separate by ~e^1.4 per impact) and sticks are rare
#: (none in the 1e5 impacts of the long run).  At the default
#: alpha = 0.5 the attractors between 60 and 95 Hz are periodic stick-release
#: cycles, not chaotic.  The start (phase0 rad, vrel0 mm/s, just after an impact)
#: is on the attractor: the exact map's state 1e4 events after (0.3, 50), fixed
#: here so that the compared window does not change with the kernel's last bits;
#: the reference reaches no stick in its first 1000 impacts.

CASE = {"f": 82.0, "alpha": 0.8, "phase0": 1.6362617649333338, "vrel0": 135.8286096710472}

#: A flight whose time differs from the reference by more than this fraction of
#: it ended at a different contact (a missed or spurious one), not an inaccurate one.
WRONG_CONTACT_REL = 0.01

TITLE = (
    "Flat ball work-precision: impact-time error against cost "
    "(exact, fixed step, solve_ivp, heyoka)"
)
QUICK: dict[str, Any] = {
    "n_impacts": 40,
    "exact_tols": [1e-4, 1e-10],
    "fixed": [(1e-4, 1e-6), (1e-5, 1e-6), (1e-4, 1e-8)],
    "ivp": [
        ("RK45", "lab", 1e-6, math.inf),
        ("RK45", "lab", 1e-6, 0.05),
        ("DOP853", "plate", 1e-10, math.inf),
    ],
    "long_run": 2_000,
    "long_run_fixed": [(1e-4, 1e-6)],
    "continuous_events": 200_000,
    "repeats": 3,
    "min_time": 0.02,
}
FULL: dict[str, Any] = {
    "n_impacts": 300,
    "exact_tols": [1e-4, 1e-7, 1e-10, 1e-13],
    "fixed": [
        (1e-4, 1e-6),
        (1e-5, 1e-6),
        (1e-6, 1e-6),
        (1e-4, 1e-7),
        (1e-4, 1e-8),
        (1e-4, 1e-10),
    ],
    "ivp": [
        ("RK45", "lab", 1e-3, math.inf),
        ("RK45", "lab", 1e-9, math.inf),
        ("DOP853", "lab", 1e-13, math.inf),
        ("RK45", "lab", 1e-6, 0.05),
        ("DOP853", "lab", 1e-10, 0.05),
        ("RK45", "plate", 1e-3, math.inf),
        ("RK45", "plate", 1e-6, math.inf),
        ("RK45", "plate", 1e-9, math.inf),
        ("DOP853", "plate", 1e-6, math.inf),
        ("DOP853", "plate", 1e-10, math.inf),
        ("DOP853", "plate", 1e-13, math.inf),
    ],
    "long_run": 100_000,
    "long_run_fixed": [(1e-4, 1e-6), (1e-5, 1e-6)],
    "continuous_events": 2_000_000,
    "repeats": 5,
    "min_time": 0.2,
}


def case_params() -> Params:
    """Parameters of the benchmark case (default parameters (docs/model.md) but f and alpha)."""
    return Params(f=CASE["f"], alpha=CASE["alpha"])


def start_states(params: Params, n_impacts: int) -> dict[str, np.ndarray]:
    """Float64 start states on the chaotic orbit and the one-step reference from each.

    The reference trajectory (``reference_impacts``, from ``CASE``) gives
    ``n_impacts`` start states ``(phase, vrel)``; the reference is then computed
    again from each *rounded* state, one impact ahead, so that a method's
    difference to it is its own one-step error.

    Returns
    -------
    dict of arrays of shape (n_impacts,)
        ``phase`` (rad), ``vrel`` (mm/s): start states; ``tau`` (s): reference
        flight time; ``v`` (mm/s): reference absolute post-impact velocity.
    """

    phase, vrel = CASE["phase0"], CASE["vrel0"]
    traj = reference_impacts(params, phase, vrel, n_impacts)
    phases = np.concatenate(([phase], traj["phase"][:-1]))
    vrels = np.concatenate(([vrel], traj["vrel"][:-1]))
    tau = np.empty(n_impacts)
    v = np.empty(n_impacts)
    w = params.w
    for i in range(n_impacts):
        one = reference_impacts(params, float(phases[i]), float(vrels[i]), 1)
        # t is absolute from t0 = phase / w; the difference is exact to ~1e-18 s.
        tau[i] = one["t"][0] - phases[i] / w
        v[i] = one["v"][0]
    return {"phase": phases, "vrel": vrels, "tau": tau, "v": v}


def _post_impact_v(kp, phases, tau, vrel_minus):
    """Absolute post-impact velocity v+ = -alpha vrel- + u (mm/s), docs/model.md impact law."""
    return -kp.alpha * vrel_minus - kp.A * kp.w * np.cos(phases + kp.w * tau)


def one_step_errors(kp, states, tau, vrel_minus) -> dict[str, float]:
    """Max and median one-step errors of impact time (s) and post-impact velocity (mm/s)."""
    dt = np.abs(tau - states["tau"])
    dv = np.abs(_post_impact_v(kp, states["phase"], tau, vrel_minus) - states["v"])
    dt = np.where(np.isfinite(dt), dt, np.inf)
    dv = np.where(np.isfinite(dv), dv, np.inf)
    return {
        "wrong_contacts": int(np.count_nonzero(dt > WRONG_CONTACT_REL * states["tau"])),
        "max_time_error_s": float(dt.max()),
        "median_time_error_s": float(np.median(dt)),
        "max_velocity_error": float(dv.max()),
        "median_velocity_error": float(np.median(dv)),
    }


def _bench_exact(kp, states, settings) -> list[dict[str, Any]]:
    n = states["phase"].size
    # A flight takes well under a microsecond: time the start states repeated to
    # _EXACT_TILE flights so that the Python call costs nothing in comparison.
    reps = -(-_EXACT_TILE // n)
    phases, vrels = np.tile(states["phase"], reps), np.tile(states["vrel"], reps)
    tau_t, vm_t = np.empty(n * reps), np.empty(n * reps)
    rows = []
    for step_rel in [ROOT_STEP_REL, *settings["exact_tols"]]:
        tau = np.empty(n)
        vm = np.empty(n)
        n_evals, status = flat_one_step(states["phase"], states["vrel"], kp, step_rel, tau, vm)
        raise_for_status(status, "exact")

        def run(step_rel=step_rel):
            raise_for_status(flat_one_step(phases, vrels, kp, step_rel, tau_t, vm_t)[1], "exact")

        timing = measure(run, repeats=settings["repeats"], min_time=settings["min_time"])
        if step_rel == ROOT_STEP_REL:
            setting = f"default (ROOT_STEP_REL = {ROOT_STEP_REL / EPS:g} eps)"
        else:
            setting = f"step_rel={step_rel:g}"
        # How early the contact is, in units of the tolerance's width step_rel tau.
        early = (states["tau"] - tau) / (step_rel * states["tau"])
        row = {"method": "exact", "setting": setting, "step_rel": step_rel}
        row.update(gap_evals_per_impact=n_evals / n, max_early_per_step_rel=float(early.max()))
        row.update(**timing.rates("impacts", n * reps), **one_step_errors(kp, states, tau, vm))
        row["_tau"] = tau
        rows.append(row)
    row = rows[0]

    periods, phase, vrel, kind = 0.0, CASE["phase0"], CASE["vrel0"], IMPACT
    n_events = settings["continuous_events"]

    def run_continuous():
        status = flat_run(FlatState(periods, phase, vrel, kind), kp, n_events, None)[2]
        raise_for_status(status, "exact continuous run")

    timing = measure(run_continuous, repeats=settings["repeats"], min_time=settings["min_time"])
    continuous = {
        "method": "exact",
        "setting": f"continuous run, {n_events} events (flat_run)",
        **timing.rates("impacts", n_events),
        "max_time_error_s": row["max_time_error_s"],
        "max_velocity_error": row["max_velocity_error"],
        "_tau": row["_tau"],
    }
    return [row, continuous, *rows[1:]]


def _bench_fixed(kp, states, settings) -> list[dict[str, Any]]:
    n = states["phase"].size
    rows = []
    for dt, dt_min in settings["fixed"]:
        tau = np.empty(n)
        vm = np.empty(n)
        evals = [0]

        def run(dt=dt, dt_min=dt_min, tau=tau, vm=vm, evals=evals):
            evals[0], status = fixed_step_one_step(
                states["phase"], states["vrel"], dt, dt_min, kp, tau, vm
            )
            raise_for_status(status, "fixed-step")

        timing = measure(run, repeats=settings["repeats"], min_time=settings["min_time"])
        row = {"method": "fixed_step", "setting": f"dt={dt:g} s, dt_min={dt_min:g} s"}
        row.update(dt=dt, dt_min=dt_min, gap_evals_per_impact=evals[0] / n, _tau=tau)
        row.update(**timing.rates("impacts", n), **one_step_errors(kp, states, tau, vm))
        rows.append(row)
    return rows


def _bench_ivp(kp, states, settings) -> list[dict[str, Any]]:
    n = states["phase"].size
    rows = []
    for method, frame, rtol, max_step in settings["ivp"]:
        tau = np.empty(n)
        vm = np.empty(n)
        args = (method, frame, rtol, max_step)

        def run(args=args, tau=tau, vm=vm):
            for i in range(n):
                tau[i], vm[i] = ivp_flight(
                    kp, float(states["phase"][i]), float(states["vrel"][i]), *args
                )

        # solve_ivp is slow: each repeat is one pass over the flights.
        timing = measure(run, repeats=settings["repeats"], min_time=0.0)
        setting = f"{method} {frame} frame, rtol={rtol:g}"
        if math.isfinite(max_step):
            setting += f", max_step={max_step:g} T"
        row = {"method": "solve_ivp", "setting": setting}
        row.update(ivp_method=method, frame=frame, rtol=rtol, max_step_periods=max_step, _tau=tau)
        row.update(**timing.rates("impacts", n), **one_step_errors(kp, states, tau, vm))
        rows.append(row)
    return rows


def _bench_heyoka(kp, states, settings) -> list[dict[str, Any]]:
    """The heyoka row (Taylor method, tolerance eps); none if heyoka is not installed."""
    if not heyoka_available():
        return []
    n = states["phase"].size
    tau = np.empty(n)
    vm = np.empty(n)
    taylor = FlatTaylor(kp)

    def run():
        for i in range(n):
            tau[i], vm[i] = taylor.flight(float(states["phase"][i]), float(states["vrel"][i]))

    timing = measure(run, repeats=settings["repeats"], min_time=settings["min_time"])
    row = {"method": "heyoka", "setting": f"Taylor order {taylor.ta.order} plate frame, tol=eps"}
    row.update(tol=taylor.ta.tol, _tau=tau)
    row.update(**timing.rates("impacts", n), **one_step_errors(kp, states, tau, vm))
    return [row]


#: Number of flights per timed call of the exact one-step loop.
_EXACT_TILE = 10_000

#: Batches for the batch-means standard error of long-run averages.
_N_BATCHES = 50


def _moments(v: np.ndarray, n_batches: int = _N_BATCHES) -> dict[str, float]:
    """Mean and variance of ``v`` with batch-means standard errors of both."""
    batches = np.array_split(v, n_batches)
    means = np.array([b.mean() for b in batches])
    variances = np.array([b.var() for b in batches])
    return {
        "mean_v": float(v.mean()),
        "var_v": float(v.var()),
        "stderr_mean_v": float(means.std(ddof=1) / math.sqrt(n_batches)),
        "stderr_var_v": float(variances.std(ddof=1) / math.sqrt(n_batches)),
    }


def _distinct(phase: np.ndarray, tol: float = 1e-9) -> int:
    """Number of impact phases that differ by more than ``tol`` rad."""
    s = np.sort(phase)
    return int(1 + np.count_nonzero(np.diff(s) > tol))


def long_run_stats(params: Params, n_impacts: int, fixed) -> list[dict[str, Any]]:
    """Long-run statistics of the chaotic case: exact map vs fixed-step methods.

    For each method: the number of distinct impact phases (to 1e-9 rad), mean
    and variance of the absolute post-impact velocity (mm/s) over ``n_impacts``
    impacts from ``CASE``, the batch-means standard error of the mean,
    and the chattering events (exact map: sticks; fixed step: micro-bounces,
    flights of at most 2 ``dt_min``).
    """
    kp = params.kernel()
    periods, phase, vrel, kind = 0.0, CASE["phase0"], CASE["vrel0"], IMPACT
    out = []
    # The exact map also records stick and release events; run until n_impacts impacts.
    n_events = n_impacts + n_impacts // 100 + 10
    arrays = [np.empty(n_events) for _ in range(3)] + [np.empty(n_events, dtype=np.int64)]
    start = FlatState(periods, phase, vrel, kind)
    _, n_done, status = flat_run(start, kp, n_events, FlatArrays(*arrays))
    raise_for_status(status, "long run (exact)")
    ev_phase, ev_vrel, ev_kind = arrays[1][:n_done], arrays[2][:n_done], arrays[3][:n_done]
    impacts = np.flatnonzero(ev_kind == IMPACT)[:n_impacts]
    last = impacts[-1] + 1
    ph = ev_phase[impacts]
    v = ev_vrel[impacts] - kp.A * kp.w * np.cos(ph)
    row = {"method": "exact", "setting": "default", "n_impacts": int(impacts.size)}
    row.update(distinct_phases=_distinct(ph), **_moments(v))
    row.update(chatter_events=int(np.count_nonzero(ev_kind[:last] == STICK)))
    out.append(row)
    for dt, dt_min in fixed:
        per, ph, vr = (np.empty(n_impacts) for _ in range(3))
        n_done, status = fixed_step_run(periods, phase, vrel, dt, dt_min, kp, per, ph, vr)
        raise_for_status(status, "long run (fixed step)")
        flight = np.diff(np.concatenate(([periods], per)) * TWO_PI + np.concatenate(([phase], ph)))
        flight /= kp.w
        v = vr - kp.A * kp.w * np.cos(ph)
        row = {"method": "fixed_step", "setting": f"dt={dt:g} s, dt_min={dt_min:g} s"}
        row.update(n_impacts=int(n_done), distinct_phases=_distinct(ph), **_moments(v))
        row.update(micro_bounces=int(np.count_nonzero(flight <= 2.0 * dt_min)))
        out.append(row)
    return out


class FlatBenchResult(Result):
    """Rows of the flat-ball work-precision benchmark (B2) and long-run statistics.

    ``meta["rows"]``: one dict per method and setting (``method``, ``setting``,
    ``impacts_per_s``, ``max_time_error_s`` (s), ``max_velocity_error`` (mm/s),
    ``cost_ratio_to_exact``, ``wrong_contacts``, ``gap_evals_per_impact``; exact rows
    also ``step_rel`` and ``max_early_per_step_rel``, the largest
    ``(tau_ref - tau) / (step_rel tau_ref)``, ...); ``meta["long_run"]``: see
    ``long_run_stats``.  The arrays repeat the numeric columns in row order and
    hold, per compared flight, ``start_phase``, ``start_vrel``, ``ref_tau``, ``ref_v``
    and ``flight_time`` (rows x flights, s).
    """

    kind = "bench_flat"

    def plot(self, ax=None, which: str = "time"):
        """Work-precision: max one-step error (``which`` = time or velocity) vs cost per impact,
        each point numbered as in ``point_key``."""
        import matplotlib.pyplot as plt

        key = {"time": "max_time_error_s", "velocity": "max_velocity_error"}[which]
        if ax is None:
            _, ax = plt.subplots()
        # A zero error (exact in float64) is drawn at the floor, with an open marker.
        floor = 1e-18 if which == "time" else 1e-15
        number = 1
        speed, clock = rate_key(self.meta["rows"], "impacts")
        for method, marker, rows in self.drawn_rows():
            cost = np.array([1e6 / r[speed] for r in rows])
            err = np.array([r[key] for r in rows])
            ax.loglog(cost, np.maximum(err, floor), marker, label=method.replace("_", " "))
            number = number_points(ax, cost, np.maximum(err, floor), number)
        ax.set_xlabel(f"cost per impact (µs of {clock}, single core)")
        ax.set_ylabel(
            "max one-step error of impact time (s)"
            if which == "time"
            else "max one-step error of v+ (mm/s)"
        )
        ax.legend(fontsize=8)
        return ax

    def drawn_rows(self) -> list[tuple[str, str, list[dict[str, Any]]]]:
        """``(method, marker, rows)`` of the work-precision panels, in the order drawn."""
        markers = {"exact": "o", "fixed_step": "s", "solve_ivp": "^", "heyoka": "D"}
        drawn = []
        for method, marker in markers.items():
            rows = [r for r in self.meta["rows"]
                    if r["method"] == method and "continuous" not in r["setting"]]  # fmt: skip
            if rows:
                drawn.append((method, marker, rows))
        return drawn

    def point_key(self) -> list[str]:
        """The points of the panels in words, in the order of their numbers."""
        return [describe(r) for _, _, rows in self.drawn_rows() for r in rows]


def number_points(ax, x, y, first: int) -> int:
    """Write the numbers ``first, first + 1, ...`` beside the points (x, y); returns the next."""
    for i, (xi, yi) in enumerate(zip(x, y, strict=True)):
        ax.annotate(str(first + i), (xi, yi), fontsize=7, xytext=(3, 2), textcoords="offset points")
    return first + len(x)


def draw_point_key(fig, lines: list[str]) -> None:
    """The numbered points in words, as a column right of the panels of ``fig``."""
    text = "\n".join(f"{i}: {line}" for i, line in enumerate(lines, start=1))
    fig.text(1.0, 0.5, text, fontsize=7, va="center", ha="left", family="monospace")


def describe(row: dict[str, Any]) -> str:
    """A benchmark row's method and setting in words (steps in s, max step in periods)."""
    if row["method"] == "fixed_step":
        return f"fixed step {row['dt']:g} s, refined to {row['dt_min']:g} s"
    if row["method"] == "solve_ivp":
        text = f"solve_ivp {row['ivp_method']}, {row['frame']} frame, rtol {row['rtol']:g}"
        if math.isfinite(row["max_step_periods"]):
            text += f", max step {row['max_step_periods']:g} periods"
        return text
    if row["method"] == "heyoka":
        return "heyoka, " + row["setting"]
    step_rel = row.get("step_rel")
    if step_rel is None:  # billiard rows: the setting's first clause
        return "exact, " + row["setting"].split(" (")[0].split(",")[0]
    if step_rel == ROOT_STEP_REL:
        return f"exact, default root tolerance ({ROOT_STEP_REL / EPS:g} eps of the flight time)"
    return f"exact, root tolerance {step_rel:g} of the flight time"


def compute(settings: dict[str, Any], *, log=None) -> FlatBenchResult:
    """Run the benchmark with ``settings`` (``QUICK``, ``FULL`` or a modified copy).

    ``log`` is a callable for progress lines (default: stderr).
    """
    log = log or (lambda msg: print(msg, file=sys.stderr))
    start = time.perf_counter()
    single_thread()
    params = case_params()
    kp = params.kernel()
    n = int(settings["n_impacts"])
    if n < 1:
        raise ValueError(f"n_impacts must be >= 1, got {n}")
    if int(settings["long_run"]) < _N_BATCHES:
        raise ValueError(f"long_run must be >= {_N_BATCHES} impacts, got {settings['long_run']}")
    for step_rel in settings["exact_tols"]:
        # below ROOT_STEP_REL float steps cannot meet the stop; at 1 it is no longer relative
        if not ROOT_STEP_REL <= step_rel < 1.0:
            raise ValueError(f"exact_tols must be in [{ROOT_STEP_REL:g}, 1), got {step_rel}")
    log(f"bench flat: mpmath reference for {n} impacts")
    states = start_states(params, n)
    log("bench flat: exact map")
    rows = _bench_exact(kp, states, settings)
    log("bench flat: fixed step")
    rows += _bench_fixed(kp, states, settings)
    log("bench flat: solve_ivp")
    rows += _bench_ivp(kp, states, settings)
    log("bench flat: heyoka" if heyoka_available() else "bench flat: heyoka not installed")
    rows += _bench_heyoka(kp, states, settings)
    speed, _ = rate_key(rows, "impacts")  # CPU time: not inflated by the load of the machine
    for row in rows:
        row["cost_ratio_to_exact"] = rows[0][speed] / row[speed]
    log(f"bench flat: long run of {settings['long_run']} impacts")
    long_run = long_run_stats(params, int(settings["long_run"]), settings["long_run_fixed"])
    keys = ("impacts_per_s", "max_time_error_s", "max_velocity_error", "cost_ratio_to_exact")
    arrays = {k: np.array([r[k] for r in rows]) for k in keys}
    # Per flight, for inspection: start states, reference, and each row's flight times.
    arrays.update({f"start_{k}": states[k] for k in ("phase", "vrel")})
    arrays.update(ref_tau=states["tau"], ref_v=states["v"])
    arrays["flight_time"] = np.array([r.pop("_tau") for r in rows])
    meta = make_meta(
        params,
        wall_s=time.perf_counter() - start,
        case=CASE,
        settings=settings,
        rows=rows,
        long_run=long_run,
        peers={"heyoka": heyoka_version()},
        errors="one-step: every method restarts from the same float64 state on the orbit",
    )
    return FlatBenchResult(arrays, meta)


def draw(result: FlatBenchResult):
    """Figure of the benchmark: time and velocity work-precision panels, the numbered points
    named in words on the right."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    result.plot(axes[0], which="time")
    result.plot(axes[1], which="velocity")
    case = result.meta["case"]
    n = result.meta["settings"]["n_impacts"] if "settings" in result.meta else None
    fig.suptitle(f"flat ball work-precision (f = {case['f']} Hz, alpha = {case['alpha']}"
                 + (f", {n} one-step flights per point)" if n else ")"))  # fmt: skip
    fig.tight_layout()
    draw_point_key(fig, result.point_key())
    return fig


def table(result: FlatBenchResult) -> str:
    """The rows as a plain-text table, then the long-run statistics."""
    columns = (
        *rate_columns(result.meta["rows"], "impacts", "impacts", 10),
        *ERROR_COLUMNS,
        ("gap_evals_per_impact", "evals", 6, ".3g"),
    )
    lines = format_rows(result.meta["rows"], columns, 50)
    lines += missing_note(result.meta.get("peers"))
    lines.append("")
    lines.append(f"long run ({result.meta['case']['f']} Hz, alpha {result.meta['case']['alpha']}):")
    for r in result.meta["long_run"]:
        extra = r.get("chatter_events", r.get("micro_bounces"))
        label = "sticks" if r["method"] == "exact" else "micro-bounces"
        lines.append(
            f"{r['method']:<11} {r['setting']:<28} impacts {r['n_impacts']:>7} "
            f"distinct phases {r['distinct_phases']:>7} mean v+ {r['mean_v']:.2f} "
            f"+- {r['stderr_mean_v']:.2f} var {r['var_v']:.0f} +- {r['stderr_var_v']:.0f} "
            f"{label} {extra}"
        )
    return "\n".join(lines)
