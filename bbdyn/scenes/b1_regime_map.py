"""Scene B1: regime map -- regime label, number of attractors and basin fractions against f.

Each frequency is one point of a resumable, parallel ``bbdyn.scans.runner.run_scan``;
``regime_point`` runs ``bbdyn.classify.classify`` on the reference box there.
"""

from __future__ import annotations

import functools
import time

import numpy as np

from bbdyn import Params
from bbdyn.classify import REGIMES, classify
from bbdyn.results import Result, make_meta
from bbdyn.scans.cache import scene_folder
from bbdyn.scans.frequency import CLASSIFY_PERIOD_CPU_S, scan_cpu_forecast
from bbdyn.scans.runner import run_scan

TITLE = "Regime map: regime, attractors and basin fractions against f"
#: Regime labels in the order of the stored codes.
LABELS = ("a", "b(i)", "b(ii)", "c", "d", "other")
#: Basin fractions stored per point (largest first); more attractors are summed in the last.
MAX_ATTRACTORS = 4
QUICK = {
    "f_min": 50.0,
    "f_max": 94.0,
    "n_f": 12,
    "n": 60,
    "t": 6.0,
    "workers": None,
    "scan_dir": None,
}
#: A cheaper map: 91 frequencies (~0.5 Hz), 200 particles x 50 s (docs/figures has FULL).
MEDIUM = {"f_min": 49.8, "f_max": 95.0, "n_f": 91, "n": 200, "t": 50.0, "workers": None,
          "scan_dir": None}  # fmt: skip
FULL = {"f_min": 49.8, "f_max": 95.0, "n_f": 227, "n": 1000, "t": 50.0, "workers": None,
        "scan_dir": None}  # fmt: skip


def regime_point(f: float, seed_sequence, *, n: int, t: float) -> dict:
    """Classification at ``f`` (Hz) as numbers for the scan (top-level: workers import it)."""
    seed = int(seed_sequence.generate_state(1)[0])
    s = classify(Params(f=f), t=t, n=n, seed=seed, threads=1).summary
    fractions = np.zeros(MAX_ATTRACTORS)
    for i, att in enumerate(s["attractors"]):
        fractions[min(i, MAX_ATTRACTORS - 1)] += att["fraction"]
    locked = [a["locking_k"] or 0 for a in s["attractors"]]
    return {
        "regime": float(LABELS.index(s["regime"])),
        "n_attractors": float(s["n_attractors"]),
        "ergodic": float(s["ergodic"]),
        "unsettled_fraction": s["unsettled_fraction"],
        "fractions": fractions,
        "locking_k": float(locked[0]) if locked else 0.0,
        "D_main": s["attractors"][0]["D"] if s["attractors"] else np.nan,
    }


class SceneB1Result(Result):
    """Arrays: ``f`` (Hz), ``regime`` (codes into ``LABELS``), ``n_attractors``, ``ergodic``,
    ``unsettled_fraction``, ``fractions`` (n_f, MAX_ATTRACTORS), ``locking_k``, ``D_main``."""

    kind = "scene_b1"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def cost(settings: dict) -> dict[str, float]:
    """Forecast of the CPU time (s) of the classification scan of ``settings``:
    ``bbdyn.scans.frequency.scan_cpu_forecast`` at a classification's cost per period."""
    f_sum = 0.5 * (settings["f_min"] + settings["f_max"]) * settings["n_f"]
    size = (f_sum, settings["n_f"], settings["n"], settings["t"])
    return scan_cpu_forecast(*size, period_cpu_s=CLASSIFY_PERIOD_CPU_S, workers=settings["workers"])


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> SceneB1Result:
    """Classify the reference box at ``n_f`` frequencies in ``[f_min, f_max]`` (one scan).

    The scan is kept (resumable) in ``bbdyn.scans.cache.scene_folder("regime", ...)`` under
    ``out_dir``, or in ``settings["scan_dir"]``.
    """
    start = time.perf_counter()
    freqs = np.round(np.linspace(settings["f_min"], settings["f_max"], settings["n_f"]), 6)
    point = functools.partial(regime_point, n=int(settings["n"]), t=float(settings["t"]))
    folder = scene_folder("regime", settings, seed, out_dir)
    scan = run_scan(freqs.tolist(), point, out_dir=folder, seed=seed,
                    workers=settings["workers"], progress=progress)  # fmt: skip
    arrays = {k: np.asarray(v) for k, v in scan.arrays.items()}
    counts = {lab: int(np.sum(arrays["regime"] == i)) for i, lab in enumerate(LABELS)}
    meta = make_meta(seed=seed, wall_s=time.perf_counter() - start,
                     key_numbers={"points per regime": counts})  # fmt: skip
    return SceneB1Result(arrays, meta)


def draw(result: Result, ax=None):
    """Regime strip, number of attractors and stacked basin fractions against f (Hz), the
    title naming the f-range, n and t; returns the Figure.  With ``ax`` given, only the
    basin fractions are drawn there."""
    import matplotlib.pyplot as plt

    order = np.argsort(result["f"])
    f = result["f"][order]
    if ax is not None:
        _draw_fractions(ax, result, order)
        return ax.figure
    fig, (ax_reg, ax_n, ax_fr) = plt.subplots(
        3, 1, figsize=(10, 6.5), sharex=True, height_ratios=(0.6, 1, 2), layout="constrained"
    )
    draw_regime_strip(ax_reg, result)
    ax_n.step(f, result["n_attractors"][order], where="mid", color="k", lw=1)
    ax_n.plot(f, result["n_attractors"][order], "ko", ms=2.5)
    ax_n.yaxis.set_major_locator(plt.MaxNLocator(integer=True))
    ax_n.set(ylabel="attractors", ylim=(-0.3, max(1, np.max(result["n_attractors"])) + 0.5))
    _draw_fractions(ax_fr, result, order)
    ax_fr.set_xlabel("f (Hz)")
    ax_reg.set_title(_title(result, f))
    return fig


def _title(result: Result, f: np.ndarray) -> str:
    """The figure title: f-range and count (Hz), ensemble size n and run time t (s)."""
    s = result.meta.get("settings", {})
    run = f"n = {s['n']} particles, t = {s['t']:g} s" if {"n", "t"} <= s.keys() else "n, t unknown"
    return f"Regime map, f = {f[0]:g}-{f[-1]:g} Hz ({f.size} frequencies), {run} per frequency"


def draw_regime_strip(ax, result: Result, **legend_kw) -> None:
    """The regime bands of ``result`` (``regime_bands``) as coloured spans along f (Hz); the
    legend (placed right of ``ax`` unless ``legend_kw`` says otherwise) names and explains
    the regimes drawn."""
    from matplotlib.patches import Patch

    colors = _regime_colors()
    bands = regime_bands(result)
    for lo, hi, label in bands:
        ax.axvspan(lo, hi, color=colors[label], lw=0)
    drawn = [lab for lab in LABELS if any(band[2] == lab for band in bands)]
    handles = [Patch(color=colors[lab], label=f"{lab}: {REGIMES[lab]}") for lab in drawn]
    place = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.05)} | legend_kw
    ax.legend(handles=handles, fontsize=7, frameon=False, title="regime (B1 classifier)",
              title_fontsize=8, alignment="left", **place)  # fmt: skip
    ax.set(ylim=(0, 1), yticks=[], ylabel="regime")


def _regime_colors() -> dict[str, tuple]:
    """A fixed colour per regime label (the same in every figure)."""
    import matplotlib.pyplot as plt

    cmap = plt.get_cmap("tab10")
    return {lab: cmap([0, 1, 2, 3, 4, 7][i]) for i, lab in enumerate(LABELS)}


def _draw_fractions(ax, result: Result, order: np.ndarray) -> None:
    """Basin fractions stacked from the largest attractor up, the unsettled fraction on top;
    only series that are non-zero somewhere are drawn and listed."""
    f = result["f"][order]
    fr = result["fractions"][order]
    names = [f"attractor {i + 1}" for i in range(fr.shape[1])]
    names[-1] = f"attractors {fr.shape[1]}+" if fr.shape[1] == MAX_ATTRACTORS else names[-1]
    series = [(fr[:, i], name, f"C{i}") for i, name in enumerate(names)]
    series.append((result["unsettled_fraction"][order], "unsettled", "0.55"))
    drawn = [s for s in series if np.any(s[0] > 0)]
    ax.stackplot(f, [s[0] for s in drawn], labels=[s[1] for s in drawn],
                 colors=[s[2] for s in drawn], alpha=0.8, lw=0)  # fmt: skip
    ax.set(ylabel="basin fraction", ylim=(0, 1))
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)


def regime_bands(result: Result) -> list[tuple[float, float, str]]:
    """Runs of equal regime label as ``(f_lo, f_hi, label)`` bands (Hz), each band reaching
    half way to the neighbouring frequencies (drawn by ``draw_regime_strip``)."""
    order = np.argsort(result["f"])
    f, codes = result["f"][order], result["regime"][order].astype(int)
    edges = np.concatenate([[f[0]], 0.5 * (f[1:] + f[:-1]), [f[-1]]])
    bands = []
    start = 0
    for i in range(1, f.size + 1):
        if i == f.size or codes[i] != codes[start]:
            bands.append((float(edges[start]), float(edges[i]), LABELS[codes[start]]))
            start = i
    return bands
