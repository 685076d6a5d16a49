"""Scene B7: the drift current of a tilted billiard (docs/tilt.md; model: docs/model.md, "Tilt").

Left panels, at one small tilt ``phi`` over the S3 frequency range: the drift velocity
``v_d`` (``bbdyn.ensemble.EnsembleResult.drift``: late-window slope of the mean
displacement, one standard error over particles), the mobility ``v_d / (g sin phi)`` and
the diffusion coefficient about the drift (``einstein_D(..., drift=True)``), with the flat
ball's stable k/1 orbits shaded (closed-form tongues with ``g cos phi``).  Right panel: the
mobility against ``phi`` at two frequencies (log scale in phi), whose flat part is the
linear response; ``key_numbers`` gives where it ends (``linear_range``: the first tilt whose
mobility differs from the smallest tilt's by more than ``Z_LINEAR`` combined standard
errors) and the widest run of neighbouring tilts with one mobility (``plateau``).

Every point is an ensemble from the reference box (``bbdyn.ensemble.ensemble``, seed
``seed``), run on one thread; its CPU time is stored (``cpu_s``), so the cost of a setting
can be extrapolated (``cost``).
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.ensemble import ensemble
from bbdyn.params import Params
from bbdyn.results import Result, make_meta
from bbdyn.scenes.b5_lyapunov import tongue_bands

TITLE = "Tilted billiard: drift velocity, mobility and D against f; mobility against the tilt"
QUICK = {
    "f_start": 49.8, "f_stop": 95.0, "f_step": 2.5, "phi": 0.5, "n": 64, "t": 10.0,
    "sweep_f": (58.0, 85.2), "sweep_phi": (0.1, 0.5, 2.0), "sweep_n": 64, "sweep_t": 10.0,
}  # fmt: skip
#: The setting of the figure in the docs (fits the figure budget of 2 shared cores).
MEDIUM = {
    "f_start": 49.8, "f_stop": 95.0, "f_step": 0.4, "phi": 0.5, "n": 500, "t": 20.0,
    "sweep_f": (58.0, 85.2),
    "sweep_phi": (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 4.0, 8.0),
    "sweep_n": 2000, "sweep_t": 20.0,
}  # fmt: skip
FULL = {
    "f_start": 49.8, "f_stop": 95.0, "f_step": 0.2, "phi": 0.5, "n": 2000, "t": 40.0,
    "sweep_f": (58.0, 85.2),
    "sweep_phi": (0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 4.0, 8.0),
    "sweep_n": 4000, "sweep_t": 40.0,
}  # fmt: skip
#: Combined standard errors beyond which a mobility leaves the linear response.
Z_LINEAR = 3.0
#: Standard errors below zero for a drift to count as uphill (negative mobility).
Z_UPHILL = 3.0
#: Outputs per ensemble.
KEYS = ("v_d", "v_d_se", "mobility", "mobility_se", "D", "D_se", "cpu_s", "n_failed")


class SceneB7Result(Result):
    """Arrays (n_f,): ``f`` (Hz), ``v_d``/``v_d_se`` (mm/s), ``mobility``/``mobility_se`` (s),
    ``D``/``D_se`` (mm^2/s, about the drift), ``cpu_s`` (CPU s of the point), ``n_failed``
    (particles whose kernel failed, left out of the estimates); ``tongues``
    (k, 2) k/1 bands (Hz).  Sweep, arrays (2, m): ``sweep_phi`` (degrees) and the same
    ``sweep_*`` outputs; ``sweep_f`` (2,) Hz."""

    kind = "scene_b7"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def frequencies(settings: dict) -> np.ndarray:
    """The frequency grid (Hz): ``f_start`` to ``f_stop`` in steps of ``f_step``."""
    n = int(round((settings["f_stop"] - settings["f_start"]) / settings["f_step"])) + 1
    return np.round(settings["f_start"] + settings["f_step"] * np.arange(n), 9)


def drift_point(f: float, phi: float, n: int, t: float, seed: int) -> dict[str, float]:
    """``KEYS`` of one ensemble at ``f`` (Hz) and tilt ``phi`` (degrees), on one thread."""
    params = Params(f=float(f), phi=float(phi))
    cpu = time.process_time()
    res = ensemble(params, n=int(n), t=float(t), seed=seed, threads=1)
    v, v_se = res.drift()
    D, D_se = res.D()
    g_t = params.g_t
    return {"v_d": v, "v_d_se": v_se, "mobility": v / g_t, "mobility_se": v_se / abs(g_t),
            "D": D, "D_se": D_se, "cpu_s": time.process_time() - cpu,
            "n_failed": float(np.count_nonzero(~res.ok))}  # fmt: skip


def work(settings: dict, rate_s: float | None = None) -> dict[str, float]:
    """Points of ``settings`` and, with the measured mean CPU seconds per particle and
    simulated second ``rate_s``, the forecast CPU time (s).  (Not the scene protocol's
    ``cost``: the tilted search has no forecast model of its own; ``docs/data/tilt_numbers.py``
    measures the rate.)"""
    n_f = frequencies(settings).size
    n_sweep = len(settings["sweep_f"]) * len(settings["sweep_phi"])
    work = n_f * settings["n"] * settings["t"] + n_sweep * settings["sweep_n"] * settings["sweep_t"]
    out = {"points": float(n_f + n_sweep), "particle_seconds": float(work)}
    if rate_s is not None:
        out["cpu_s"] = float(work * rate_s)
    return out


def compute(settings: dict, seed: int = 0) -> SceneB7Result:
    """The f grid at ``phi`` and the tilt sweep at ``sweep_f`` (see the module docstring)."""
    start = time.perf_counter()
    freqs = frequencies(settings)
    arrays = {k: np.empty(freqs.size) for k in KEYS}
    for i, f in enumerate(freqs):
        point = drift_point(f, settings["phi"], settings["n"], settings["t"], seed)
        for k in KEYS:
            arrays[k][i] = point[k]
    sweep_f = np.asarray(settings["sweep_f"], dtype=float)
    phis = np.asarray(settings["sweep_phi"], dtype=float)
    for k in KEYS:
        arrays["sweep_" + k] = np.empty((sweep_f.size, phis.size))
    for i, f in enumerate(sweep_f):
        for j, phi in enumerate(phis):
            point = drift_point(f, phi, settings["sweep_n"], settings["sweep_t"], seed)
            for k in KEYS:
                arrays["sweep_" + k][i, j] = point[k]
    p = Params(f=float(freqs[0]), phi=float(settings["phi"]))
    arrays.update(f=freqs, sweep_f=sweep_f, sweep_phi=np.tile(phis, (sweep_f.size, 1)))
    arrays["tongues"] = tongue_bands(p.alpha, freqs[0], freqs[-1], p.A, p.g_n)
    meta = make_meta(p, seed=seed, wall_s=time.perf_counter() - start, **settings)
    result = SceneB7Result(arrays, meta)
    result.meta["key_numbers"] = key_numbers(result)
    return result


def linear_range(phi: np.ndarray, mu: np.ndarray, mu_se: np.ndarray) -> tuple[float, float]:
    """``(last, first_off)`` (degrees): the largest tilt up to which every mobility agrees with
    the smallest tilt's within ``Z_LINEAR`` combined standard errors, and the first tilt that
    does not (NaN if none)."""
    z = np.abs(mu - mu[0]) / np.hypot(mu_se, mu_se[0])
    off = np.nonzero(z[1:] > Z_LINEAR)[0]
    if off.size == 0:
        return float(phi[-1]), math.nan
    return float(phi[off[0]]), float(phi[off[0] + 1])


def plateau(phi: np.ndarray, mu: np.ndarray, mu_se: np.ndarray) -> dict:
    """The widest run of neighbouring tilts whose mobilities all lie within ``Z_LINEAR``
    standard errors (each combined with the weighted mean's) of their weighted mean: its
    first and last tilt (degrees), the mean with its standard error (s) and the next tilt
    (NaN at the end of the sweep)."""
    best = (0, 0)
    for i in range(phi.size):
        for j in range(i + 1, phi.size + 1):
            w = 1.0 / mu_se[i:j] ** 2
            mean, se = np.sum(w * mu[i:j]) / np.sum(w), 1.0 / math.sqrt(np.sum(w))
            if np.any(np.abs(mu[i:j] - mean) > Z_LINEAR * np.hypot(mu_se[i:j], se)):
                break
            if j - i > best[1] - best[0]:
                best = (i, j)
    i, j = best
    w = 1.0 / mu_se[i:j] ** 2
    return {"from": float(phi[i]), "to": float(phi[j - 1]),
            "mobility": {"value": float(np.sum(w * mu[i:j]) / np.sum(w)),
                         "se": float(1.0 / math.sqrt(np.sum(w)))},
            "next": float(phi[j]) if j < phi.size else math.nan}  # fmt: skip


def key_numbers(result: Result) -> dict:
    """The numbers docs/tilt.md quotes (values with standard errors as ``{"value", "se"}``)."""
    f, v, se = result["f"], result["v_d"], result["v_d_se"]
    mu, mu_se = result["mobility"], result["mobility_se"]
    top = int(np.argmax(mu))
    uphill = f[v < -Z_UPHILL * se]
    out = {
        "phi": float(result.meta["phi"]),
        "n_f": int(f.size),
        "max_mobility": {"value": float(mu[top]), "se": float(mu_se[top])},
        "max_mobility_f": float(f[top]),
        "max_v_d": {"value": float(v[top]), "se": float(se[top])},
        "uphill_f": [float(x) for x in uphill],
        "n_uphill": int(uphill.size),
        "cpu_s": float(result["cpu_s"].sum() + result["sweep_cpu_s"].sum()),
        "cpu_s_per_particle_second": cpu_rate(result),
        "n_failed": int(result["n_failed"].sum() + result["sweep_n_failed"].sum()),
        "sweep": {},
    }
    for i, fs in enumerate(result["sweep_f"]):
        phi = result["sweep_phi"][i]
        m, m_se = result["sweep_mobility"][i], result["sweep_mobility_se"][i]
        last, first_off = linear_range(phi, m, m_se)
        out["sweep"][f"{fs:g}"] = {
            "mobility_small": {"value": float(m[0]), "se": float(m_se[0])},
            "phi_small": float(phi[0]),
            "linear_up_to": last,
            "first_nonlinear": first_off,
            "mobility_largest": {"value": float(m[-1]), "se": float(m_se[-1])},
            "phi_largest": float(phi[-1]),
            "plateau": plateau(phi, m, m_se),
            "mobility": {f"{x:g}": {"value": float(v), "se": float(e)}
                         for x, v, e in zip(phi, m, m_se, strict=True)},
        }  # fmt: skip
    return out


def cpu_rate(result: Result) -> float:
    """Mean CPU seconds per particle and simulated second over every point of ``result``."""
    meta = result.meta
    work = result["f"].size * meta["n"] * meta["t"]
    work += result["sweep_cpu_s"].size * meta["sweep_n"] * meta["sweep_t"]
    return float((result["cpu_s"].sum() + result["sweep_cpu_s"].sum()) / work)


def draw(result: Result, ax=None):
    """v_d, mobility and D against f (left; v_d alone on ``ax`` if given) and the mobility
    against phi (right); returns the Figure."""
    if ax is not None:
        _draw_f(result, ax, "v_d", "drift velocity $v_d$ (mm/s)")
        return ax.figure
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(11.0, 8.0))
    grid = fig.add_gridspec(3, 2, width_ratios=(1.6, 1.0))
    axes = [fig.add_subplot(grid[0, 0])]
    axes += [fig.add_subplot(grid[r, 0], sharex=axes[0]) for r in (1, 2)]
    _draw_f(result, axes[0], "v_d", "drift velocity $v_d$ (mm/s)")
    _draw_f(result, axes[1], "mobility", r"mobility $v_d / (g \sin\phi)$ (s)")
    _draw_f(result, axes[2], "D", "D about the drift (mm$^2$/s)")
    axes[2].set(xlabel="f (Hz)", yscale="symlog")
    axes[0].set_title(rf"tilt $\phi$ = {result.meta['phi']:g}°, n = {result.meta['n']}, "
                      rf"t = {result.meta['t']:g} s")  # fmt: skip
    axes[0].legend(fontsize=7, loc="upper left")
    side = fig.add_subplot(grid[:, 1])
    _draw_sweep(result, side)
    fig.tight_layout()
    return fig


def _draw_f(result: Result, ax, key: str, label: str) -> None:
    for i, (lo, hi) in enumerate(result["tongues"]):
        ax.axvspan(lo, hi, color="C2", alpha=0.2,
                   label="stable k/1 orbit (flat, g cos phi)" if i == 0 else None)  # fmt: skip
    ax.errorbar(result["f"], result[key], result[key + "_se"], fmt=".", ms=3, color="C0",
                elinewidth=0.8, label="ensemble, one standard error")  # fmt: skip
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(ylabel=label)


def _draw_sweep(result: Result, ax) -> None:
    for i, f in enumerate(result["sweep_f"]):
        phi = result["sweep_phi"][i]
        ax.errorbar(phi, result["sweep_mobility"][i], result["sweep_mobility_se"][i],
                    fmt="o-", ms=4, color=f"C{i}", label=f"f = {f:g} Hz")  # fmt: skip
    ax.set(xscale="log", xlabel=r"tilt $\phi$ (degrees)",
           ylabel=r"mobility $v_d / (g \sin\phi)$ (s)")  # fmt: skip
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_title("mobility against the tilt (flat: linear response)")
    ax.legend(fontsize=8)
