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

from bbdyn.classify import classify
from bbdyn.core.billiard_tangent import (
    SpectrumWindows,
    billiard_tangent_run,
    complete_frame,
)
from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import IMPACT, OK, STATUS_MESSAGES, STUCK_FOREVER
from bbdyn.core.tangent import TangentWindows, flat_tangent_run
from bbdyn.ensemble import initial_conditions, kernel_states
from bbdyn.params import Params
from bbdyn.results import Result, make_meta

__all__ = [
    "BilliardLyapunovResult",
    "LyapunovResult",
    "billiard_lyapunov",
    "billiard_lyapunov_from",
    "flat_lyapunov",
    "flat_lyapunov_from",
    "top_orbit_exponent",
]

#: Initial relative velocities are drawn in (0, V_BOX_HI] mm/s (as ``flatball.flat_ensemble``).
V_BOX_HI = 40.0


#: Windows whose exponents disagree with p below this (chi^2 test, ``window_agreement``)
#: are flagged: the exponent still drifts in time.
WINDOW_P_MIN = 1e-3


def window_agreement(growth: np.ndarray, elapsed: np.ndarray) -> dict:
    """Do the windows give the same exponent within their errors?  A chi^2 test.

    ``growth`` and ``elapsed`` (n particles, w windows): each particle's log growth and
    its seconds (or events) in each window.  The particles with a finite exponent
    ``growth / elapsed`` in every window give each window's mean and standard error; the
    window means are tested against their weighted mean, chi^2 with w - 1 degrees of
    freedom.  Returns ``window_chi2``, ``window_dof``, ``window_p`` (NaN when there is
    nothing to compare: one window, fewer than two particles, or a window without
    spread) and ``windows_agree`` (``window_p >= WINDOW_P_MIN``, True when untested).
    """
    from scipy.stats import chi2

    with np.errstate(divide="ignore", invalid="ignore"):
        lam = growth / elapsed
    lam = lam[np.all(np.isfinite(lam), axis=1)]
    n, w = lam.shape
    out = {"window_chi2": math.nan, "window_dof": w - 1, "window_p": math.nan}
    if n >= 2 and w >= 2:
        var = lam.var(axis=0, ddof=1) / n
        if np.all(var > 0):
            mean = np.sum(lam.mean(axis=0) / var) / np.sum(1 / var)
            out["window_chi2"] = float(np.sum((lam.mean(axis=0) - mean) ** 2 / var))
            out["window_p"] = float(chi2.sf(out["window_chi2"], w - 1))
    out["windows_agree"] = not out["window_p"] < WINDOW_P_MIN
    return out


def _check_windows(params: Params, t: float, windows: int) -> None:
    """Refuse windows shorter than one driving period (nothing to measure in them)."""
    if t * params.f < windows:
        raise ValueError(
            f"t = {t:g} s in {windows} windows leaves less than one driving period "
            f"(1/f = {1 / params.f:.4g} s) per window: use t >= {windows / params.f:.4g} s "
            "or fewer windows"
        )


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
        ``impacts_per_s`` (mean impact rate); the agreement of the windows'
        conditional largest exponents (``window_agreement``).
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
        out.update(window_agreement(self["log_growth"][:, :, 0], self["duration"]))
        return out

    def plot(self, ax=None):
        return _plot_windows(self.window_exponents(), ax)


def _plot_windows(lam: np.ndarray, ax=None):
    """The conditional largest exponent of each window (1/s), the convergence check."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots()
    ax.plot(np.arange(1, lam.size + 1), lam, "o-")
    ax.set(xlabel="window", ylabel="conditional largest exponent (1/s)")
    return ax


def _denominator(
    per: str, counts: np.ndarray, duration: np.ndarray, count: str = "impact"
) -> np.ndarray:
    """Elapsed seconds (``per = "second"``) or the number of events (``per = count``)."""
    if per == "second":
        return duration
    if per == count:
        return counts.astype(float)
    raise ValueError(f"per must be 'second' or {count!r}, got {per!r}")


def _check_untilted(params: Params) -> None:
    """Refuse a tilted floor: the billiard's tangent dynamics (``core.billiard_tangent``)
    is that of the untilted model."""
    if params.phi != 0.0:
        raise ValueError(
            f"the billiard's Lyapunov exponents are computed for an untilted floor only, got "
            f"phi = {params.phi:g} degrees; use phi = 0"
        )


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
    _check_windows(params, t, windows)
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
    scratch = TangentWindows(
        np.zeros((1, 2)), np.zeros(1, np.int64), np.zeros(1, np.int64), np.full(1, np.nan)
    )
    state = (0.0, phase, vrel, IMPACT)
    if t0 > 0:
        state, status = flat_tangent_run(state, kp, np.array([t0]), frame, scratch)
        if status == STUCK_FOREVER:
            # stuck for good before the measurement: a collapse, then no events
            collapses[0] += 1
            return status, np.diff(np.concatenate([[t0], t_ends])) / (kp.w / TWO_PI)
        if status != OK:
            return status, np.zeros(t_ends.size)
    start = state[0] + state[1] / TWO_PI
    ends = np.full(t_ends.size, np.nan)
    out = TangentWindows(log_growth, impacts, collapses, ends)
    _, status = flat_tangent_run(state, kp, t_ends, frame, out)
    return status, _window_durations(start, ends, t_ends, status, kp)


def _window_durations(start, ends, t_ends, status, kp) -> np.ndarray:
    """Durations (s) of the windows from the run's start and each window's last event (periods).

    Stuck for good (``STUCK_FOREVER``): the rest of the measurement passes without events.
    A window without events ends where the previous one did.
    """
    if status == STUCK_FOREVER:
        ends[np.isnan(ends)] = t_ends[np.isnan(ends)]
    filled = np.concatenate([[start], ends])
    for k in range(1, filled.size):
        if np.isnan(filled[k]):
            filled[k] = filled[k - 1]
    return np.diff(filled) / (kp.w / TWO_PI)


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


# ---- the billiard ----------------------------------------------------------------------------
#: ``labels`` of particles that were not classified (``billiard_lyapunov``).
NOT_CLASSIFIED = -3


class BilliardLyapunovResult(Result):
    """Growth of the tangent vectors of an ensemble of billiard particles (largest exponent,
    or all four).

    Arrays (n particles, w windows): ``log_growth`` (n, w) sums of ``log |J v| / |v|``
    of the first vector over the events of each window; ``collisions`` (n, w) IMPACT and
    STICK events;
    ``collapses`` (n, w) sticks at a wedge (the whole tangent space collapses, the
    exponent is ``-inf``); ``duration`` (n, w) seconds between the last events of
    successive windows; ``status`` (n,); ``initial`` (n, 3) the initial conditions
    ``(s, vx+, vy+)`` at t = 0 (mm, mm/s); ``labels`` (n,) the attractor of each particle
    found by ``bbdyn.classify`` (``-1`` unsettled, ``-2`` failed, ``NOT_CLASSIFIED``).
    With the whole spectrum (meta ``spectrum``): ``spectrum_growth`` (n, w, 4) sums of
    ``log R_ii`` over the *carried* events (impact to impact: no stick, release or flight
    from a release); ``log_det`` (n, w) the closed-form ``log |det J|`` summed over the
    same events (``core.billiard_tangent.event_log_det``); ``carried`` (n, w) their number
    and ``carried_time`` (n, w) their seconds; ``sticks`` (n, w) STICK events.
    Meta: ``n``, ``t``, ``transient``, ``windows``, ``spectrum``, ``qr_every``, params, seed.
    """

    kind = "billiard_lyapunov"

    def _totals(self):
        return (
            self["log_growth"].sum(axis=1),
            self["collisions"].sum(axis=1),
            self["duration"].sum(axis=1),
        )

    def conditional_exponents(self, per: str = "second") -> np.ndarray:
        """Largest exponent (n,) from the growth between collapses, per second (1/s) or per
        collision; NaN for a particle without a collision in the measurement."""
        growth, collisions, duration = self._totals()
        denom = _denominator(per, collisions, duration, "collision")
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = growth / denom
        lam[collisions == 0] = math.nan
        # stuck for good (Gamma <= 1) before or during the measurement: the state stays
        # where it is, neighbouring states too, so the growth after the stick is zero
        stuck = (self["status"] == STUCK_FOREVER) & (collisions == 0)
        lam[stuck] = 0.0
        return lam

    def exponents(self, per: str = "second") -> np.ndarray:
        """Largest exponent (n,) per second (1/s) or per collision; ``-inf`` for a collapse."""
        lam = self.conditional_exponents(per)
        lam[self["collapses"].sum(axis=1) > 0] = -math.inf
        return lam

    def window_exponents(self, per: str = "second", select=None) -> np.ndarray:
        """Conditional largest exponent (w,) of each window, pooled over the (selected)
        particles: the convergence check in time."""
        sel = np.ones(self["status"].shape, bool) if select is None else select
        growth = self["log_growth"][sel].sum(axis=0)
        denom = _denominator(
            per, self["collisions"][sel].sum(axis=0), self["duration"][sel].sum(axis=0),
            "collision",
        )  # fmt: skip
        with np.errstate(divide="ignore", invalid="ignore"):
            return growth / denom

    def summary(self, select=None) -> dict:
        """Means and standard errors over the (selected) particles.

        Keys ``lam1_per_s``, ``lam1_per_s_se`` (1/s), ``lam1_per_collision``,
        ``lam1_per_collision_se``: ``-inf`` (error NaN) if a particle collapsed; the same
        with ``cond_`` for the growth between collapses; ``collapse_fraction``,
        ``collisions_per_s``, ``n``, ``window_cond_lam1_per_s`` (1/s, per window) and their
        agreement (``window_agreement``); with the whole spectrum, ``spectrum_summary``.
        """
        sel = np.ones(self["status"].shape, bool) if select is None else np.asarray(select)
        out = {"n": int(np.sum(sel))}
        collapsed = self["collapses"][sel].sum(axis=1) > 0
        for per, tag in (("second", "per_s"), ("collision", "per_collision")):
            cond = self.conditional_exponents(per)[sel]
            ok = np.isfinite(cond)
            out[f"lam1_{tag}"], out[f"lam1_{tag}_se"] = (
                (-math.inf, math.nan) if collapsed.any() else _mean_se(cond)
            )
            out[f"cond_lam1_{tag}"], out[f"cond_lam1_{tag}_se"] = (
                _mean_se(cond[ok]) if ok.any() else (math.nan, math.nan)
            )
        _, collisions, duration = self._totals()
        out["collapse_fraction"] = float(np.mean(collapsed)) if collapsed.size else math.nan
        total = float(np.sum(duration[sel]))
        out["collisions_per_s"] = float(np.sum(collisions[sel]) / total) if total > 0 else math.nan
        out["window_cond_lam1_per_s"] = [float(x) for x in self.window_exponents(select=sel)]
        out.update(window_agreement(self["log_growth"][sel], self["duration"][sel]))
        if "spectrum_growth" in self.arrays:
            out.update(self.spectrum_summary(sel))
        return out

    def _require_spectrum(self) -> None:
        if "spectrum_growth" not in self.arrays:
            raise ValueError("the whole spectrum needs a run with spectrum=True")

    def free(self) -> np.ndarray:
        """(n,) whether the whole frame carried every measured event of the particle (no
        stick, release or collapse): only then are all four exponents finite."""
        self._require_spectrum()
        collisions = self["collisions"].sum(axis=1)
        return (
            (self["carried"].sum(axis=1) == collisions)
            & (collisions > 0)
            & (self["collapses"].sum(axis=1) == 0)
            & (self["status"] == OK)
        )

    def spectrum(self, per: str = "second") -> np.ndarray:
        """All four exponents (n, 4), largest first, per second (1/s) or per collision.

        A particle carried through every event (``free``): the sums of ``log R_ii`` over
        the elapsed time or the collisions.  A particle that stuck: its largest exponent
        (``exponents``, the position along the floor survives the stick) and ``-inf`` three
        times (a stick leaves one direction); a collapse (stick at a wedge): four ``-inf``.
        """
        self._require_spectrum()
        lam = np.full((self["status"].size, 4), -math.inf)
        lam[:, 0] = self.exponents(per)
        free = self.free()
        growth = self["spectrum_growth"].sum(axis=1)
        denom = _denominator(
            per, self["collisions"].sum(axis=1), self["duration"].sum(axis=1), "collision"
        )
        lam[free, 1:] = growth[free, 1:] / denom[free, None]
        return lam

    def free_spectrum(self, per: str = "second") -> np.ndarray:
        """The four exponents (n, 4) from the growth over the carried events only (between
        sticks), per second of them (1/s) or per carried event; NaN without one."""
        self._require_spectrum()
        denom = _denominator(
            per, self["carried"].sum(axis=1), self["carried_time"].sum(axis=1), "event"
        )
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = self["spectrum_growth"].sum(axis=1) / denom[:, None]
        lam[self["carried"].sum(axis=1) == 0] = math.nan
        return lam

    def determinant_check(self) -> tuple[np.ndarray, np.ndarray]:
        """Per particle (n,): the sum of the four exponents per carried event and the mean
        closed-form ``log |det J|`` over the same events (NaN without one)."""
        self._require_spectrum()
        carried = self["carried"].sum(axis=1).astype(float)
        with np.errstate(divide="ignore", invalid="ignore"):
            qr = self["spectrum_growth"].sum(axis=(1, 2)) / carried
            closed = self["log_det"].sum(axis=1) / carried
        return qr, closed

    def spectrum_summary(self, select=None) -> dict:
        """The spectrum's numbers over the (selected) particles, mean and standard error of
        each exponent (lists of four, largest first).

        ``spectrum_per_s`` (1/s), ``spectrum_per_collision`` (``-inf``, error NaN, where a
        particle stuck: ``spectrum``); ``free_spectrum_per_s``, ``free_spectrum_per_event``
        (between sticks, over the particles with a carried event); ``spectrum_sum_per_event``
        and ``log_det_per_event`` (the QR sum against the closed form, per carried event),
        ``spectrum_sum_deviation`` (the largest difference of the two over the particles);
        ``stuck_fraction`` (particles with a stick or collapse), ``stick_event_fraction``
        (STICK events per collision), ``inf_exponents`` (most ``-inf`` exponents of a
        particle), ``carried_fraction`` (carried events per collision).
        """
        sel = np.ones(self["status"].shape, bool) if select is None else np.asarray(select)
        out = {}
        for key, lam in (
            ("spectrum_per_s", self.spectrum("second")),
            ("spectrum_per_collision", self.spectrum("collision")),
            ("free_spectrum_per_s", self.free_spectrum("second")),
            ("free_spectrum_per_event", self.free_spectrum("event")),
        ):
            lam = lam[sel]
            if key.startswith("free"):
                lam = lam[np.all(np.isfinite(lam), axis=1)]
            pairs = [_mean_se(lam[:, i]) if lam.shape[0] else (math.nan, math.nan)
                     for i in range(4)]  # fmt: skip
            out[key], out[f"{key}_se"] = [p[0] for p in pairs], [p[1] for p in pairs]
        qr, closed = (x[sel] for x in self.determinant_check())
        ok = np.isfinite(qr)
        for key, x in (("spectrum_sum_per_event", qr), ("log_det_per_event", closed)):
            out[key], out[f"{key}_se"] = _mean_se(x[ok]) if ok.any() else (math.nan, math.nan)
        out["spectrum_sum_deviation"] = float(np.max(np.abs(qr[ok] - closed[ok]))) if ok.any() \
            else math.nan
        collisions = self["collisions"][sel].sum()
        out["stuck_fraction"] = float(np.mean(~self.free()[sel])) if sel.any() else math.nan
        out["stick_event_fraction"] = float(self["sticks"][sel].sum() / collisions) \
            if collisions else math.nan
        out["carried_fraction"] = float(self["carried"][sel].sum() / collisions) \
            if collisions else math.nan
        spec = self.spectrum("second")[sel]
        out["inf_exponents"] = int(np.max(np.sum(spec == -math.inf, axis=1))) if sel.any() else 0
        return out

    def by_attractor(self) -> list[dict]:
        """``summary`` of the particles of each attractor (``labels >= 0``), with its
        ``attractor`` label and ``fraction`` of the particles; [] if none was classified."""
        labels = self["labels"]
        out = []
        for a in np.unique(labels[labels >= 0]):
            sel = labels == a
            out.append({"attractor": int(a), "fraction": float(np.mean(sel)), **self.summary(sel)})
        return out

    def plot(self, ax=None):
        return _plot_windows(self.window_exponents(), ax)


def _start_frame(m: int) -> np.ndarray:
    """The first tangent frame (4, m): ``(1, 1, 1, 1) / 2`` and, for m > 1, its complement."""
    frame = np.zeros((4, m))
    frame[:, 0] = 0.5
    complete_frame(frame)
    return frame


def billiard_lyapunov_from(
    params: Params,
    states,
    *,
    t: float,
    transient: float = 0.0,
    windows: int = 4,
    spectrum: bool = False,
    qr_every: int = 1,
) -> BilliardLyapunovResult:
    """Largest exponent (or the whole spectrum) of billiard particles from kernel event states.

    Parameters
    ----------
    params : Params
    states : array_like (n, 7)
        Event states ``(periods, phase, tile, xi, vx, vyrel, kind)`` (``core.billiard``),
        e.g. ``bbdyn.ensemble.kernel_states``.
    t : float
        Measurement time (s) after the transient, split into ``windows`` equal windows.
    transient : float
        Time (s) run first with the tangent frame but not measured (>= 0).
    windows : int
        Number of windows (>= 1), for the convergence check.
    spectrum : bool
        Carry four tangent vectors (all four exponents) instead of one.
    qr_every : int
        Impact-to-impact events between two QR steps (>= 1).

    Returns
    -------
    BilliardLyapunovResult
        (``initial`` NaN, ``labels`` NOT_CLASSIFIED); raises ``RuntimeError`` naming the
        particle if a kernel fails.  The first tangent vector starts as ``(1, 1, 1, 1) / 2``
        in the section coordinates ``(theta, x, vx, vyrel)`` (rad, mm, mm/s, mm/s), the
        others (``spectrum``) as a basis of its complement.
    """
    _check_untilted(params)
    t = _check_positive("t", t, "s")
    transient = float(transient)
    if not (math.isfinite(transient) and transient >= 0):
        raise ValueError(f"transient must be a finite number >= 0 s, got {transient}")
    windows = _check_count("windows", windows)
    qr_every = _check_count("qr_every", qr_every)
    _check_windows(params, t, windows)
    states = np.atleast_2d(np.asarray(states, float))
    if states.ndim != 2 or states.shape[1] != 7 or not np.all(np.isfinite(states)):
        raise ValueError(f"states must be a finite (n, 7) array, got shape {states.shape}")
    kp = params.kernel()
    start = time.perf_counter()
    n = states.shape[0]
    m = 4 if spectrum else 1
    t0 = transient * params.f  # periods
    t_ends = t0 + (t * params.f) * np.arange(1, windows + 1) / windows
    log_growth = np.zeros((n, windows))
    collisions = np.zeros((n, windows), np.int64)
    collapses = np.zeros((n, windows), np.int64)
    duration = np.zeros((n, windows))
    status = np.zeros(n, np.int64)
    spec = SpectrumWindows(
        np.zeros((n, windows, m)), np.zeros((n, windows)), np.zeros((n, windows), np.int64),
        np.zeros((n, windows)), np.zeros((n, windows), np.int64),
    )  # fmt: skip
    for i in range(n):
        state = (*states[i, :6], int(states[i, 6]))
        frame = _start_frame(m)
        st = OK
        if t0 > 0:
            state, st = billiard_tangent_run(
                state, kp, np.array([t0]), frame, qr_every, *_scratch_windows(1, m)
            )
        ends = np.full(windows, np.nan)
        first = state[0] + state[1] / TWO_PI
        if st == OK:
            out = TangentWindows(log_growth[i], collisions[i], collapses[i], ends)
            _, st = billiard_tangent_run(
                state, kp, t_ends, frame, qr_every, out, SpectrumWindows(*(a[i] for a in spec))
            )
        first = min(max(first, t0), t_ends[0])  # stuck for good in the transient: from t0
        status[i] = st
        if st not in (OK, STUCK_FOREVER):
            raise RuntimeError(
                f"particle {i} (state {tuple(states[i])}): {STATUS_MESSAGES[st]}"
            )
        duration[i] = _window_durations(first, ends, t_ends, st, kp)
    arrays = dict(
        log_growth=log_growth, collisions=collisions, collapses=collapses, duration=duration,
        status=status, initial=np.full((n, 3), np.nan), labels=np.full(n, NOT_CLASSIFIED),
    )  # fmt: skip
    if spectrum:
        arrays.update(
            spectrum_growth=spec.log, log_det=spec.log_det, carried=spec.carried,
            carried_time=spec.carried_time / params.f, sticks=spec.sticks,
        )  # fmt: skip
    meta = make_meta(
        params, wall_s=time.perf_counter() - start, n=n, t=t, transient=transient,
        windows=windows, spectrum=spectrum, qr_every=qr_every,
    )  # fmt: skip
    return BilliardLyapunovResult(arrays, meta)


def _scratch_windows(n_w: int, m: int) -> tuple[TangentWindows, SpectrumWindows]:
    """Output arrays of ``billiard_tangent_run`` for ``n_w`` windows whose numbers are dropped."""
    return (
        TangentWindows(np.zeros(n_w), np.zeros(n_w, np.int64), np.zeros(n_w, np.int64),
                       np.zeros(n_w)),
        SpectrumWindows(np.zeros((n_w, m)), np.zeros(n_w), np.zeros(n_w, np.int64),
                        np.zeros(n_w), np.zeros(n_w, np.int64)),
    )  # fmt: skip


def billiard_lyapunov(
    params: Params,
    n: int,
    *,
    t: float,
    transient: float = 1.0,
    windows: int = 4,
    seed: int = 0,
    classify_attractors: bool = False,
    t_classify: float | None = None,
    spectrum: bool = False,
    qr_every: int = 1,
) -> BilliardLyapunovResult:
    """Largest Lyapunov exponent (or all four) of ``n`` billiard particles from the reference box.

    The initial conditions ``(s, vx+, vy+)`` at t = 0 are those of
    ``bbdyn.ensemble.ensemble(params, n, seed=seed)`` (``initial_conditions``).  With
    ``classify_attractors`` the same initial conditions are first classified by
    ``bbdyn.classify.classify(params, t=t_classify, n=n, seed=seed)`` (``t_classify``
    defaults to ``transient + t``), whose attractor labels are stored (``by_attractor``).
    See ``billiard_lyapunov_from`` for ``t``, ``transient`` (s), ``windows``, ``spectrum``
    and ``qr_every``.

    Examples
    --------
    >>> res = billiard_lyapunov(Params(f=85.2), 2, t=1.0, transient=0.5, seed=1)
    >>> res["log_growth"].shape
    (2, 4)
    """
    n = _check_count("n", n)
    _check_untilted(params)
    _check_windows(params, _check_positive("t", t, "s"), _check_count("windows", windows))
    start = time.perf_counter()
    labels = np.full(n, NOT_CLASSIFIED)
    if classify_attractors:
        t_c = float(transient) + float(t) if t_classify is None else t_classify
        cls = classify(params, t=t_c, n=n, seed=seed)
        ics, labels = np.asarray(cls["initial"], float), np.asarray(cls["labels"])
    else:
        ics = initial_conditions(params, n, seed)
    res = billiard_lyapunov_from(
        params, kernel_states(params, ics), t=t, transient=transient, windows=windows,
        spectrum=spectrum, qr_every=qr_every,
    )  # fmt: skip
    res.arrays["initial"] = ics
    res.arrays["labels"] = labels
    res.meta.update(seed=seed, wall_s=time.perf_counter() - start, classified=classify_attractors)
    if classify_attractors:
        res.meta["classification"] = cls.summary
    return res


def top_orbit_exponent(params: Params, k: int) -> float:
    """Largest exponent (1/s) of the vertical k/1 orbit on an arc top, in closed form.

    The flat ball's k/1 orbit bouncing on the top of an arc (``xi = 0``, ``vx = 0``) is an
    orbit of the billiard; its horizontal perturbations follow the curvature block
    ``[[1, tau], [kappa, beta + kappa tau]]`` (``derivations/billiard_orbit_jacobian.py``)
    with ``kappa tau = 4 pi^2 k^2 g (alpha + beta) / ((1 + alpha) w^2 R)``, whose
    multiplier ``mu = (T + sqrt(T^2 - 4 beta)) / 2``, ``T = 1 + beta + kappa tau``, exceeds
    1: the exponent is ``log(mu) / tau`` with ``tau = k / f``.  (Per collision: ``log mu``.)
    """
    k = _check_count("k", k)
    p = params
    kappa_tau = 4 * math.pi**2 * k**2 * p.g * (p.alpha + p.beta) / ((1 + p.alpha) * p.w**2 * p.R)
    trace = 1 + p.beta + kappa_tau
    mu = (trace + math.sqrt(trace * trace - 4 * p.beta)) / 2
    return math.log(mu) * p.f / k
