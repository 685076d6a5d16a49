"""Scene B6: fine structure of D(f) on nested frequency grids (docs/fine_structure.md).

Around each centre frequency, D(f) (``bbdyn.scans.frequency.diffusion_point``, error
bars one standard error over particles) on levels of decreasing step (a window of
``points`` frequencies per level).  Per level, ``bbdyn.scans.fine_structure.level_test``
asks whether neighbouring values differ more than their errors allow (beyond a
linear trend across the window) and gives the noise-corrected mean squared
increment S2; where S2 is resolved on two or more levels, its log-log slope against
the step gives a Hoelder-type exponent H (S2 ~ step^(2 H)).

All points of a setting form one resumable scan (``bbdyn.scans.runner.run_scan``) kept
under ``out_dir`` (``bbdyn.scans.cache.scene_folder("finestructure", ...)``).
``settings["scheduler"]`` (a dask scheduler address or client), else the environment
variable ``BBDYN_SCHEDULER``, runs it on a cluster
(``BBDYN_SCHEDULER=tcp://host:8786 bbdyn scene B6 --full``); ``settings["workers"]``
sets the local processes.  Neither enters the scan folder's name: a scan started
locally can be finished on a cluster and gives the same numbers (seeds depend on the
frequency only, ``bbdyn.scans.runner``).
"""

from __future__ import annotations

import functools
import math
import os
import time

import numpy as np

from bbdyn.params import Params
from bbdyn.results import Result, make_meta
from bbdyn.scans import fine_structure as fs
from bbdyn.scans.cache import scene_folder
from bbdyn.scans.frequency import check_scan_size, diffusion_point, scan_cpu_forecast
from bbdyn.scans.runner import run_scan

TITLE = "Fine structure of D(f): nested grids around chosen frequencies, scaling of increments"
_STEPS = (0.2, 0.05, 0.01, 0.002)
QUICK = {"centres": (85.2,), "steps": _STEPS, "points": 7, "n": 50, "t": 5.0}
#: The setting measured for docs/fine_structure.md (fits in 15 min of 2 shared cores).
MEDIUM = {"centres": (85.2,), "steps": _STEPS, "points": 21, "n": 15000, "t": 20.0}
#: One point per regime band (docs/classification.md) and 85.2 Hz; see the budget in
#: docs/fine_structure.md.
FULL = {"centres": (58.0, 70.0, 85.2, 89.0), "steps": _STEPS, "points": 21, "n": 40000,
        "t": 20.0}  # fmt: skip
#: Where the scan can run (``settings["device"]``; ``bbdyn.scans.runner.run_scan``).
DEVICES = ("cpu", "cuda")
#: environment variable naming a dask scheduler for the scan (when settings name none)
SCHEDULER_VARIABLE = "BBDYN_SCHEDULER"
#: bootstrap resamples per point (the bootstrap is only a cross-check of D_err)
N_BOOT = 200
#: Level panels side by side in the figure of ``draw``.
LEVEL_COLUMNS = 2
#: Marker of each centre in the scaling plot (cycled).
CENTRE_MARKERS = ("o", "s", "D", "^", "v", "P")


class FineStructureResult(Result):
    """Arrays: per frequency ``f`` (Hz), ``D``, ``D_err`` (mm^2/s), ``centre``, ``level``
    (indices), ``cpu_s`` (CPU s of the point's worker process); ``centres`` (c,) Hz, ``steps``
    (L,) Hz; per centre and level (c, L): ``chi2``, ``dof``, ``p``, ``S2``, ``S2_err``,
    ``S2_spread`` (mm^4/s^2), ``level_cpu_s`` (summed ``cpu_s``); per centre (c,): ``H``,
    ``H_err``, ``H_levels``."""

    kind = "scene_b6"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[-1]


def grid_points(settings: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every (frequency, centre index, level index) of ``settings``; a frequency shared by
    two levels (the centre) appears once per level."""
    rows = [
        (f, c, lv)
        for c, centre in enumerate(settings["centres"])
        for lv, step in enumerate(settings["steps"])
        for f in fs.nested_grid(centre, step, settings["points"])
    ]
    f, c, lv = (np.array(col) for col in zip(*rows, strict=True))
    return f, c.astype(int), lv.astype(int)


def cost(settings: dict) -> dict[str, float]:
    """Forecast of the CPU time (s) of the scan of every grid point of ``settings``:
    ``bbdyn.scans.frequency.scan_cpu_forecast``."""
    values = np.unique(grid_points(settings)[0])
    return scan_cpu_forecast(values.sum(), values.size, settings["n"], settings["t"],
                             workers=settings.get("workers"))  # fmt: skip


def run_points(settings: dict, seed: int, out_dir=None, progress=False):
    """The scan of all grid points of ``settings`` (computed, resumed or loaded); with
    ``settings["eta"] > 0`` at that noise amplitude (scene B8)."""
    f, _, _ = grid_points(settings)
    values = np.unique(f)
    n, t = int(settings["n"]), float(settings["t"])
    check_scan_size(float(values.min()), float(values.max()), values.size, n=n, t=t)
    noise = {"eta": float(settings["eta"])} if settings.get("eta") else {}
    compute = functools.partial(diffusion_point, n=n, t=t, n_boot=N_BOOT, **noise)
    return run_scan(
        values.tolist(),
        compute,
        out_dir=scene_folder("finestructure", settings, seed, out_dir),
        seed=seed,
        workers=settings.get("workers"),
        scheduler=_scheduler(settings),
        progress=progress,
        device=settings.get("device", "cpu"),
    )


def _scheduler(settings: dict):
    """The dask scheduler of the scan: ``settings["scheduler"]``, else ``$BBDYN_SCHEDULER``;
    none for a scan on the GPU (``settings["device"]``)."""
    if settings.get("device", "cpu") != "cpu":
        return None
    return settings.get("scheduler") or os.environ.get(SCHEDULER_VARIABLE) or None


def compute(
    settings: dict, seed: int = 0, out_dir=None, progress=False
) -> FineStructureResult:
    """Run (or resume) the scan of ``settings`` and test every level; see the module docstring."""
    start = time.perf_counter()
    scan = run_points(settings, seed, out_dir, progress)
    f, cidx, lidx = grid_points(settings)
    pos = np.searchsorted(scan.values, f)
    cpu = scan.point_cpu_s()
    arrays = {"f": f, "centre": cidx, "level": lidx, "D": scan["D"][pos],
              "D_err": scan["D_se"][pos], "cpu_s": cpu[pos]}  # fmt: skip
    centres = np.asarray(settings["centres"], dtype=float)
    steps = np.asarray(settings["steps"], dtype=float)
    arrays.update(centres=centres, steps=steps)
    arrays.update(_level_tables(arrays, centres.size, steps.size))
    meta = make_meta(seed=seed, wall_s=time.perf_counter() - start,
                     scan_compute=scan.meta["compute"], n=int(settings["n"]),
                     t=float(settings["t"]), scan_cpu_s=float(cpu.sum()))  # fmt: skip
    noisy = Params(f=85.2, eta=float(settings.get("eta") or 0.0))
    meta["params"] = {k: v for k, v in noisy.to_dict().items() if k != "f"}
    result = FineStructureResult(arrays, meta)
    result.meta["key_numbers"] = key_numbers(result)
    result.meta["table"] = table(result)
    return result


def _level_tables(arrays: dict, n_centres: int, n_levels: int) -> dict[str, np.ndarray]:
    """The structure test per (centre, level) and the scaling exponent per centre."""
    names = ("chi2", "dof", "p", "S2", "S2_err", "S2_spread")
    out = {k: np.full((n_centres, n_levels), math.nan) for k in (*names, "level_cpu_s")}
    for c in range(n_centres):
        for lv in range(n_levels):
            sel = (arrays["centre"] == c) & (arrays["level"] == lv)
            test = fs.level_test(arrays["D"][sel], arrays["D_err"][sel])
            for k in names:
                out[k][c, lv] = test[k]
            out["level_cpu_s"][c, lv] = arrays["cpu_s"][sel].sum()
    fits = [
        fs.scaling_exponent(arrays["steps"], out["S2"][c], out["S2_err"][c], out["S2_spread"][c])
        for c in range(n_centres)
    ]
    out.update({f"H{s}": np.array([fit[k] for fit in fits])
                for s, k in (("", "H"), ("_err", "H_err"), ("_levels", "levels"))})  # fmt: skip
    return out


def level_rows(result: Result) -> list[dict]:
    """One row per centre and level: the test, the size, the time and the verdict."""
    rows = []
    for c, centre in enumerate(result["centres"]):
        for lv, step in enumerate(result["steps"]):
            test = {k: float(result[k][c, lv]) for k in ("chi2", "dof", "p", "S2", "S2_err")}
            rows.append({"centre": float(centre), "step": float(step), **test,
                         "cpu_s": float(result["level_cpu_s"][c, lv]),
                         "verdict": fs.verdict(test, "mm^2/s")})  # fmt: skip
    return rows


def table(result: Result) -> str:
    """The structure test per level as a Markdown table."""
    lines = ["| centre (Hz) | step (Hz) | chi2 / dof | p | S2 (mm^4/s^2) | time (s) | conclusion |",
             "|---:|---:|---:|---:|---:|---:|---|"]  # fmt: skip
    for r in level_rows(result):
        lines.append(f"| {r['centre']:g} | {r['step']:g} | {r['chi2']:.1f} / {r['dof']:g} | "
                     f"{r['p']:.2g} | {r['S2']:.3g} +- {r['S2_err']:.2g} | {r['cpu_s']:.0f} | "
                     f"{r['verdict']} |")  # fmt: skip
    return "\n".join(lines)


def key_numbers(result: Result) -> dict:
    """Per centre and level the verdict, per centre the exponent, and the cost."""
    rows = level_rows(result)
    key = {f"{r['centre']:g} Hz, step {r['step']:g} Hz": r["verdict"] for r in rows}
    for centre in result["centres"]:
        found = [r for r in rows if r["centre"] == centre and r["p"] < fs.P_STRUCTURE]
        rest = [r for r in rows if r["centre"] == centre and r["p"] >= fs.P_STRUCTURE]
        parts = [
            f"{words} at steps {_steps_text(group)} Hz"
            for words, group in (("structure", found), ("not resolved", rest))
            if group
        ]
        key[f"{centre:g} Hz conclusion"] = (
            f"{'; '.join(parts)} (p < {fs.P_STRUCTURE:g} counts as structure)"
        )  # fmt: skip
    for c, centre in enumerate(result["centres"]):
        h, err, used = (float(result[k][c]) for k in ("H", "H_err", "H_levels"))
        key[f"{centre:g} Hz exponent H (S2 ~ step^2H)"] = (
            f"{h:.2f} +- {err:.2f} from {used:.0f} levels" if math.isfinite(h)
            else f"not measurable ({used:.0f} resolved levels, need 2)"
        )  # fmt: skip
    key["median D_err (mm^2/s)"] = f"{float(np.median(result['D_err'])):.3g}"
    key["precision cost D_err^2 x time per point (mm^4/s^2 s)"] = f"{precision_cost(result):.3g}"
    key["scan time, summed over points (s)"] = round(result.meta["scan_cpu_s"], 1)
    full = cost_estimate(result, FULL)
    key["FULL setting estimate"] = (
        f"{full['points']} points, about {full['cpu_s'] / 3600:.2g} hours of one core, "
        f"D_err about {full['D_err']:.2g} mm^2/s"
    )
    return key


def _steps_text(rows: list[dict]) -> str:
    return ", ".join(f"{r['step']:g}" for r in rows)


def precision_cost(result: Result) -> float:
    """Median over points of ``D_err^2 x seconds``: constant while D_err ~ n^-1/2 and the
    time ~ n (scene B3), so a point with error ``D_err`` costs about this / D_err^2 seconds.
    Times are the CPU times of the points' worker processes (one numba thread each); a
    result computed before CPU time was recorded holds wall times, which exceed them."""
    return float(np.median(result["D_err"] ** 2 * result["cpu_s"]))


def cost_estimate(result: Result, settings: dict) -> dict[str, float]:
    """Seconds (one core) and D_err of ``settings`` extrapolated from a measured ``result``: CPU per
    point ~ n t f (events per period are about constant; B3), D_err ~ n^-1/2 (at the
    measured frequencies: other centres differ)."""
    f, _, _ = grid_points(settings)
    values = np.unique(f)
    per_unit = np.median(result["cpu_s"] / (result["f"] * result.meta["n"] * result.meta["t"]))
    cpu = float(per_unit * settings["n"] * settings["t"] * values.sum())
    d_err = float(np.median(result["D_err"]) * math.sqrt(result.meta["n"] / settings["n"]))
    return {"points": int(values.size), "cpu_s": cpu, "D_err": d_err}


def draw(result: Result, ax=None):
    """The nested grids (per centre, one panel per level, two panels a row) with error bars and,
    below them, the scaling plot (S2 against step, log-log); with ``ax``, only the scaling plot
    there.  A level's colour is the same in its panel and in the scaling plot.  Returns the
    Figure."""
    if ax is not None:
        _draw_scaling(result, ax)
        return ax.figure
    import matplotlib.pyplot as plt

    n_c, n_l = result["centres"].size, result["steps"].size
    rows_per_centre = -(-n_l // LEVEL_COLUMNS)
    n_rows = n_c * rows_per_centre
    fig = plt.figure(figsize=(10.0, 2.6 * n_rows + 4.2), layout="constrained")
    grid = fig.add_gridspec(n_rows + 1, LEVEL_COLUMNS, height_ratios=[1] * n_rows + [1.5])
    for c in range(n_c):
        for lv in range(n_l):
            row, col = divmod(lv, LEVEL_COLUMNS)
            _draw_level(result, c, lv, fig.add_subplot(grid[c * rows_per_centre + row, col]))
    _draw_scaling(result, fig.add_subplot(grid[n_rows, :]))
    fig.suptitle(f"D(f) on nested grids, n = {result.meta['n']}, t = {result.meta['t']:g} s, "
                 "bars: 1 standard error")  # fmt: skip
    return fig


def _draw_level(result: Result, c: int, lv: int, ax) -> None:
    sel = (result["centre"] == c) & (result["level"] == lv)
    centre, step = result["centres"][c], result["steps"][lv]
    ax.errorbar(result["f"][sel] - centre, result["D"][sel], result["D_err"][sel], fmt="o-",
                ms=3, lw=0.8, capsize=1.5, color=f"C{lv}")  # fmt: skip
    p = result["p"][c, lv]
    p_text = "p < 1e-300" if p == 0 else f"p = {p:.2g}"  # a p-value below the smallest double
    ax.set_title(f"{centre:g} Hz, step {step:g} Hz: {p_text}", fontsize=10)
    ax.set_xlabel(f"f - {centre:g} (Hz)")
    ax.locator_params(axis="x", nbins=5)
    ax.set_ylabel(r"$D$ (mm$^2$/s)")


def _draw_scaling(result: Result, ax) -> None:
    """S2 per level (the level's colour), one marker per centre; open markers are upper
    bounds where S2 is not resolved.  The legend shows each centre's marker."""
    from matplotlib.lines import Line2D
    from matplotlib.ticker import NullLocator

    steps = result["steps"]
    handles, unresolved = [], False
    for c, centre in enumerate(result["centres"]):
        marker = CENTRE_MARKERS[c % len(CENTRE_MARKERS)]
        s2, err = result["S2"][c], result["S2_err"][c]
        for lv, step in enumerate(steps):
            if s2[lv] > fs.Z_RESOLVED * err[lv]:
                ax.errorbar(step, s2[lv], err[lv], fmt=marker, ms=7, capsize=2, color=f"C{lv}")
            else:
                unresolved = True
                bound = max(s2[lv] + fs.Z_RESOLVED * err[lv], 0.0)
                ax.plot(step, bound, marker, ms=7, color=f"C{lv}", mfc="none")
        label = f"{centre:g} Hz"
        if math.isfinite(result["H"][c]):
            label += f": H = {result['H'][c]:.2f} ± {result['H_err'][c]:.2f}"
        handles.append(Line2D([], [], ls="none", marker=marker, color="0.3", ms=7, label=label))
    if unresolved:
        handles.append(Line2D([], [], ls="none", marker="o", color="0.3", mfc="none", ms=7,
                              label=f"not resolved: S2 + {fs.Z_RESOLVED:g} SE (upper bound)"))
    ax.set(xscale="log", yscale="log", xlabel="grid step (Hz)", ylabel=r"$S_2$ (mm$^4$/s$^2$)")
    ax.set_xticks(steps, [f"{s:g}" for s in steps])
    ax.xaxis.set_minor_locator(NullLocator())
    ax.set_title("noise-corrected mean squared increment of D between neighbouring grid points "
                 "(colour: the level, as in its panel)", fontsize=10)
    ax.legend(handles=handles)
