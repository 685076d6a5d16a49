"""Scene B1: regime map -- regime label, number of attractors and basin fractions against f.

Each frequency is one point of a resumable, parallel ``bbdyn.scans.runner.run_scan``;
``regime_point`` runs ``bbdyn.classify.classify`` on the reference box there.
"""

from __future__ import annotations

import functools
import time

import numpy as np

from bbdyn.results import Result, make_meta

TITLE = "Regime map: regime, attractors and basin fractions against f (classifier, issue 6)"
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
#: The setting of docs/figures/B1_medium.png: 91 frequencies (~0.5 Hz), 200 particles x 50 s.
MEDIUM = {"f_min": 49.8, "f_max": 95.0, "n_f": 91, "n": 200, "t": 50.0, "workers": None,
          "scan_dir": None}  # fmt: skip
FULL = {"f_min": 49.8, "f_max": 95.0, "n_f": 227, "n": 1000, "t": 50.0, "workers": None,
        "scan_dir": None}  # fmt: skip


def regime_point(f: float, seed_sequence, *, n: int, t: float) -> dict:
    """Classification at ``f`` (Hz) as numbers for the scan (top-level: workers import it)."""
    from bbdyn import Params
    from bbdyn.classify import classify

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


def cost(settings: dict) -> float:
    """Upper estimate of the CPU time (s) of the classification scan of ``settings``."""
    from bbdyn.scans.frequency import cpu_estimate

    f_sum = 0.5 * (settings["f_min"] + settings["f_max"]) * settings["n_f"]
    return cpu_estimate(f_sum, settings["n"], settings["t"])


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> SceneB1Result:
    """Classify the reference box at ``n_f`` frequencies in ``[f_min, f_max]`` (one scan).

    The scan is kept (resumable) in ``bbdyn.scans.cache.scene_folder("regime", ...)`` under
    ``out_dir``, or in ``settings["scan_dir"]``.
    """
    from bbdyn.scans.cache import scene_folder
    from bbdyn.scans.runner import run_scan

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
    """Regime bands, number of attractors and stacked basin fractions; returns the Figure."""
    import matplotlib.pyplot as plt

    if ax is None:
        fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    else:
        fig, axes = ax.figure, [ax, ax.twinx()]
    f = result["f"]
    order = np.argsort(f)
    f, reg = f[order], result["regime"][order].astype(int)
    step = np.median(np.diff(f)) if f.size > 1 else 1.0
    colors = plt.get_cmap("tab10")
    for i, lab in enumerate(LABELS):
        sel = reg == i
        if sel.any():
            axes[0].bar(f[sel], 1.0, width=step, color=colors(i), alpha=0.35, label=lab)
    axes[0].plot(f, result["n_attractors"][order] / 4, "ko-", ms=3, label="attractors / 4")
    axes[0].plot(f, result["unsettled_fraction"][order], "rx", ms=4, label="unsettled")
    axes[0].set(ylim=(0, 1.05), ylabel="regime band")
    axes[0].legend(ncol=4, fontsize=7, loc="upper right")
    fr = result["fractions"][order]
    axes[1].stackplot(f, fr.T, labels=[f"attractor {i}" for i in range(fr.shape[1])], alpha=0.7)
    axes[1].set(xlabel="f (Hz)", ylabel="basin fraction", ylim=(0, 1))
    axes[1].legend(fontsize=7, loc="lower right")
    return fig


def regime_bands(result: Result) -> list[tuple[float, float, str]]:
    """Runs of equal regime label as ``(f_lo, f_hi, label)`` bands (Hz), each band reaching
    half way to the neighbouring frequencies (for S3's shading)."""
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
