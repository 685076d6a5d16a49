"""Ensembles of billiard particles and their steady-state observables (MODEL.md section 3).

``ensemble`` draws (or takes) initial conditions, runs ``core.ensemble.run_ensemble``
in parallel over particles and returns an ``EnsembleResult``: per-particle
displacements at the sample times, period-averaged energies, stuck fractions,
collision and jump counts, optionally the jump sequences and a collision record.

Initial conditions are post-collision states on the floor of tile 0 at t = 0,
given as ``(s, vx+, vy+)``: arc length from the left wedge (mm) and absolute
velocities (mm/s).  Particle ``i`` draws row ``i`` of one ``(n, 3)`` array of
uniforms from ``np.random.default_rng(np.random.SeedSequence(seed))``, so its
initial condition depends only on the seed and on ``i`` (not on ``n``, nor on
the number of threads).
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass

import numba
import numpy as np

from bbdyn.billiard import check_params
from bbdyn.core.status import FAILURES, STATUS_MESSAGES, SimulationError
from bbdyn.params import Params
from bbdyn.results import Result, make_meta

__all__ = ["Box", "reference_box", "initial_conditions", "ensemble", "EnsembleResult"]

OBSERVABLES = ("displacement", "energy", "jumps", "record")


@dataclass(frozen=True)
class Box:
    """A box of post-collision initial conditions, uniform in each coordinate.

    ``s`` in mm (within ``[0, s_max]``), ``vx`` and ``vy`` in mm/s; ``vy`` is
    drawn in the half-open ``(vy[0], vy[1]]`` so that ``vy > 0`` for a lower bound 0.
    """

    s: tuple[float, float]
    vx: tuple[float, float]
    vy: tuple[float, float]

    def __post_init__(self) -> None:
        for name in ("s", "vx", "vy"):
            lo, hi = (float(v) for v in getattr(self, name))
            if not (math.isfinite(lo) and math.isfinite(hi) and lo <= hi):
                raise ValueError(f"box {name} must be finite with low <= high, got ({lo}, {hi})")
            object.__setattr__(self, name, (lo, hi))


def reference_box(params: Params) -> Box:
    """The reference box of MODEL.md: 0 <= s <= s_max, |vx+| <= 40, 0 < vy+ <= 40 (mm/s)."""
    return Box(s=(0.0, params.s_max), vx=(-40.0, 40.0), vy=(0.0, 40.0))


def initial_conditions(params: Params, n: int, seed, box: Box | None = None) -> np.ndarray:
    """``n`` initial conditions ``(s, vx+, vy+)`` drawn uniformly from ``box``; shape (n, 3)."""
    box = reference_box(params) if box is None else box
    u = np.random.default_rng(np.random.SeedSequence(seed)).random((n, 3))
    out = np.empty((n, 3))
    out[:, 0] = box.s[0] + (box.s[1] - box.s[0]) * u[:, 0]
    out[:, 1] = box.vx[0] + (box.vx[1] - box.vx[0]) * u[:, 1]
    out[:, 2] = box.vy[1] - (box.vy[1] - box.vy[0]) * u[:, 2]  # in (lo, hi]
    return out


def kernel_states(params: Params, ics: np.ndarray) -> np.ndarray:
    """Kernel states of post-collision initial conditions ``(s, vx+, vy+)`` at t = 0."""
    from bbdyn.core.ensemble import initial_states

    s = ics[:, 0]
    if np.any((s < 0) | (s > params.s_max)):
        raise ValueError(f"initial s must be in [0, s_max = {params.s_max}] mm")
    states = np.empty((ics.shape[0], 7))
    bad = initial_states(ics, params.kernel(), states)
    if bad >= 0:
        raise ValueError(
            f"initial conditions must leave the floor (post-collision states); particle {bad}, "
            f"(s, vx, vy) = {tuple(ics[bad])}, moves into the arc"
        )
    return states


def periods_phase(times_s: np.ndarray, f: float) -> tuple[np.ndarray, np.ndarray]:
    """Split times (s) into whole periods and phase w t mod 2 pi."""
    cycles = np.asarray(times_s, dtype=float) * f
    whole = np.floor(cycles)
    return whole, (cycles - whole) * 2.0 * math.pi


@contextlib.contextmanager
def numba_threads(threads: int | None):
    """Run the block with ``threads`` numba threads (all if None); yields the number used."""
    if threads is not None and not 1 <= int(threads) <= numba.config.NUMBA_NUM_THREADS:
        raise ValueError(f"threads must be in [1, {numba.config.NUMBA_NUM_THREADS}], got {threads}")
    old = numba.get_num_threads()
    if threads is not None:
        numba.set_num_threads(int(threads))
    try:
        yield numba.get_num_threads()
    finally:
        numba.set_num_threads(old)


def raise_for_particles(status: np.ndarray, ics: np.ndarray) -> None:
    """Raise ``SimulationError`` naming the first particle whose kernel status is a failure."""
    failed = np.flatnonzero(np.isin(status, FAILURES))
    if failed.size:
        i = failed[0]
        raise SimulationError(
            f"{failed.size} particle(s) failed, e.g. particle {i} from (s, vx, vy) = "
            f"{tuple(ics[i])}: {STATUS_MESSAGES[int(status[i])]} (status {status[i]})"
        )


def ensemble(
    params: Params,
    *,
    t: float,
    n: int | None = None,
    seed=None,
    box: Box | None = None,
    initial=None,
    sample_times=None,
    transient: float | None = None,
    observables=("displacement", "energy"),
    jump_capacity: int = 1024,
    record_particles: int = 0,
    record_window: tuple[float, float] | None = None,
    record_capacity: int = 4096,
    threads: int | None = None,
    fast_forward: bool = True,
) -> EnsembleResult:
    """Run an ensemble of independent particles for ``t`` seconds.

    Parameters
    ----------
    params : Params
    t : float
        Simulated time (s), > 0.
    n : int, optional
        Number of particles drawn from ``box`` (default 1000); not with ``initial``.
    seed : int or None
        Seed of ``np.random.SeedSequence``; stored in the metadata.
    box : Box, optional
        Box of initial conditions; default ``reference_box(params)``.
    initial : array of shape (n, 3), optional
        Explicit post-collision initial conditions ``(s, vx+, vy+)`` at t = 0 in tile 0.
    sample_times : array, optional
        Times (s) in ``[0, t]`` at which displacements are recorded; default 101
        equally spaced times including 0 and ``t``.
    transient : float, optional
        Time (s) discarded before averaging; default ``t / 5``.  Averages cover the
        whole driving periods from ``ceil(transient f)`` to ``floor(t f)``.
    observables : sequence of str
        Any of ``"displacement"``, ``"energy"``, ``"jumps"``, ``"record"``.  Stuck
        fractions and collision counts are always computed.
    jump_capacity : int
        Jumps stored per particle (more are counted, not stored).
    record_particles, record_window, record_capacity
        With ``"record"``: the collisions of the first ``record_particles`` particles
        in ``record_window`` (s; default the whole run), at most ``record_capacity`` each.
    threads : int, optional
        Number of numba threads (default: numba's current setting).  Results do
        not depend on it.
    fast_forward : bool
        Skip whole stick-release cycles once a release repeats bit for bit
        (``core.ensemble.fast_forward``): the same events; counts, jumps,
        displacements exact, integrals to rounding.  Not for recorded particles.

    Returns
    -------
    EnsembleResult

    Examples
    --------
    >>> from bbdyn import Params
    >>> res = ensemble(Params(f=85.2), n=20, t=2.0, seed=1)   # doctest: +SKIP
    >>> D, D_se = res.D()                                     # doctest: +SKIP
    """

    from bbdyn.core import ensemble as core

    check_params(params)
    t = float(t)
    if not (math.isfinite(t) and t > 0):
        raise ValueError(f"t must be a finite time > 0 s, got {t}")
    unknown = set(observables) - set(OBSERVABLES)
    if unknown:
        raise ValueError(f"observables must be among {OBSERVABLES}, got {sorted(unknown)}")
    if initial is not None:
        if n is not None or box is not None:
            raise ValueError("give either initial or (n, box), not both")
        ics = np.array(initial, dtype=float, ndmin=2)
        if ics.ndim != 2 or ics.shape[1] != 3 or not np.all(np.isfinite(ics)):
            raise ValueError(f"initial must be a finite (n, 3) array, got shape {ics.shape}")
    else:
        n = 1000 if n is None else n
        if int(n) != n or n < 1:
            raise ValueError(f"n must be a positive integer, got {n}")
        ics = initial_conditions(params, int(n), seed, box)
    states = kernel_states(params, ics)
    n = ics.shape[0]

    transient = t / 5 if transient is None else float(transient)
    if not 0.0 <= transient < t:
        raise ValueError(f"transient must be in [0, t = {t}) s, got {transient}")
    window = np.array([math.ceil(transient * params.f), math.floor(t * params.f)], dtype=float)
    if window[1] <= window[0]:
        raise ValueError(f"no whole driving period between transient = {transient} s and t = {t} s")
    if sample_times is None:
        sample_times = np.linspace(0.0, t, 101)
    sample_times = np.asarray(sample_times, dtype=float)
    if sample_times.ndim != 1 or np.any(np.diff(sample_times) < 0):
        raise ValueError("sample_times must be a sorted one-dimensional array")
    if sample_times.size and (sample_times[0] < 0 or sample_times[-1] > t):
        raise ValueError(f"sample_times must lie in [0, t = {t}] s")
    if "displacement" not in observables:
        sample_times = sample_times[:0]
    s_periods, s_phase = periods_phase(sample_times, params.f)
    end_periods, end_phase = periods_phase(np.array([t]), params.f)
    end = np.array([end_periods[0], end_phase[0]])
    rec_t = (0.0, t) if record_window is None else tuple(float(v) for v in record_window)
    rp, rph = periods_phase(np.array(rec_t), params.f)
    record_win = np.array([rp[0], rph[0], rp[1], rph[1]])

    flags = 0
    for name, flag in (
        ("displacement", core.OBS_DISPLACEMENT),
        ("energy", core.OBS_ENERGY),
        ("jumps", core.OBS_JUMPS),
        ("record", core.OBS_RECORD),
    ):
        if name in observables:
            flags |= flag
    if fast_forward:
        flags |= core.OBS_FAST_FORWARD
    cap = int(jump_capacity) if "jumps" in observables else 0
    n_rec = min(int(record_particles), n) if "record" in observables else 0
    rec_cap = int(record_capacity) if n_rec else 0
    disp = np.zeros((n, s_periods.size))
    acc = np.zeros((n, 1, 4))  # one block: the energy window
    counts = np.zeros((n, core.CNT_WIDTH), dtype=np.int64)
    jump_len = np.zeros((n, cap), dtype=np.int64)
    jump_time = np.zeros((n, cap))
    record = np.zeros((n_rec, rec_cap, core.REC_WIDTH))
    final = np.zeros((n, 7))
    status = np.zeros(n, dtype=np.int64)

    start = time.perf_counter()
    with numba_threads(threads) as used_threads:
        core.run_ensemble(
            states,
            params.kernel(),
            end,
            window,
            s_periods,
            s_phase,
            record_win,
            flags,
            disp,
            acc,
            counts,
            jump_len,
            jump_time,
            record,
            final,
            status,
        )
    wall = time.perf_counter() - start
    raise_for_particles(status, ics)

    t_window = (window[1] - window[0]) / params.f
    arrays = {
        "initial": ics,
        "status": status,
        "sample_times": sample_times,
        "displacement": disp,
        "stuck_fraction": acc[:, 0, core.ACC_STUCK] / t_window,
        "collisions": counts[:, core.CNT_COLLISIONS],
        "sticks": counts[:, core.CNT_STICKS],
        "jumps": counts[:, core.CNT_JUMPS],
        "events": counts[:, core.CNT_EVENTS],
        "skipped_events": counts[:, core.CNT_SKIPPED],
        "final": final,
    }
    if "energy" in observables:
        arrays["E_x"] = acc[:, 0, core.ACC_EX] / t_window
        arrays["E_y"] = acc[:, 0, core.ACC_EY] / t_window
        arrays["E_pot"] = acc[:, 0, core.ACC_POT] / t_window
        arrays["E"] = arrays["E_x"] + arrays["E_y"] + arrays["E_pot"]
    if "jumps" in observables:
        arrays["jump_len"] = jump_len
        arrays["jump_time"] = jump_time
    if n_rec:
        arrays["record"] = record
        arrays["record_n"] = counts[:n_rec, core.CNT_RECORD]
    meta = make_meta(
        params,
        seed=seed,
        wall_s=wall,
        t=t,
        n=n,
        transient=transient,
        window_periods=window.tolist(),
        window_s=t_window,
        observables=list(observables),
        threads=used_threads,
        fast_forward=bool(fast_forward),
        box=None if initial is not None else vars(box or reference_box(params)),
    )
    return EnsembleResult(arrays, meta)


class EnsembleResult(Result):
    """Per-particle observables of an ensemble run (arrays) and its settings (meta).

    Arrays: ``initial`` (n, 3) ``(s, vx+, vy+)``; ``status`` (n,); ``sample_times`` (m,) s;
    ``displacement`` (n, m) mm; ``E, E_x, E_y, E_pot`` (n,) period-averaged energies
    (kg mm^2/s^2) over the window; ``stuck_fraction`` (n,); ``collisions``, ``sticks``,
    ``jumps`` (n,) counts in the window; ``events`` (n,) in the whole run, of which
    ``skipped_events`` (n,) were fast-forwarded; ``final`` (n, 7)
    the last event before t (periods, phase, tile, xi, vx, vyrel, kind); with jumps
    ``jump_len``, ``jump_time`` (n, cap); with a record ``record`` (n_rec, cap, 7)
    (periods, phase, tile, xi, vx, vyrel, kind) and ``record_n``.
    """

    kind = "ensemble"

    def msd(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample times (s) and the ensemble mean squared displacement (mm^2)."""
        return self["sample_times"], np.mean(self["displacement"] ** 2, axis=0)

    def D(self, window=(0.5, 1.0)) -> tuple[float, float]:
        """Einstein D and its standard error (mm^2/s), ``bbdyn.diffusion.einstein_D``."""
        from bbdyn.diffusion import einstein_D

        return einstein_D(self["sample_times"], self["displacement"], window=window)

    def jump_data(self):
        """The jumps in the averaging window as ``bbdyn.approx.JumpData``.

        Times are measured from the start of the window (``t_total`` is its length).
        Raises ValueError if the run did not record jumps or a buffer overflowed.
        """
        from bbdyn.approx import JumpData

        if "jump_len" not in self.arrays:
            raise ValueError("jumps were not recorded: run with observables including 'jumps'")
        counts, cap = self["jumps"], self["jump_len"].shape[1]
        if np.any(counts > cap):
            raise ValueError(
                f"{np.count_nonzero(counts > cap)} particle(s) made more than jump_capacity = "
                f"{cap} jumps (up to {counts.max()}); run again with a larger jump_capacity"
            )
        t0 = self.meta["window_periods"][0] / self.meta["params"]["f"]
        return JumpData.from_particles(
            [row[:k] for row, k in zip(self["jump_len"], counts, strict=True)],
            [row[:k] - t0 for row, k in zip(self["jump_time"], counts, strict=True)],
            t_total=self.meta["window_s"],
            d=self.meta["params"]["d"],
        )

    def summary(self, window=(0.5, 1.0)) -> dict[str, float]:
        """Ensemble means with standard errors over particles (plain floats, for JSON)."""
        n = self["status"].size
        out: dict[str, float] = {}
        if self["displacement"].shape[1] >= 2:
            out["D"], out["D_se"] = (float(v) for v in self.D(window))
        names = ["E", "E_x", "E_y", "E_pot", "stuck_fraction"]
        for name in names:
            if name in self.arrays:
                values = self[name]
                out[name] = float(values.mean())
                out[name + "_se"] = float(values.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan
        rate = self["collisions"] / self.meta["window_s"]
        out["collisions_per_particle_per_s"] = float(rate.mean())
        out["jumps_per_particle_per_s"] = float(np.mean(self["jumps"]) / self.meta["window_s"])
        w = 2 * math.pi * self.meta["params"]["f"]
        out["E_reference"] = 0.5 * (self.meta["params"]["A"] * w) ** 2
        return out

    def plot(self, ax=None):
        """Mean squared displacement against time, with the late-window Einstein fit."""
        import matplotlib.pyplot as plt

        if ax is None:
            _, ax = plt.subplots()
        times, msd = self.msd()
        ax.plot(times, msd, ".", label="MSD")
        if times.size >= 2:
            D, se = self.D()
            late = times >= 0.5 * times[-1]
            fit = np.polyfit(times[late], msd[late], 1)
            ax.plot(times[late], np.polyval(fit, times[late]), "-", label=f"D = {D:.3g} ± {se:.2g}")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(r"$\langle (x - x_0)^2 \rangle$ (mm$^2$)")
        ax.set_title(f"f = {self.meta['params']['f']} Hz, n = {self.meta['n']}")
        ax.legend()
        return ax
