"""Statistical cost of the diffusion coefficient (scene B3): standard error against CPU time.

At a few frequencies the reference ensemble is run with growing ensemble size n
(at fixed time t) and with growing time t (at fixed n); each run gives D with its
standard error (``bbdyn.diffusion.einstein_D``) and its CPU time.  The fitted
exponents of ``D_err ~ n^a`` and ``D_err ~ t^b`` tell a user how to spend a budget.

For a diffusive walk the per-particle MSD slope over the window [t/2, t] fluctuates
by O(D) whatever t (x^2 ~ 2 D t fluctuates by O(D t) over a window of length t/2),
so ``a = -1/2`` and ``b = 0``: a longer run does not shrink the statistical error;
it only removes the transient bias.  The cost grows like n t, hence the cheapest
error comes from many particles over the shortest t that is past the transient.
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.ensemble import ensemble
from bbdyn.params import Params
from bbdyn.results import Result, make_meta

__all__ = ["StatCostResult", "statcost", "loglog_slope"]

def loglog_slope(x, y) -> float:
    """Least-squares slope of log y against log x (the exponent of a power law)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    ok = (x > 0) & (y > 0)
    if np.count_nonzero(ok) < 2:
        return math.nan
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def _one_run(params: Params, n: int, t: float, seed: int) -> tuple[float, float, float]:
    """D, its standard error (mm^2/s) and the CPU time (s) of one ensemble run."""
    start = time.process_time()
    res = ensemble(params, n=n, t=t, seed=seed, threads=1, observables=("displacement",))
    cpu = time.process_time() - start
    D, se = res.D()
    return float(D), float(se), cpu


def statcost(settings: dict, seed: int = 0) -> StatCostResult:
    """Standard error of D and CPU time against n and against t at a few frequencies.

    Parameters
    ----------
    settings : dict
        ``f`` (Hz), ``n`` (ensemble sizes at ``t_fixed``), ``t`` (run lengths in s at
        ``n_fixed``), ``n_fixed``, ``t_fixed`` (the settings of scene B3).
    seed : int
        Seed of the initial conditions (the same for every run: runs with more
        particles contain those of smaller runs).

    Returns
    -------
    StatCostResult
        Arrays ``f`` (k,), ``n`` (p,), ``t`` (q,); ``D_n, D_err_n, cpu_n`` (k, p) and
        ``D_t, D_err_t, cpu_t`` (k, q) in mm^2/s and CPU seconds; ``slope_n``, ``slope_t``
        (k,) the exponents of D_err against n and t.  CPU time is the process time of
        one numba thread, after compilation.
    """
    s = dict(settings)
    f, ns, ts = (np.asarray(s[k], dtype=float) for k in ("f", "n", "t"))
    if np.any(ns < 2) or np.any(ns != np.round(ns)):
        raise ValueError(f"n must hold integers >= 2, got {s['n']}")
    if np.any(ts <= 0):
        raise ValueError(f"t must hold times > 0 s, got {s['t']}")
    wall = time.perf_counter()
    _one_run(Params(f=float(f[0])), 2, 0.1, seed)  # compile before timing
    arrays = {"f": f, "n": ns.astype(int), "t": ts}
    for tag, sizes, times in (("n", ns, [s["t_fixed"]] * ns.size),
                              ("t", [s["n_fixed"]] * ts.size, ts)):  # fmt: skip
        out = np.array(
            [
                [
                    _one_run(Params(f=fi), int(n), float(t), seed)
                    for n, t in zip(sizes, times, strict=True)
                ]
                for fi in f
            ]  # fmt: skip
        )
        arrays[f"D_{tag}"], arrays[f"D_err_{tag}"], arrays[f"cpu_{tag}"] = np.moveaxis(out, 2, 0)
    arrays["slope_n"] = np.array([loglog_slope(ns, e) for e in arrays["D_err_n"]])
    arrays["slope_t"] = np.array([loglog_slope(ts, e) for e in arrays["D_err_t"]])
    # cost of a relative error eps at fixed t: CPU ~ cpu(n) (D_err(n) / (eps D))^2
    rel = arrays["D_err_n"] / np.abs(arrays["D_n"])
    arrays["cpu_for_10pc"] = np.median(arrays["cpu_n"] * (rel / 0.1) ** 2, axis=1)
    meta = make_meta(seed=seed, wall_s=time.perf_counter() - wall, settings=s)
    meta["key_numbers"] = {
        f"f = {fi:g} Hz": f"D_err ~ n^{a:.2f}, t^{b:.2f}; ~{c:.3g} CPU s for 10 % at t = "
        f"{s['t_fixed']:g} s"
        for fi, a, b, c in zip(
            f, arrays["slope_n"], arrays["slope_t"], arrays["cpu_for_10pc"], strict=True
        )  # fmt: skip
    }
    return StatCostResult(arrays, meta)


class StatCostResult(Result):
    """Standard error of D and CPU time against n and t (see ``statcost``)."""

    kind = "statcost"

    def table(self) -> str:
        """A Markdown table: one row per frequency and run."""
        lines = ["| f (Hz) | n | t (s) | CPU (s) | D (mm^2/s) | D_err | D_err^2 x CPU |",
                 "|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
        settings = self.meta["settings"]
        for i, f in enumerate(self["f"]):
            for tag, sizes, times in (
                ("n", self["n"], [settings["t_fixed"]] * self["n"].size),
                ("t", [settings["n_fixed"]] * self["t"].size, self["t"]),
            ):
                for j, (n, t) in enumerate(zip(sizes, times, strict=True)):
                    D, e, c = (self[f"{k}_{tag}"][i, j] for k in ("D", "D_err", "cpu"))
                    lines.append(f"| {f:g} | {n} | {t:g} | {c:.3g} | {D:.4g} | {e:.2g} | "
                                 f"{e * e * c:.3g} |")  # fmt: skip
        return "\n".join(lines)

    def plot(self, ax=None):
        """D_err against CPU time, log-log: growing n (circles, solid) and growing t (squares,
        dashed), with the sampling error of each standard error as bars; returns the axes.

        The bars are D_err / sqrt(2 (n - 1)), the standard error of a standard error over n
        normal samples: a lower bound for heavy-tailed displacements (no repeats are saved)."""
        import matplotlib.pyplot as plt
        from matplotlib.ticker import FuncFormatter

        if ax is None:
            _, ax = plt.subplots(figsize=(9, 4.8), layout="constrained")
        settings = self.meta["settings"]
        n_of_t = np.full(self["t"].size, settings["n_fixed"])
        for i, f in enumerate(self["f"]):
            line = _errorbar_loglog(ax, self["cpu_n"][i], self["D_err_n"][i], self["n"], "o-",
                                    f"{f:g} Hz, n grows (slope {self['slope_n'][i]:.2f})")
            _errorbar_loglog(ax, self["cpu_t"][i], self["D_err_t"][i], n_of_t, "s--",
                             f"{f:g} Hz, t grows (slope {self['slope_t'][i]:.2f})",
                             color=line.get_color())  # fmt: skip
        plain = FuncFormatter(lambda v, _: f"{v:g}")
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(plain)
            axis.set_minor_formatter(plain)
        ax.set_xlabel("CPU time (s, one core)")
        ax.set_ylabel(r"standard error of $D$ (mm$^2$/s)")
        ns, ts = ", ".join(str(v) for v in self["n"]), ", ".join(f"{v:g}" for v in self["t"])
        ax.set_title(
            f"B3, statistical cost of D: n = {ns} at t = {settings['t_fixed']:g} s; "
            f"t = {ts} s at n = {settings['n_fixed']}\n"
            r"bars: $D_{err}/\sqrt{2(n-1)}$ (normal samples; one run per point, no repeats)",
            fontsize=9,
        )
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
        return ax


def _errorbar_loglog(ax, cpu, err, n, fmt: str, label: str, **style):
    """Standard errors ``err`` (mm^2/s) against CPU time ``cpu`` (s) on log-log axes, with bars
    of their own sampling error over ``n`` particles; returns the line."""
    ax.set(xscale="log", yscale="log")
    bars = ax.errorbar(cpu, err, yerr=err / np.sqrt(2.0 * (np.asarray(n) - 1)), fmt=fmt,
                       capsize=2, label=label, **style)  # fmt: skip
    return bars.lines[0]
