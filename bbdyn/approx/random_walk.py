"""Escape time, jump lengths and random-walk diffusion (docs/model.md §4).

* Escape time ``tau``: the inverse jump rate, pooled over the ensemble,
  ``tau = n_particles t_total / n_jumps`` (s), over all particles, including
  those that never jump (their time counts).  It counts the time before the
  first and after the last jump, so it is the unbiased inverse of the rate
  even when a particle jumps only a few times.  Its standard error comes from
  the spread of the jump counts over particles (delta method).
* ``D_rw = d^2 / (2 tau)`` (mm^2/s): the simple random walk with unit jumps.
* ``D_a = (d/2) sqrt((A^2 w^2 - 2 g A) / (1 + r))`` from the energy balance
  (derivation: ``derivations/random_walk.py``), with ``r = E_y / E_x``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from bbdyn.approx.jumps import JumpData
from bbdyn.params import Params

__all__ = [
    "EscapeTime",
    "JumpLengths",
    "RandomWalkEstimate",
    "AnalyticDiffusion",
    "EnergyRatio",
    "escape_time",
    "jump_length_distribution",
    "random_walk_diffusion",
    "analytic_diffusion",
    "energy_ratio",
]


class EscapeTime(NamedTuple):
    """Mean time between jumps ``tau`` (s) with its standard error.

    ``tau`` is ``inf`` when no particle jumped; ``tau_err`` is NaN when it
    cannot be estimated (one particle, or no jump).
    """

    tau: float
    tau_err: float
    n_jumps: int
    n_particles: int


class JumpLengths(NamedTuple):
    """Distribution of the signed jump lengths ``h / d`` (integers).

    ``fraction_long`` is the fraction of jumps with ``|h| > d``;
    ``mean_square`` is ``<(h/d)^2>`` (NaN without jumps).
    """

    lengths: np.ndarray
    counts: np.ndarray
    probabilities: np.ndarray
    fraction_long: float
    mean_square: float


@dataclass(frozen=True)
class RandomWalkEstimate:
    """``D_rw = d^2 / (2 tau)`` (mm^2/s) with its error, ``tau`` and the jump lengths."""

    tau: float
    tau_err: float
    D_rw: float
    D_rw_err: float
    jump_lengths: JumpLengths


class AnalyticDiffusion(NamedTuple):
    """Analytic random walk ``D_a`` (mm^2/s), its error from ``r_err``, ``E_x`` (mm^2/s^2).

    ``reason`` is empty when ``D_a`` is defined, else it says why ``D_a`` is NaN.
    """

    D_a: float
    D_a_err: float
    E_x: float
    reason: str


class EnergyRatio(NamedTuple):
    """Ratio ``r = E_y / E_x`` of the steady-state kinetic energies, with its standard error."""

    r: float
    r_err: float


def _check_jump_data(data: JumpData) -> None:
    if not isinstance(data, JumpData):
        raise ValueError(f"data must be a bbdyn.approx.JumpData, got {type(data).__name__}")


def escape_time(data: JumpData) -> EscapeTime:
    """Escape time ``tau = n_particles t_total / n_jumps`` (s), docs/model.md §4.

    The error is the delta-method standard error of ``1 / rate`` with the rate's
    error from the spread of the per-particle jump counts:
    ``tau_err = tau std(n_i) / (sqrt(N) mean(n_i))``.

    Examples
    --------
    >>> data = JumpData.from_particles([[1, -1], [1, 1, 1, -1]], [[.1, .2], [.1, .2, .3, .4]],
    ...                                t_total=1.0, d=2.0)
    >>> escape_time(data).tau
    0.3333333333333333
    """
    _check_jump_data(data)
    counts = data.counts.astype(np.float64)
    n_jumps = int(data.jumps.size)
    if n_jumps == 0:
        return EscapeTime(math.inf, math.nan, 0, data.n_particles)
    mean = counts.mean()
    tau = float(data.t_total / mean)
    if data.n_particles < 2:
        return EscapeTime(tau, math.nan, n_jumps, data.n_particles)
    rel = counts.std(ddof=1) / (math.sqrt(data.n_particles) * mean)
    return EscapeTime(tau, float(tau * rel), n_jumps, data.n_particles)


def jump_length_distribution(data: JumpData) -> JumpLengths:
    """Histogram of the signed jump lengths ``h / d`` over all jumps of all particles."""
    _check_jump_data(data)
    lengths, counts = np.unique(data.jumps, return_counts=True)
    total = counts.sum()
    if total == 0:
        return JumpLengths(lengths, counts, np.zeros(0), math.nan, math.nan)
    probabilities = counts / total
    fraction_long = float(probabilities[np.abs(lengths) > 1].sum())
    mean_square = float(np.sum(probabilities * lengths.astype(np.float64) ** 2))
    return JumpLengths(lengths, counts, probabilities, fraction_long, mean_square)


def random_walk_diffusion(data: JumpData) -> RandomWalkEstimate:
    """Random-walk diffusion coefficient ``D_rw = d^2 / (2 tau)`` (mm^2/s), docs/model.md §4.

    ``D_rw`` is linear in the mean jump count, so its relative error is that of
    the rate; it is 0 (with NaN error) when no particle jumped.  ``D_rw`` assumes
    unit jumps: compare ``jump_lengths.fraction_long`` (and the Green-Kubo ``D_0``,
    which uses ``<h^2>``) when longer jumps occur.
    """
    esc = escape_time(data)
    lengths = jump_length_distribution(data)
    if esc.n_jumps == 0:
        return RandomWalkEstimate(esc.tau, esc.tau_err, 0.0, math.nan, lengths)
    d_rw = data.d**2 / (2.0 * esc.tau)
    return RandomWalkEstimate(esc.tau, esc.tau_err, d_rw, d_rw * esc.tau_err / esc.tau, lengths)


def analytic_diffusion(params: Params, r: float, r_err: float = 0.0) -> AnalyticDiffusion:
    """Analytic random walk from the energy balance, docs/model.md §4.

    ``E = E_x + E_y + E_pot`` with ``E = A^2 w^2 / 2``, ``E_pot = g A``,
    ``E_y = r E_x`` gives ``E_x = (A^2 w^2 / 2 - g A) / (1 + r)`` and
    ``D_a = (d/2) sqrt(2 E_x) = (d/2) sqrt((A^2 w^2 - 2 g A) / (1 + r))``.

    Parameters
    ----------
    params : Params
        Uses ``A`` (mm), ``w`` (rad/s), ``g`` (mm/s^2), ``d`` (mm).
    r : float
        ``E_y / E_x`` (>= 0, or inf: then ``D_a = 0`` for Gamma >= 2), measured
        (``energy_ratio``) or given.
    r_err : float
        Standard error of ``r`` (>= 0, or NaN if unknown: then ``D_a_err`` is NaN),
        propagated: ``dD_a/dr = -D_a / (2 (1 + r))``.

    Returns
    -------
    AnalyticDiffusion
        ``D_a`` in mm^2/s; NaN with a ``reason`` where ``A^2 w^2 < 2 g A``
        (i.e. Gamma < 2: the energy balance leaves negative kinetic energy).

    Examples
    --------
    >>> round(analytic_diffusion(Params(f=85.0), r=1.0).D_a, 4)
    21.1224
    """
    if not isinstance(params, Params):
        raise ValueError(f"params must be a bbdyn.Params, got {type(params).__name__}")
    r, r_err = float(r), float(r_err)
    if not r >= 0:  # inf is allowed: no horizontal kinetic energy, D_a = 0
        raise ValueError(f"r must be finite and >= 0, or inf (E_x = 0), got {r}")
    if not (math.isnan(r_err) or (math.isfinite(r_err) and r_err >= 0)):  # NaN: unknown
        raise ValueError(f"r_err must be finite and >= 0 (or NaN: unknown), got {r_err}")
    A, w, g, d = params.A, params.w, params.g, params.d
    surplus = A**2 * w**2 - 2.0 * g * A  # twice the kinetic energy left by the balance
    if surplus < 0:
        reason = (
            f"A^2 w^2 = {A**2 * w**2:.6g} < 2 g A = {2 * g * A:.6g} mm^2/s^2 "
            f"(Gamma = {params.gamma:.4g} < 2): the energy balance leaves no kinetic energy"
        )
        return AnalyticDiffusion(math.nan, math.nan, math.nan, reason)
    e_x = 0.5 * surplus / (1.0 + r)
    d_a = 0.5 * d * math.sqrt(2.0 * e_x)
    return AnalyticDiffusion(d_a, d_a * r_err / (2.0 * (1.0 + r)), e_x, "")


def energy_ratio(E_x, E_y, E_x_err=None, E_y_err=None) -> EnergyRatio:
    """Measured ratio ``r = E_y / E_x`` of steady-state kinetic energies (docs/model.md §3, §4).

    Two forms of input:

    * per-particle time averages ``E_x``, ``E_y`` (1-D arrays of equal length
      >= 2, mm^2/s^2; no errors given): ``r = mean(E_y) / mean(E_x)`` with the
      delta-method error of a ratio of means, including their covariance,
      ``r_err^2 = var(E_y - r E_x) / (N mean(E_x)^2)``; when every ``E_x`` is 0 (no
      horizontal motion) ``r`` is inf (NaN if every ``E_y`` is 0 too) and ``r_err`` NaN;
    * ensemble means ``E_x``, ``E_y`` (floats) with standard errors
      ``E_x_err``, ``E_y_err``, taken as independent:
      ``r_err = sqrt(E_y_err^2 + r^2 E_x_err^2) / E_x``.
    """
    e_x, e_y = np.asarray(E_x, dtype=np.float64), np.asarray(E_y, dtype=np.float64)
    if not (np.all(np.isfinite(e_x)) and np.all(np.isfinite(e_y))):
        raise ValueError("E_x and E_y must be finite")
    if np.any(e_y < 0):
        raise ValueError(f"E_y must be >= 0 mm^2/s^2, got min {e_y.min()}")
    if e_x.ndim == 1 and E_x_err is None and E_y_err is None:
        if e_y.shape != e_x.shape or e_x.size < 2:
            raise ValueError(
                "per-particle E_x and E_y must be 1-D arrays of equal length >= 2, "
                f"got shapes {e_x.shape} and {e_y.shape}"
            )
        if np.any(e_x < 0):
            raise ValueError(f"E_x must be >= 0 mm^2/s^2, got min {e_x.min()}")
        if e_x.mean() == 0:  # no horizontal motion (e.g. all stuck at Gamma <= 1)
            return EnergyRatio(math.inf if e_y.mean() > 0 else math.nan, math.nan)
        r = e_y.mean() / e_x.mean()
        r_err = np.std(e_y - r * e_x, ddof=1) / (math.sqrt(e_x.size) * e_x.mean())
        return EnergyRatio(float(r), float(r_err))
    if e_x.ndim != 0 or e_y.ndim != 0 or E_x_err is None or E_y_err is None:
        raise ValueError(
            "give either per-particle arrays E_x, E_y (no errors) or scalar means with "
            "E_x_err and E_y_err"
        )
    s_x, s_y = float(E_x_err), float(E_y_err)
    if not (math.isfinite(s_x) and s_x >= 0 and math.isfinite(s_y) and s_y >= 0):
        raise ValueError(f"E_x_err and E_y_err must be finite and >= 0, got {s_x}, {s_y}")
    if e_x <= 0:
        raise ValueError(f"E_x must be > 0 mm^2/s^2, got {float(e_x)}")
    r = float(e_y / e_x)
    return EnergyRatio(r, math.hypot(s_y, r * s_x) / float(e_x))
