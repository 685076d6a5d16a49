"""Scene B4: higher-order tongues and period-doubling cascades of the flat ball.

Left: the (Gamma, alpha) plane with the closed-form k/1 tongues of scene S1 (shaded),
the successive period doublings of each k/1 orbit (curves ``Gamma_n(alpha)``, by
continuation of the exact map, ``bbdyn.flat.continuation.cascade``) and the stable
intervals of k/m orbits (from the saddle-node to the first doubling, found by
continuation of orbits located by Newton, ``bbdyn.flat.continuation.km_regions``).
Right: a bifurcation diagram at one alpha (impact phases against Gamma) from
direct iteration of the exact map (``bbdyn.flat.continuation.bifurcation_diagram``),
with the doublings found by continuation as dashed lines.  Everything is dimensionless (the map
depends on Gamma and alpha only).
"""

from __future__ import annotations

import time

import numpy as np

from bbdyn.flat.continuation import bifurcation_diagram, cascade, km_regions
from bbdyn.flat.tongues import tongue_gamma_hi, tongue_gamma_lo
from bbdyn.results import Result, make_meta
from bbdyn.scenes import figure_axes

TITLE = "Higher-order tongues k/m and period-doubling cascades of the k/1 orbits (exact map)"
QUICK = {
    "kmax": 3,
    "levels": 4,
    "alphas": (0.3, 0.5, 0.7),
    "km": ((1, 2), (3, 2), (2, 3), (3, 4)),
    "km_gammas": (1.5, 2.5, 3.0, 4.0),
    "km_phases": 24,
    "diagram_alpha": 0.5,
    "diagram_gamma": (1.45, 1.75),
    "n_gamma": 150,
    "transient": 400,
    "record": 64,
}
FULL = {
    "kmax": 3,
    "levels": 8,
    "alphas": tuple(np.round(np.linspace(0.2, 0.8, 13), 3).tolist()),
    "km": ((1, 2), (3, 2), (5, 2), (2, 3), (4, 3), (5, 3), (3, 4), (5, 4)),
    "km_gammas": tuple(np.round(np.linspace(1.0, 6.0, 21), 3).tolist()),
    "km_phases": 24,
    "diagram_alpha": 0.5,
    "diagram_gamma": (1.45, 1.75),
    "n_gamma": 1200,
    "transient": 2000,
    "record": 256,
}


class SceneB4Result(Result):
    """Arrays: ``alphas`` (a,), ``doublings`` (kmax, a, levels) Gamma of the n-th doubling
    (NaN where the cascade stopped); ``km_k``, ``km_m``, ``km_alpha``, ``km_lo``,
    ``km_hi`` (r,) stable k/m intervals; ``diag_gamma`` (p,), ``diag_phase`` (p, record)
    impact phases of direct iteration (NaN for non-impact events); ``diag_doublings``
    (kmax, levels) at the diagram's alpha.  Meta: settings, cascade stop reasons."""

    kind = "scene_b4"

    def plot(self, ax=None):
        fig = draw(self)
        return fig.axes[0]


def _doublings(settings) -> tuple[np.ndarray, list[str]]:
    kmax, levels = int(settings["kmax"]), int(settings["levels"])
    alphas = np.asarray(settings["alphas"], dtype=float)
    out = np.full((kmax, len(alphas), levels), np.nan)
    reasons = []
    for i in range(kmax):
        for j, a in enumerate(alphas):
            gammas, status, why, _ = cascade(i + 1, float(a), levels)
            out[i, j, : len(gammas)] = gammas
            if status != "done":
                reasons.append(f"k = {i + 1}, alpha = {a}: {status}: {why}")
    return out, reasons


def _stable_intervals(branch) -> list[tuple[float, float]]:
    """Gamma intervals from a fold to the adjacent flip along the branch (either order).

    Between them both multipliers are inside the unit circle: a complex pair has
    modulus alpha^m (their product is det = alpha^(2m) < 1), and a real multiplier
    that leaves +1 at the fold toward -1 cannot exceed 1 without a second +1
    crossing, which the continuation would have located as another fold."""
    kinds, gammas = branch["bif_kind"], branch["bif_gamma"]
    out = []
    for a in range(len(kinds) - 1):
        if {int(kinds[a]), int(kinds[a + 1])} == {0, 1}:
            out.append(tuple(sorted((float(gammas[a]), float(gammas[a + 1])))))
    return out


def _km(settings) -> dict:
    rows = []
    for k, m in settings["km"]:
        for a in settings["alphas"]:
            for br in km_regions(
                int(k), int(m), float(a), settings["km_gammas"], n_phase=int(settings["km_phases"])
            ):
                rows += [(k, m, a, lo, hi) for lo, hi in _stable_intervals(br) if hi > lo]
    rows = sorted(set(rows))
    cols = list(zip(*rows, strict=True)) if rows else [()] * 5
    names = ("km_k", "km_m", "km_alpha", "km_lo", "km_hi")
    return {n: np.array(c, dtype=float) for n, c in zip(names, cols, strict=True)}


def compute(settings: dict, seed: int = 0) -> SceneB4Result:
    """Cascades on the alpha grid, k/m intervals, and the direct-iteration diagram."""
    start = time.perf_counter()
    doublings, reasons = _doublings(settings)
    diag_gamma = np.linspace(*settings["diagram_gamma"], int(settings["n_gamma"]))
    diag_phase = bifurcation_diagram(
        diag_gamma, float(settings["diagram_alpha"]), int(settings["transient"]),
        int(settings["record"]),
    )  # fmt: skip
    a = float(settings["diagram_alpha"])
    diag_doublings = np.full((int(settings["kmax"]), int(settings["levels"])), np.nan)
    for i in range(int(settings["kmax"])):
        gammas = cascade(i + 1, a, int(settings["levels"]))[0]
        diag_doublings[i, : len(gammas)] = gammas
    arrays = {
        "k": np.arange(1, int(settings["kmax"]) + 1),
        "alphas": np.asarray(settings["alphas"], dtype=float),
        "doublings": doublings,
        **_km(settings),
        "diag_gamma": diag_gamma,
        "diag_phase": diag_phase,
        "diag_doublings": diag_doublings,
    }
    meta = make_meta(
        seed=seed, wall_s=time.perf_counter() - start, cascade_stops=reasons,
        diagram_alpha=a,
    )  # fmt: skip
    return SceneB4Result(arrays, meta)


def draw(result: Result, ax=None):
    """Left: (Gamma, alpha) plane; right: bifurcation diagram.  Returns the Figure."""
    import matplotlib.pyplot as plt

    fig, (left, right) = (
        plt.subplots(1, 2, figsize=(12, 4.8)) if ax is None else (ax.figure, (ax, None))
    )
    _draw_plane(result, left)
    if right is not None:
        _draw_diagram(result, right)
    return fig


def _draw_plane(result, ax):
    _, ax = figure_axes(ax)
    a = np.linspace(0.0, 1.0, 201)
    for k in result["k"]:
        ax.fill_betweenx(a, tongue_gamma_lo(k, a, np), tongue_gamma_hi(k, a, np), alpha=0.25)
    alphas = result["alphas"]
    for i in range(len(result["k"])):
        for n in range(1, result["doublings"].shape[2]):
            label = "doublings n >= 2 (continuation)" if i == 0 and n == 1 else None
            ax.plot(result["doublings"][i, :, n], alphas, "k.-", lw=0.6, ms=2, label=label)
    pairs = sorted({(int(k), int(m)) for k, m in zip(result["km_k"], result["km_m"], strict=True)})
    for c, (k, m) in enumerate(pairs):
        sel = (result["km_k"] == k) & (result["km_m"] == m)
        lo, hi, al = result["km_lo"][sel], result["km_hi"][sel], result["km_alpha"][sel]
        color = f"C{(c + 3) % 10}"
        ax.plot(np.stack([lo, hi]), np.stack([al, al]), "-", color=color, lw=3)
        ax.plot(0.5 * (lo + hi), al, "o", color=color, ms=3, label=f"{k}/{m} stable (fold to flip)")
    ax.set(xlabel=r"$\Gamma$", ylabel=r"$\alpha$", ylim=(0, 1), xlim=(0, 7))
    ax.set_title("k/1 tongues (shaded), doublings, k/m intervals")
    ax.legend(loc="upper right", fontsize=6)


def _draw_diagram(result, ax):
    g, ph = result["diag_gamma"], result["diag_phase"]
    ax.plot(np.repeat(g, ph.shape[1]), ph.ravel(), ",k", alpha=0.6)
    for i in range(result["diag_doublings"].shape[0]):
        for x in result["diag_doublings"][i]:
            if np.isfinite(x) and g[0] <= x <= g[-1]:
                ax.axvline(x, color="r", lw=0.5, ls="--")
    ax.set(xlabel=r"$\Gamma$", ylabel="impact phase (rad)", xlim=(g[0], g[-1]), ylim=(0, 2 * np.pi))
    ax.set_title(f"direct iteration, alpha = {result.meta['diagram_alpha']}; dashed: continuation")
