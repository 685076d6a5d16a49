"""Scene B5: the largest Lyapunov exponent against the driving frequency over the S3 range.

Top panel, the billiard (``bbdyn.lyapunov.billiard_lyapunov``): at each frequency the
reference box is classified (``bbdyn.classify``) and the largest exponent per second is
drawn for each attractor with one standard error over its particles (marker by the
attractor's character), over bands of the regime label (colours of scene B1).  The
dashed lines are the closed-form exponent of the vertical k/1 orbit on an arc top
(``top_orbit_exponent``) inside the flat ball's k/1 tongues, where it exists.

Bottom panel, the flat ball (``bbdyn.lyapunov.flat_lyapunov``): at each frequency an
ensemble of particles, the largest exponent per second with one standard error over
particles.  Where a particle sticks its exponent is ``-inf``; the figure then shows the
conditional exponent (growth between sticks) with an open marker, and the fraction of
particles that stuck.  The shaded bands are the frequencies of the flat ball's stable
k/1 orbits (closed-form Arnold tongues, ``bbdyn.flat.tongues``), where the exponent must be
negative.
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.flat.tongues import frequency_at_gamma, tongue_gamma_hi, tongue_gamma_lo
from bbdyn.lyapunov import billiard_lyapunov, flat_lyapunov, top_orbit_exponent
from bbdyn.params import Params
from bbdyn.results import Result, make_meta
from bbdyn.scenes import figure_axes
from bbdyn.scenes.b1_regime_map import LABELS, regime_bands

TITLE = (
    "Largest Lyapunov exponent against f (S3 range): billiard per attractor with regime "
    "bands; flat ball with k/1 tongues"
)
#: ``billiard_*``: the billiard's grid and ensemble (classified per frequency).
QUICK = {
    "f_start": 49.8, "f_stop": 95.0, "n_f": 10, "n": 6, "t": 4.0, "transient": 1.0,
    "billiard_n_f": 6, "billiard_n": 12, "billiard_t": 5.0, "billiard_transient": 1.0,
}  # fmt: skip
MEDIUM = {
    "f_start": 49.8, "f_stop": 95.0, "n_f": 46, "n": 20, "t": 20.0, "transient": 2.0,
    "billiard_n_f": 46, "billiard_n": 20, "billiard_t": 20.0, "billiard_transient": 2.0,
}  # fmt: skip
FULL = {
    "f_start": 49.8, "f_stop": 95.0, "n_f": 227, "n": 50, "t": 50.0, "transient": 5.0,
    "billiard_n_f": 227, "billiard_n": 50, "billiard_t": 50.0, "billiard_transient": 5.0,
}  # fmt: skip
#: Characters of an attractor (``bbdyn.classify``), in the order of the stored codes (a new
#: character goes at the end, so that saved codes keep their meaning; results saved before
#: "trapped cycle" existed call trapped stick-release cycles "creeping").
CHARACTERS = ("at rest", "locked", "creeping", "intermittent", "irregular", "trapped cycle")
#: Attractors stored per frequency (more are dropped, the smallest basins first).
MAX_ATTRACTORS = 4


class SceneB5Result(Result):
    """Flat ball, arrays (n_f,): ``f`` (Hz), ``lam1``/``lam1_se`` (1/s; -inf if a particle
    stuck), ``cond_lam1``/``cond_lam1_se`` (1/s, between sticks), ``stuck_fraction``,
    ``lam1_per_impact``/``cond_lam1_per_impact``; ``tongues`` (k, 2) k/1 frequency bands (Hz).

    Billiard, arrays (m,): ``b_f`` (Hz), ``b_lam1``/``b_lam1_se`` (1/s, whole ensemble),
    ``b_lam1_per_collision``, ``b_collapse_fraction``, ``b_regime`` (codes into
    ``b1_regime_map.LABELS``); (m, MAX_ATTRACTORS), NaN-padded: ``att_lam1``/``att_lam1_se``
    (1/s), ``att_lam1_per_collision``/``_se``, ``att_fraction``, ``att_character`` (codes
    into ``CHARACTERS``, -1 none)."""

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
    arrays.update(billiard_arrays(settings, seed))
    meta = make_meta(p, seed=seed, wall_s=time.perf_counter() - start, **settings)
    return SceneB5Result(arrays, meta)


def billiard_arrays(settings: dict, seed: int) -> dict:
    """The billiard's exponents per frequency and attractor (see ``SceneB5Result``)."""
    freqs = np.linspace(settings["f_start"], settings["f_stop"], int(settings["billiard_n_f"]))
    m = freqs.size
    scalars = ("b_lam1", "b_lam1_se", "b_lam1_per_collision", "b_collapse_fraction", "b_regime")
    out = {k: np.full(m, math.nan) for k in scalars}
    for key in ("att_lam1", "att_lam1_se", "att_lam1_per_collision", "att_lam1_per_collision_se",
                "att_fraction", "att_character"):  # fmt: skip
        out[key] = np.full((m, MAX_ATTRACTORS), math.nan)
    out["att_character"][:] = -1
    for i, f in enumerate(freqs):
        res = billiard_lyapunov(
            Params(f=float(f)), int(settings["billiard_n"]), t=float(settings["billiard_t"]),
            transient=float(settings["billiard_transient"]), seed=seed, classify_attractors=True,
        )  # fmt: skip
        s = res.summary()
        out["b_lam1"][i], out["b_lam1_se"][i] = s["lam1_per_s"], s["lam1_per_s_se"]
        out["b_lam1_per_collision"][i] = s["lam1_per_collision"]
        out["b_collapse_fraction"][i] = s["collapse_fraction"]
        cls = res.meta["classification"]
        out["b_regime"][i] = LABELS.index(cls["regime"])
        atts = sorted(res.by_attractor(), key=lambda a: -a["fraction"])[:MAX_ATTRACTORS]
        for j, a in enumerate(atts):
            out["att_lam1"][i, j], out["att_lam1_se"][i, j] = a["lam1_per_s"], a["lam1_per_s_se"]
            out["att_lam1_per_collision"][i, j] = a["lam1_per_collision"]
            out["att_lam1_per_collision_se"][i, j] = a["lam1_per_collision_se"]
            out["att_fraction"][i, j] = a["fraction"]
            character = cls["attractors"][a["attractor"]]["character"]
            out["att_character"][i, j] = CHARACTERS.index(character)
    out["b_f"] = freqs
    return out


def draw(result: Result, ax=None):
    """Billiard (top; on ``ax`` alone if given) and flat ball (bottom); returns the Figure."""
    has_billiard = "b_f" in result.arrays
    if ax is not None:
        (draw_billiard if has_billiard else draw_flat)(result, ax)
        return ax.figure
    import matplotlib.pyplot as plt

    if not has_billiard:  # a result saved before the billiard was added
        fig, ax = figure_axes(None, figsize=(7.0, 4.5))
        draw_flat(result, ax)
        fig.tight_layout()
        return fig
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 8.0), sharex=True)
    draw_billiard(result, axes[0])
    draw_flat(result, axes[1])
    fig.tight_layout()
    return fig


def draw_billiard(result: Result, ax) -> None:
    """Largest exponent of each attractor against f over the regime bands, and the closed-form
    top-orbit exponents inside the flat k/1 tongues."""
    import matplotlib.pyplot as plt

    colors = plt.get_cmap("tab10")
    bands = {"f": result["b_f"], "regime": result["b_regime"]}
    seen = set()
    for lo, hi, lab in regime_bands(bands):
        ax.axvspan(lo, hi, color=colors(LABELS.index(lab)), alpha=0.18,
                   label=f"regime {lab}" if lab not in seen else None)  # fmt: skip
        seen.add(lab)
    markers = {"at rest": "s", "locked": "D", "creeping": "v", "intermittent": "o",
               "irregular": "^", "trapped cycle": "<"}  # fmt: skip
    f = result["b_f"]
    for code, name in enumerate(CHARACTERS):
        sel = result["att_character"] == code
        if not sel.any():
            continue
        rows = np.nonzero(sel)[0]
        lam, se = result["att_lam1"][sel], result["att_lam1_se"][sel]
        finite = np.isfinite(lam)
        ax.errorbar(f[rows][finite], lam[finite], se[finite], fmt=markers[name], ms=4,
                    color="k", mfc="w" if name == "creeping" else "k", label=name)  # fmt: skip
    p = Params(f=float(f[0]))
    k = 1
    while (lo := frequency_at_gamma(tongue_gamma_lo(k, p.alpha), p.A, p.g)) < f[-1]:
        hi = min(frequency_at_gamma(tongue_gamma_hi(k, p.alpha), p.A, p.g), f[-1])
        fk = np.linspace(max(lo, f[0]), hi, 30)
        lam_k = [top_orbit_exponent(Params(f=float(x)), k) for x in fk]
        ax.plot(fk, lam_k, "C3--", lw=1.2, label="top orbit k/1 (closed form)" if k == 1 else None)
        k += 1
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set(ylabel="largest exponent (1/s)", yscale="symlog")
    ax.margins(y=0.1)
    ax.set_title("Billiard: largest Lyapunov exponent per attractor")
    ax.legend(fontsize=7, ncol=3, loc="lower right")


def draw_flat(result: Result, ax) -> None:
    """Largest exponent (filled: all particles free; open: conditional, some stuck) against f,
    the stuck fraction on a second axis, k/1 tongues shaded."""
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
