"""Attractors, basins, ergodicity and the dynamical regime at one frequency (docs/model.md, 5).

``trajectory_features`` runs an ensemble (one or several boxes of initial
conditions, or given ones) and measures per-trajectory features after a
transient (``core/features.py``): time averages per block of the averaging
window, flight-time statistics, impact-phase coherence, the period of the
vertical impact sequence, creep runs and jumps; the same run samples each
displacement at the times ``bbdyn simulate`` uses.  ``classify_features`` groups
the trajectories into attractors, decides ergodicity and the regime, and gives
each attractor its Einstein D (``attractor_D``, the estimator of ``bbdyn
simulate`` over the attractor's particles) and energies; ``classify`` does both.
The rules and every threshold are in ``Thresholds`` and in docs/classification.md.

The flat ball is the billiard with a flat floor: R -> infinity (R = 1e9 mm
reproduces the flat map's impact sequence, tests/test_billiard_limits.py), so
one feature path serves both.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from bbdyn.core import features as core
from bbdyn.core.ensemble import CARRY_WIDTH, CNT_WIDTH, RunTimes, run_features
from bbdyn.core.features import FeatureThresholds
from bbdyn.core.status import FAILURES
from bbdyn.diffusion import drift_velocity, einstein_D, einstein_D_windows, per_particle_slopes
from bbdyn.ensemble import Box, initial_conditions, kernel_states, reference_box
from bbdyn.params import Params, check_params
from bbdyn.results import Result, make_meta
from bbdyn.runs import (
    allocate,
    check_n,
    check_run,
    failed_particles,
    new_carry,
    noise_key,
    numba_threads,
    periods_phase,
    run_chunked,
)

__all__ = [
    "Thresholds",
    "FeatureResult",
    "Classification",
    "trajectory_features",
    "classify_features",
    "classify",
    "attractor_D",
    "REGIMES",
    "UNITS",
]

REGIMES = {
    "a": "trapped: no trap changes, no diffusion",
    "b(i)": "nonergodic: two or more coexisting attractors",
    "b(ii)": "phase locked: one attractor, vertical motion locked to the drive",
    "c": "creeping: long runs of tiny hops, diffusion suppressed",
    "d": "ergodic intermittent: one attractor, resonant flights and creeps alternate",
    "other": "one attractor outside (a)-(d)",
}

#: Block features compared between trajectories (names of FeatureResult.block_values).
GROUP_FEATURES = ("E_kin", "collision_rate", "stuck_fraction", "tiny_fraction", "jump_rate")
#: Displacement samples per trajectory, equally spaced over the run: the default of
#: ``bbdyn.ensemble.ensemble``, so that an attractor's D is ``bbdyn simulate``'s estimator.
SAMPLES = 101
#: Energies of an attractor, time averages over the window (kg mm^2/s^2).
ENERGIES = ("E", "E_kin", "E_x", "E_y", "E_pot")
#: Units of the dimensioned numbers of ``Classification.summary`` (a key's ``_se`` and the
#: entries of ``D_windows`` share its unit; fractions and counts are dimensionless).
UNITS = {
    "f": "Hz", "t": "s", "transient": "s", "D": "mm^2/s", "D_windows.t_centre": "s",
    **{name: "kg mm^2/s^2" for name in ENERGIES}, "E_reference": "kg mm^2/s^2",
    "jump_rate": "1/s", "collision_rate": "1/s",
}  # fmt: skip


@dataclass(frozen=True)
class Thresholds:
    """Named thresholds of the classifier (all user-changeable).

    Measurement (used while running; changing them needs a new run):

    tiny : float
        A flight shorter than ``tiny`` driving periods is a tiny hop (0.1).
    k_tol : float
        A flight within ``k_tol`` periods of an integer k is locked to k (0.1; the
        bumps spread resonant flights by a few hundredths of a period).
    kmax : int
        Largest locking number counted (8).
    pmax : int
        Largest period of the impact sequence searched (32).
    hist_width : float
        Flight-time histogram bin (periods) (0.02); flights beyond 10 periods share
        the last bin.
    hop_floor : float
        An impact after a flight shorter than ``hop_floor`` periods is not counted as a
        collision (1e-4; 0 counts every impact): it is in the tail of a chattering
        sequence, of which the kernel resolves a number of bounces set by a numerical
        tolerance before summing the rest in closed form (``core.features``;
        docs/classification.md, "Rules").

    Decision (applied to stored features):

    period_tol : float
        The vertical impact sequence has period p if collision n and n - p differ by
        at most this in phase (fraction of 2 pi) and in vyrel (units of g T) over the
        whole window, with at least ``4 p`` collisions (1e-6).
    z : float
        Two time averages agree when they differ by at most ``z`` combined standard
        errors (from the blocks) plus ``abs_tol`` (4).
    abs_tol : float
        Absolute agreement floor in the scaled units of ``GROUP_FEATURES`` (energies
        in A^2 w^2 / 2, rates per period, fractions) (0.01).  It keeps exactly
        periodic trajectories (zero fluctuation) together despite rounding.
    min_members : int
        Groups smaller than this are not attractors; their members are unsettled (3).
    trapped_jumps : float
        Regime (a) when every attractor makes fewer jumps per period (1e-3).
    lock_min : float
        An attractor is locked to k when this fraction of its flights is (0.9).
    mean_lock_tol : float
        An attractor without tiny hops is also locked to k when its mean flight time is
        within this of k periods (one collision per k periods on average, as for a
        period-doubled k/1 orbit whose single flights differ from k) (0.005).
    creep_min : float
        An attractor creeps when this fraction of its collisions are tiny hops (0.5); one
        that also makes no jumps (``trapped_jumps``) is a trapped cycle instead: it
        chatters, sticks and is released in the same trap, D = 0.
    intermittent_min : float
        Intermittent when both locked flights and tiny hops make at least this
        fraction of the collisions (0.05) without either reaching its own threshold.
    ergodic_chi2 : float
        Ergodic when, for every compared feature, the spread of the time averages
        over the ensemble is within this factor of their own fluctuations
        (reduced chi^2 <= ergodic_chi2) (3).
    max_unsettled : float
        Ergodicity and the regime need at most this unsettled fraction (0.05).
    """

    tiny: float = 0.1
    k_tol: float = 0.1
    kmax: int = 8
    pmax: int = 32
    hist_width: float = 0.02
    hop_floor: float = 1e-4
    period_tol: float = 1e-6
    z: float = 4.0
    abs_tol: float = 0.01
    min_members: int = 3
    trapped_jumps: float = 1e-3
    lock_min: float = 0.9
    mean_lock_tol: float = 0.005
    creep_min: float = 0.5
    intermittent_min: float = 0.05
    ergodic_chi2: float = 3.0
    max_unsettled: float = 0.05

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if name == "hop_floor":  # 0: every impact is a collision
                if not (math.isfinite(value) and value >= 0):
                    raise ValueError(f"hop_floor must be a finite number >= 0, got {value}")
            elif not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value}")
        for name in ("kmax", "pmax", "min_members"):
            if int(getattr(self, name)) != getattr(self, name):
                raise ValueError(f"{name} must be an integer, got {getattr(self, name)}")
        if not self.k_tol < 0.5:
            raise ValueError(f"k_tol must be < 0.5 periods, got {self.k_tol}")

    def kernel(self):
        """The measurement thresholds as the features kernel takes them
        (``core.features.FeatureThresholds``)."""
        return FeatureThresholds(self.tiny, self.k_tol, int(self.kmax), self.hist_width,
                                 self.hop_floor)  # fmt: skip


# ---- features ------------------------------------------------------------------------------
def _initial_sources(params, boxes, n, initial):
    """The checked sources of the initial conditions, before anything is drawn:
    ``(initial as an (m, 3) array or None, boxes or None, n per box, m in all)``."""
    if initial is not None:
        ics = np.array(initial, dtype=float, ndmin=2)
        if ics.ndim != 2 or ics.shape[1] != 3 or not np.all(np.isfinite(ics)):
            raise ValueError(f"initial must be a finite (n, 3) array, got shape {ics.shape}")
        return ics, None, ics.shape[0], ics.shape[0]
    n = check_n(n)
    boxes = [reference_box(params)] if boxes is None else list(boxes)
    if not boxes or not all(isinstance(b, Box) for b in boxes):
        raise ValueError(f"boxes must be a non-empty list of Box, got {boxes!r}")
    return None, boxes, n, n * len(boxes)


def _states_from(params, ics, boxes, n, seed, start_phase):
    """Initial conditions (``ics``, or ``n`` drawn from each box), their kernel states and
    the box index of each."""
    if ics is not None:
        box_index = np.full(ics.shape[0], -1)
    else:
        # box 0 draws exactly as bbdyn.ensemble.ensemble(seed=seed); box j > 0 from (seed, j)
        seeds = [seed] + [None if seed is None else [seed, j] for j in range(1, len(boxes))]
        ics = np.concatenate([
            initial_conditions(params, n, s, b, phase=start_phase)
            for s, b in zip(seeds, boxes, strict=True)
        ])  # fmt: skip
        box_index = np.repeat(np.arange(len(boxes)), n)
    # post-collision states at phase start_phase: shift vy so that vyrel = vy - u(start_phase)
    u0, u1 = -params.A * params.w, -params.A * params.w * math.cos(start_phase)
    shifted = ics.copy()
    shifted[:, 2] += u0 - u1
    states = kernel_states(params, shifted)
    states[:, 1] = start_phase
    return ics, states, box_index


def trajectory_features(
    params: Params,
    *,
    t: float,
    n: int = 1000,
    seed=None,
    boxes: list[Box] | None = None,
    initial=None,
    start_phase: float = 0.0,
    transient: float | None = None,
    blocks: int = 16,
    thresholds: Thresholds | None = None,
    threads: int | None = None,
    on_failure: str = "keep",
    progress=None,
) -> FeatureResult:
    """Per-trajectory features after a transient, computed on the fly.

    Parameters
    ----------
    params : Params
    t : float
        Simulated time (s).
    n : int
        Particles per box (default 1000).
    seed : int or None
        Box 0 draws as ``bbdyn.ensemble.initial_conditions(params, n, seed, box)``,
        box j > 0 with the seed ``[seed, j]``.
    boxes : list of Box, optional
        Boxes of post-collision initial conditions (default: the reference box).
    initial : array (m, 3), optional
        Explicit ``(s, vx+, vy+)`` instead of boxes.
    start_phase : float
        Phase w t (rad, in [0, 2 pi)) of the initial collisions (default 0).
    transient : float, optional
        Discarded time (s), default ``t / 2``.
    blocks : int
        Blocks of the averaging window (>= 4), for the fluctuations of time averages.
    thresholds : Thresholds, optional
        Only the measurement fields are used here.
    threads : int, optional
        Numba threads (results do not depend on it).
    on_failure : {"keep", "raise"}
        Trajectories the kernel fails on: kept out of every attractor (label -2 in
        ``classify_features``, counted in ``meta["n_failed"]``, with a warning), or raise
        ``SimulationError`` (``bbdyn.runs.failed_particles``).
    progress : callable, optional
        Told the fraction of the simulated time done (``bbdyn.runs.run_chunked``).

    Returns
    -------
    FeatureResult
    """

    check_params(params)
    th = Thresholds() if thresholds is None else thresholds
    if not 0.0 <= start_phase < 2 * math.pi:
        raise ValueError(f"start_phase must be in [0, 2 pi), got {start_phase}")
    if int(blocks) != blocks or blocks < 4:
        raise ValueError(f"blocks must be an integer >= 4, got {blocks}")
    run = check_run(params, t, float(t) / 2 if transient is None else transient, int(blocks))
    t, transient, p0, L = run.t, run.transient, run.p0, run.L
    sample_times = np.linspace(start_phase / params.w, t, SAMPLES)
    if np.count_nonzero(sample_times >= transient) < 2:
        raise ValueError(
            f"transient = {transient} s leaves fewer than 2 of the {SAMPLES} displacement "
            f"samples in [transient, t = {t}] s; use transient <= {sample_times[-2]} s"
        )
    given, boxes, n, m = _initial_sources(params, boxes, n, initial)
    # ---- the features run: size checked before the initial conditions are drawn, chunked
    # (Ctrl-C stops it between chunks)

    nbins = int(round(10.0 / th.hist_width)) + 1
    shapes = {
        "blocks": ((m, int(blocks), core.BF_WIDTH), float),
        "hist": ((m, nbins), float),
        "kcount": ((m, int(th.kmax) + 1), float),
        "glob": ((m, core.G_WIDTH), float),
        "mismatch": ((m, int(th.pmax)), float),
        "displacement": ((m, SAMPLES), float),
        "counts": ((m, CNT_WIDTH), np.int64),
        "status": ((m,), np.int64),
    }
    limits = {"params": params, "n": m, "t": t}
    out, _ = allocate(shapes, extra=m * 8 * (CARRY_WIDTH + 3 * int(th.pmax)), limits=limits)
    ics, states, box_index = _states_from(params, given, boxes, n, seed, start_phase)
    carry = new_carry(states, 0, int(th.pmax), noise_key(seed) if params.eta > 0 else (0, 0))
    s_periods, s_phase = periods_phase(sample_times, params.f)
    end = np.array([v[0] for v in periods_phase(np.array([t]), params.f)])
    times = RunTimes(end[0], end[1], p0, L, int(blocks), s_periods, s_phase)
    feature_th = th.kernel()
    kp = params.kernel(noise=True)
    buffers = core.FeatureOut(**out)

    def advance(budget):
        run_features(carry, budget, kp, times, feature_th, buffers)

    start = time.perf_counter()
    with numba_threads(threads):
        run_chunked(advance, carry, out["status"], end[0], progress=progress)
    wall = time.perf_counter() - start
    failures = failed_particles(out["status"], ics, on_failure)
    del out["counts"]
    # ---- end of the features run
    out.update(initial=ics, box_index=box_index, sample_times=sample_times)
    meta = make_meta(
        params,
        seed=seed,
        wall_s=wall,
        t=t,
        n=m,
        transient=transient,
        window_periods=[p0, p0 + blocks * L],
        block_periods=L,
        start_phase=start_phase,
        boxes=None if initial is not None else [vars(b) for b in boxes],
        thresholds=asdict(th),
        **failures,
    )
    return FeatureResult(out, meta)


class FeatureResult(Result):
    """Per-trajectory features (``core/features.py``) of an ensemble, and how they were run.

    Arrays: ``blocks`` (n, nb, 8), ``hist`` (n, nbins), ``kcount`` (n, kmax + 1),
    ``glob`` (n, 6), ``mismatch`` (n, pmax), ``initial`` (n, 3) ``(s, vx+, vy+)``,
    ``box_index`` (n,) (-1 for given initial conditions), ``status`` (n,),
    ``sample_times`` (SAMPLES,) s from the start to t and ``displacement`` (n, SAMPLES)
    ``x(t_k) - x(0)`` (mm).
    """

    kind = "trajectory_features"

    @property
    def params(self) -> Params:
        return Params(**self.meta["params"])

    def block_energies(self) -> dict[str, np.ndarray]:
        """Per-block time averages of ``ENERGIES`` (kg mm^2/s^2), shape (n, nb) each.

        ``E_kin = E_x + E_y`` and ``E = E_kin + E_pot``; the blocks have equal length, so
        their mean over the blocks is the time average over the window.
        """
        b = self["blocks"]
        block_s = self.meta["block_periods"] / self.params.f
        cols = (("E_x", core.BF_EX), ("E_y", core.BF_EY), ("E_pot", core.BF_POT))
        out = {name: b[..., col] / block_s for name, col in cols}
        out["E_kin"] = out["E_x"] + out["E_y"]
        out["E"] = out["E_kin"] + out["E_pot"]
        return out

    def block_values(self) -> dict[str, np.ndarray]:
        """Per-block time averages, shape (n, nb) each, in scaled units.

        ``ENERGIES`` in units of A^2 w^2 / 2 (docs/model.md; kg mm^2/s^2 when
        A = 0); ``collision_rate`` and ``jump_rate`` per driving period; ``stuck_fraction``
        of the time; ``tiny_fraction`` and ``locked_fraction`` of the collisions (0 when
        there is none).
        """
        p = self.params
        b = self["blocks"]
        L = self.meta["block_periods"]
        block_s = L / p.f
        e_ref = 0.5 * (p.A * p.w) ** 2 if p.A > 0 else 1.0
        coll = b[..., core.BF_COLL]
        safe = np.maximum(coll, 1.0)
        out = {name: v / e_ref for name, v in self.block_energies().items()}
        out.update({
            "stuck_fraction": b[..., core.BF_STUCK] / block_s,
            "collision_rate": coll / L,
            "jump_rate": b[..., core.BF_JUMPS] / L,
            "tiny_fraction": b[..., core.BF_TINY] / safe,
            "locked_fraction": b[..., core.BF_LOCKED] / safe,
        })  # fmt: skip
        return out

    def D_window(self) -> tuple[float, float]:
        """The Einstein D's window ``(transient / t, 1)``: fractions of t, as ``einstein_D``."""
        return self.meta["transient"] / self.meta["t"], 1.0

    def per_particle(self) -> dict[str, np.ndarray]:
        """Time averages over the window and their standard errors (``name + "_se"``)."""
        nb = self["blocks"].shape[1]
        out = {}
        for name, v in self.block_values().items():
            out[name] = v.mean(axis=1)
            out[name + "_se"] = v.std(axis=1, ddof=1) / math.sqrt(nb)
            # first and second half, for the settling test
            out[name + "_h1"] = v[:, : nb // 2].mean(axis=1)
            out[name + "_h2"] = v[:, nb // 2 :].mean(axis=1)
            half = (
                v[:, : nb // 2].std(axis=1, ddof=1) ** 2 + v[:, nb // 2 :].std(axis=1, ddof=1) ** 2
            )
            out[name + "_hse"] = np.sqrt(half / (nb // 2))
        g = self["glob"]
        coll = self["blocks"][..., core.BF_COLL].sum(axis=1)
        safe = np.maximum(coll, 1.0)
        out["collisions"] = coll
        out["coherence"] = np.hypot(g[:, core.G_COS], g[:, core.G_SIN]) / safe
        out["flight_mean"] = g[:, core.G_TF] / safe
        out["flight_std"] = np.sqrt(
            np.maximum(g[:, core.G_TF2] / safe - out["flight_mean"] ** 2, 0)
        )
        out["creep_runs"] = g[:, core.G_RUNS]
        out["creep_run_max"] = g[:, core.G_RUNMAX]
        tiny = self["blocks"][..., core.BF_TINY].sum(axis=1)
        out["creep_run_mean"] = np.where(
            g[:, core.G_RUNS] > 0, tiny / np.maximum(g[:, core.G_RUNS], 1), 0
        )
        kc = self["kcount"]
        out["locking_k"] = np.where(kc.sum(axis=1) > 0, np.argmax(kc, axis=1), 0)
        out["period"] = self.periods(self.meta["thresholds"]["period_tol"])
        return out

    def periods(self, period_tol: float) -> np.ndarray:
        """Smallest p <= pmax with mismatch <= period_tol and >= 4 p collisions; 0 if none."""
        coll = self["blocks"][..., core.BF_COLL].sum(axis=1)
        lags = np.arange(1, self["mismatch"].shape[1] + 1)
        ok = (self["mismatch"] <= period_tol) & (coll[:, None] >= 4 * lags[None, :])
        return np.where(ok.any(axis=1), lags[np.argmax(ok, axis=1)], 0)

    def plot(self, ax=None):
        """Time-averaged energy against tiny-hop fraction, one point per trajectory."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        pp = self.per_particle()
        ax.errorbar(pp["tiny_fraction"], pp["E"], yerr=pp["E_se"], fmt=".", ms=3, lw=0.5)
        ax.set(xlabel="tiny-hop fraction", ylabel=r"$\langle E\rangle / (A^2\omega^2/2)$")
        return ax


# ---- attractors, ergodicity, regime ---------------------------------------------------------
def _agree(a, a_se, b, b_se, th):
    """Averages agree within fluctuations: ``|a - b| <= z sqrt(se_a^2 + se_b^2) + abs_tol``."""
    return np.abs(a - b) <= th.z * np.sqrt(a_se**2 + b_se**2) + th.abs_tol


def _group(pp, idx, th):
    """Connected components of the 'agree on every GROUP_FEATURE' graph on particles ``idx``."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    adj = np.ones((idx.size, idx.size), dtype=bool)
    for name in GROUP_FEATURES:
        m, se = pp[name][idx], pp[name + "_se"][idx]
        adj &= _agree(m[:, None], se[:, None], m[None, :], se[None, :], th)
    return connected_components(csr_matrix(adj), directed=False)[1]


def _character(att, th):
    """How an attractor moves: 'at rest', 'locked', 'trapped cycle' (tiny hops, sticks and
    releases without jumps), 'creeping' (runs of tiny hops between jumps), 'intermittent' or
    'irregular'."""
    if att["collision_rate"] == 0.0:
        return "at rest"
    k = round(att["flight_mean"])
    mean_locked = k >= 1 and abs(att["flight_mean"] - k) <= th.mean_lock_tol
    if att["locked_fraction"] >= th.lock_min or (
        mean_locked and att["tiny_fraction"] < th.intermittent_min
    ):
        return "locked"
    if att["tiny_fraction"] >= th.creep_min:
        return "trapped cycle" if att["trapped"] else "creeping"
    if min(att["locked_fraction"], att["tiny_fraction"]) >= th.intermittent_min:
        return "intermittent"
    return "irregular"


def _mode(values):
    vals, counts = np.unique(values, return_counts=True)
    return int(vals[np.argmax(counts)])


def classify_features(feat: FeatureResult, thresholds: Thresholds | None = None) -> Classification:
    """Attractors, basins, ergodicity and the regime from stored features (no new run).

    Rules (docs/classification.md): a trajectory is *settled* when every compared time
    average (``GROUP_FEATURES``) agrees between the first and second half of the window;
    settled trajectories whose averages pairwise agree (``Thresholds.z``, ``abs_tol``) are
    linked, and each connected group of at least ``min_members`` is an attractor; the
    others get label -1 (unsettled); trajectories the kernel failed on get -2 (failed).  Basin
    fractions, the unsettled and the failed fraction sum to one.
    Each attractor gets its Einstein D (``attractor_D`` over its trajectories, window
    ``FeatureResult.D_window``), energies (kg mm^2/s^2) and stuck fraction with standard
    errors over its trajectories (the keys of ``bbdyn simulate``; units in ``UNITS``).
    The measurement fields of ``thresholds`` must be those the features were run with.
    """
    # features stored before hop_floor existed counted every impact
    run_th = {"hop_floor": 0.0, **feat.meta["thresholds"]}
    th = Thresholds(**run_th) if thresholds is None else thresholds
    for name in ("tiny", "k_tol", "kmax", "pmax", "hist_width", "hop_floor"):
        if getattr(th, name) != run_th[name]:
            raise ValueError(
                f"thresholds.{name} = {getattr(th, name)} differs from the run's {run_th[name]}: "
                "measurement thresholds need a new run (trajectory_features)"
            )
    p = feat.params
    pp = feat.per_particle()
    pp["period"] = feat.periods(th.period_tol)
    n = pp["E"].size
    failed = np.isin(feat["status"], FAILURES)
    settled = ~failed
    for name in GROUP_FEATURES:
        diff = np.abs(pp[name + "_h1"] - pp[name + "_h2"])
        settled &= diff <= th.z * pp[name + "_hse"] + th.abs_tol
    labels = np.where(failed, -2, -1)
    idx = np.flatnonzero(settled)
    if idx.size:
        comp = _group(pp, idx, th)
        sizes = np.bincount(comp)
        order = [c for c in np.argsort(-sizes, kind="stable") if sizes[c] >= th.min_members]
        for new, c in enumerate(order):
            labels[idx[comp == c]] = new
    times, disp, window = feat["sample_times"], feat["displacement"], feat.D_window()
    averages = {name: v.mean(axis=1) for name, v in feat.block_energies().items()}
    averages["stuck_fraction"] = pp["stuck_fraction"]
    attractors = []
    for a in range(labels.max() + 1):
        mem = np.flatnonzero(labels == a)
        att = {"fraction": mem.size / n, "members": int(mem.size)}
        att.update(attractor_D(times, disp[mem], window, drift=p.phi != 0.0))
        for name, values in averages.items():
            att[name], att[name + "_se"] = _mean_se(values[mem])
        for name in ("tiny_fraction", "locked_fraction", "coherence", "flight_mean",
                     "creep_run_mean"):  # fmt: skip
            att[name] = float(pp[name][mem].mean())
        att["jump_rate"] = float(pp["jump_rate"][mem].mean() * p.f)  # per second
        att["collision_rate"] = float(pp["collision_rate"][mem].mean() * p.f)
        att["creep_run_max"] = int(pp["creep_run_max"][mem].max())
        att["period"] = _mode(pp["period"][mem]) or None
        att["dominant_k"] = _mode(pp["locking_k"][mem])
        att["trapped"] = att["jump_rate"] / p.f < th.trapped_jumps
        att["character"] = _character(att, th)
        locked = att["character"] == "locked"
        att["locking_k"] = round(att["flight_mean"]) if locked else None
        # representative: the member closest to the attractor's median, in units of the spread
        dev = np.zeros(mem.size)
        for name in GROUP_FEATURES:
            v = pp[name][mem]
            dev += ((v - np.median(v)) / (v.std() + th.abs_tol)) ** 2
        rep = mem[np.argmin(dev)]
        att["representative"] = {"index": int(rep), "initial": feat["initial"][rep].tolist()}
        if feat["box_index"].max() > 0:
            boxes = feat["box_index"]
            att["box_fractions"] = [
                float(np.mean(labels[boxes == b] == a)) for b in np.unique(boxes)
            ]
        attractors.append(att)
    unsettled = float(np.mean(labels == -1))

    # ergodicity: one attractor, few unsettled, time averages spread only by their fluctuations
    chi2 = {}
    if idx.size > 1:
        for name in GROUP_FEATURES:
            m, se = pp[name][idx], pp[name + "_se"][idx]
            var = se**2 + (th.abs_tol / th.z) ** 2
            chi2[name] = float(np.sum((m - m.mean()) ** 2 / var) / (idx.size - 1))
    ergodic = (
        len(attractors) == 1
        and unsettled <= th.max_unsettled
        and bool(chi2)
        and max(chi2.values()) <= th.ergodic_chi2
    )
    regime, reason = _regime(attractors, unsettled, th)
    summary = {
        "f": p.f,
        "gamma": p.gamma,
        "regime": regime,
        "regime_meaning": REGIMES.get(regime, ""),
        "reason": reason,
        "ergodic": bool(ergodic),
        "ergodicity": {
            "n_attractors": len(attractors),
            "unsettled_fraction": unsettled,
            "reduced_chi2": chi2,
            "max_reduced_chi2": th.ergodic_chi2,
        },  # fmt: skip
        "n_attractors": len(attractors),
        "attractors": attractors,
        "E_reference": 0.5 * (p.A * p.w) ** 2,
        "units": UNITS,
        "unsettled_fraction": unsettled,
        "failed_fraction": float(np.mean(failed)),
        "failures": feat.meta.get("failures", {}),
        "n": n,
        "t": feat.meta["t"],
        "transient": feat.meta["transient"],
        "seed": feat.meta.get("seed"),
        "feature_wall_s": feat.meta["wall_s"],
        "thresholds": asdict(th),
    }
    meta = make_meta(p, seed=feat.meta.get("seed"), summary=summary)
    arrays = {"labels": labels, "initial": feat["initial"], "box_index": feat["box_index"]}
    for name in ("E", "E_kin", "tiny_fraction", "locked_fraction", "jump_rate",
                 "stuck_fraction", "period", "locking_k", "coherence"):  # fmt: skip
        arrays[name] = pp[name]
    arrays["D"] = np.full(n, np.nan)  # failed trajectories have no displacement to fit
    arrays["D"][~failed] = 0.5 * per_particle_slopes(times, disp[~failed], window)
    return Classification(arrays, meta)


def attractor_D(times, displacement, window=(0.5, 1.0), drift=False) -> dict:
    """Einstein D of a group of trajectories (an attractor), as ``bbdyn simulate`` gives it.

    ``D`` and ``D_se`` (mm^2/s): ``bbdyn.diffusion.einstein_D``, the least-squares slope / 2
    of the group's mean squared displacement over ``window`` (fractions of the last sample
    time), with the standard error over trajectories; ``D_windows``: ``t_centre`` (s), ``D``
    and ``D_se`` in four successive windows from 0.2 t (``einstein_D_windows``), the
    evidence that D has converged.  A group of one trajectory has no standard error: all NaN.

    Parameters
    ----------
    times : array (m,)
        Sample times (s).
    displacement : array (k, m)
        ``x(t) - x(0)`` (mm) of the group's trajectories at ``times``.
    window : (float, float)
        As in ``einstein_D``.
    drift : bool
        A tilted floor: D about the group's mean drift (``einstein_D(..., drift=True)``),
        and its drift velocity ``v_d``, ``v_d_se`` (mm/s, ``drift_velocity``) added.
    """
    if displacement.shape[0] < 2:
        nan = [math.nan] * 4
        out = {"D": math.nan, "D_se": math.nan,
               "D_windows": {"t_centre": nan, "D": nan, "D_se": nan}}  # fmt: skip
        if drift:
            out.update(v_d=math.nan, v_d_se=math.nan)
        return out
    D, se = einstein_D(times, displacement, window, drift=drift)
    centres, D_w, se_w = einstein_D_windows(times, displacement, drift=drift)
    out = {
        "D": float(D),
        "D_se": float(se),
        "D_windows": {"t_centre": centres.tolist(), "D": D_w.tolist(), "D_se": se_w.tolist()},
    }
    if drift:
        out["v_d"], out["v_d_se"] = (float(v) for v in drift_velocity(times, displacement, window))
    return out


def _mean_se(values):
    """Mean over trajectories and its standard error (NaN for one trajectory), as floats."""
    if values.size < 2:
        return float(values.mean()), math.nan
    return float(values.mean()), float(values.std(ddof=1) / math.sqrt(values.size))


def _regime(attractors, unsettled, th):
    """Regime label (docs/model.md, section 5) and the sentence that decided it."""
    if not attractors:
        return "other", "no settled attractor: every trajectory is unsettled (longer t?)"
    chars = ", ".join(f"{a['character']} ({a['fraction']:.3g})" for a in attractors)
    note = f"; {unsettled:.3g} unsettled (uncertain)" if unsettled > th.max_unsettled else ""
    if all(a["trapped"] for a in attractors):
        return "a", f"every attractor makes < {th.trapped_jumps} jumps per period: {chars}{note}"
    if len(attractors) >= 2:
        return "b(i)", f"{len(attractors)} coexisting attractors: {chars}{note}"
    a = attractors[0]
    label = {"locked": "b(ii)", "creeping": "c", "intermittent": "d"}.get(a["character"], "other")
    return label, (
        f"one attractor, {a['character']}: locked flights {a['locked_fraction']:.3g} "
        f"(k = {a['dominant_k']}), tiny hops {a['tiny_fraction']:.3g}, "
        f"jump rate {a['jump_rate']:.3g}/s{note}"
    )


def classify(
    params: Params,
    *,
    t: float = 50.0,
    n: int = 1000,
    seed=None,
    boxes: list[Box] | None = None,
    initial=None,
    start_phase: float = 0.0,
    transient: float | None = None,
    blocks: int = 16,
    thresholds: Thresholds | None = None,
    threads: int | None = None,
    on_failure: str = "keep",
    progress=None,
) -> Classification:
    """Classify the dynamics at ``params``: ``trajectory_features`` then ``classify_features``.

    Examples
    --------
    >>> c = classify(Params(f=45.0, R=1e9), t=2.0, n=20, seed=1)   # doctest: +SKIP
    >>> c.summary["regime"]                                       # doctest: +SKIP
    'a'
    """
    feat = trajectory_features(
        params, t=t, n=n, seed=seed, boxes=boxes, initial=initial, start_phase=start_phase,
        transient=transient, blocks=blocks, thresholds=thresholds, threads=threads,
        on_failure=on_failure, progress=progress,
    )  # fmt: skip
    out = classify_features(feat, thresholds)
    out.meta["summary"]["feature_wall_s"] = feat.meta["wall_s"]
    return out


class Classification(Result):
    """Attractors, basins, ergodicity and regime (``meta["summary"]``, JSON-ready).

    Arrays: ``labels`` (n,) attractor per trajectory (-1 unsettled, -2 failed), ``initial`` (n, 3),
    ``box_index`` (n,), and per-trajectory time averages used as evidence (energies in
    A^2 w^2 / 2, as ``FeatureResult.block_values``), with ``D`` (mm^2/s) each trajectory's
    MSD slope / 2 over the D window (``diffusion.per_particle_slopes``): its mean over an
    attractor's trajectories is the attractor's D.
    """

    kind = "classification"

    @property
    def summary(self) -> dict:
        return self.meta["summary"]

    def plot(self, ax=None):
        """Each trajectory's <E> against its tiny-hop fraction, coloured by attractor."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        lab = self["labels"]
        for a in np.unique(lab[lab > -2]):  # failed trajectories have no time averages
            sel = lab == a
            name = "unsettled" if a < 0 else f"attractor {a} ({np.mean(sel):.2f})"
            ax.plot(self["tiny_fraction"][sel], self["E"][sel], "." if a >= 0 else "x", label=name)
        s = self.summary
        ax.set(xlabel="tiny-hop fraction", ylabel=r"$\langle E\rangle / (A^2\omega^2/2)$",
               title=f"f = {s['f']} Hz: regime {s['regime']}, ergodic {s['ergodic']}")  # fmt: skip
        ax.legend(fontsize=8)
        return ax
