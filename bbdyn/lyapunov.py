"""Lyapunov exponents of the flat bouncing ball through impacts and sticks (docs/lyapunov.md).

``flat_lyapunov`` runs an ensemble of flat balls with their tangent frames
(``bbdyn.core.tangent``) and returns, per particle and per time window, the
growth of the two orthonormalised tangent vectors (QR method), the impacts
carried and the sticks (collapses of the tangent space).  ``LyapunovResult``
turns them into exponents per second and per impact with standard errors over
the particles, and into exponents per window for a convergence check.

A particle that sticks even once during the measurement has both exponents
``-inf``: the state after the release does not depend on the state before the
stick.  The *conditional* exponents count only the finite growth between
collapses (the frame restarts with the identity at each release), per second
of the whole run or per impact carried; they describe how fast nearby states
separate before the next stick.
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import IMPACT, OK, STATUS_MESSAGES, STUCK_FOREVER
from bbdyn.core.tangent import flat_tangent_run
from bbdyn.params import Params
from bbdyn.results import Result, make_meta

__all__ = ["LyapunovResult", "flat_lyapunov", "flat_lyapunov_from"]

#: Initial relative velocities are drawn in (0, V_BOX_HI] mm/s (as ``flatball.flat_ensemble``).
V_BOX_HI = 40.0


def _mean_se(values: np.ndarray) -> tuple[float, float]:
    """Mean and standard error of the mean over the first axis (NaN-free input)."""
    n = values.shape[0]
    mean = float(np.mean(values))
    if n < 2 or not np.all(np.isfinite(values)):
        return mean, math.nan
    return mean, float(np.std(values, ddof=1) / math.sqrt(n))


class LyapunovResult(Result):
    """Tangent growth of an ensemble of flat balls.

    Arrays (n particles, w windows): ``log_growth`` (n, w, 2) sums of
    ``log R[0, 0]``, ``log R[1, 1]``; ``impacts`` (n, w) impacts carried by the
    Jacobian; ``collapses`` (n, w) sticks; ``duration`` (n, w) seconds between
    the last events of successive windows; ``status`` (n,) the kernel's final
    status (``OK`` or ``STUCK_FOREVER``).  Meta: ``n``, ``t``, ``transient``,
    ``windows``, params, seed.
    """

    kind = "flat_lyapunov"

    def _totals(self):
        growth = self["log_growth"].sum(axis=1)
        return growth, self["impacts"].sum(axis=1), self["duration"].sum(axis=1)

    def conditional_exponents(self, per: str = "second") -> np.ndarray:
        """Exponents (n, 2) from the growth between collapses, per second (1/s) or per impact.

        NaN for a particle without an impact carried by the Jacobian (nothing measured:
        e.g. stuck for good before the measurement)."""
        growth, impacts, duration = self._totals()
        denom = _denominator(per, impacts, duration)
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = growth / denom[:, None]
        lam[impacts == 0] = math.nan
        return lam

    def exponents(self, per: str = "second") -> np.ndarray:
        """Exponents (n, 2) per second (1/s) or per impact; ``-inf`` for a particle that stuck."""
        lam = self.conditional_exponents(per)
        lam[self["collapses"].sum(axis=1) > 0] = -math.inf
        return lam

    def window_exponents(self, per: str = "second") -> np.ndarray:
        """Conditional largest exponent (w,) of each window, pooled over the particles."""
        growth = self["log_growth"][:, :, 0].sum(axis=0)
        denom = _denominator(per, self["impacts"].sum(axis=0), self["duration"].sum(axis=0))
        with np.errstate(divide="ignore", invalid="ignore"):
            return growth / denom

    def summary(self) -> dict:
        """Ensemble means and standard errors over particles (exponents in 1/s and per impact).

        Keys ``lam1_per_s``, ``lam1_per_s_se``, ``lam2_per_s``, ... and
        ``lam1_per_impact`` ..., each ``-inf`` if any particle stuck; the same
        with ``cond_`` prefixed for the conditional exponents (over the
        particles with at least one impact carried); ``stuck_fraction``,
        ``impacts_per_s`` (mean impact rate).
        """
        out = {}
        stuck = self["collapses"].sum(axis=1) > 0
        for per, tag in (("second", "per_s"), ("impact", "per_impact")):
            lam, cond = self.exponents(per), self.conditional_exponents(per)
            ok = np.all(np.isfinite(cond), axis=1)
            for i in (0, 1):
                out[f"lam{i + 1}_{tag}"], out[f"lam{i + 1}_{tag}_se"] = (
                    (-math.inf, math.nan) if stuck.any() else _mean_se(lam[:, i])
                )
                out[f"cond_lam{i + 1}_{tag}"], out[f"cond_lam{i + 1}_{tag}_se"] = (
                    _mean_se(cond[ok, i]) if ok.any() else (math.nan, math.nan)
                )
        _, impacts, duration = self._totals()
        out["stuck_fraction"] = float(np.mean(stuck))
        out["impacts_per_s"] = float(np.sum(impacts) / np.sum(duration))
        return out

    def plot(self, ax=None):
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        lam = self.window_exponents()
        ax.plot(np.arange(1, lam.size + 1), lam, "o-")
        ax.set(xlabel="window", ylabel="conditional largest exponent (1/s)")
        return ax


def _denominator(per: str, impacts: np.ndarray, duration: np.ndarray) -> np.ndarray:
    if per == "second":
        return duration
    if per == "impact":
        return impacts.astype(float)
    raise ValueError(f"per must be 'second' or 'impact', got {per!r}")


def _check_positive(name: str, value, unit: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number > 0 {unit}, got {value}")
    return value


def _check_count(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


def flat_lyapunov_from(
    params: Params, phase0, vrel0, *, t: float, transient: float = 0.0, windows: int = 4
) -> LyapunovResult:
    """Tangent growth of flat balls started just after impacts at ``(phase0, vrel0)``.

    Parameters
    ----------
    params : Params
    phase0, vrel0 : array_like (n,)
        Impact phases (rad) and relative velocities after them (mm/s, >= 0).
    t : float
        Measurement time (s) after the transient, split into ``windows`` equal windows.
    transient : float
        Time (s) run first with the frame but not measured (>= 0).
    windows : int
        Number of windows (>= 1), for the convergence check.

    Returns
    -------
    LyapunovResult
        Raises ``RuntimeError`` naming the particle if a kernel fails.
    """
    t = _check_positive("t", t, "s")
    transient = float(transient)
    if not (math.isfinite(transient) and transient >= 0):
        raise ValueError(f"transient must be a finite number >= 0 s, got {transient}")
    windows = _check_count("windows", windows)
    phase0, vrel0 = (
        np.atleast_1d(np.asarray(phase0, float)),
        np.atleast_1d(np.asarray(vrel0, float)),
    )
    if phase0.shape != vrel0.shape or phase0.ndim != 1:
        raise ValueError(
            f"phase0 and vrel0 must be 1D of one length, got {phase0.shape}, {vrel0.shape}"
        )
    if not (np.all(np.isfinite(phase0)) and np.all(np.isfinite(vrel0)) and np.all(vrel0 >= 0)):
        raise ValueError("phase0 must be finite and vrel0 finite and >= 0 mm/s")
    kp = params.kernel()
    start = time.perf_counter()
    n = phase0.size
    t0 = transient * params.f  # periods
    t_ends = t0 + (t * params.f) * np.arange(1, windows + 1) / windows
    log_growth = np.zeros((n, windows, 2))
    impacts = np.zeros((n, windows), np.int64)
    collapses = np.zeros((n, windows), np.int64)
    duration = np.zeros((n, windows))
    status = np.zeros(n, np.int64)
    for i in range(n):
        status[i], duration[i] = _run_one(
            kp, phase0[i] % TWO_PI, vrel0[i], t0, t_ends, log_growth[i], impacts[i], collapses[i]
        )
        if status[i] not in (OK, STUCK_FOREVER):
            raise RuntimeError(
                f"particle {i} (phase0 {phase0[i]!r}, vrel0 {vrel0[i]!r}): "
                f"{STATUS_MESSAGES[status[i]]}"
            )
    arrays = dict(
        log_growth=log_growth, impacts=impacts, collapses=collapses, duration=duration,
        status=status, phase0=phase0, vrel0=vrel0,
    )  # fmt: skip
    meta = make_meta(
        params, wall_s=time.perf_counter() - start, n=n, t=t, transient=transient, windows=windows
    )
    return LyapunovResult(arrays, meta)


def _run_one(kp, phase, vrel, t0, t_ends, log_growth, impacts, collapses):
    """Transient then measurement of one particle; returns (status, window durations in s)."""
    frame = np.array([1.0, 0.0, 0.0, 1.0])
    scratch = (np.zeros((1, 2)), np.zeros(1, np.int64), np.zeros(1, np.int64), np.full(1, np.nan))
    state = (0.0, phase, vrel, IMPACT)
    if t0 > 0:
        *state, status = flat_tangent_run(*state, kp, np.array([t0]), frame, *scratch)
        if status == STUCK_FOREVER:
            # stuck for good before the measurement: a collapse, then no events
            collapses[0] += 1
            return status, np.diff(np.concatenate([[t0], t_ends])) / (kp.w / TWO_PI)
        if status != OK:
            return status, np.zeros(t_ends.size)
    start = state[0] + state[1] / TWO_PI
    ends = np.full(t_ends.size, np.nan)
    *_, status = flat_tangent_run(*state, kp, t_ends, frame, log_growth, impacts, collapses, ends)
    if status == STUCK_FOREVER:
        # stuck for good: the rest of the measurement passes without events
        ends[np.isnan(ends)] = t_ends[np.isnan(ends)]
    # windows without events: their end is the previous window's
    filled = np.concatenate([[start], ends])
    for k in range(1, filled.size):
        if np.isnan(filled[k]):
            filled[k] = filled[k - 1]
    return status, np.diff(filled) / (kp.w / TWO_PI)


def flat_lyapunov(
    params: Params, n: int, *, t: float, transient: float = 1.0, windows: int = 4, seed: int = 0
) -> LyapunovResult:
    """Lyapunov exponents of ``n`` flat balls from random initial impacts.

    Particle i draws its phase uniformly in [0, 2 pi) and ``vrel`` uniformly in
    (0, 40] mm/s from ``np.random.SeedSequence(seed).spawn(n)[i]``: its numbers
    depend only on (seed, i).  See ``flat_lyapunov_from`` for ``t``,
    ``transient`` (s) and ``windows``.

    Examples
    --------
    >>> res = flat_lyapunov(Params(f=58.0), 2, t=1.0, transient=0.5, seed=1)
    >>> res["log_growth"].shape
    (2, 4, 2)
    """
    n = _check_count("n", n)
    draws = np.array(
        [np.random.default_rng(c).random(2) for c in np.random.SeedSequence(seed).spawn(n)]
    )
    res = flat_lyapunov_from(
        params, TWO_PI * draws[:, 0], V_BOX_HI * (1.0 - draws[:, 1]),
        t=t, transient=transient, windows=windows,
    )  # fmt: skip
    res.meta["seed"] = seed
    return res
