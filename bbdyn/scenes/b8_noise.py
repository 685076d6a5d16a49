"""Scene B8: D(f) under random restitution, and which structure survives (docs/noise.md).

The restitution coefficients are drawn afresh for every collision with amplitude eta
(``Params.eta``, docs/model.md "Noise").  Two parts, each a set of resumable scans:

* D(f) over the paper's range at each eta of ``etas`` (``bbdyn.scans.cache.diffusion_scan``,
  the scan of S3 at that eta).  For each peak of ``PEAKS`` its *prominence*, the mean of D
  over the peak's window minus the mean over its flanks (standard error from the points'
  errors, every point having its own particles): the peak *survives* at eta while the
  prominence exceeds ``Z_SURVIVE`` standard errors; its ratio to the prominence at eta = 0
  says how much of it is left.
* The fine-structure statistic of scene B6 at each eta of ``fine_etas``: one level of
  ``points`` frequencies of step ``step`` around ``centre`` (B6's finest level, its scan
  ``bbdyn.scenes.b6_fine_structure.run_points``), tested by
  ``bbdyn.scans.fine_structure.level_test``: the noise-corrected mean squared increment S2
  of D between neighbouring frequencies and the p-value of "D is linear across the window".
  The fine structure is *washed out* from the smallest eta from which on no level shows
  structure (p >= ``P_STRUCTURE``).

Seeds: a point's initial conditions and its noise key come from the point's seed
(``bbdyn.scans.runner.point_seed``: the scan seed and f), the same at every eta, so the
particles start alike and only the noise differs.
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.flat.tongues import tongue_intervals
from bbdyn.params import Params
from bbdyn.results import Result, make_meta
from bbdyn.scans import fine_structure as fs
from bbdyn.scans.cache import diffusion_scan, setting_grid
from bbdyn.scans.frequency import scan_cpu_forecast
from bbdyn.scenes import b6_fine_structure as b6
from bbdyn.scenes import figure_axes

TITLE = "D(f) under random restitution: which peaks and which fine structure survive noise"
__all__ = ["TITLE", "QUICK", "MEDIUM", "FULL", "PEAKS", "compute", "cost", "draw"]

_GRID = {"f_start": 49.8, "f_stop": 95.0}
_FINE = {"centre": 85.2, "step": 0.002}
#: Seconds to a minute on 2 cores: every output, nothing resolved.
QUICK = {
    **_GRID,
    "f_step": 1.0,
    "etas": (0.0, 0.1),
    "n": 20,
    "t": 5.0,
    **_FINE,
    "points": 5,
    "fine_etas": (0.0, 0.01),
    "fine_n": 50,
}
#: The documented run (docs/noise.md), sized to about 15 CPU minutes: the paper's grid with
#: 200 particles per point, and B6's finest level with a quarter of B6's particles.
MEDIUM = {
    **_GRID,
    "f_step": 0.2,
    "etas": (0.0, 0.01, 0.05, 0.2),
    "n": 200,
    "t": 20.0,
    **_FINE,
    "points": 21,
    "fine_etas": (0.0, 1e-4, 1e-3, 1e-2, 0.1),
    "fine_n": 10000,
}
#: The paper's ensemble size on its grid and B6's FULL particles at its finest level; cost
#: extrapolated from MEDIUM in its key numbers.
FULL = {**MEDIUM, "n": 1000, "fine_n": 40000}

#: Peaks of D(f) (Hz): name -> (window, flanks).  "1:1": the 1/1 resonance and its
#: coexisting attractors (regime b, docs/classification.md) against the low plateau of
#: regime c; "77 Hz": the small peak of the reference paper near 77 Hz; "3:1": the peak at
#: the former 3/1 tongue, bbdyn's largest, against its sides.
PEAKS = {
    "1:1": ((57.0, 66.0), ((69.0, 76.0),)),
    "77 Hz": ((76.6, 77.2), ((74.0, 76.4), (77.4, 79.0))),
    "3:1": ((88.0, 91.0), ((80.0, 87.0), (92.0, 95.0))),
}
#: A peak survives while its prominence exceeds this many standard errors.
Z_SURVIVE = 3.0
#: Colours of the eta curves (cycled).
ETA_COLOURS = ("k", "tab:blue", "tab:green", "tab:red", "tab:purple", "tab:brown")


class NoiseResult(Result):
    """Arrays: ``f`` (n_f,) Hz, ``etas`` (k,), ``D``, ``D_err`` (k, n_f) mm^2/s, ``cpu_s``
    (k, n_f) s per point, ``tongues`` (m, 3) ``(k, f_lo, f_hi)`` Hz; the fine level:
    ``fine_f`` (p,) Hz, ``fine_etas`` (j,), ``fine_D``, ``fine_D_err`` (j, p), ``fine_cpu_s``
    (j, p); per fine eta (j,): ``chi2``, ``dof``, ``p``, ``S2``, ``S2_err`` (mm^4/s^2).
    ``meta["summary"]``: prominences and survival per peak and eta, the fine structure per
    eta, the washout eta and the cost (``summarize``)."""

    kind = "scene_b8"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def _eta_key(eta: float) -> str:
    return f"{eta:g}"


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> NoiseResult:
    """Run (or resume) the scans of ``settings`` and summarize them (module docstring)."""
    start = time.perf_counter()
    t = float(settings["t"])
    rows = []
    for eta in settings["etas"]:
        grid = {k: settings[k] for k in ("f_start", "f_stop", "f_step", "n")}
        scan = diffusion_scan({**grid, "t": t, "eta": float(eta)}, seed, out_dir, progress)
        rows.append((scan["D"], scan["D_se"], scan.point_cpu_s()))
    f = setting_grid(settings)
    arrays = {"f": f, "etas": np.asarray(settings["etas"], dtype=float)}
    arrays.update(
        {k: np.array([r[i] for r in rows]) for i, k in enumerate(("D", "D_err", "cpu_s"))}
    )
    arrays["tongues"] = tongue_intervals(Params(f=60.0), float(f.min()), float(f.max()))
    arrays.update(_fine(settings, seed, out_dir, progress))
    meta = make_meta(
        Params(f=float(f[0])),
        seed=seed,
        wall_s=time.perf_counter() - start,
        n=int(settings["n"]),
        t=t,
        fine_n=int(settings["fine_n"]),
    )
    meta["params"].pop("f")  # f is scanned; eta is the row's (``etas``)
    result = NoiseResult(arrays, meta)
    result.meta["summary"] = summarize(result, settings)
    result.meta["key_numbers"] = key_numbers(result)
    result.meta["tables"] = {"peaks": peak_table(result), "fine": fine_table(result)}
    return result


def _fine(settings: dict, seed: int, out_dir, progress) -> dict[str, np.ndarray]:
    """B6's level test of the fine grid at each eta of ``fine_etas``."""
    tests, rows = [], []
    for eta in settings["fine_etas"]:
        level = {
            "centres": (settings["centre"],),
            "steps": (settings["step"],),
            "points": settings["points"],
            "n": settings["fine_n"],
            "t": settings["t"],
            "eta": float(eta),
        }
        scan = b6.run_points(level, seed, out_dir, progress)
        rows.append((scan["D"], scan["D_se"], scan.point_cpu_s()))
        tests.append(fs.level_test(scan["D"], scan["D_se"]))
        fine_f = scan.values
    out = {"fine_f": fine_f, "fine_etas": np.asarray(settings["fine_etas"], dtype=float)}
    for i, k in enumerate(("fine_D", "fine_D_err", "fine_cpu_s")):
        out[k] = np.array([r[i] for r in rows])
    for k in ("chi2", "dof", "p", "S2", "S2_err"):
        out[k] = np.array([test[k] for test in tests])
    return out


def _window_mean(f, D, err, windows) -> tuple[float, float]:
    """Mean of D over the grid points in ``windows`` ((lo, hi) Hz, closed) and its standard
    error; NaN if no point falls in them."""
    sel = np.zeros(f.size, dtype=bool)
    for lo, hi in windows:
        sel |= (f >= lo - 1e-9) & (f <= hi + 1e-9)
    if not sel.any():
        return math.nan, math.nan
    return float(D[sel].mean()), float(math.sqrt(np.sum(err[sel] ** 2)) / sel.sum())


def prominence(f, D, err, peak: str) -> dict:
    """Prominence of ``PEAKS[peak]`` in D(f): window mean minus flank mean, its standard
    error, z and whether it survives (z > ``Z_SURVIVE``)."""
    window, flanks = PEAKS[peak]
    top, top_se = _window_mean(f, D, err, (window,))
    side, side_se = _window_mean(f, D, err, flanks)
    value, se = top - side, math.hypot(top_se, side_se)
    z = value / se if se > 0 else (math.inf if value > 0 else 0.0)
    return {
        "prominence": {"value": value, "se": se},
        "window_mean": top,
        "flank_mean": side,
        "z": z,
        "survives": bool(z > Z_SURVIVE),
    }


def summarize(result: Result, settings: dict) -> dict:
    """The numbers docs/noise.md quotes: per peak and eta the prominence (and its ratio to
    eta = 0); per fine eta the rms increment and the test; the washout eta; the cost."""
    f, etas = result["f"], result["etas"]
    peaks = {}
    for name in PEAKS:
        rows = {
            _eta_key(eta): prominence(f, result["D"][i], result["D_err"][i], name)
            for i, eta in enumerate(etas)
        }
        ref = rows[_eta_key(etas[0])]["prominence"]["value"] if etas[0] == 0 else math.nan
        for row in rows.values():
            row["ratio"] = row["prominence"]["value"] / ref if ref else math.nan
        peaks[name] = rows
    fine = {}
    for j, eta in enumerate(result["fine_etas"]):
        s2, err, p = (float(result[k][j]) for k in ("S2", "S2_err", "p"))
        fine[_eta_key(eta)] = {
            "S2": {"value": s2, "se": err},
            "p": p,
            "structure": bool(p < fs.P_STRUCTURE),
            "rms": math.sqrt(max(s2, 0.0)),
            "rms_bound": math.sqrt(max(s2 + fs.Z_RESOLVED * err, 0.0)),
            "median_D_err": float(np.median(result["fine_D_err"][j])),
        }
    return {
        "peaks": peaks,
        "fine": fine,
        "washout_eta": washout_eta(result),
        "cost": cost_summary(result, settings),
    }


def washout_eta(result: Result) -> float | None:
    """The smallest fine eta > 0 from which on (it and every larger one) the fine level shows
    no structure (p >= ``P_STRUCTURE``); None if structure remains at the largest."""
    etas, p = result["fine_etas"], result["p"]
    order = np.argsort(etas)
    found = None
    for j in order[::-1]:
        if p[j] < fs.P_STRUCTURE:
            break
        if etas[j] > 0:
            found = float(etas[j])
    return found


def _period_rate(cpu, f, n: int, t: float) -> float:
    """Median CPU seconds per particle and driving period of scan points."""
    return float(np.median(cpu / (np.asarray(f) * n * t)))


def cost_summary(result: Result, settings: dict) -> dict:
    """Measured CPU time of the two parts, the rates per particle and period, and the FULL
    setting's CPU time extrapolated from them (time ~ n t f per point)."""
    t = float(settings["t"])
    grid_rate = _period_rate(result["cpu_s"], result["f"], settings["n"], t)
    fine_rate = _period_rate(result["fine_cpu_s"], result["fine_f"], settings["fine_n"], t)
    out = {
        "grid_cpu_s": float(result["cpu_s"].sum()),
        "fine_cpu_s": float(result["fine_cpu_s"].sum()),
        "grid_points": int(result["cpu_s"].size),
        "fine_points": int(result["fine_cpu_s"].size),
        "grid_period_cpu_s": grid_rate,
        "fine_period_cpu_s": fine_rate,
    }
    full = FULL
    grid_sum = setting_grid(full).sum() * len(full["etas"])
    fine_sum = result["fine_f"].sum() * len(full["fine_etas"])
    out["full_cpu_s"] = float(
        grid_rate * full["n"] * t * grid_sum + fine_rate * full["fine_n"] * t * fine_sum
    )
    return out


def cost(settings: dict) -> dict[str, float]:
    """Forecast of the CPU time (s) of ``settings``: ``scan_cpu_forecast`` of every scan (the
    ensembles' rate without fast-forward is about that of the forecast's)."""
    grid = setting_grid(settings)
    fine = fs.nested_grid(settings["centre"], settings["step"], settings["points"])
    parts = [
        scan_cpu_forecast(
            grid.sum(), grid.size, settings["n"], settings["t"], workers=settings.get("workers")
        )
        for _ in settings["etas"]
    ]
    parts += [
        scan_cpu_forecast(
            fine.sum(),
            fine.size,
            settings["fine_n"],
            settings["t"],
            workers=settings.get("workers"),
        )
        for _ in settings["fine_etas"]
    ]
    return {k: float(sum(p[k] for p in parts)) for k in parts[0]}


def key_numbers(result: Result) -> dict:
    """Survival of each peak per eta, the fine structure per eta, the washout and the cost."""
    summary = result.meta["summary"]
    key = {}
    for name, rows in summary["peaks"].items():
        key[f"peak {name}: prominence (mm^2/s) by eta"] = "; ".join(
            f"eta {eta}: {r['prominence']['value']:.3g} +- {r['prominence']['se']:.2g} "
            f"({'survives' if r['survives'] else 'gone'}, {r['ratio']:.2f} of eta 0)"
            for eta, r in rows.items()
        )
    for eta, r in summary["fine"].items():
        key[f"fine structure at eta {eta}"] = fs.verdict(
            {"p": r["p"], "S2": r["S2"]["value"], "S2_err": r["S2"]["se"]}, "mm^2/s"
        )
    w = summary["washout_eta"]
    key["fine structure washed out from eta"] = "not within the etas run" if w is None else f"{w:g}"
    c = summary["cost"]
    key["CPU time (s): D(f) scans, fine level"] = f"{c['grid_cpu_s']:.0f}, {c['fine_cpu_s']:.0f}"
    key["FULL setting estimate"] = f"about {c['full_cpu_s'] / 3600:.2g} hours of one core"
    return key


def peak_table(result: Result) -> dict:
    """Prominence of each peak at each eta, as a data table (docs/_ext/datavalue.py)."""
    rows = []
    for name, by_eta in result.meta["summary"]["peaks"].items():
        for eta, r in by_eta.items():
            rows.append(
                [
                    name,
                    eta,
                    f"{r['window_mean']:.3g}",
                    f"{r['flank_mean']:.3g}",
                    f"{r['prominence']['value']:.3g} ± {r['prominence']['se']:.2g}",
                    f"{r['z']:.1f}",
                    f"{r['ratio']:.2f}",
                    "survives" if r["survives"] else "gone",
                ]
            )
    columns = [
        "peak",
        "eta",
        "window mean (mm^2/s)",
        "flank mean (mm^2/s)",
        "prominence (mm^2/s)",
        "z",
        "of eta = 0",
        "verdict",
    ]
    return {"columns": columns, "rows": rows}


def fine_table(result: Result) -> dict:
    """The fine level's test at each eta, as a data table."""
    rows = []
    for eta, r in result.meta["summary"]["fine"].items():
        rows.append(
            [
                eta,
                f"{r['median_D_err']:.2g}",
                f"{r['S2']['value']:.3g} ± {r['S2']['se']:.2g}",
                f"{r['p']:.2g}",
                f"{r['rms']:.3g}",
                f"{r['rms_bound']:.3g}",
                "structure" if r["structure"] else "not resolved",
            ]
        )
    columns = [
        "eta",
        "median D error (mm^2/s)",
        "S2 (mm^4/s^2)",
        "p",
        "rms increment (mm^2/s)",
        "2-sigma bound (mm^2/s)",
        "verdict",
    ]
    return {"columns": columns, "rows": rows}


def draw(result: Result, ax=None):
    """D(f) at every eta (error bands), the tongues and peak windows shaded; below, the fine
    level's rms increment against eta; with ``ax``, only D(f) there.  Returns the Figure."""
    if ax is not None:
        _draw_curves(result, ax)
        return ax.figure
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(11, 8.2), layout="constrained")
    grid = fig.add_gridspec(2, 2, height_ratios=(1.3, 1))
    _draw_curves(result, fig.add_subplot(grid[0, :]))
    _draw_fine_levels(result, fig.add_subplot(grid[1, 0]))
    _draw_fine_rms(result, fig.add_subplot(grid[1, 1]))
    return fig


def _draw_curves(result: Result, ax) -> None:
    _, ax = figure_axes(ax)
    for i, (k, lo, hi) in enumerate(result["tongues"]):
        ax.axvspan(
            lo,
            hi,
            color="tab:orange",
            alpha=0.12,
            lw=0,
            label="k/1 tongue of the flat ball" if i == 0 else None,
        )
        ax.text(
            0.5 * (lo + hi),
            1.0,
            f"{int(k)}/1",
            transform=ax.get_xaxis_transform(),
            ha="center",
            va="bottom",
            fontsize=8,
            color="tab:orange",
        )
    f = result["f"]
    for i, eta in enumerate(result["etas"]):
        colour = ETA_COLOURS[i % len(ETA_COLOURS)]
        D, err = result["D"][i], result["D_err"][i]
        ax.fill_between(f, D - err, D + err, color=colour, alpha=0.15, lw=0)
        ax.plot(f, D, "-", color=colour, lw=1.0, label=f"eta = {eta:g}")
    for i, (name, (window, _)) in enumerate(PEAKS.items()):
        ax.axvspan(*window, color="0.5", alpha=0.12, lw=0, label="peak windows" if i == 0 else None)
        ax.text(
            0.5 * sum(window),
            0.93,
            name,
            transform=ax.get_xaxis_transform(),
            ha="center",
            fontsize=8,
            color="0.3",
        )
    ax.set(xlabel="f (Hz)", ylabel=r"$D$ (mm$^2$/s)")
    n, t = result.meta["n"], result.meta["t"]
    ax.set_title(
        f"D(f) under random restitution (eta: relative amplitude), n = {n} particles, "
        f"t = {t:g} s; bands: 1 standard error",
        pad=14,
    )
    ax.legend(loc="upper left", fontsize=8)


def _draw_fine_levels(result: Result, ax) -> None:
    centre = float(np.median(result["fine_f"]))
    for j, eta in enumerate(result["fine_etas"]):
        colour = f"C{j}"
        ax.errorbar(
            result["fine_f"] - centre,
            result["fine_D"][j],
            result["fine_D_err"][j],
            fmt="o-",
            ms=2.5,
            lw=0.8,
            capsize=1.5,
            color=colour,
            label=f"eta = {eta:g}",
        )
    ax.set(xlabel=f"f - {centre:g} (Hz)", ylabel=r"$D$ (mm$^2$/s)")
    ax.set_title("the finest level of scene B6 at each eta", fontsize=10)
    ax.legend(fontsize=7, ncol=2)


def _draw_fine_rms(result: Result, ax) -> None:
    """rms increment sqrt(S2) against eta (eta = 0 drawn at the left edge); open markers:
    2-sigma upper bounds where the level shows no structure."""
    etas = result["fine_etas"]
    positive = etas[etas > 0]
    x0 = positive.min() / 10 if positive.size else 1e-5
    for j, eta in enumerate(etas):
        x = eta if eta > 0 else x0
        s2, err, p = result["S2"][j], result["S2_err"][j], result["p"][j]
        if p < fs.P_STRUCTURE:
            rms = math.sqrt(max(s2, 0.0))
            lo = math.sqrt(max(s2 - err, 0.0))
            hi = math.sqrt(max(s2 + err, 0.0))
            ax.errorbar(x, rms, [[rms - lo], [hi - rms]], fmt="o", color=f"C{j}", capsize=2)
        else:
            ax.plot(
                x,
                math.sqrt(max(s2 + fs.Z_RESOLVED * err, 0.0)),
                "v",
                mfc="none",
                color=f"C{j}",
                ms=8,
            )
    ax.set_xscale("log")
    ticks = [x0, *positive]
    ax.set_xticks(ticks, ["0", *(f"{e:g}" for e in positive)])
    ax.set(xlabel="eta", ylabel="rms increment (mm$^2$/s)")
    ax.set_title(
        f"filled: structure (p < {fs.P_STRUCTURE:g}); open: no structure, "
        f"{fs.Z_RESOLVED:g}-sigma bound",
        fontsize=10,
    )
