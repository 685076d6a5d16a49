"""Scene S9: Einstein D against the random-walk approximations D_rw and D_a (docs/model.md §4).

For f above 65.6 Hz, per frequency (``bbdyn.scans.green_kubo.gk_point``): the Einstein D of
the reference ensemble, ``D_rw = d^2 / (2 tau)`` with the escape time tau from the
same simulation, and the analytic ``D_a = (d/2) sqrt((A^2 w^2 - 2 g A) / (1 + r))``
with the energy ratio ``r = E_y / E_x`` measured there (drawn in a second panel).
``D_a`` does not exist for Gamma < 2 (f < 70.46 Hz at the defaults): the energy
balance leaves no kinetic energy; those frequencies are shaded and counted, not filled.

The scan points are kept on disk (``bbdyn.scans.cache.scene_folder("gk", ...)``), so an interrupted
full run resumes where it stopped.
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn import Params
from bbdyn.results import Result, make_meta
from bbdyn.scans.cache import gk_scene_scan, grid_cpu_forecast
from bbdyn.schema import standard_key

TITLE = "Random walk: Einstein D, D_rw (tau from simulation) and D_a (measured r) against f"
QUICK = {"f_start": 66.0, "f_stop": 94.0, "f_step": 2.0, "n": 100, "t": 40.0}
FULL = {"f_start": 65.8, "f_stop": 95.0, "f_step": 0.2, "n": 1000, "t": 200.0}

#: Outputs of the scan kept by the scene.
KEYS = ("D", "D_err", "D_rw", "D_rw_err", "D_a", "D_a_err", "r", "r_err", "tau", "tau_err")


class SceneS9Result(Result):
    """Arrays: ``f`` (Hz), ``gamma``, and per f ``D, D_rw, D_a`` (mm^2/s), ``r``, ``tau`` (s),
    each with ``_err``; ``D_a`` is NaN where Gamma < 2."""

    kind = "scene_s9"

    def plot(self, ax=None):
        fig = draw(self, ax)
        return ax if ax is not None else fig.axes[0]


def scan_points(settings: dict, seed: int, out_dir, *, keys, progress=False):
    """The ``keys`` outputs of ``gk_scene_scan`` (computed or resumed), sorted by f."""
    scan = gk_scene_scan(settings, seed, out_dir, progress)
    order = np.argsort(scan.values)
    arrays = {"f": scan.values[order]}
    # the scene keeps its array names; the scan's are the schema's (X_se for X_err)
    arrays.update({k: scan[standard_key(k)][order] for k in keys})
    return arrays, scan.meta


def cost(settings: dict) -> dict[str, float]:
    """Forecast of the CPU time (s) of the scan of ``settings`` (shared with S10):
    ``bbdyn.scans.frequency.scan_cpu_forecast``."""
    return grid_cpu_forecast(settings)


def compute(settings: dict, seed: int = 0, out_dir=None, progress=False) -> SceneS9Result:
    """Scan the frequencies of ``settings`` (``f_start``, ``f_stop``, ``f_step`` in Hz, ``n``
    particles, ``t`` s) and collect D, D_rw, D_a, r; the scan is kept in
    ``bbdyn.scans.cache.scene_folder("gk", settings, seed, out_dir)``, so a rerun resumes it."""
    start = time.perf_counter()
    arrays, scan_meta = scan_points(settings, seed, out_dir, keys=KEYS, progress=progress)
    f = arrays["f"]
    arrays["gamma"] = np.array([Params(f=v).gamma for v in f])
    p0 = Params(f=float(f[0]))
    f_gamma2 = math.sqrt(2 * p0.g / p0.A) / (2 * math.pi)  # A w^2 = 2 g
    no_da = ~np.isfinite(arrays["D_a"])
    diffusive = arrays["D"] > 3 * arrays["D_err"]
    key = {
        "frequencies": f"{f.size} from {f[0]:g} to {f[-1]:g} Hz",
        "D_a undefined (Gamma < 2)": (
            f"{int(no_da.sum())} of {f.size} frequencies, all below f = {f_gamma2:.2f} Hz"
            if np.all(f[no_da] < f_gamma2)
            else f"{int(no_da.sum())} frequencies (not only Gamma < 2: check)"
        ),
        "measured r = E_y/E_x": f"{np.nanmin(arrays['r']):.3g} to {np.nanmax(arrays['r']):.3g}",
        "median D_rw / D (D > 3 err)": _median_ratio(arrays["D_rw"], arrays["D"], diffusive),
        "median D_a / D (D > 3 err)": _median_ratio(arrays["D_a"], arrays["D"], diffusive & ~no_da),
        "max D": f"{np.max(arrays['D']):.3g} mm^2/s at {f[np.argmax(arrays['D'])]:g} Hz",
    }
    meta = make_meta(
        seed=seed,
        wall_s=time.perf_counter() - start,
        f_gamma2=f_gamma2,
        scan_manifest={k: scan_meta.get(k) for k in ("compute", "seed", "bbdyn_version")},
        key_numbers=key,
    )
    meta["params"] = {k: v for k, v in p0.to_dict().items() if k != "f"}
    return SceneS9Result(arrays, meta)


def _median_ratio(num: np.ndarray, den: np.ndarray, mask: np.ndarray) -> str:
    if not np.any(mask):
        return "no frequency with D > 3 err"
    return f"{np.median(num[mask] / den[mask]):.3g} over {int(mask.sum())} frequencies"


def draw(result: Result, ax=None):
    """D, D_rw, D_a against f on a log axis (top) and the measured r (bottom); returns the
    Figure.  Values within two standard errors of zero or below (no escape seen, or too few
    to tell), which a log axis cannot show, are marked on its bottom edge."""
    import matplotlib.pyplot as plt

    if ax is None:
        fig, (ax, ax_r) = plt.subplots(
            2, 1, figsize=(9.5, 6.5), sharex=True, height_ratios=(2.2, 1), layout="constrained"
        )
    else:
        fig, ax_r = ax.figure, None
    f = result["f"]
    f2 = result.meta["f_gamma2"]
    for a in (ax, ax_r):
        if a is not None and f[0] < f2:
            label = r"$\Gamma < 2$: $D_a$ undefined" if a is ax else None
            a.axvspan(f[0], f2, color="0.9", zorder=0, lw=0, label=label)
    ax.set_yscale("log")
    series = (("D", "o", "Einstein $D$"), ("D_rw", "s-", r"$D_{rw} = d^2 / 2\tau$"),
              ("D_a", "^-", "$D_a$ (measured $r$)"))  # fmt: skip
    for i, (key, fmt, label) in enumerate(series):
        _log_series(ax, f, result[key], result[key + "_err"], fmt, f"C{i}", label, row=i)
    if any(_near_zero(result[k], result[k + "_err"]).any() for k, _, _ in series):
        ax.plot([], [], "v", color="0.4", mfc="none", label="within 2 standard errors of 0\n"
                "or below: along the bottom edge")  # fmt: skip
    ax.set_ylabel("$D$ (mm$^2$/s, log scale)")
    ax.set_title(_title(result))
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    if ax_r is not None:
        ax_r.errorbar(f, result["r"], result["r_err"], fmt="o-", ms=3, lw=0.8, color="C3")
        ax_r.set_ylabel("$r = E_y / E_x$ (1)")
        ax_r.set_xlabel("$f$ (Hz)")
    else:
        ax.set_xlabel("$f$ (Hz)")
    return fig


def _title(result: Result) -> str:
    """f-range (Hz), n and t (s) of the scan behind the figure."""
    f = result["f"]
    run = result.meta.get("scan_manifest", {}).get("compute", {}).get("kwargs", {})
    nt = f"n = {run['n']} particles, t = {run['t']:g} s" if {"n", "t"} <= run.keys() else ""
    return (f"Einstein $D$ and random-walk approximations\n"
            f"f = {f[0]:g}-{f[-1]:g} Hz ({f.size} frequencies), {nt or 'n, t unknown'}; "
            "bars: 1 standard error")  # fmt: skip


def _near_zero(y: np.ndarray, err: np.ndarray) -> np.ndarray:
    """Finite values ``y`` not above two standard errors ``err``: zero within the noise."""
    return np.isfinite(y) & ~(y > 2 * err)


def _log_series(ax, f, y, err, fmt: str, color: str, label: str, row: int = 0) -> None:
    """``y`` (mm^2/s) with error bars on a log axis; values within two standard errors of
    zero or below as open triangles along the bottom edge, series ``row`` a little higher
    than series ``row - 1`` so that they do not hide each other (NaN stays a gap)."""
    low = _near_zero(y, err)
    ax.errorbar(f, np.where(low, np.nan, y), err, fmt=fmt, ms=3, lw=0.8, capsize=2,
                color=color, label=label)  # fmt: skip
    if low.any():
        ax.plot(f[low], np.full(low.sum(), 0.025 * row), "v", color=color, mfc="none", ms=5,
                clip_on=False, transform=ax.get_xaxis_transform())  # fmt: skip
