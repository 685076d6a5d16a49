"""Velocity autocorrelation, Green-Kubo D and distributions at one frequency.

See docs/distributions.md.

``correlations(params, n=..., t=...)`` runs two independent reference ensembles
(docs/model.md §3) at one frequency and returns a ``CorrelationResult`` with

* the velocity autocorrelation ``C(tau) = <vx(s) vx(s + tau)>`` (mm^2/s^2) in continuous
  time, averaged over time origins ``s`` after the transient and over particles, and the
  Green-Kubo integral ``D_GK(T) = int_0^T C(tau) dtau`` (mm^2/s) with its standard error
  over particles; the Einstein D (``EnsembleResult.D``) of a second ensemble drawn from
  an independent seed stream, and ``z = (D_GK - D) / sqrt(D_GK_se^2 + D_se^2)``;
* the displacement distribution ``P(x, tau)`` of ``x(s + tau) - x(s)`` at a few lags and
  its excess kurtosis against ``tau``, with jackknife errors over particles;
* the distribution of the position within a tile, ``u = x mod d`` (0 and d are wedges,
  d/2 a bump top), at collisions and at fixed times;
* the distribution of the number of tiles crossed per flight, ``|l_{j+1} - l_j|`` between
  consecutive collisions (IMPACT or STICK).

The motion x(t) between events.  A flight moves at its constant ``vx``; a STICK rides the
floor with ``vx = 0`` and its RELEASE leaves with ``vx = 0`` (a vertical hop), so x is
piecewise linear in t.  A chattering sequence whose tail the event kernel sums in closed
form (``core.billiard.chatter_sum``) is one STICK event at the time of rest, moved along
the arc by the sum's drift: its few-nanosecond tail is integrated, like every observable of
the ensemble kernel, as part of the flight that ends in it, and the drift (nanometres)
puts x(t) on the STICK point at that time.  x(t) is thus exact at every event time and
linear in between; ``bin_velocities`` and ``exact_correlation`` take it as such (knots
``(t_i, x_i)``).

``C`` is computed on a grid of ``h = period / bins_per_period``.  The ensemble kernel
evaluates x exactly at the grid times ``s_k`` (``EnsembleResult["displacement"]``), so
``V_k = (x(s_{k+1}) - x(s_k)) / h`` is the exact time average of vx over bin k, and

    c_m = <V_k V_{k+m}> = int C(tau) Lambda_h(tau - m h) dtau,

C smoothed by the triangle ``Lambda_h`` of half-width h (unit area): exact where C is
straight on the scale h, and h is 1/16 of a period by default, short against flights of
about a period.  The GK integral needs no such condition: the triangles sum to one, so
``h (c_0 / 2 + sum_{m=1}^{M} c_m) = int_0^{T} C(tau) w(tau) dtau`` exactly, with weight 1
up to ``M h`` and a linear taper to 0 at ``T = (M + 1) h``.  ``exact_correlation`` is the
piecewise form itself (no grid), for short runs and checks.

D_GK and the Einstein D estimate the same number in different ways: D_GK integrates the
correlation of velocities up to a cutoff, with time origins along each trajectory after the
transient (it assumes stationarity and that C has decayed by the cutoff; its error grows
with the cutoff); the Einstein D fits the slope of the mean squared displacement from t = 0
over the late half of the run of another set of particles (it assumes the MSD is linear
there).  A long correlation tail beyond the cutoff, or a drift of the state during the run,
separates them.

>>> from bbdyn import Params
>>> res = correlations(Params(f=85.2), n=20, t=10.0, seed=0)     # doctest: +SKIP
>>> res.meta["D_GK"], res.meta["D_GK_se"], res.meta["z"]          # doctest: +SKIP
"""

from __future__ import annotations

import math
import time

import numpy as np

from bbdyn.billiard import xi_at_arc_length
from bbdyn.ensemble import ensemble, initial_conditions
from bbdyn.params import Params, check_params
from bbdyn.results import Result, make_meta
from bbdyn.runs import check_n, check_run

__all__ = [
    "CorrelationResult",
    "bin_velocities",
    "correlations",
    "exact_correlation",
    "excess_kurtosis",
    "gk_running",
    "grid_times",
    "jump_lengths",
    "lag_moments",
    "binned_correlation",
    "pull",
]

#: Bins per driving period of the velocity grid (``h = period / BINS_PER_PERIOD``).
BINS_PER_PERIOD = 16
#: Particles per ensemble run of the correlation ensemble (bounds the memory of the grid).
BATCH = 100
#: Bins of the histograms of P(x, tau) and of the position within a tile.
N_BINS = 60
#: Half-width of the P(x, tau) histograms: the larger of ``HIST_SIGMAS`` Einstein standard
#: deviations ``sqrt(2 D tau)`` (D raised by two standard errors) and ``HIST_SPAN`` times the
#: largest |x(s + tau) - x(s)| of the first batch of particles (bounded, trapped motion).
HIST_SIGMAS, HIST_SPAN = 6.0, 1.5
#: Stored lags of C: every grid lag up to DENSE_LAGS_S (s), then 400 log-spaced ones.
DENSE_LAGS_S = 1.0
#: Lags (log-spaced, one period to a third of the window) of the kurtosis curve.
N_KURTOSIS_LAGS = 16


def bin_velocities(t: np.ndarray, x: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Mean velocity (mm/s) over each bin ``[grid_k, grid_{k+1}]`` of the piecewise linear
    x(t) through the knots ``(t, x)``: ``(x(grid_{k+1}) - x(grid_k)) / h_k`` (exact)."""
    xs = np.interp(grid, t, x)
    return np.diff(xs) / np.diff(grid)


def exact_correlation(t: np.ndarray, x: np.ndarray, lags, t0: float, t1: float) -> np.ndarray:
    """``C(tau) = (1 / (t1 - t0)) int_{t0}^{t1} v(s) v(s + tau) ds`` (mm^2/s^2), exactly.

    ``v`` is the slope of the piecewise linear x(t) through the knots ``(t, x)`` (s, mm);
    with ``v`` constant on each interval ``[a, b]``, ``int_a^b v(s + tau) ds = x(b + tau) -
    x(a + tau)``, so C is a sum over the intervals in ``[t0, t1]`` of ``v`` times a
    displacement.  Needs ``t[0] <= t0 < t1`` and ``t1 + max(lags) <= t[-1]``; cost
    ``O(intervals x lags)``.
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    lags = np.asarray(lags, float)
    if not (t[0] <= t0 < t1 and t1 + lags.max(initial=0.0) <= t[-1]):
        raise ValueError(
            f"the knots must cover [t0, t1 + max(lag)] = [{t0}, {t1 + lags.max(initial=0.0)}] s, "
            f"they cover [{t[0]}, {t[-1]}] s"
        )
    inner = t[(t > t0) & (t < t1)]
    edges = np.concatenate(([t0], inner, [t1]))
    v = np.diff(np.interp(edges, t, x)) / np.diff(edges)
    out = np.empty(lags.shape)
    for j, lag in enumerate(lags):
        out[j] = np.dot(v, np.diff(np.interp(edges + lag, t, x)))
    return out / (t1 - t0)


def binned_correlation(V: np.ndarray, n_lags: int) -> np.ndarray:
    """``c_m = mean_k V_k V_{k+m}`` for m = 0..n_lags - 1 over the origins ``k < K - n_lags
    + 1`` (the same origins for every lag), per row of ``V`` (particles x K bins), by FFT.
    Shape ``(rows, n_lags)``."""
    V = np.atleast_2d(V)
    K = V.shape[1]
    n_orig = K - n_lags + 1
    if n_orig < 1:
        raise ValueError(f"{K} bins hold no origin for {n_lags} lags")
    size = 1 << int(math.ceil(math.log2(K + n_lags)))
    full = np.fft.rfft(V, size, axis=1)
    head = np.fft.rfft(V[:, :n_orig], size, axis=1)
    corr = np.fft.irfft(np.conj(head) * full, size, axis=1)[:, :n_lags]
    return corr / n_orig


def gk_running(c: np.ndarray, h: float) -> np.ndarray:
    """The Green-Kubo integral (mm^2/s) of binned correlations ``c`` (mm^2/s^2, rows of
    ``c_0 .. c_M`` on lags ``m h``, h in s) for each cutoff m: ``h (c_0 / 2 + c_1 + ... +
    c_m)``, i.e. ``int C(tau) w(tau) dtau`` with weight 1 up to ``m h`` and a linear taper to
    0 at ``(m + 1) h`` (the bin triangles sum to one).  Same shape as ``c``."""
    c = np.asarray(c, float)
    return h * (np.cumsum(c, axis=-1) - 0.5 * c[..., :1])


def lag_moments(X: np.ndarray, lag: int) -> tuple[np.ndarray, np.ndarray]:
    """Per row of ``X`` (particles x grid times, mm), the mean of ``dx^2`` and ``dx^4`` of
    ``dx = X[:, k + lag] - X[:, k]`` over every origin k; two arrays of shape (rows,)."""
    dx = X[:, lag:] - X[:, :-lag]
    sq = dx * dx
    return sq.mean(axis=1), (sq * sq).mean(axis=1)


def jump_lengths(tile: np.ndarray) -> np.ndarray:
    """Tiles crossed by each flight, ``|l_{j+1} - l_j|`` between consecutive collisions of
    one particle (``tile`` at its IMPACT and STICK events, in time order); integers."""
    return np.abs(np.diff(np.asarray(tile, float))).astype(np.int64)


def excess_kurtosis(m2: np.ndarray, m4: np.ndarray) -> tuple[float, float]:
    """Excess kurtosis ``<dx^4> / <dx^2>^2 - 3`` of per-particle moments and its jackknife
    standard error over particles."""
    n = m2.size
    k = m4.mean() / m2.mean() ** 2 - 3.0
    if n < 2 or not m2.mean() > 0:
        return (k if m2.mean() > 0 else math.nan), math.nan
    s2, s4 = m2.sum(), m4.sum()
    loo = ((s4 - m4) / (n - 1)) / ((s2 - m2) / (n - 1)) ** 2 - 3.0
    return float(k), float(math.sqrt((n - 1) / n * np.sum((loo - loo.mean()) ** 2)))


def pull(a: float, a_se: float, b: float, b_se: float) -> float:
    """``(a - b) / sqrt(a_se^2 + b_se^2)`` of two independent estimates; NaN with no error."""
    se = math.hypot(a_se, b_se)
    return float((a - b) / se) if se > 0 else math.nan


class CorrelationResult(Result):
    """Velocity autocorrelation, Green-Kubo D and distributions at one frequency.

    Arrays: ``lag`` (s) and ``C``, ``C_se`` (mm^2/s^2, binned, ``correlations``);
    ``D_GK_running``, ``D_GK_running_se`` (mm^2/s, the GK integral with its cutoff at
    ``lag + h``); ``P_times`` (s), ``P_edges`` (mm, one row per time), ``P_density``
    (1/mm), ``P_var`` and ``P_var_se`` (mm^2); ``kurtosis_lags`` (s), ``kurtosis``,
    ``kurtosis_se``, ``msd_lags`` (mm^2); ``tile_edges`` (mm, 0..d), ``tile_density_impacts``
    and ``tile_density_times`` (1/mm); ``jump_counts`` (flights crossing 0, 1, 2, ...
    tiles).  ``meta``: ``D_GK``, ``D_GK_se``, ``D``, ``D_se`` (Einstein), ``z``,
    ``cutoff`` (s), ``C0`` and ``two_E_x`` (mm^2/s^2), the runs' sizes and times.
    """

    kind = "correlations"

    def plot(self, ax=None):
        """C(tau) with its error band; returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        lag, C, se = self["lag"], self["C"], self["C_se"]
        ax.fill_between(lag, C - se, C + se, color="C0", alpha=0.3, lw=0)
        ax.plot(lag, C, "C0-", lw=0.8)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set(xlabel=r"$\tau$ (s)", ylabel=r"$C(\tau)$ (mm$^2$/s$^2$)")
        ax.set_title(
            f"f = {self.meta['params']['f']} Hz: $D_{{GK}}$ = {self.meta['D_GK']:.3g} ± "
            f"{self.meta['D_GK_se']:.2g}, $D$ = {self.meta['D']:.3g} ± {self.meta['D_se']:.2g}"
        )
        return ax


def grid_times(params: Params, p0: float, p1: float, bins_per_period: int) -> np.ndarray:
    """Grid times (s) from ``p0`` to ``p1`` whole periods, ``bins_per_period`` per period."""
    k = np.arange(int(round((p1 - p0) * bins_per_period)) + 1)
    return (p0 + k / bins_per_period) / params.f


def correlations(
    params: Params,
    *,
    n: int = 200,
    t: float = 50.0,
    transient: float | None = None,
    seed=0,
    cutoff: float = 10.0,
    times=(0.1, 1.0, 5.0),
    bins_per_period: int = BINS_PER_PERIOD,
    record_particles: int = 20,
    record_capacity: int = 20000,
    threads: int | None = None,
) -> CorrelationResult:
    """Correlations and distributions of the reference ensemble at ``params.f``.

    Parameters
    ----------
    params : Params
    n : int
        Particles of each of the two ensembles (>= 2).
    t : float
        Simulated time (s); averages over the whole periods from ``ceil(transient f)``
        to ``floor(t f)``, ``transient`` default ``t / 5`` (as ``bbdyn.ensemble``).
    seed : int
        The Einstein ensemble draws its initial conditions with the seed ``[seed, 0]``,
        the correlation ensemble with ``[seed, 1]`` (independent streams).
    cutoff : float
        Upper limit T (s) of the Green-Kubo integral; at most a third of the window.
    times : sequence of float
        Lags (s) of the histograms of P(x, tau) (each at most a third of the window).
    bins_per_period : int
        Grid bins per driving period (``h = 1 / (f bins_per_period)``).
    record_particles, record_capacity : int
        Collisions of the first ``record_particles`` particles of the correlation
        ensemble (at most ``record_capacity`` each, the first of the window) give the
        position in a tile at collisions and the tiles crossed per flight.
    threads : int, optional
        numba threads (the numbers do not depend on it).

    Returns
    -------
    CorrelationResult
    """
    check_params(params)
    n = check_n(n)
    run = check_run(params, t, float(t) / 5 if transient is None else transient)
    bins_per_period = int(bins_per_period)
    if bins_per_period < 1:
        raise ValueError(f"bins_per_period must be an integer >= 1, got {bins_per_period}")
    p0, p1 = run.p0, run.p0 + run.L
    window = (p1 - p0) / params.f
    h = 1.0 / (params.f * bins_per_period)
    n_lags = int(round(float(cutoff) / h))
    times = np.atleast_1d(np.asarray(times, float))
    if not (math.isfinite(cutoff) and 1 <= n_lags and cutoff <= window / 3):
        raise ValueError(
            f"cutoff must be in [{h:.3g}, {window / 3:.4g}] s (one bin to a third of the "
            f"averaging window {window:.4g} s), got {cutoff}"
        )
    if times.size == 0 or not np.all((times >= h) & (times <= window / 3)):
        raise ValueError(
            f"times must lie in [{h:.3g}, {window / 3:.4g}] s (one bin to a third of the "
            f"averaging window), got {times.tolist()}"
        )
    start, cpu_start = time.perf_counter(), time.process_time()
    einstein = ensemble(params, n=n, t=run.t, transient=run.transient, seed=[seed, 0],
                        threads=threads)  # fmt: skip
    D_E, D_E_se = einstein.D()
    grid = grid_times(params, p0, p1, bins_per_period)
    P_lags = np.unique(np.rint(times / h).astype(int))
    k_lags = np.unique(np.rint(np.geomspace(bins_per_period, len(grid) / 3, N_KURTOSIS_LAGS)))
    k_lags = k_lags.astype(int)
    sigma = np.sqrt(2.0 * max(D_E + 2 * D_E_se, 0.0) * P_lags * h)
    tile_edges = np.linspace(0.0, params.d, N_BINS + 1)
    acc = _Accumulator(n, n_lags, len(P_lags), len(k_lags), N_BINS)
    ics = initial_conditions(params, n, [seed, 1])
    x0 = 0.5 * params.d + np.array([xi_at_arc_length(params, s) for s in ics[:, 0]])
    record = _Record(record_particles, record_capacity, lag_exact=4.0 / params.f, h=h)
    events = 0
    E_x = []
    for lo in range(0, n, BATCH):
        hi = min(lo + BATCH, n)
        ens = ensemble(
            params, initial=ics[lo:hi], t=run.t, transient=run.transient, sample_times=grid,
            observables=("displacement", "energy", "record"),
            record_particles=max(0, min(record_particles - lo, hi - lo)),
            record_window=(p0 / params.f, p1 / params.f), record_capacity=record_capacity,
            threads=threads, on_failure="raise",
        )  # fmt: skip
        events += int(ens["events"].sum())
        E_x.append(ens["E_x"])
        X = ens["displacement"]  # mm from x(0), at the grid times
        if lo == 0:
            P_edges = _P_edges(X, P_lags, sigma)
        acc.add(X, x0[lo:hi, None] + X, h, P_lags, k_lags, P_edges, tile_edges)
        record.add(ens, params, p0)
    arrays, numbers = acc.finish(h, P_lags, k_lags, P_edges, tile_edges)
    arrays.update(record.finish(tile_edges))
    E_x = np.concatenate(E_x)
    z, z_mean = (pull(numbers[k], numbers[k + "_se"], D_E, D_E_se) for k in ("D_GK", "D_GK_mean"))
    meta = make_meta(
        params, seed=seed, wall_s=time.perf_counter() - start,
        cpu_s=time.process_time() - cpu_start, n=n, t=run.t, transient=run.transient,
        window_periods=[p0, p1], h=h, bins_per_period=bins_per_period, cutoff=n_lags * h,
        D=float(D_E), D_se=float(D_E_se), **numbers, z=z, z_mean=z_mean,
        two_E_x=float(2 * E_x.mean()),
        two_E_x_se=float(2 * E_x.std(ddof=1) / math.sqrt(n)),
        record_particles=min(record_particles, n), collisions_recorded=record.collisions,
        flights=int(arrays["jump_counts"].sum()), events=events,
    )  # fmt: skip
    return CorrelationResult(arrays, meta)


class _Record:
    """What the collision records of the first particles give: the position in a tile at
    collisions, the tiles crossed per flight and the exact C(tau) at short lags."""

    def __init__(self, particles, capacity, lag_exact, h):
        self.particles, self.capacity = particles, capacity
        self.lags = np.arange(int(round(lag_exact / h)) + 1) * h
        self.xi, self.jumps, self.C = [], [], []
        self.collisions = 0

    def add(self, ens, params, p0):
        if "record" not in ens.arrays:  # a batch after the recorded particles
            return
        for i in range(ens["record"].shape[0]):
            # the record holds the collisions (IMPACT, STICK), not the releases
            rec = ens["record"][i, : min(int(ens["record_n"][i]), self.capacity)]
            self.collisions += rec.shape[0]
            self.xi.append(rec[:, 3])
            self.jumps.append(jump_lengths(rec[:, 2]))
            t = (rec[:, 0] - p0) / params.f + rec[:, 1] / params.w
            x = (rec[:, 2] + 0.5) * params.d + rec[:, 3]
            if t.size > 1 and t[-1] - t[0] > 3 * self.lags[-1]:  # collisions fix x(t) between
                self.C.append(exact_correlation(t, x, self.lags, t[0], t[-1] - self.lags[-1]))

    def finish(self, tile_edges):
        half = 0.5 * tile_edges[-1]
        xi = np.concatenate(self.xi) if self.xi else np.zeros(0)
        flights = np.concatenate(self.jumps) if self.jumps else np.zeros(0, np.int64)
        return {
            "tile_density_impacts": _density(np.histogram(xi + half, tile_edges)[0], tile_edges),
            "jump_counts": np.bincount(flights, minlength=1),
            "exact_lag": self.lags,
            "C_exact": np.mean(self.C, axis=0) if self.C else np.full(self.lags.shape, np.nan),
        }


class _Accumulator:
    """Sums over batches of particles: the correlations and GK integrals (sums and sums of
    squares over particles), the per-particle GK estimates and lag moments, and the
    histograms of P(x, tau) and of the position in a tile at the grid times."""

    def __init__(self, n, n_lags, n_P, n_k, n_bins):
        self.sums = np.zeros((4, n_lags + 1))  # C, C^2, running GK, its square
        self.gk = np.zeros((n, 2))  # per particle: GK at the cutoff, mean over [T/2, T]
        self.P_m2 = np.zeros((n, n_P))
        self.k_m2 = np.zeros((n, n_k))
        self.k_m4 = np.zeros((n, n_k))
        self.P_counts = np.zeros((n_P, n_bins))
        self.P_total = np.zeros(n_P)
        self.tile_counts = np.zeros(n_bins)
        self.row = 0

    def add(self, X, x_abs, h, P_lags, k_lags, P_edges, tile_edges):
        rows = slice(self.row, self.row + X.shape[0])
        self.row += X.shape[0]
        C = binned_correlation(np.diff(X, axis=1) / h, self.sums.shape[1])
        running = gk_running(C, h)  # per particle, each cutoff
        self.sums += np.stack([C.sum(0), (C * C).sum(0), running.sum(0), (running**2).sum(0)])
        # and its Cesaro form: averaged over the cutoffs in [T / 2, T]
        self.gk[rows] = np.stack([running[:, -1], running[:, C.shape[1] // 2 :].mean(1)], 1)
        for j, lag in enumerate(P_lags):
            dx = X[:, lag:] - X[:, :-lag]
            self.P_m2[rows, j] = np.mean(dx * dx, axis=1)
            self.P_counts[j] += np.histogram(dx, P_edges[j])[0]
            self.P_total[j] += dx.size
        for j, lag in enumerate(k_lags):
            self.k_m2[rows, j], self.k_m4[rows, j] = lag_moments(X, lag)
        self.tile_counts += np.histogram(np.mod(x_abs, tile_edges[-1]), tile_edges)[0]

    def finish(self, h, P_lags, k_lags, P_edges, tile_edges):
        n = self.gk.shape[0]
        mean = self.sums[0::2] / n
        se = np.sqrt(np.maximum(self.sums[1::2] / n - mean**2, 0.0) / (n - 1))
        kurt = np.array([excess_kurtosis(self.k_m2[:, j], self.k_m4[:, j])
                         for j in range(len(k_lags))])  # fmt: skip
        keep = _thin(mean.shape[1], int(round(DENSE_LAGS_S / h)))
        arrays = {
            "lag": keep * h,
            "C": mean[0, keep],
            "C_se": se[0, keep],
            "D_GK_running": mean[1, keep],
            "D_GK_running_se": se[1, keep],
            "P_times": P_lags * h,
            "P_edges": P_edges,
            "P_density": self.P_counts / (self.P_total[:, None] * np.diff(P_edges, axis=1)),
            "P_outside": 1.0 - self.P_counts.sum(axis=1) / self.P_total,
            "P_var": self.P_m2.mean(axis=0),
            "P_var_se": self.P_m2.std(axis=0, ddof=1) / math.sqrt(n),
            "kurtosis_lags": k_lags * h,
            "kurtosis": kurt[:, 0],
            "kurtosis_se": kurt[:, 1],
            "msd_lags": self.k_m2.mean(axis=0),
            "tile_edges": tile_edges,
            "tile_density_times": _density(self.tile_counts, tile_edges),
        }
        gk, gk_se = self.gk.mean(0), self.gk.std(0, ddof=1) / math.sqrt(n)
        numbers = {"D_GK": float(gk[0]), "D_GK_se": float(gk_se[0]),
                   "D_GK_mean": float(gk[1]), "D_GK_mean_se": float(gk_se[1])}  # fmt: skip
        return arrays, numbers


def _P_edges(X: np.ndarray, lags: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Bin edges (mm) of the P(x, tau) histograms, one row per lag (``HIST_SIGMAS``,
    ``HIST_SPAN``), from the grid positions ``X`` of the first batch."""
    reach = np.array([np.max(np.abs(X[:, lag:] - X[:, :-lag])) for lag in lags])
    half = np.maximum(HIST_SIGMAS * sigma, HIST_SPAN * reach)
    half = np.where(half > 0, half, 1.0)  # nothing moved: any bins
    return np.linspace(-1.0, 1.0, N_BINS + 1) * half[:, None]


def _density(counts: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Histogram counts as a probability density (1 / unit of ``edges``); zeros if empty."""
    return counts / (max(counts.sum(), 1) * np.diff(edges))


def _thin(size: int, dense: int, n_log: int = 400) -> np.ndarray:
    """Indices kept of a lag grid of ``size``: all below ``dense``, then ``n_log``
    log-spaced ones, and the last (the cutoff)."""
    log = np.geomspace(max(dense, 1), size - 1, n_log) if size - 1 > dense else []
    return np.unique(
        np.concatenate([np.arange(min(dense, size)), np.rint(log), [size - 1]]).astype(int)
    )
