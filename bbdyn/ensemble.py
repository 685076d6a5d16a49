"""Ensembles of billiard particles and their steady-state observables (docs/model.md §3).

``ensemble`` draws (or takes) initial conditions, runs ``core.ensemble.run_ensemble``
in parallel over particles and returns an ``EnsembleResult``: per-particle
displacements at the sample times, period-averaged energies, stuck fractions,
collision and jump counts, optionally the jump sequences and a collision record.

Initial conditions are post-collision states on the floor of tile 0 at t = 0,
given as ``(s, vx+, vy+)``: arc length from the left wedge (mm) and absolute
velocities (mm/s).  Particle ``i`` draws row ``i`` of one ``(n, 3)`` array of
uniforms from ``np.random.default_rng(np.random.SeedSequence(seed))`` (drawn again
from its own stream if that state moves into the arc, ``initial_conditions``), so its
initial condition depends only on the seed and on ``i`` (not on ``n``, nor on
the number of threads).

Runs are checked, cut into chunks and their failed particles handled by ``bbdyn.runs``
(shared with ``bbdyn.classify`` and the scans).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from bbdyn.approx.jumps import JumpData
from bbdyn.core import ensemble as core
from bbdyn.core.status import FAILURES, FAST_FORWARD_MODES
from bbdyn.diffusion import drift_velocity, einstein_D
from bbdyn.gpu import CudaJob, check_device, device_info, run_cuda
from bbdyn.params import Params, check_params
from bbdyn.results import Result, make_meta
from bbdyn.runs import (
    MAX_BYTES,
    MAX_EVENTS,
    ON_FAILURE,
    RunWindow,
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
    "Box",
    "reference_box",
    "initial_conditions",
    "ensemble",
    "ensembles",
    "EnsembleResult",
]

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
    """The reference box of docs/model.md: ``0 <= s <= s_max``, ``|vx+| <= 40``,
    ``0 < vy+ <= 40`` (mm/s)."""
    return Box(s=(0.0, params.s_max), vx=(-40.0, 40.0), vy=(0.0, 40.0))


#: Draws per batch, and most batches, when a particle's first draw from a box does not
#: leave the floor (``initial_conditions``).
REDRAW_BATCH, MAX_REDRAW_BATCHES = 64, 16


def initial_conditions(
    params: Params, n: int, seed, box: Box | None = None, *, phase: float = 0.0
) -> np.ndarray:
    """``n`` initial conditions ``(s, vx+, vy+)`` drawn uniformly from the part of ``box``
    that leaves the floor; shape (n, 3).

    Particle ``i`` takes row ``i`` of one ``(n, 3)`` array of uniforms from
    ``np.random.default_rng(np.random.SeedSequence(seed))``.  A row whose velocity moves into
    the arc relative to the floor at phase ``phase`` (rad; not a post-collision state: near
    the wedges of a steep arc, R close to d/2) is drawn again from the particle's own
    stream ``SeedSequence(entropy, spawn_key=(i,))`` until it leaves the floor.  So the
    draws are uniform on the part of the box that leaves the floor, particle ``i`` still
    depends only on the seed and ``i``, and where the whole box leaves the floor (the
    reference box at the default R = 25 mm) the rows are the first draws.  ValueError if a
    particle finds no such state in ``REDRAW_BATCH * MAX_REDRAW_BATCHES`` draws (a box
    (almost) entirely moving into the floor).
    """
    box = reference_box(params) if box is None else box
    entropy = np.random.SeedSequence(seed)
    out = _box_points(box, np.random.default_rng(entropy).random((n, 3)))
    u = -params.A * params.w * math.cos(phase)  # the floor's velocity
    for i in np.flatnonzero(~_leaving_floor(params, out, u)):
        stream = np.random.default_rng(
            np.random.SeedSequence(entropy.entropy, spawn_key=(*entropy.spawn_key, int(i)))
        )
        for _ in range(MAX_REDRAW_BATCHES):
            draws = _box_points(box, stream.random((REDRAW_BATCH, 3)))
            good = np.flatnonzero(_leaving_floor(params, draws, u))
            if good.size:
                out[i] = draws[good[0]]
                break
        else:
            raise ValueError(
                f"box {box} has (almost) no post-collision states: particle {i} found none "
                f"that leaves the floor in {REDRAW_BATCH * MAX_REDRAW_BATCHES} draws; choose "
                "velocities that move away from the arc (vy+ above the floor's velocity "
                f"{u:.4g} mm/s)"
            )
    return out


def _box_points(box: Box, u: np.ndarray) -> np.ndarray:
    """Points ``(s, vx, vy)`` of ``box`` from uniforms ``u`` in [0, 1), shape (m, 3)."""
    out = np.empty(u.shape)
    out[:, 0] = box.s[0] + (box.s[1] - box.s[0]) * u[:, 0]
    out[:, 1] = box.vx[0] + (box.vx[1] - box.vx[0]) * u[:, 1]
    out[:, 2] = box.vy[1] - (box.vy[1] - box.vy[0]) * u[:, 2]  # in (lo, hi]
    return out


def _leaving_floor(params: Params, ics: np.ndarray, u: float) -> np.ndarray:
    """Which rows ``(s, vx+, vy+)`` of ``ics`` leave the floor moving at ``u`` (mm/s)."""
    ok = np.empty(ics.shape[0], dtype=np.bool_)
    core.leaving_floor(ics, u, params.kernel(noise=True), ok)
    return ok


def kernel_states(params: Params, ics: np.ndarray) -> np.ndarray:
    """Kernel states of post-collision initial conditions ``(s, vx+, vy+)`` at t = 0."""
    s = ics[:, 0]
    if np.any((s < 0) | (s > params.s_max)):
        raise ValueError(f"initial s must be in [0, s_max = {params.s_max}] mm")
    states = np.empty((ics.shape[0], 7))
    bad = core.initial_states(ics, params.kernel(noise=True), states)
    if bad >= 0:
        raise ValueError(
            f"initial conditions must leave the floor (post-collision states); particle {bad}, "
            f"(s, vx, vy) = {tuple(ics[bad])}, moves into the arc"
        )
    return states


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
    fast_forward: str | bool = "converged",
    on_failure: str = "keep",
    max_events: float = MAX_EVENTS,
    max_bytes: float = MAX_BYTES,
    chunk_events: int | None = None,
    progress=None,
    device: str = "cpu",
) -> EnsembleResult:
    """Run an ensemble of independent particles for ``t`` seconds; an ``EnsembleResult``.

    ``n`` particles (default 1000, at least ``N_MIN`` = 2) drawn from ``box`` (default
    ``reference_box(params)``) with ``seed``, or the rows ``(s, vx+, vy+)`` of ``initial``
    (post-collision states at t = 0 in tile 0; not with ``n`` or ``box``).  Displacements at
    ``sample_times`` (s in ``[0, t]``, default 101 equally spaced); averages over the whole
    driving periods from ``ceil(transient f)`` (``transient`` default ``t / 5``) to
    ``floor(t f)``.  ``observables``: any of ``"displacement"``, ``"energy"``, ``"jumps"``
    (at most ``jump_capacity`` stored per particle, all counted), ``"record"`` (the
    collisions of the first ``record_particles`` particles in ``record_window`` s, default
    the whole run, at most ``record_capacity`` each); stuck fractions and counts always.

    ``fast_forward`` skips whole stick-release cycles (``core.fast_forward``; not for
    recorded particles): ``"bitwise"`` once a release repeats bit for bit (the same events,
    counts and displacements, integrals to rounding); ``"converged"`` (default, also True)
    besides once a cycle has converged to within ``FF_DRIFT_TOL`` = 1e-12 mm (positions
    within 1e-12 mm, integrals within 1e-12 relative); ``"off"`` (also False) event by
    event; with random restitution (``params.eta > 0``) no cycle repeats and it is always
    ``"off"`` (``meta["fast_forward"]``).  ``on_failure``: ``"keep"`` or ``"raise"``
    (``runs.failed_particles``).  ``seed`` also keys the random restitution
    (``runs.noise_key``): particle ``i``'s collisions draw from (seed, i, flight index).
    ``max_events``, ``max_bytes``: refuse larger runs (``runs.check_size``).  The run goes
    in chunks of ``chunk_events`` events (``runs.run_chunked``: Ctrl-C stops it between
    chunks, ``progress`` is told the fraction done) on ``threads`` numba threads; the
    numbers depend on neither.

    ``device="cuda"`` runs the particles on an NVIDIA GPU (``bbdyn.gpu``, docs/gpu.md): the
    same initial conditions and event loop, one thread per particle, without fast-forward
    (``meta["fast_forward"]`` is ``"off"``) and without ``"record"``; ``NoDeviceError``
    without a GPU.  ``meta["device"]`` and ``meta["device_name"]`` say where it ran.

    >>> res = ensemble(Params(f=85.2), n=20, t=2.0, seed=1)   # doctest: +SKIP
    >>> D, D_se = res.D()                                     # doctest: +SKIP
    """
    options = dict(
        t=t, n=n, box=box, initial=initial, sample_times=sample_times, transient=transient,
        observables=observables, jump_capacity=jump_capacity, record_particles=record_particles,
        record_window=record_window, record_capacity=record_capacity,
        fast_forward=fast_forward, max_events=max_events, max_bytes=max_bytes,
    )  # fmt: skip
    return ensembles([params], [seed], device=device, threads=threads, on_failure=on_failure,
                     chunk_events=chunk_events, progress=progress, **options)[0]  # fmt: skip


def ensembles(
    params_list,
    seeds,
    *,
    t: float,
    device: str = "cpu",
    threads: int | None = None,
    on_failure: str = "keep",
    chunk_events: int | None = None,
    progress=None,
    **options,
) -> list[EnsembleResult]:
    """``ensemble(params, seed=seed, **options)`` for each pair of ``params_list`` and
    ``seeds``; a list of ``EnsembleResult``.

    On the CPU the ensembles run one after the other, each exactly as ``ensemble`` runs
    it.  With ``device="cuda"`` all of them go to the GPU together (``bbdyn.gpu.run_cuda``:
    the points of a scan in one or a few launches); each result's ``wall_s`` and ``cpu_s``
    are then those of the whole run, ``meta["batch"]`` the number of ensembles in it,
    ``meta["launches"]`` its kernel launches and ``meta["device_bytes"]`` the device memory
    of its largest group of points (``bbdyn.gpu.run_cuda``).
    ``progress`` gets the fraction done of the whole.
    """
    check_device(device)
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise TypeError(f"ensembles() got unknown options {unknown}; it takes {_OPTIONS}")
    if on_failure not in ON_FAILURE:
        raise ValueError(f"on_failure must be one of {ON_FAILURE}, got {on_failure!r}")
    info = device_info(device)  # NoDeviceError before anything is allocated
    options["t"] = t
    jobs = [_prepare(p, seed, device, options) for p, seed in zip(params_list, seeds, strict=True)]
    if device == "cuda":
        start, cpu_start = time.perf_counter(), time.process_time()
        cuda_jobs = [CudaJob(j.params.kernel(noise=True), j.times, j.obs, j.carry.state,
                             j.buffers) for j in jobs]  # fmt: skip
        stats = run_cuda(cuda_jobs, chunk_events=chunk_events, progress=progress)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
        info |= {"batch": len(jobs), "launches": stats["launches"], "device_bytes": stats["bytes"]}
        return [_finish(j, wall, cpu, None, on_failure, info) for j in jobs]
    results = []
    for k, job in enumerate(jobs):
        tell = None if progress is None else (lambda x, k=k: progress((k + x) / len(jobs)))
        start, cpu_start = time.perf_counter(), time.process_time()
        with numba_threads(threads) as used_threads:
            _run_cpu(job, chunk_events, tell)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu_start
        results.append(_finish(job, wall, cpu, used_threads, on_failure, info))
    return results


#: The options of ``ensembles``: those of ``ensemble`` that each ensemble takes.
_OPTIONS = ("n", "box", "initial", "sample_times", "transient", "observables",
            "jump_capacity", "record_particles", "record_window", "record_capacity",
            "fast_forward", "max_events", "max_bytes")  # fmt: skip


def _run_cpu(job: _Job, chunk_events, progress) -> None:
    """Run one job's particles on the CPU (``core.run_ensemble`` in chunks)."""
    kp, times = job.params.kernel(noise=True), job.times
    run_chunked(
        lambda budget: core.run_ensemble(job.carry, budget, kp, times, job.obs, job.buffers),
        job.carry, job.buffers.status, times.end_periods + times.end_phase / (2 * math.pi),
        chunk_events=chunk_events, progress=progress,
    )  # fmt: skip


@dataclass
class _Job:
    """One ensemble ready to run: its validated inputs, kernel arguments and output arrays."""

    params: Params
    seed: object
    run: RunWindow
    ics: np.ndarray
    sample_times: np.ndarray
    observables: tuple
    box: Box | None
    mode: str
    estimate: dict
    out: dict
    times: tuple
    obs: tuple
    carry: tuple
    buffers: tuple


def _prepare(params: Params, seed, device: str, options: dict) -> _Job:
    """Validate one ensemble of ``ensembles``, allocate its arrays, draw its particles."""
    o = options
    check_params(params)
    observables = tuple(o.get("observables", ("displacement", "energy")))
    run, n, ics = _check_inputs(params, o["t"], o.get("n"), o.get("box"), o.get("initial"),
                                o.get("transient"), observables)  # fmt: skip
    fast_forward = o.get("fast_forward", "converged")
    if device == "cuda":
        if "record" in observables:
            raise ValueError("observables 'record' runs on the CPU only: leave out device")
        fast_forward_mode(fast_forward)  # checked; the device makes every event
        fast_forward = "off"
    sample_times = _sample_times(o.get("sample_times"), run.t, "displacement" in observables)
    times, obs, mode = _kernel_inputs(params, run, sample_times, observables, fast_forward,
                                      o.get("record_window"))  # fmt: skip
    n_rec = min(int(o.get("record_particles", 0)), n) if "record" in observables else 0
    jump_cap = int(o.get("jump_capacity", 1024)) if "jumps" in observables else 0
    caps = (jump_cap, n_rec, int(o.get("record_capacity", 4096)))
    lags = core.FF_LAGS if mode != "off" else 0
    limits = dict(params=params, n=n, t=run.t, max_events=o.get("max_events", MAX_EVENTS),
                  max_bytes=o.get("max_bytes", MAX_BYTES))  # fmt: skip
    out, estimate = _allocate_outputs(n, sample_times.size, caps, lags, limits)
    box = o.get("box")
    if ics is None:
        ics = initial_conditions(params, n, seed, box)
    key = noise_key(seed) if params.eta > 0 else (0, 0)
    carry = new_carry(kernel_states(params, ics), lags, 0, key)
    return _Job(params, seed, run, ics, sample_times, observables,
                None if o.get("initial") is not None else (box or reference_box(params)),
                mode, estimate, out, times, obs, carry, core.EnsembleOut(**out))  # fmt: skip


def _finish(job: _Job, wall, cpu, threads, on_failure, info) -> EnsembleResult:
    """The ``EnsembleResult`` of a job that has run."""
    failed = failed_particles(job.buffers.status, job.ics, on_failure)
    run, params = job.run, job.params
    meta = make_meta(
        params, seed=job.seed, wall_s=wall, cpu_s=cpu, t=run.t, n=job.ics.shape[0],
        transient=run.transient, window_periods=[run.p0, run.p0 + run.L],
        window_s=_window_s(run, params.f), halves_periods=_halves(run),
        observables=list(job.observables), threads=threads, fast_forward=job.mode,
        box=None if job.box is None else vars(job.box), estimate=job.estimate, **info,
        **failed,
    )  # fmt: skip
    arrays = _result_arrays(params, run, job.ics, job.sample_times, job.out, job.observables)
    return EnsembleResult(arrays, meta)


def _check_inputs(params, t, n, box, initial, transient, observables):
    """Validate ``ensemble``'s run: its ``RunWindow``, the number of particles and the
    explicit initial conditions (None when they are drawn from a box)."""
    unknown = set(observables) - set(OBSERVABLES)
    if unknown:
        raise ValueError(f"observables must be among {OBSERVABLES}, got {sorted(unknown)}")
    run = check_run(params, t, float(t) / 5 if transient is None else transient)
    if initial is None:
        return run, check_n(1000 if n is None else n), None
    if n is not None or box is not None:
        raise ValueError("give either initial or (n, box), not both")
    ics = np.array(initial, dtype=float, ndmin=2)
    if ics.ndim != 2 or ics.shape[1] != 3 or ics.shape[0] < 1 or not np.all(np.isfinite(ics)):
        raise ValueError(f"initial must be a finite (n, 3) array, n >= 1, got {ics.shape}")
    return run, ics.shape[0], ics


def _halves(run: RunWindow) -> list[float]:
    """``[p0, split, p1]`` (whole periods): the averaging window and the end of its first half."""
    return [run.p0, float(math.floor(run.p0 + run.L / 2)), run.p0 + run.L]


def _window_s(run: RunWindow, f: float) -> float:
    """The length of the averaging window (s)."""
    return (run.p0 + run.L - run.p0) / f


def _kernel_inputs(params, run, sample_times, observables, fast_forward, record_window):
    """The kernel's ``RunTimes`` and ``Observables`` for ``ensemble``, and the fast-forward
    mode."""
    s_periods, s_phase = periods_phase(sample_times, params.f)
    end_periods, end_phase = periods_phase(np.array([run.t]), params.f)
    times = core.RunTimes(end_periods[0], end_phase[0], run.p0, run.L, 1, s_periods, s_phase)
    rec_t = (0.0, run.t) if record_window is None else tuple(float(v) for v in record_window)
    flags = 0
    for name, flag in (
        ("displacement", core.OBS_DISPLACEMENT),
        ("energy", core.OBS_ENERGY),
        ("jumps", core.OBS_JUMPS),
        ("record", core.OBS_RECORD),
    ):
        if name in observables:
            flags |= flag
    mode = "off" if params.eta > 0 else fast_forward_mode(fast_forward)
    if mode != "off":
        flags |= core.OBS_FAST_FORWARD
    if mode == "converged":
        flags |= core.OBS_FF_CONVERGED
    split = _halves(run)[1]
    return times, core.Observables(flags, *periods_phase(np.array(rec_t), params.f), split), mode


def _allocate_outputs(n, n_samples, caps, lags, limits):
    """The kernel's output arrays (``core.EnsembleOut``'s fields) once ``check_size``
    accepts the run, and its estimate; ``caps``: jumps per particle, recorded particles
    and collisions recorded per particle."""
    jump_cap, n_rec, rec_cap = caps
    rec_cap = rec_cap if n_rec else 0
    return allocate(
        {
            "displacement": ((n, n_samples), float),
            "blocks": ((n, 2, 4), float),  # the energy window and its first half
            "counts": ((n, core.CNT_WIDTH), np.int64),
            "jump_len": ((n, jump_cap), np.int64),
            "jump_time": ((n, jump_cap), float),
            "record": ((n_rec, rec_cap, core.REC_WIDTH), float),
            "final": ((n, 7), float),
            "status": ((n,), np.int64),
        },
        # initial conditions, their uniforms, states and the carried loop states
        extra=n * 8 * (3 + 3 + 7 + core.CARRY_WIDTH + lags * (6 + 4 + core.CNT_WIDTH)),
        limits=limits,
    )


def _result_arrays(params, run, ics, sample_times, out, observables) -> dict:
    """The arrays of an ``EnsembleResult`` from the kernel's outputs ``out``."""
    acc, counts, status = out["blocks"], out["counts"], out["status"]
    t_window = _window_s(run, params.f)
    arrays = {
        "initial": ics,
        "status": status,
        "sample_times": sample_times,
        "displacement": out["displacement"],
        "stuck_fraction": acc[:, 0, core.ACC_STUCK] / t_window,
        "collisions": counts[:, core.CNT_COLLISIONS],
        "sticks": counts[:, core.CNT_STICKS],
        "jumps": counts[:, core.CNT_JUMPS],
        "events": counts[:, core.CNT_EVENTS],
        "skipped_events": counts[:, core.CNT_SKIPPED],
        "final": out["final"],
    }
    if "energy" in observables:
        arrays["E_x"] = acc[:, 0, core.ACC_EX] / t_window
        arrays["E_y"] = acc[:, 0, core.ACC_EY] / t_window
        arrays["E_pot"] = acc[:, 0, core.ACC_POT] / t_window
        arrays["E"] = arrays["E_x"] + arrays["E_y"] + arrays["E_pot"]
        arrays.update(_energy_halves(acc, _halves(run), params.f, status))
    if "jumps" in observables:
        arrays["jump_len"] = out["jump_len"]
        arrays["jump_time"] = out["jump_time"]
    n_rec = out["record"].shape[0]
    if n_rec:
        arrays["record"] = out["record"]
        arrays["record_n"] = counts[:n_rec, core.CNT_RECORD]
    return arrays


def fast_forward_mode(fast_forward) -> str:
    """The fast-forward mode of ``ensemble``: one of FAST_FORWARD_MODES (True is
    ``"converged"``, False ``"off"``); ValueError otherwise."""
    if fast_forward is True or fast_forward is False:
        return "converged" if fast_forward else "off"
    if fast_forward not in FAST_FORWARD_MODES:
        raise ValueError(f"fast_forward must be one of {FAST_FORWARD_MODES}, got {fast_forward!r}")
    return fast_forward


def _energy_halves(acc: np.ndarray, cuts: list, f: float, status: np.ndarray) -> dict:
    """Energies averaged over the early and late half of the window, shape (n, 2) each.

    ``acc`` (n, 2, 4): the kernel's integrals over the window ``[p0, p1]`` and over
    ``[p0, split]``, ``cuts = [p0, split, p1]`` (whole periods), ``f`` in Hz.  The late
    half is the whole minus the early one.  NaN for a window of one period (no halves)
    and for the particles that failed (``status``; they have no late half).
    """
    p0, split, p1 = cuts
    n = acc.shape[0]
    out = {}
    for name, col in (("E_x", core.ACC_EX), ("E_y", core.ACC_EY), ("E_pot", core.ACC_POT)):
        halves = np.full((n, 2), math.nan)
        if split > p0:
            early, whole = acc[:, 1, col], acc[:, 0, col]
            halves[:, 0] = early / ((split - p0) / f)
            halves[:, 1] = (whole - early) / ((p1 - split) / f)
        halves[np.isin(status, FAILURES)] = math.nan
        out[name + "_halves"] = halves
    out["E_halves"] = out["E_x_halves"] + out["E_y_halves"] + out["E_pot_halves"]
    return out


def _sample_times(sample_times, t: float, wanted: bool) -> np.ndarray:
    """Validated sample times (s) in ``[0, t]``: default 101 equally spaced; none if not wanted."""
    if sample_times is None:
        sample_times = np.linspace(0.0, t, 101)
    sample_times = np.asarray(sample_times, dtype=float)
    if sample_times.ndim != 1 or np.any(np.diff(sample_times) < 0):
        raise ValueError("sample_times must be a sorted one-dimensional array")
    if sample_times.size and (sample_times[0] < 0 or sample_times[-1] > t):
        raise ValueError(f"sample_times must lie in [0, t = {t}] s")
    return sample_times if wanted else sample_times[:0]


class EnsembleResult(Result):
    """Per-particle observables of an ensemble run (arrays) and its settings (meta).

    Arrays: ``initial`` (n, 3) ``(s, vx+, vy+)``; ``status`` (n,); ``sample_times`` (m,) s;
    ``displacement`` (n, m) mm; ``E, E_x, E_y, E_pot`` (n,) period-averaged energies
    (kg mm^2/s^2) over the window, and ``E_halves`` ... ``E_pot_halves`` (n, 2) over its
    early and late half (whole periods ``meta["halves_periods"] = [p0, split, p1]``,
    ``split = floor((p0 + p1) / 2)``; NaN for failed particles and a one-period window);
    ``stuck_fraction`` (n,); ``collisions``, ``sticks``,
    ``jumps`` (n,) counts in the window; ``events`` (n,) in the whole run, of which
    ``skipped_events`` (n,) were fast-forwarded; ``final`` (n, 7)
    the last event before t (periods, phase, tile, xi, vx, vyrel, kind); with jumps
    ``jump_len``, ``jump_time`` (n, cap); with a record ``record`` (n_rec, cap, 7)
    (periods, phase, tile, xi, vx, vyrel, kind) and ``record_n``.

    A particle whose kernel failed (``status`` in ``core.status.FAILURES``; ``meta["n_failed"]``
    of them, ``meta["failures"]`` by status name) keeps its rows, NaN displacements after
    the failure and integrals up to it; the estimators (``msd``, ``D``, ``summary``,
    ``jump_data``) use the particles that succeeded (``ok``) only.
    """

    kind = "ensemble"

    @property
    def ok(self) -> np.ndarray:
        """Boolean mask (n,) of the particles that reached the end (status not a failure)."""
        return ~np.isin(self["status"], FAILURES)

    def msd(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample times (s) and the mean squared displacement (mm^2) over the ``ok`` particles."""
        return self["sample_times"], np.mean(self["displacement"][self.ok] ** 2, axis=0)

    def D(self, window=(0.5, 1.0)) -> tuple[float, float]:
        """Einstein D and its standard error (mm^2/s) over the ``ok`` particles (>= 2 needed).

        ``bbdyn.diffusion.einstein_D``; on a tilted floor (``phi != 0``) about the mean drift.
        """
        tilted = self.meta["params"].get("phi", 0.0) != 0.0
        return einstein_D(
            self["sample_times"], self["displacement"][self.ok], window=window, drift=tilted
        )

    def drift(self, window=(0.5, 1.0)) -> tuple[float, float]:
        """Drift velocity ``v_d`` and its standard error (mm/s) over the ``ok`` particles:
        ``bbdyn.diffusion.drift_velocity``."""
        return drift_velocity(self["sample_times"], self["displacement"][self.ok], window=window)

    def jump_data(self):
        """The jumps in the averaging window as ``bbdyn.approx.JumpData``.

        Times are measured from the start of the window (``t_total`` is its length).
        Raises ValueError if the run did not record jumps or a buffer overflowed.
        """
        if "jump_len" not in self.arrays:
            raise ValueError("jumps were not recorded: run with observables including 'jumps'")
        ok = self.ok
        counts, cap = self["jumps"][ok], self["jump_len"].shape[1]
        if np.any(counts > cap):
            raise ValueError(
                f"{np.count_nonzero(counts > cap)} particle(s) made more than jump_capacity = "
                f"{cap} jumps (up to {counts.max()}); run again with a larger jump_capacity"
            )
        t0 = self.meta["window_periods"][0] / self.meta["params"]["f"]
        return JumpData.from_particles(
            [row[:k] for row, k in zip(self["jump_len"][ok], counts, strict=True)],
            [row[:k] - t0 for row, k in zip(self["jump_time"][ok], counts, strict=True)],
            t_total=self.meta["window_s"],
            d=self.meta["params"]["d"],
        )

    def summary(self, window=(0.5, 1.0)) -> dict:
        """Means with standard errors over the ``ok`` particles (plain numbers, for JSON).

        Also ``n_ok``, ``n_failed`` and ``failures`` (status name -> count).  Standard
        errors (and D) are NaN with fewer than two ``ok`` particles.
        """
        ok = self.ok
        n = int(np.count_nonzero(ok))
        out: dict = {"n_ok": n, "n_failed": int(ok.size - n)}
        out["failures"] = dict(self.meta.get("failures", {}))
        if self["displacement"].shape[1] >= 2:
            D = self.D(window) if n >= 2 else (math.nan, math.nan)
            out["D"], out["D_se"] = (float(v) for v in D)
        names = ["E", "E_x", "E_y", "E_pot", "stuck_fraction"]
        for name in names:
            if name in self.arrays:
                values = self[name][ok]
                out[name] = float(values.mean())
                out[name + "_se"] = float(values.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan
        rate = self["collisions"][ok] / self.meta["window_s"]
        out["collisions_per_particle_per_s"] = float(rate.mean())
        out["jumps_per_particle_per_s"] = float(np.mean(self["jumps"][ok]) / self.meta["window_s"])
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
