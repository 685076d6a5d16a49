"""Scene B9: distributions and the velocity autocorrelation at a few frequencies.

At each frequency (``bbdyn.correlations.correlations``: two independent reference ensembles,
averages after the transient ``t / 5``), one row of panels:

* (a) the displacement distribution ``P(x, tau)`` of ``x(s + tau) - x(s)`` (time origins s
  after the transient) at a few lags against the Gaussian of variance ``2 D tau`` (D the
  Einstein D), and (a') its excess kurtosis against tau with jackknife errors;
* (b) the density of the position within a tile, ``x mod d`` (wedges at 0 and d, the bump
  top at d/2), at collisions (IMPACT and STICK events) and at fixed times (the grid times);
* (c) the number of tiles crossed per flight (log scale: the tail);
* (d) ``C(tau) = <vx(s) vx(s + tau)>`` (binned, and exact at short lags from the collision
  records), with the running Green-Kubo integral against the Einstein D.

``result.meta["table"]`` is the Green-Kubo table (D_GK at the cutoff and its Cesaro mean,
Einstein D, both pulls z), ``meta["rows"]`` the same numbers per frequency with the
kurtosis peak and the jump-length tail.
"""

from __future__ import annotations

import time

import numpy as np

from bbdyn.correlations import correlations
from bbdyn.params import Params
from bbdyn.results import Result, make_meta

TITLE = (
    "Distributions and correlations: P(x, t) and kurtosis, position in a tile, tiles per "
    "flight, velocity autocorrelation and Green-Kubo D against Einstein D"
)
_F = (58.0, 70.2, 77.2, 85.2, 88.4)
QUICK = {"f": _F, "n": 40, "t": 20.0, "cutoff": 4.0, "times": (0.1, 1.0, 4.0),
         "record_particles": 10, "record_capacity": 5000}  # fmt: skip
FULL = {"f": _F, "n": 1000, "t": 100.0, "cutoff": 20.0, "times": (0.1, 1.0, 10.0),
        "record_particles": 50, "record_capacity": 40000}  # fmt: skip

#: Arrays of a ``CorrelationResult`` kept per frequency (suffix ``_<index>``).
PER_F = (
    "lag", "C", "C_se", "D_GK_running", "D_GK_running_se", "P_times", "P_edges", "P_density",
    "P_var", "kurtosis_lags", "kurtosis", "kurtosis_se", "tile_edges", "tile_density_impacts",
    "tile_density_times", "jump_counts", "exact_lag", "C_exact",
)  # fmt: skip
#: Numbers of a ``CorrelationResult``'s meta kept per frequency in ``meta["rows"]``.
NUMBERS = ("D_GK", "D_GK_se", "D_GK_mean", "D_GK_mean_se", "D", "D_se", "z", "z_mean",
           "cutoff", "two_E_x", "two_E_x_se", "flights", "collisions_recorded", "events",
           "wall_s")  # fmt: skip
#: Tiles per flight at which the tail ``P(|dl| >= k)`` is reported.
TAIL_AT = (1, 2, 3, 5, 10)


class SceneB9Result(Result):
    """Arrays: ``f`` (Hz) and, per frequency index i, the arrays ``PER_F`` of
    ``bbdyn.correlations.CorrelationResult`` with the suffix ``_i``.  ``meta["rows"]``:
    per frequency the numbers ``NUMBERS`` of its result, ``kurtosis_max`` (with ``_se`` and
    its lag, s), the jump tail ``P(|dl| >= k)`` for ``TAIL_AT`` and ``D_GK_swing`` (mm^2/s,
    the range of the running GK integral over the cutoffs in ``[T/2, T]``); ``meta["table"]``: the
    Green-Kubo table (columns, rows) for the docs; ``meta["jump_max"]``: the most tiles one
    recorded flight crossed, over all frequencies."""

    kind = "scene_b9"

    def plot(self, ax=None):
        return draw(self)


def _row(res, f: float) -> dict:
    """The stored numbers of one frequency's ``CorrelationResult``."""
    row = {"f": f, **{k: res.meta[k] for k in NUMBERS}}
    k = int(np.nanargmax(res["kurtosis"]))
    row["kurtosis_max"] = {"value": float(res["kurtosis"][k]), "se": float(res["kurtosis_se"][k])}
    row["kurtosis_max_lag"] = float(res["kurtosis_lags"][k])
    row["kurtosis_last"] = {"value": float(res["kurtosis"][-1]),
                            "se": float(res["kurtosis_se"][-1])}  # fmt: skip
    row["kurtosis_last_lag"] = float(res["kurtosis_lags"][-1])
    counts = res["jump_counts"]
    total = max(int(counts.sum()), 1)
    row["jump_tail"] = {str(j): float(counts[j:].sum() / total) for j in TAIL_AT}
    row["jump_max"] = int(np.flatnonzero(counts)[-1]) if counts.any() else 0
    late = res["lag"] >= 0.5 * res.meta["cutoff"]
    row["D_GK_swing"] = float(np.ptp(res["D_GK_running"][late]))
    return row


def gk_table(rows: list[dict]) -> dict:
    """The Green-Kubo table of ``meta["table"]`` (``data-table`` of docs/distributions.md)."""

    def pm(value, se):
        return f"{value:.3g} ± {se:.2g}"

    columns = ["f (Hz)", "D_GK (mm²/s)", "D_GK, mean over [T/2, T]", "Einstein D (mm²/s)",
               "z", "z (mean)", "cutoff T (s)"]  # fmt: skip
    body = [
        [f"{r['f']:g}", pm(r["D_GK"], r["D_GK_se"]), pm(r["D_GK_mean"], r["D_GK_mean_se"]),
         pm(r["D"], r["D_se"]), f"{r['z']:.2f}", f"{r['z_mean']:.2f}", f"{r['cutoff']:.3g}"]
        for r in rows
    ]  # fmt: skip
    return {"columns": columns, "rows": body}


def compute(settings: dict, seed: int = 0) -> SceneB9Result:
    """``correlations`` at each frequency of ``settings["f"]`` with the other settings."""
    start = time.perf_counter()
    keys = ("n", "t", "cutoff", "times", "record_particles", "record_capacity")
    arrays: dict = {"f": np.asarray(settings["f"], float)}
    rows = []
    for i, f in enumerate(arrays["f"]):
        res = correlations(Params(f=float(f)), seed=seed, **{k: settings[k] for k in keys})
        arrays.update({f"{name}_{i}": res[name] for name in PER_F})
        rows.append(_row(res, float(f)))
    key = {
        f"{r['f']:g} Hz": f"D_GK = {r['D_GK']:.3g} ± {r['D_GK_se']:.2g}, Einstein D = "
        f"{r['D']:.3g} ± {r['D_se']:.2g} mm^2/s (z = {r['z']:.2f}); kurtosis peak "
        f"{r['kurtosis_max']['value']:.3g} at {r['kurtosis_max_lag']:.2g} s"
        for r in rows
    }
    meta = make_meta(seed=seed, wall_s=time.perf_counter() - start, rows=rows,
                     table=gk_table(rows), key_numbers=key,
                     jump_max=max(r["jump_max"] for r in rows))  # fmt: skip
    meta["params"] = {k: v for k, v in Params(f=85.2).to_dict().items() if k != "f"}
    return SceneB9Result(arrays, meta)


def draw(result: Result):
    """One row of panels per frequency: (a) P(x, tau), (a') kurtosis, (b) position in a
    tile, (c) tiles per flight, (d) C(tau) and the running Green-Kubo integral."""
    import matplotlib.pyplot as plt

    f = result["f"]
    fig, axes = plt.subplots(len(f), 5, figsize=(19, 3.1 * len(f)), layout="constrained",
                             squeeze=False)  # fmt: skip
    for i, (fi, row) in enumerate(zip(f, result.meta["rows"], strict=True)):
        a = {name: result[f"{name}_{i}"] for name in PER_F}
        _draw_P(axes[i, 0], a, row)
        ax = axes[i, 1]
        ax.errorbar(a["kurtosis_lags"], a["kurtosis"], a["kurtosis_se"], fmt="o-", ms=3,
                    capsize=2)  # fmt: skip
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set(xscale="log", xlabel=r"$\tau$ (s)", ylabel="excess kurtosis")
        ax = axes[i, 2]
        mid = 0.5 * (a["tile_edges"][1:] + a["tile_edges"][:-1])
        ax.step(mid, a["tile_density_impacts"], where="mid", label="at collisions")
        ax.step(mid, a["tile_density_times"], where="mid", label="at fixed times")
        ax.set(xlabel="x mod d (mm)", ylabel="density (1/mm)", xlim=(0, a["tile_edges"][-1]))
        ax.legend(fontsize=7, frameon=False)
        ax = axes[i, 3]
        counts = a["jump_counts"]
        ax.bar(np.arange(counts.size), counts / max(counts.sum(), 1), color="C2")
        ax.set_xticks(np.arange(counts.size))
        ax.set(yscale="log", xlabel="tiles crossed per flight", ylabel="fraction of flights")
        _draw_C(axes[i, 4], a, row)
        axes[i, 0].set_title(f"f = {fi:g} Hz", loc="left", fontweight="bold")
    for j, label in enumerate(["(a) P(x, τ)", "(a') kurtosis", "(b) position in a tile",
                               "(c) jump lengths", "(d) C(τ), D_GK(T)"]):  # fmt: skip
        axes[0, j].set_title(label, loc="right", fontsize=9)
    return fig


def _draw_P(ax, a: dict, row: dict) -> None:
    """P(x, tau) at the stored lags (log density) with the Gaussians of variance 2 D tau."""
    for j, tau in enumerate(a["P_times"]):
        edges = a["P_edges"][j]
        mid = 0.5 * (edges[1:] + edges[:-1])
        dens = np.where(a["P_density"][j] > 0, a["P_density"][j], np.nan)
        ax.step(mid, dens, where="mid", color=f"C{j}", lw=0.9, label=f"τ = {tau:.3g} s")
        var = 2.0 * row["D"] * tau
        if var > 0:
            ax.plot(mid, np.exp(-(mid**2) / (2 * var)) / np.sqrt(2 * np.pi * var), "--",
                    color=f"C{j}", lw=0.8)  # fmt: skip
    positive = a["P_density"][a["P_density"] > 0]
    limits = (0.3 * positive.min(), 3.0 * positive.max()) if positive.size else (None, None)
    ax.set(yscale="log", xlabel=r"$x(s+\tau) - x(s)$ (mm)", ylabel="P (1/mm)", ylim=limits)
    ax.legend(fontsize=7, frameon=False, title="dashed: 2Dτ", title_fontsize=7)


def _draw_C(ax, a: dict, row: dict) -> None:
    """C(tau) (left axis) and the running GK integral with the Einstein band (right axis)."""
    lag = a["lag"]
    ax.fill_between(lag[1:], (a["C"] - a["C_se"])[1:], (a["C"] + a["C_se"])[1:],
                    color="C0", alpha=0.3, lw=0)  # fmt: skip
    ax.plot(lag[1:], a["C"][1:], "C0-", lw=0.8, label="C (binned)")
    ax.plot(a["exact_lag"][1:], a["C_exact"][1:], "k.", ms=2, label="C (exact, records)")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set(xscale="log", xlabel=r"$\tau$, $T$ (s)", ylabel=r"$C$ (mm$^2$/s$^2$)")
    twin = ax.twinx()
    run, se = a["D_GK_running"], a["D_GK_running_se"]
    twin.fill_between(lag[1:], (run - se)[1:], (run + se)[1:], color="C3", alpha=0.25, lw=0)
    twin.plot(lag[1:], run[1:], "C3-", lw=1.0, label=r"$\int_0^T C$")
    twin.axhspan(row["D"] - row["D_se"], row["D"] + row["D_se"], color="k", alpha=0.15, lw=0)
    twin.axhline(row["D"], color="k", lw=0.8, ls=":", label="Einstein D")
    twin.set_ylabel(r"$D$ (mm$^2$/s)", color="C3")
    ax.legend(fontsize=7, frameon=False, loc="lower left")
    twin.legend(fontsize=7, frameon=False, loc="upper left")
