"""Scene B5: the largest Lyapunov exponent against the driving frequency over the S3 range.

The flat ball (``bbdyn.lyapunov.flat_lyapunov``; the billiard's tangent
dynamics is not implemented yet, docs/lyapunov.md): at each frequency an
ensemble of particles, the largest exponent per second with one standard error
over particles.  Where a particle sticks its exponent is ``-inf``; the figure
then shows the conditional exponent (growth between sticks) with an open
marker, and the fraction of particles that stuck.  The shaded bands are the
frequencies of the flat ball's stable k/1 orbits (closed-form Arnold tongues,
``bbdyn.tongues``), where the exponent must be negative.
"""

from __future__ import annotations

import time

import numpy as np

from bbdyn.lyapunov import flat_lyapunov
from bbdyn.params import Params
from bbdyn.results import Result, make_meta
from bbdyn.scenes import figure_axes
from bbdyn.tongues import frequency_at_gamma, tongue_gamma_hi, tongue_gamma_lo

TITLE = "Largest Lyapunov exponent of the flat ball against f (S3 range), k/1 tongues shaded"
QUICK = {"f_start": 49.8, "f_stop": 95.0, "n_f": 10, "n": 6, "t": 4.0, "transient": 1.0}
MEDIUM = {"f_start": 49.8, "f_stop": 95.0, "n_f": 46, "n": 20, "t": 20.0, "transient": 2.0}
FULL = {"f_start": 49.8, "f_stop": 95.0, "n_f": 227, "n": 50, "t": 50.0, "transient": 5.0}


class SceneB5Result(Result):
    """Arrays (n_f,): ``f`` (Hz), ``lam1``/``lam1_se`` (1/s; -inf if a particle stuck),
    ``cond_lam1``/``cond_lam1_se`` (1/s, between sticks), ``stuck_fraction``,
    ``lam1_per_impact``/``cond_lam1_per_impact``; ``tongues`` (k, 2) k/1 frequency bands (Hz)."""

    kind = "scene_b5"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def tongue_bands(alpha: float, f_lo: float, f_hi: float, A: float, g: float) -> np.ndarray:
    """Frequency bands (Hz) of the stable k/1 orbits that meet ``[f_lo, f_hi]``, (k, 2)."""
    bands = []
    k = 1
    while frequency_at_gamma(tongue_gamma_lo(k, alpha), A, g) < f_hi:
        lo = frequency_at_gamma(tongue_gamma_lo(k, alpha), A, g)
        hi = frequency_at_gamma(tongue_gamma_hi(k, alpha), A, g)
        if hi > f_lo:
            bands.append((float(lo), float(hi)))
        k += 1
    return np.array(bands).reshape(-1, 2)


def compute(settings: dict, seed: int = 0) -> SceneB5Result:
    """Exponents at ``n_f`` frequencies, ``n`` particles each (seeded per frequency by ``seed``)."""
    start = time.perf_counter()
    freqs = np.linspace(settings["f_start"], settings["f_stop"], int(settings["n_f"]))
    keys = ("lam1", "lam1_se", "cond_lam1", "cond_lam1_se", "stuck_fraction")
    keys_imp = ("lam1_per_impact", "cond_lam1_per_impact")
    arrays = {k: np.empty(freqs.size) for k in keys + keys_imp}
    for i, f in enumerate(freqs):
        res = flat_lyapunov(
            Params(f=float(f)), int(settings["n"]), t=float(settings["t"]),
            transient=float(settings["transient"]), seed=seed,
        )  # fmt: skip
        s = res.summary()
        for k in keys:
            arrays[k][i] = s[k.replace("lam1", "lam1_per_s") if "lam1" in k else k]
        for k in keys_imp:
            arrays[k][i] = s[k]
    p = Params(f=float(freqs[0]))
    arrays["f"] = freqs
    arrays["tongues"] = tongue_bands(p.alpha, freqs[0], freqs[-1], p.A, p.g)
    meta = make_meta(p, seed=seed, wall_s=time.perf_counter() - start, **settings)
    return SceneB5Result(arrays, meta)


def draw(result: Result, ax=None):
    """Largest exponent (filled: all particles free; open: conditional, some stuck) against f,
    the stuck fraction on a second axis, k/1 tongues shaded; returns the Figure."""
    fig, ax = figure_axes(ax, figsize=(7.0, 4.5))
    f = result["f"]
    for i, (lo, hi) in enumerate(result["tongues"]):
        ax.axvspan(
            lo, hi, color="C2", alpha=0.2, label="stable k/1 orbit (flat)" if i == 0 else None
        )
    free = np.isfinite(result["lam1"])
    ax.errorbar(f[free], result["lam1"][free], result["lam1_se"][free], fmt="o", color="C0",
                label=r"$\lambda_1$ (no particle stuck)")  # fmt: skip
    ax.errorbar(f[~free], result["cond_lam1"][~free], result["cond_lam1_se"][~free], fmt="o",
                mfc="none", color="C1",
                label=r"$\lambda_1$ between sticks (true $\lambda_1=-\infty$)")  # fmt: skip
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(xlabel="f (Hz)", ylabel=r"largest exponent (1/s)", yscale="symlog")
    ax2 = ax.twinx()
    ax2.plot(f, result["stuck_fraction"], "k:", lw=1)
    ax2.set(ylabel="fraction of particles that stuck", ylim=(-0.02, 1.02))
    ax.set_title("Flat ball: largest Lyapunov exponent")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, fontsize=7)
    fig.tight_layout()
    return fig
