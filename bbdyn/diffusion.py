"""Diffusion coefficient from the mean squared displacement (docs/model.md §3).

Einstein: ``D = lim <(x(t) - x(0))^2> / (2 t)``.  It is estimated from the slope
of the ensemble MSD over a late time window, not from one time, because the MSD
carries a transient offset that the slope does not see.

The least-squares slope of the MSD over sample times ``t_k`` is linear in the
per-particle squared displacements:

    slope = sum_k c_k MSD(t_k) = (1/n) sum_i sum_k c_k x_i(t_k)^2,
    c_k = (t_k - tbar) / sum_j (t_j - tbar)^2,

so it is exactly the mean of the per-particle slopes ``s_i = sum_k c_k x_i(t_k)^2``.
Particles are independent, hence the standard error of the slope is
``std(s_i) / sqrt(n)``, whatever the correlations along one trajectory.

Under a drift (a tilted floor, docs/model.md "Tilt") the MSD grows as ``v_d^2 t^2 +
2 D t``: ``D`` is then half the slope of the *variance* about the mean displacement
(``einstein_D(..., drift=True)``), and the drift velocity ``v_d`` is the slope of the
mean displacement (``drift_velocity``), both over the same late window.
"""

from __future__ import annotations

import math

import numpy as np

from bbdyn.core.tolerances import DOT_ROUND_PER_TERM

__all__ = [
    "drift_removed",
    "drift_velocity",
    "einstein_D",
    "einstein_D_bootstrap",
    "einstein_D_windows",
    "per_particle_slopes",
    "window_consistency",
]


def _check(times, displacements):
    times = np.asarray(times, dtype=float)
    disp = np.asarray(displacements, dtype=float)
    if times.ndim != 1:
        raise ValueError(f"times must be one-dimensional, got shape {times.shape}")
    if disp.ndim != 2 or disp.shape[1] != times.size:
        raise ValueError(
            f"displacements must have shape (n_particles, {times.size}), got {disp.shape}"
        )
    if disp.shape[0] < 2:
        raise ValueError(f"need at least 2 particles for a standard error, got {disp.shape[0]}")
    if np.any(np.diff(times) <= 0):
        raise ValueError("times must be strictly increasing")
    if not np.all(np.isfinite(disp)):
        raise ValueError("displacements must be finite")
    return times, disp


def _slope_D(times, disp, mask):
    t = times[mask]
    if t.size < 2:
        raise ValueError(f"the window holds {t.size} sample time(s); need at least 2")
    c = (t - t.mean()) / np.sum((t - t.mean()) ** 2)
    per_particle = (disp[:, mask] ** 2) @ c
    n = per_particle.size
    return 0.5 * per_particle.mean(), 0.5 * per_particle.std(ddof=1) / np.sqrt(n)


def drift_removed(displacements):
    """Displacements (n, m) about their mean at each time, scaled by ``sqrt(n / (n - 1))``
    so that the mean of their squares is the unbiased variance about the drift (n >= 2).

    Every estimator of D applied to them measures the spread about the drift, as a tilted
    floor needs (``einstein_D(..., drift=True)``)."""
    disp = np.asarray(displacements, dtype=float)
    n = disp.shape[0]
    return (disp - disp.mean(axis=0)) * math.sqrt(n / (n - 1))


def drift_velocity(times, displacements, window=(0.5, 1.0)):
    """Drift velocity ``v_d`` and its standard error from the late-time mean displacement.

    The least-squares slope of ``<x(t) - x(0)>`` over the window (the mean of the
    per-particle slopes, so its standard error is ``std / sqrt(n)`` over particles);
    ``<x(t) - x(0)> / t`` at large t, without the transient's offset.

    Returns
    -------
    v_d, v_d_se : float
        mm/s.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.linspace(0.01, 1.0, 100)
    >>> x = 2.0 * t + np.cumsum(rng.normal(0, 0.1, (2000, 100)), axis=1)
    >>> v, se = drift_velocity(t, x)
    >>> bool(abs(v - 2.0) < 4 * se)
    True
    """
    times, disp = _check(times, displacements)
    mask = _window_mask(times, window)
    t = times[mask]
    if t.size < 2:
        raise ValueError(f"the window holds {t.size} sample time(s); need at least 2")
    c = (t - t.mean()) / np.sum((t - t.mean()) ** 2)
    per_particle = disp[:, mask] @ c
    return per_particle.mean(), per_particle.std(ddof=1) / np.sqrt(per_particle.size)


def einstein_D(times, displacements, window=(0.5, 1.0), drift=False):
    """Diffusion coefficient and its standard error from the late-time MSD slope.

    Parameters
    ----------
    times : array, shape (m,)
        Sample times (s), strictly increasing.
    displacements : array, shape (n, m)
        ``x_i(t_k) - x_i(0)`` (mm) of n independent particles.
    window : (float, float)
        Fractions ``(start, end)`` of ``times[-1]``: the fit uses the sample times
        in ``[start * t_max, end * t_max]``.
    drift : bool
        If True, ``D`` is half the slope of the variance about the mean displacement
        (the displacements are centred on their mean at each time and scaled by
        ``sqrt(n / (n - 1))``: the unbiased variance), as it must be under a drift; the
        standard error is that of the centred per-particle slopes (it neglects the
        mean's own error, a relative correction of order 1/n).

    Returns
    -------
    D, D_se : float
        ``D = slope / 2`` (mm^2/s) and its standard error over particles.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.linspace(0.01, 1.0, 100)
    >>> x = np.cumsum(rng.normal(0, np.sqrt(2 * 3.0 * 0.01), (4000, 100)), axis=1)
    >>> D, se = einstein_D(t, x)
    >>> bool(abs(D - 3.0) < 4 * se)
    True
    """
    times, disp = _check(times, displacements)
    if drift:
        disp = drift_removed(disp)
    return _slope_D(times, disp, _window_mask(times, window))


def _window_mask(times, window):
    """Sample times in ``[start * t_max, end * t_max]``, ``window = (start, end)``."""
    start, end = (float(v) for v in window)
    if not 0.0 <= start < end <= 1.0:
        raise ValueError(f"window must satisfy 0 <= start < end <= 1, got {window}")
    t_max = times[-1]
    return (times >= start * t_max) & (times <= end * t_max)


def einstein_D_windows(times, displacements, n_windows=4, start=0.2, drift=False):
    """D and its standard error from successive, disjoint late windows (convergence evidence).

    The interval ``[start * t_max, t_max]`` is cut into ``n_windows`` equal windows;
    a converged D gives estimates that agree within their errors and show no trend.
    ``drift``: about the mean displacement, as in ``einstein_D``.

    Returns
    -------
    centres, D, D_se : arrays of shape (n_windows,)
        Window centres (s), and D (mm^2/s) with its standard error in each window.
    """
    times, disp = _check(times, displacements)
    if drift:
        disp = drift_removed(disp)
    if int(n_windows) < 1:
        raise ValueError(f"n_windows must be >= 1, got {n_windows}")
    if not 0.0 <= start < 1.0:
        raise ValueError(f"start must be in [0, 1), got {start}")
    t_max = times[-1]
    edges = np.linspace(start * t_max, t_max, int(n_windows) + 1)
    centres = 0.5 * (edges[:-1] + edges[1:])
    D = np.empty(int(n_windows))
    se = np.empty(int(n_windows))
    for j in range(int(n_windows)):
        mask = (times >= edges[j]) & (times <= edges[j + 1])
        D[j], se[j] = _slope_D(times, disp, mask)
    return centres, D, se


# ---- error checks and convergence evidence (issue 4) ----------------------------------------
def per_particle_slopes(times, displacements, window=(0.5, 1.0)):
    """Per-particle MSD slopes ``s_i = sum_k c_k x_i(t_k)^2`` over a window (mm^2/s).

    Their mean is the least-squares slope of the ensemble MSD, so ``mean(s) / 2`` is
    ``einstein_D``'s D (see the module docstring).  ``window`` as in ``einstein_D``.

    Returns
    -------
    array, shape (n,)
    """
    return _slopes_and_rounding(times, displacements, window)[0]


def _slopes_and_rounding(times, displacements, window):
    """Per-particle slopes and a bound on their rounding errors (DOT_ROUND_PER_TERM)."""
    times, disp = _check(times, displacements)
    start, end = (float(v) for v in window)
    if not 0.0 <= start < end <= 1.0:
        raise ValueError(f"window must satisfy 0 <= start < end <= 1, got {window}")
    mask = (times >= start * times[-1]) & (times <= end * times[-1])
    t = times[mask]
    if t.size < 2:
        raise ValueError(f"the window holds {t.size} sample time(s); need at least 2")
    spread = np.sum((t - t.mean()) ** 2)
    c = (t - t.mean()) / spread
    squares = disp[:, mask] ** 2
    # the weights are rounded relative to the times themselves, not to t - tbar
    scale = (np.abs(t) + abs(t.mean())) / spread
    return squares @ c, t.size * DOT_ROUND_PER_TERM * (squares @ scale)


def einstein_D_bootstrap(times, displacements, window=(0.5, 1.0), n_boot=2000, seed=None):
    """Bootstrap over particles of the Einstein D: an independent check of its error.

    Resamples the particles with replacement ``n_boot`` times.  The bootstrap standard
    error agrees with ``einstein_D``'s when the per-particle slopes have a finite
    variance; the percentile interval also shows skew (rare escapes of a few particles).

    Returns
    -------
    se, lo, hi : float
        Bootstrap standard error of D and its 2.5 % and 97.5 % percentiles (mm^2/s).
    """
    s = per_particle_slopes(times, displacements, window)
    if int(n_boot) < 2:
        raise ValueError(f"n_boot must be >= 2, got {n_boot}")
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, s.size, size=(int(n_boot), s.size))
    boot = 0.5 * s[idx].mean(axis=1)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return float(boot.std(ddof=1)), float(lo), float(hi)


def window_consistency(times, displacements, n_windows=4, start=0.2):
    """Test that D is the same in successive windows (``einstein_D_windows``).

    The window estimates share particles, so they are correlated; the test uses
    the per-particle differences of successive window slopes and their covariance
    over particles (Hotelling's T^2 for paired means, F-distributed for normal data,
    chi-square with ``rank`` degrees of freedom for many particles).

    Returns
    -------
    t2, dof, p : float, int, float
        T^2 statistic, degrees of freedom (rank of the covariance of the differences)
        and p-value of "D does not change between windows".  Without any spread
        (e.g. every particle trapped), ``p`` is 1 if the differences vanish, else 0.
    """
    from scipy import stats

    times, disp = _check(times, displacements)
    if int(n_windows) < 2:
        raise ValueError(f"n_windows must be >= 2 to compare windows, got {n_windows}")
    if not 0.0 <= start < 1.0:
        raise ValueError(f"start must be in [0, 1), got {start}")
    edges = np.linspace(start, 1.0, int(n_windows) + 1)
    pairs = zip(edges[:-1], edges[1:], strict=True)
    slopes, rounding = (np.stack(a, axis=1) for a in zip(
        *(_slopes_and_rounding(times, disp, w) for w in pairs), strict=True))  # fmt: skip
    diff = np.diff(slopes, axis=1)  # (n, n_windows - 1)
    # differences within rounding are zero: frozen (trapped) particles carry no spread
    diff[np.abs(diff) <= rounding[:, 1:] + rounding[:, :-1]] = 0.0
    n = diff.shape[0]
    mean = diff.mean(axis=0)
    cov = np.atleast_2d(np.cov(diff, rowvar=False)) / n
    dof = int(np.linalg.matrix_rank(cov, hermitian=True))
    if dof == 0:
        return (0.0, 0, 1.0) if np.all(mean == 0) else (math.inf, 0, 0.0)
    t2 = float(mean @ np.linalg.pinv(cov, hermitian=True) @ mean)
    if n > dof:
        p = float(stats.f.sf(t2 * (n - dof) / (dof * (n - 1)), dof, n - dof))
    else:
        p = float(stats.chi2.sf(t2, dof))
    return t2, dof, p
