"""Fine structure of a measured function such as D(f) (issue 14, scene B6; docs/fine_structure.md).

A function y(x) is measured with independent Gaussian errors ``se`` on nested grids:
level l is a window of ``points`` equally spaced values of step ``h_l`` around a centre.
Per level this module asks whether the values vary between neighbours more than the
errors allow, and, where they do over several levels, how the variation scales with h.

The test.  The increments ``d_i = y_{i+1} - y_i`` (K = m - 1 of them) have, under the
null hypothesis "y is linear over the window", the mean ``mu h`` (the same for all i)
and the covariance ``C = B S B^T`` with ``S = diag(se^2)`` and B the difference
operator: ``C_ii = se_i^2 + se_{i+1}^2``, ``C_{i,i+1} = -se_{i+1}^2`` (neighbouring
increments share a point).  ``chi2 = (d - mu 1)^T C^{-1} (d - mu 1)``, minimised over
mu, has K - 1 = m - 2 degrees of freedom; it equals the chi-squared of a weighted
straight-line fit to the m values (a test checks the identity), so a linear trend
across the window is not counted as structure; curvature across the window is (a
smooth function shows "structure" on a window wide enough for its curvature to exceed
the errors).  ``detrend=False`` tests mu = 0
(K degrees of freedom) instead.

The size.  ``S2 = |P d|^2 / K - tr(P C) / K`` with ``P = I - 1 1^T / K`` is an
unbiased estimate of the mean squared increment about the window's mean increment
(the noise part ``tr(P C) / K`` is subtracted exactly); its variance for Gaussian
errors is ``(2 tr((P C)^2) + 4 delta^T P C P delta) / K^2`` (delta: the true
increments, estimated by d).  For a function with Hoelder exponent H, ``S2 ~ h^(2 H)``:
``scaling_exponent`` fits H on log-log over the levels where S2 is resolved.
``S2_spread`` (the standard error of the mean of the squared increments in the window)
measures how well one window represents its scale.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

__all__ = [
    "P_STRUCTURE",
    "Z_RESOLVED",
    "increment_covariance",
    "detectable_rms",
    "level_test",
    "n_for_error",
    "nested_grid",
    "scaling_exponent",
    "takagi",
    "verdict",
]

#: p-value below which a level's variation is called structure.
P_STRUCTURE = 0.01
#: S2 counts as resolved (enters the scaling fit) when S2 > Z_RESOLVED times its error.
Z_RESOLVED = 2.0


def nested_grid(centre: float, step: float, points: int) -> np.ndarray:
    """``points`` values of spacing ``step`` centred on ``centre`` (an odd ``points`` holds
    ``centre`` itself), rounded to 1e-9 so that grid points are exact scan keys."""
    if int(points) != points or points < 3:
        raise ValueError(f"points must be an integer >= 3, got {points}")
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f"step must be a finite step > 0, got {step}")
    offsets = np.arange(int(points)) - 0.5 * (int(points) - 1)
    return np.round(float(centre) + step * offsets, 9)


def increment_covariance(se) -> np.ndarray:
    """Covariance ``B diag(se^2) B^T`` (K, K) of the increments of values with errors ``se``."""
    var = np.asarray(se, dtype=float) ** 2
    cov = np.diag(var[:-1] + var[1:])
    shared = -var[1:-1]
    idx = np.arange(shared.size)
    cov[idx, idx + 1] = shared
    cov[idx + 1, idx] = shared
    return cov


def _check_level(y, se) -> tuple[np.ndarray, np.ndarray]:
    y, se = np.asarray(y, dtype=float), np.asarray(se, dtype=float)
    if y.ndim != 1 or y.shape != se.shape or y.size < 4:
        raise ValueError(
            f"y and se must be 1-d arrays of the same length >= 4, got shapes {y.shape}, {se.shape}"
        )
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(se)) and np.all(se > 0)):
        raise ValueError(
            "y must be finite and se finite and > 0 (a zero error, e.g. a trapped point "
            f"with D = 0 exactly, cannot be tested); got se = {se.tolist()}"
        )
    return y, se


def level_test(y, se, *, detrend: bool = True) -> dict[str, float]:
    """Structure test and noise-corrected size of the increments of one level.

    Parameters
    ----------
    y, se : array_like, shape (m,), m >= 4
        Values on an equally spaced grid and their standard errors (> 0), same units.
    detrend : bool
        Allow a linear trend across the window (the mean increment is fitted), default.

    Returns
    -------
    dict
        ``chi2``, ``dof``, ``p`` (upper tail); ``S2``, ``S2_err`` (units of y squared):
        the noise-corrected mean squared increment and its standard error; ``noise2``:
        the noise part subtracted; ``mean_increment``.
    """
    y, se = _check_level(y, se)
    d = np.diff(y)
    k = d.size
    cov = increment_covariance(se)
    inv = np.linalg.inv(cov)
    ones = np.ones(k)
    mu = float(ones @ inv @ d / (ones @ inv @ ones)) if detrend else 0.0
    r = d - mu
    chi2 = float(r @ inv @ r)
    dof = k - 1 if detrend else k
    proj = np.eye(k) - np.full((k, k), 1.0 / k)
    pc = proj @ cov
    noise2 = float(np.trace(pc) / k)
    pd = proj @ d
    s2 = float(pd @ pd / k) - noise2
    var = (2.0 * np.trace(pc @ pc) + 4.0 * pd @ cov @ pd) / k**2
    spread = float(np.std(pd**2, ddof=1) / math.sqrt(k))
    return {
        "chi2": chi2,
        "dof": float(dof),
        "p": float(stats.chi2.sf(chi2, dof)),
        "S2": s2,
        "S2_err": float(math.sqrt(var)),
        "S2_spread": spread,
        "noise2": noise2,
        "mean_increment": float(np.mean(d)),
    }


def verdict(test: dict[str, float], units: str = "") -> str:
    """The conclusion a level's ``level_test`` supports, in words."""
    unit = f" {units}" if units else ""
    if test["p"] < P_STRUCTURE:
        rms = math.sqrt(max(test["S2"], 0.0))
        p = f"p = {test['p']:.2g}" if test["p"] > 0 else "p < 1e-300"  # below double range
        return f"structure ({p}); rms increment {rms:.3g}{unit}"
    bound = math.sqrt(max(test["S2"] + Z_RESOLVED * test["S2_err"], 0.0))
    return (
        f"not resolved at this precision (p = {test['p']:.2g}); "
        f"rms increment < {bound:.3g}{unit} ({Z_RESOLVED:g} sigma)"
    )


def scaling_exponent(steps, s2, s2_err, s2_spread) -> dict[str, float]:
    """Hoelder-type exponent H of ``S2 ~ step^(2 H)`` from the resolved levels.

    A weighted straight-line fit of log S2 against log step over the levels with
    ``S2 > Z_RESOLVED * S2_err`` (resolved above the measurement noise).  A level's
    weight comes from ``hypot(S2_err, S2_spread) / S2``: the spread of the squared
    increments within the window, which a deterministic fractal shows even without
    noise, counts as uncertainty of the level's S2 (conservative: it holds the noise
    again).  With more than two levels the error is scaled up by sqrt(chi2/dof) when
    the levels scatter more than their errors.

    Returns
    -------
    dict
        ``H``, ``H_err`` (nan with fewer than two resolved levels), ``levels`` (used),
        ``chi2_dof`` of the fit (nan with two levels).
    """
    h, s, e, spread = (np.asarray(a, dtype=float) for a in (steps, s2, s2_err, s2_spread))
    ok = s > Z_RESOLVED * e
    nan = {"H": math.nan, "H_err": math.nan, "levels": float(ok.sum()), "chi2_dof": math.nan}
    if ok.sum() < 2:
        return nan
    x, y, sig = np.log(h[ok]), np.log(s[ok]), np.hypot(e[ok], spread[ok]) / s[ok]
    w = 1.0 / sig**2
    xm = np.sum(w * x) / np.sum(w)
    sxx = np.sum(w * (x - xm) ** 2)
    slope = float(np.sum(w * (x - xm) * y) / sxx)
    err = 1.0 / math.sqrt(sxx)
    chi2_dof = math.nan
    if ok.sum() > 2:
        resid = y - (np.sum(w * y) / np.sum(w) + slope * (x - xm))
        chi2_dof = float(np.sum(w * resid**2) / (ok.sum() - 2))
        err *= math.sqrt(max(chi2_dof, 1.0))
    return {"H": slope / 2, "H_err": err / 2, "levels": float(ok.sum()), "chi2_dof": chi2_dof}


def detectable_rms(points: int) -> float:
    """Smallest rms increment resolved (``S2 > Z_RESOLVED * S2_err``) on a level of
    ``points`` values with equal errors, in units of that error: ``sqrt(Z_RESOLVED x the
    pure-noise S2_err)``.  Divide the structure one wants to see by it to get the error
    to budget for."""
    y = np.zeros(int(points))
    return math.sqrt(Z_RESOLVED * level_test(y, np.ones(y.size))["S2_err"])


def n_for_error(n0: int, se0: float, se_target: float) -> int:
    """Ensemble size giving the standard error ``se_target`` when ``n0`` gave ``se0``
    (``se ~ n^-1/2``, scene B3; the cost grows like n)."""
    if not (se0 > 0 and se_target > 0 and n0 >= 2):
        raise ValueError(f"need n0 >= 2 and errors > 0, got n0={n0}, se0={se0}, "
                         f"se_target={se_target}")  # fmt: skip
    return max(2, math.ceil(n0 * (se0 / se_target) ** 2))


def takagi(x, H: float, terms: int = 40) -> np.ndarray:
    """Takagi-Landsberg function ``sum_n 2^(-n H) s(2^n x)``, s = distance to the nearest
    integer: continuous, Hoelder exponent H (0 < H < 1) everywhere, nowhere smooth.
    A synthetic fractal for the tests and notebook 07."""
    if not 0 < H < 1:
        raise ValueError(f"H must lie in (0, 1), got {H}")
    x = np.asarray(x, dtype=float)
    out = np.zeros_like(x)
    for n in range(int(terms)):
        u = np.ldexp(x, n)
        out += 2.0 ** (-n * H) * np.abs(u - np.round(u))
    return out
