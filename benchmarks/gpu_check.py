"""The device check of the CUDA engine: agreement with the committed full scan, and speed.

Runs unattended on one GPU within ``--budget-s`` seconds (default 420: the whole script,
compilation included, with its own clock; a part that would not fit is cut short and
extrapolated, or skipped, and the report says which) and writes ONE JSON report:

* ``gpu``: model, compute capability, memory, driver and runtime versions; ``compile_s``:
  the first (tiny) GPU ensemble, which compiles the kernel (and the CPU helpers).
* ``agreement``: ``diffusion_points`` on the GPU (what ``bbdyn scan --device cuda`` runs) at
  20 frequencies of the committed full scan's grid across 50-95 Hz, n = 1000, t = 200 s,
  its seed: z-values of D, E and E_x against ``docs/figures/S3_full`` (``z_scores`` of
  ``benchmarks/scan_compare.py``: regular points, where both runs share their orbits, agree
  to rounding and count as z = 0); passes with no |z| beyond 3.5 and chi^2/dof in
  [0.7, 1.3] (for 20 points chi^2/dof scatters by sqrt(2/20) = 0.32: the report gives it).
* ``full_scan``: the ensembles of the whole S3 full scan (227 frequencies, n = 1000,
  t = 200 s, seed 0) in one GPU run: its wall time (the engine's run, without compilation
  and without drawing the initial conditions), events per second, device memory, and the
  CPU time the committed scan took for the same ensembles (``S3_full`` metadata, worker
  processes on one thread each; with fast-forward) with the ratio; its z table against
  ``S3_full`` (227 points).  Cut short at the deadline: the fraction done and the
  extrapolated time.
* ``b6``: scene B6 at its FULL setting, centre by centre while time remains (the
  ensembles of its points on the GPU, D per point), else one point's rate and the
  extrapolation to the whole setting; the scene's host-side bootstrap is not run.

Usage (from the repository root; bbdyn need not be installed, only numpy, scipy, numba,
numba-cuda)::

    python benchmarks/gpu_check.py [--out REPORT.json] [--budget-s 420]
    NUMBA_ENABLE_CUDASIM=1 python benchmarks/gpu_check.py --smoke --out /tmp/r.json

``--out`` defaults to ``$OUT/gpu_report.json`` when ``$OUT`` is set.  ``--smoke`` runs every
part at a tiny size (numba's CUDA simulator: ``NUMBA_ENABLE_CUDASIM=1``), to check the
script, not the device.
"""

import argparse
import datetime
import json
import math
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

import numpy as np  # noqa: E402

#: The committed full scan the GPU is compared with.
S3_FULL = ROOT / "docs" / "figures" / "S3_full.npz"
#: Pass marks of the agreement (the issue's).
Z_MAX, CHI2_BAND = 3.5, (0.7, 1.3)
#: Sizes: the full check, and the smoke test of the script (simulator).
FULL = {"agree_points": 20, "n": 1000, "t": 200.0, "scan_points": None}
SMOKE = {"agree_points": 3, "n": 4, "t": 1.0, "scan_points": 5}
#: B6 in the smoke test: one centre, two levels of three points, tiny ensembles.
B6_SMOKE = {"centres": (85.2,), "steps": (0.2, 0.05), "points": 3, "n": 6, "t": 1.0}
#: Seconds kept free at the end (writing the report, interpreter exit).
RESERVE_S = 15.0


class OutOfTime(Exception):
    """Raised from a run's progress callback when its deadline has passed."""


class Clock:
    """The script's clock: seconds since start, and deadlines."""

    def __init__(self, budget_s: float):
        self.start, self.budget = time.perf_counter(), float(budget_s)

    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def left(self) -> float:
        return self.budget - RESERVE_S - self.elapsed()

    def watch(self, deadline_s: float):
        """A progress callback that records the fraction done and stops the run (OutOfTime)
        once ``deadline_s`` (script seconds) has passed."""
        seen = {"fraction": 0.0}

        def progress(fraction):
            seen["fraction"] = float(fraction)
            if self.elapsed() > deadline_s and fraction < 1.0:
                raise OutOfTime(fraction)

        return progress, seen


def gpu_info() -> dict:
    """Model, compute capability, memory, driver and runtime of the current device."""
    from numba import cuda

    from bbdyn.gpu import cuda_device, simulated

    info = {"name": cuda_device(), "simulated": simulated()}
    if simulated():
        return info
    dev = cuda.get_current_device()
    info["compute_capability"] = list(dev.compute_capability)
    free, total = cuda.current_context().get_memory_info()
    info.update(memory_total_bytes=int(total), memory_free_bytes=int(free))
    for key, get in (("driver", lambda: cuda.cudadrv.driver.driver.get_version()),
                     ("runtime", lambda: cuda.runtime.get_version())):  # fmt: skip
        try:
            info[key] = ".".join(str(v) for v in get())
        except Exception as err:  # versions are information, not a condition
            info[key] = f"unknown ({type(err).__name__})"
    return info


def compile_kernel() -> float:
    """Seconds of the first GPU ensemble (tiny): compiles the kernel and the CPU helpers."""
    from bbdyn import Params
    from bbdyn.ensemble import ensemble

    start = time.perf_counter()
    ensemble(Params(f=85.2), n=2, t=0.05, seed=0, device="cuda")
    return time.perf_counter() - start


def grid() -> np.ndarray:
    """The committed full scan's frequencies (Hz)."""
    with np.load(S3_FULL) as z:
        return np.asarray(z["f"], float)


def agreement_frequencies(count: int) -> np.ndarray:
    """``count`` frequencies of the full scan's grid spread evenly over 50-95 Hz."""
    f = grid()
    f = f[(f >= 50.0) & (f <= 95.0)]
    return np.unique(f[np.round(np.linspace(0, f.size - 1, count)).astype(int)])


def compare(new: dict) -> dict:
    """z table of ``new`` (f, D, D_err, E, E_err, E_x, E_x_err) against the full scan."""
    from scan_compare import QUANTITIES, load_old, z_scores

    result = z_scores(load_old(S3_FULL), new)
    out = {"n_points": result["n_points"], "f": result["f"].tolist()}
    for name, _, _ in QUANTITIES:
        q = result[name]
        z = np.asarray(q["z"])
        free = int(z.size - q["n_exact"])
        out[name] = {
            "z": z.tolist(), "max_abs_z": float(np.max(np.abs(z))) if z.size else math.nan,
            "n_beyond": int(np.sum(np.abs(z) > Z_MAX)), "chi2_per_dof": q["chi2_per_dof"],
            "chi2_per_dof_scatter": math.sqrt(2.0 / free) if free else math.nan,
            "mean_z": q["mean_z"], "n_exact": q["n_exact"],
        }  # fmt: skip
        chi2 = q["chi2_per_dof"]
        out[name]["passed"] = bool(out[name]["n_beyond"] == 0 and (
            not math.isfinite(chi2) or CHI2_BAND[0] <= chi2 <= CHI2_BAND[1]))  # fmt: skip
    out["passed"] = all(out[name]["passed"] for name, _, _ in QUANTITIES)
    return out


def part_agreement(sizes: dict, clock: Clock, deadline_s: float) -> dict:
    """(a) ``diffusion_points`` on the GPU at the agreement frequencies, against S3_full."""
    from bbdyn.scans.frequency import diffusion_points
    from bbdyn.scans.runner import point_seed

    freqs = agreement_frequencies(sizes["agree_points"])
    progress, seen = clock.watch(deadline_s)
    start = time.perf_counter()
    try:
        seeds = [point_seed(0, f) for f in freqs]
        outs = diffusion_points(freqs.tolist(), seeds, device="cuda", n=sizes["n"],
                                t=sizes["t"], progress=progress)  # fmt: skip
    except OutOfTime:
        return {"done": False, "fraction": seen["fraction"], "wall_s": time.perf_counter() - start}
    new = {"f": freqs}
    for name in ("D", "E", "E_x"):
        new[name] = np.array([o[name] for o in outs])
        new[name + "_err"] = np.array([o[name + "_se"] for o in outs])
    out = {"done": True, "wall_s": time.perf_counter() - start, "n": sizes["n"], "t": sizes["t"]}
    out.update(compare(new))
    out["values"] = {k: v.tolist() for k, v in new.items() if k != "f"}
    return out


def committed_cpu() -> dict:
    """The CPU time of the committed full scan (its workers' process time) and its events."""
    meta = json.loads(S3_FULL.with_suffix(".json").read_text())["meta"]
    with np.load(S3_FULL) as z:
        events = float(np.sum(z["events"]))
    return {"cpu_s": float(meta["scan_cpu_s"]), "events": events, "settings": meta["settings"],
            "fast_forward": "converged"}  # fmt: skip


def run_ensembles(freqs, n: int, t: float, clock: Clock, deadline_s: float) -> dict:
    """The ensembles of a frequency scan's points (``diffusion_points``' seeds and sample
    times) in one GPU run; timings, events, and D, E, E_x with their errors per point."""
    from bbdyn import Params
    from bbdyn.ensemble import ensembles
    from bbdyn.gpu import state_bytes
    from bbdyn.scans.frequency import N_SAMPLES, point_seeds
    from bbdyn.scans.runner import point_seed

    seeds = [point_seeds(point_seed(0, f))[0] for f in freqs]
    progress, seen = clock.watch(deadline_s)
    start = time.perf_counter()
    out = {"points": len(freqs), "n": n, "t": t,
           "state_bytes": state_bytes(len(freqs) * n, N_SAMPLES)}  # fmt: skip
    try:
        times = np.linspace(0.0, t, N_SAMPLES)
        results = ensembles([Params(f=f) for f in freqs], seeds, device="cuda", n=n, t=t,
                            sample_times=times, progress=progress)  # fmt: skip
    except OutOfTime:
        wall = time.perf_counter() - start
        done = seen["fraction"]
        out.update(done=False, fraction=done, wall_s=wall,
                   extrapolated_s=wall / done if done else math.inf)  # fmt: skip
        return out
    events = float(sum(int(r["events"].sum()) for r in results))
    gpu_wall = results[0].meta["wall_s"]  # the engine's run, common to the batch
    out.update(launches=results[0].meta["launches"], device_bytes=results[0].meta["device_bytes"])
    out.update(done=True, wall_s=time.perf_counter() - start, gpu_wall_s=gpu_wall,
               events=events, events_per_s=events / gpu_wall,
               n_failed=int(sum(r.meta["n_failed"] for r in results)))  # fmt: skip
    summaries = [r.summary() for r in results]
    out["new"] = {"f": np.asarray(freqs, float)}
    for name in ("D", "E", "E_x"):
        out["new"][name] = np.array([s[name] for s in summaries])
        out["new"][name + "_err"] = np.array([s[name + "_se"] for s in summaries])
    return out


def scan_frequencies(sizes: dict) -> np.ndarray:
    """The frequencies of the full-scan part: the whole grid, or a few of it (smoke)."""
    f = grid()
    return f if sizes["scan_points"] is None else f[:: f.size // sizes["scan_points"]]


def part_full_scan(sizes: dict, clock: Clock, deadline_s: float) -> dict:
    """(b) The full scan's ensembles on the GPU, timed; CPU time of the same work."""
    out = run_ensembles(scan_frequencies(sizes), sizes["n"], sizes["t"], clock, deadline_s)
    cpu = committed_cpu()
    out["cpu"] = cpu
    if out["done"]:
        new = out.pop("new")
        out["agreement"] = {k: v for k, v in compare(new).items() if k != "f"}
        if sizes["scan_points"] is None:
            out["cpu_over_gpu_wall"] = cpu["cpu_s"] / out["gpu_wall_s"]
    return out


def part_b6(settings: dict, clock: Clock, rate: float | None) -> dict:
    """(c) B6 centre by centre while time remains; else one point and the extrapolation.

    ``rate``: particle-periods per GPU second measured by the full scan (None if unknown),
    to forecast a centre before starting it."""
    from bbdyn.scenes.b6_fine_structure import grid_points

    out = {"settings": {k: list(v) if isinstance(v, tuple) else v for k, v in settings.items()},
           "centres": []}  # fmt: skip
    f_all, c_all, _ = grid_points(settings)
    n, t = int(settings["n"]), float(settings["t"])
    work = {
        c: float(np.unique(f_all[c_all == c]).sum()) * n * t
        for c in range(len(settings["centres"]))
    }
    out["particle_periods"] = float(sum(work.values()))
    for c, centre in enumerate(settings["centres"]):
        freqs = np.unique(f_all[c_all == c])
        forecast = work[c] / rate if rate else None
        if forecast is not None and forecast > 0.8 * clock.left():
            break
        run = run_ensembles(freqs, n, t, clock, clock.elapsed() + clock.left())
        run.pop("new", None)
        run["centre"] = centre
        out["centres"].append(run)
        if not run["done"]:
            break
        rate = work[c] / run["gpu_wall_s"]
    done = [r for r in out["centres"] if r["done"]]
    out["complete"] = len(done) == len(settings["centres"])
    if not done and clock.left() > 5:  # one point: the rate
        f0 = np.unique(f_all)[:1]
        run = run_ensembles(f0, n, t, clock, clock.elapsed() + clock.left())
        run.pop("new", None)
        out["one_point"] = run
        if run["done"]:
            rate = float(f0.sum()) * n * t / run["gpu_wall_s"]
    out["rate_particle_periods_per_s"] = rate
    out["extrapolated_gpu_s"] = out["particle_periods"] / rate if rate else None
    return out


def default_out() -> Path | None:
    return Path(os.environ["OUT"]) / "gpu_report.json" if os.environ.get("OUT") else None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=default_out(),
                        help="report path (default: $OUT/gpu_report.json)")  # fmt: skip
    parser.add_argument("--budget-s", type=float, default=420.0, help="seconds for everything")
    parser.add_argument("--smoke", action="store_true", help="tiny sizes (CUDA simulator)")
    args = parser.parse_args()
    if args.out is None:
        parser.error("give --out (or set $OUT)")
    clock = Clock(args.budget_s)
    report = {"kind": "gpu_report", "smoke": args.smoke, "budget_s": args.budget_s,
              "created_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
              "command": "python benchmarks/gpu_check.py" + " --smoke" * args.smoke}  # fmt: skip

    def save():
        report["total_s"] = clock.elapsed()
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(report, indent=1, allow_nan=True) + "\n")

    from bbdyn import __version__
    from bbdyn.sources import package_digest

    report.update(bbdyn_version=__version__, bbdyn_source=package_digest())
    try:
        report["gpu"] = gpu_info()
        report["compile_s"] = compile_kernel()
        sizes = SMOKE if args.smoke else FULL
        # (a) gets at most a quarter of what is left, (b) what remains but a fifth for (c)
        report["agreement"] = part_agreement(sizes, clock, clock.elapsed() + clock.left() / 4)
        save()
        report["full_scan"] = part_full_scan(sizes, clock, clock.elapsed() + 0.8 * clock.left())
        save()
        full = report["full_scan"]
        work = float(scan_frequencies(sizes).sum()) * sizes["n"] * sizes["t"]
        rate = work / full["gpu_wall_s"] if full.get("done") else None
        from bbdyn.scenes.b6_fine_structure import FULL as B6_FULL

        report["b6"] = part_b6(B6_SMOKE if args.smoke else B6_FULL, clock, rate)
    except Exception as err:  # the report says what failed; the parts done are kept
        report["error"] = f"{type(err).__name__}: {err}"
    save()
    print(json.dumps({k: report.get(k) for k in ("gpu", "compile_s", "total_s", "error")}))
    print(f"report: {args.out}")
    return 1 if "error" in report else 0


if __name__ == "__main__":
    sys.exit(main())
