"""Cost model of the full S3-S5 frequency scan: `bbdyn bench scan-cost`.

Model.  A scan point at frequency f with ``n`` particles and ``t`` simulated seconds
costs ``n t c(f)`` CPU seconds, with ``c(f)`` the CPU time (s) per particle-second of a
run of that length.  ``c`` is measured at a few sampled frequencies as ``T(n_s, t_s) /
(n_s t_s)``, ``T`` the CPU time of ``diffusion_point`` (this process,
``time.process_time``, numba on one thread), median over ``repeats`` runs with different
seeds.  Runs as long as the scan's (``t_s = t`` = 200 s, the full setting): the cost per
particle-second is not constant in time (stick-release cycles are fast-forwarded once
they repeat, which takes a while), so a rate measured on short runs misses it (the
previous model, the difference of runs of 20 and 40 s, overestimated the 49.8-53 Hz band
by 90 %).  The point's set-up and fit are counted per particle (``1 / n_s`` of them;
small against ``n t c``).  Between the samples of one band (``BANDS``: regimes of
different cost) ``c`` is interpolated linearly in f; the band's prediction is the sum of
``n t c(f)`` over its grid points with the full ``n`` and ``t``, the total the sum over the
bands.

Error estimate.  (1) Realization and timing: the relative spread (max - min) / median of
the repeats (different particles).  (2) Interpolation: each interior sample of a band is
predicted from its two neighbours (leave one out); the rms relative miss over all bands is
the relative error of an interpolated point.  A band's relative error is the quadrature
sum of the two (its samples' worst spread); the total adds the bands' errors in
quadrature.  A band with a narrow expensive feature between its samples (a periodic
window) is underestimated beyond this estimate: more samples show it.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from bbdyn.reference.timing import single_thread
from bbdyn.results import Result, make_meta
from bbdyn.scans.frequency import N_SAMPLES, diffusion_point
from bbdyn.scans.runner import point_seed

__all__ = ["BANDS", "FULL", "QUICK", "agreement_sentence", "band_masks", "band_sums", "compute",
           "measured_bands", "measured_table", "predict",
           "predicted_vs_measured_table", "sample_frequencies",
           "table"]  # fmt: skip

#: Cost bands of the scan (Hz, grid points included at both ends): different regimes.

BANDS = ((49.8, 53.0), (53.2, 57.4), (57.6, 65.0), (65.2, 80.0), (80.2, 95.0))
#: The full S3-S5 scan: grid step (Hz), particles, simulated time (s).
F_STEP, FULL_N, FULL_T = 0.2, 1000, 200.0

TITLE = "Cost model of the full S3-S5 scan: CPU time per particle-second against f"
QUICK = {"samples": 20, "n": 8, "t": FULL_T, "repeats": 2}
FULL = {"samples": 40, "n": 16, "t": FULL_T, "repeats": 2}


def band_grid(lo: float, hi: float, step: float = F_STEP) -> np.ndarray:
    """Grid frequencies of one band, ``lo`` to ``hi`` included, rounded to 1e-9 Hz."""
    return np.round(lo + step * np.arange(math.floor((hi - lo) / step + 1e-9) + 1), 9)


def sample_frequencies(samples: int, bands=BANDS) -> list[np.ndarray]:
    """Sampled grid frequencies per band: both ends, the rest shared equally (widest first).

    ``samples`` >= 2 per band.  Within a band they are equally spaced, snapped to the grid.
    """
    if samples < 2 * len(bands):
        raise ValueError(f"samples must be >= {2 * len(bands)} (2 per band), got {samples}")
    spare = samples - 2 * len(bands)
    extra = np.full(len(bands), spare // len(bands))
    widest = np.argsort([lo - hi for lo, hi in bands], kind="stable")
    extra[widest[: spare % len(bands)]] += 1
    out = []
    for (lo, hi), m in zip(bands, extra + 2, strict=True):
        grid = band_grid(lo, hi)
        idx = np.unique(np.round(np.linspace(0, grid.size - 1, min(m, grid.size))).astype(int))
        out.append(grid[idx])
    return out


def predict(
    samples: list[np.ndarray], costs: list[np.ndarray], bands=BANDS, n=FULL_N, t=FULL_T
) -> np.ndarray:
    """Predicted CPU time (s) per band: ``sum over the band's grid of n t c(f)``.

    ``costs[i]`` holds ``c`` (CPU s per particle-second) at ``samples[i]``, the
    sampled frequencies of band ``i`` (increasing, including its ends); ``c`` is
    interpolated linearly in between.
    """
    out = []
    for (lo, hi), f_s, c_s in zip(bands, samples, costs, strict=True):
        grid = band_grid(lo, hi)
        out.append(n * t * float(np.sum(np.interp(grid, f_s, c_s))))
    return np.array(out)


def loo_rel_errors(samples: list[np.ndarray], costs: list[np.ndarray]) -> np.ndarray:
    """Relative misses of each interior sample predicted linearly from its neighbours."""
    misses = []
    for f_s, c_s in zip(samples, costs, strict=True):
        for j in range(1, len(f_s) - 1):
            guess = np.interp(f_s[j], (f_s[j - 1], f_s[j + 1]), (c_s[j - 1], c_s[j + 1]))
            misses.append((guess - c_s[j]) / c_s[j])
    return np.array(misses)


def point_cpu(f: float, n: int, t: float, seed: int) -> float:
    """CPU time (s) of ``diffusion_point`` at ``f`` with ``n`` particles, ``t`` s and the
    scan's seed ``point_seed(seed, f)``.

    The MSD samples are as far apart as in the full scan (``t / (n_samples - 1)``
    = ``FULL_T / (N_SAMPLES - 1)``, at least 11 samples): periodic stick-release
    cycles are fast-forwarded only between samples, so denser samples would cost more.
    """

    n_samples = max(11, round(t / FULL_T * (N_SAMPLES - 1)) + 1)
    start = time.process_time()
    diffusion_point(f, point_seed(seed, f), n=n, t=t, n_samples=n_samples, n_boot=10)
    return time.process_time() - start


class ScanCostResult(Result):
    """Scan cost model: sampled ``f``, ``c`` (CPU s per particle-second) and its spread;
    ``meta["rows"]`` one per band and the total (``predicted_cpu_s``, ``error_cpu_s``)."""

    kind = "bench_scan_cost"

    def plot(self, ax=None):
        """c(f) at the samples (with spread) and the bands."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        f, c, spread = self["f"], self["cost"], self["spread"]
        ax.errorbar(f, 1e6 * c, yerr=np.nan_to_num(1e6 * spread * np.abs(c) / 2), fmt="o-", ms=3)
        for lo, _ in BANDS[1:]:
            ax.axvline(lo - 0.1, color="0.7", lw=0.8)
        ax.set_xlabel("f (Hz)")
        ax.set_ylabel("CPU µs per particle-second (1 thread)")
        return ax


def compute(
    settings: dict[str, Any],
    *,
    log: Callable[[str], None] | None = None,
    timer: Callable[[float, int, float, int], float] = point_cpu,
) -> ScanCostResult:
    """Measure ``c`` at the sampled frequencies with ``timer(f, n, t, seed) -> CPU s`` and
    predict.

    ``settings``: ``samples`` (>= 10), ``n``, ``t`` (s), ``repeats`` (seeds 0, 1, ...).  One
    untimed warm-up call first (numba compilation).
    """
    log = log or (lambda msg: None)
    unknown = sorted(set(settings) - set(FULL))
    if unknown:
        raise ValueError(
            f"scan-cost settings take {sorted(FULL)}, not {unknown} (--impacts and --long-run "
            "apply to the flat and billiard targets): leave them out"
        )
    wall = time.perf_counter()
    n, t, repeats = int(settings["n"]), float(settings["t"]), int(settings["repeats"])
    if n < 2 or not t > 0 or repeats < 1:
        raise ValueError(f"need n >= 2, t > 0 s and repeats >= 1; got n={n}, t={t}, {repeats=}")
    single_thread()
    samples = sample_frequencies(int(settings["samples"]))
    timer(float(samples[0][0]), 2, min(t, 1.0), 0)  # compile and warm up; not counted
    costs, spreads = [], []
    for f_s in samples:
        c_band, s_band = [], []
        for f in f_s:
            runs = [timer(float(f), n, t, seed) / (n * t) for seed in range(repeats)]
            med = statistics.median(runs)
            c_band.append(med)
            s_band.append((max(runs) - min(runs)) / abs(med) if med else math.inf)
            log(f"scan-cost: {f:.1f} Hz: {1e6 * med:.1f} µs per particle-second")
        costs.append(np.array(c_band))
        spreads.append(np.array(s_band))
    pred = predict(samples, costs)
    loo = loo_rel_errors(samples, costs)
    interp_rel = float(np.sqrt(np.mean(loo**2))) if loo.size else math.nan
    rows = []
    for (lo, hi), p, s in zip(BANDS, pred, spreads, strict=True):
        rel = math.hypot(float(s.max()), interp_rel)
        rows.append(_row(f"{lo:.1f}-{hi:.1f} Hz", p, rel * p, pred.sum()))
    total_err = math.sqrt(sum(r["error_cpu_s"] ** 2 for r in rows))
    rows.append(_row("total", pred.sum(), total_err, pred.sum()))
    arrays = {
        "f": np.concatenate(samples),
        "cost": np.concatenate(costs),
        "spread": np.concatenate(spreads),
        "loo_rel": loo,
    }
    meta = make_meta(
        wall_s=time.perf_counter() - wall,
        settings=settings,
        rows=rows,
        full={"f_step": F_STEP, "n": FULL_N, "t": FULL_T, "bands": [list(b) for b in BANDS]},
        interp_rel_error=interp_rel,
    )
    return ScanCostResult(arrays, meta)


def _row(band: str, cpu: float, err: float, total: float) -> dict[str, Any]:
    return {
        "method": "scan-cost",
        "setting": band,
        "predicted_cpu_s": float(cpu),
        "error_cpu_s": float(err),
        "share": float(cpu / total),
    }


def table(result: ScanCostResult) -> str:
    """Prediction per band and in total, with the model's error estimate."""
    s = result.meta["settings"]
    lines = [
        f"full scan (f step {F_STEP} Hz, n={FULL_N}, t={FULL_T} s) from {len(result['f'])} "
        f"sampled frequencies at n={s['n']}, t={s['t']} s, median of {s['repeats']} seeds:",
        f"{'band':<16} {'CPU s':>9} {'+-':>7} {'share':>6}",
    ]
    for r in result.meta["rows"]:
        lines.append(
            f"{r['setting']:<16} {r['predicted_cpu_s']:>9.4g} {r['error_cpu_s']:>7.2g} "
            f"{r['share']:>6.1%}"
        )
    lines.append(f"interpolation error (leave one out, rms): {result.meta['interp_rel_error']:.1%}")
    lines.append("samples (Hz: CPU µs per particle-second):")
    pairs = zip(result["f"], result["cost"], strict=True)
    lines.append("  ".join(f"{f:.1f}: {1e6 * c:.3g}" for f, c in pairs))
    return "\n".join(lines)


def predicted_vs_measured_table(
    predicted: list[list[dict]], measured: list[list[dict]], labels: list[str]
) -> str:
    """Markdown table: per band, each prediction (``meta["rows"]`` of a result, +- its
    error) beside the measured CPU s of the scan it predicts (``points`` with ``f`` and
    ``cpu_s``), one pair of columns per label, and the ratio of the first to the last of each.
    """
    sums = [band_sums(points) for points in measured]
    head = [f"predicted, {x} | measured, {x}" for x in labels]
    lines = [
        f"| band (Hz) | {' | '.join(head)} | predicted ratio | measured ratio |",
        "|---|" + "---:|" * (2 * len(labels) + 2),
    ]
    names = [f"{lo:g}-{hi:g}" for lo, hi in BANDS] + ["all"]
    for i, name in enumerate(names):
        cells, pred, meas = [], [], []
        for rows, scan_sums in zip(predicted, sums, strict=True):
            r = rows[i]
            pred.append(r["predicted_cpu_s"])
            meas.append(scan_sums[i])
            cells += [f"{r['predicted_cpu_s']:.0f} +- {r['error_cpu_s']:.0f}",
                      f"{scan_sums[i]:.0f}"]  # fmt: skip
        ratios = f"{pred[0] / pred[-1]:.2f} | {meas[0] / meas[-1]:.2f}"
        lines.append(f"| {name} | {' | '.join(cells)} | {ratios} |")
    return "\n".join(lines)


def band_sums(points: list[dict], bands=BANDS) -> list[float]:
    """CPU s of the points of each band (ends included), then of all of them."""
    _, cpu, masks = band_masks(points, bands)
    return [float(cpu[m].sum()) for m in masks] + [float(cpu.sum())]


def band_masks(points: list[dict], bands=BANDS):
    """``f`` (Hz), ``cpu_s`` and one mask per band of ``bands`` (ends included) of the points
    of ``bbdyn scan --json``."""
    f = np.array([p["f"] for p in points], dtype=float)
    cpu = np.array([p["cpu_s"] for p in points], dtype=float)
    return f, cpu, [(f >= lo - 1e-9) & (f <= hi + 1e-9) for lo, hi in bands]


def measured_bands(points: list[dict], bands=BANDS) -> list[dict[str, Any]]:
    """Where a real scan's time went: per band of ``bands`` and then for all points
    (``band`` "all"), the summed ``cpu_s`` of the points of ``bbdyn scan --json``
    (``points``: dicts with ``f`` in Hz and ``cpu_s``), its share, the number of points and
    the costliest point (``costliest_cpu_s`` at ``costliest_f``; None in an empty band)."""
    f, cpu, masks = band_masks(points, bands)
    names = [f"{lo:g}-{hi:g}" for lo, hi in bands] + ["all"]
    out = []
    for name, sel in zip(names, [*masks, np.ones(f.size, bool)], strict=True):
        top = int(np.argmax(np.where(sel, cpu, -1.0)))
        out.append({"band": name, "cpu_s": float(cpu[sel].sum()),
                    "share": float(cpu[sel].sum() / cpu.sum()), "points": int(sel.sum()),
                    "costliest_cpu_s": float(cpu[top]) if sel.any() else None,
                    "costliest_f": float(f[top]) if sel.any() else None})  # fmt: skip
    return out


def measured_table(points: list[dict], bands=BANDS) -> str:
    """``measured_bands`` as a markdown table (band, CPU s, share, points, costliest point)."""
    lines = ["| band (Hz) | CPU s | share | points | costliest point |", "|---|---:|---:|---:|---|"]
    rows = measured_bands(points, bands)
    for r in rows[:-1]:
        costliest = "-"
        if r["points"]:
            costliest = f"{r['costliest_cpu_s']:.1f} s at {r['costliest_f']:g} Hz"
        lines.append(f"| {r['band']} | {r['cpu_s']:.0f} | {r['share']:.0%} | {r['points']} "
                     f"| {costliest} |")  # fmt: skip
    lines.append(f"| all | {rows[-1]['cpu_s']:.0f} | 100% | {rows[-1]['points']} | |")
    return "\n".join(lines)


def measured_speedup_table(before: list[dict], after: list[dict], bands=BANDS) -> str:
    """Two real scans of the same grid compared per band of ``bands``: the summed ``cpu_s``
    of each (points of ``bbdyn scan --json``) and their ratio, before / after (markdown)."""
    f_old, f_new = (np.sort([p["f"] for p in scan]) for scan in (before, after))
    if not np.array_equal(f_old, f_new):
        raise ValueError("the two scans must have the same frequency grid")
    lines = ["| band (Hz) | CPU s before | CPU s after | before / after |", "|---|---:|---:|---:|"]
    names = [f"{lo:g}-{hi:g}" for lo, hi in bands] + ["all"]
    for name, a, b in zip(names, band_sums(before, bands), band_sums(after, bands), strict=True):
        lines.append(f"| {name} | {a:.0f} | {b:.0f} | {a / b:.2f} |")
    return "\n".join(lines)


def agreement_sentence(before: list[dict], after: list[dict]) -> str:
    """How two real scans of the same grid and seeds differ, point by point (a sentence):
    the points whose D, E and E_x are all equal, and the largest differences, of D in units of
    its standard error and of E and E_x relative to their value."""
    old = {p["f"]: p for p in before}
    pairs = [(old[p["f"]], p) for p in after]
    if len(pairs) != len(before):
        raise ValueError("the two scans must have the same frequency grid")
    same = sum(all(a[k] == b[k] for k in ("D", "E", "E_x")) for a, b in pairs)

    def worst(key, scale):
        diffs = [abs(a[key] - b[key]) for a, b in pairs]
        return max(d / scale(a, b) if d else 0.0 for d, (a, b) in zip(diffs, pairs, strict=True))

    d_se = worst("D", lambda a, b: max(a["D_se"], b["D_se"]))
    rel = {k: worst(k, lambda a, b, k=k: max(abs(a[k]), abs(b[k]))) for k in ("E", "E_x")}
    return (f"{same} of {len(pairs)} points have the same D, E and E_x; elsewhere D differs by "
            f"at most {d_se:.1g} of its standard error, E by {rel['E']:.1g} and E_x by "
            f"{rel['E_x']:.1g} of their values")  # fmt: skip


def draw(result: ScanCostResult):
    """Figure: c(f) at the samples."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    result.plot(ax)
    total = result.meta["rows"][-1]
    ax.set_title(
        f"predicted full scan: {total['predicted_cpu_s']:.3g} +- {total['error_cpu_s']:.2g} CPU s",
        fontsize=9,
    )
    fig.tight_layout()
    return fig
