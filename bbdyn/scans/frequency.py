"""Diffusion coefficient and steady-state energies across frequency (issue 4, docs/model.md §3).

``diffusion_point(f, seed_sequence, n=..., t=...)`` is the compute function of a
frequency scan (``bbdyn.scans.runner.run_scan``): one reference ensemble at ``f``, and
every number S3, S4 and S5 draw, each with its standard error and the evidence
that it has converged.  ``frequency_scan`` runs it over a grid of frequencies.

Errors and convergence, per frequency:

* ``D, D_se``: late-window MSD slope / 2, ``[t/2, t]``, standard error over
  particles (``bbdyn.diffusion.einstein_D``); ``D_boot_se, D_boot_lo, D_boot_hi``:
  a bootstrap over particles as an independent check of that error and of its skew.
* ``D_windows, D_windows_se``: D in 4 successive windows of ``[t/5, t]``;
  ``D_windows_p``: p-value of "D is the same in every window" (Hotelling T^2 over
  particles, ``bbdyn.diffusion.window_consistency``); ``D_converged`` is 0 if p < P_FLAG.
* ``E_drift, E_drift_se`` (and ``E_x_drift``): late minus early half of the
  averaging window, mean over the particles with its standard error;
  ``energy_stationary`` is 0 if either drift differs from 0 at p < P_FLAG and by more
  than the rounding of the energy integrals (a particle stuck for good has the same
  energy in both halves, to rounding, with a scatter as small).  Exact for
  each particle and free: the ensemble integrates the early half on the way
  (``E_halves``, ``E_x_halves`` of ``bbdyn.ensemble.ensemble``).
* ``trapped``: 1 if every particle was stuck for good (Gamma <= 1) before the first
  D window began; then x is constant there and D = 0 exactly (``D_se = 0``).

The keys are those of the result schema (``bbdyn.schema``, docs/schema.md).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from bbdyn.core.status import STUCK_FOREVER
from bbdyn.core.tolerances import OBS_INTEGRAL_REL_TOL, SUM_ROUND_PER_TERM
from bbdyn.diffusion import (
    drift_removed,
    drift_velocity,
    einstein_D,
    einstein_D_bootstrap,
    einstein_D_windows,
    window_consistency,
)
from bbdyn.ensemble import ensembles
from bbdyn.params import Params
from bbdyn.runs import EVENT_COST_S, EVENTS_PER_PERIOD, check_n, check_run, check_size
from bbdyn.scans.progress import rough_duration
from bbdyn.scans.runner import local_workers, run_scan

__all__ = [
    "MAX_POINTS",
    "P_FLAG",
    "average_rounding",
    "check_scan_size",
    "cpu_estimate",
    "scan_cpu_forecast",
    "diffusion_fit",
    "diffusion_point",
    "diffusion_points",
    "point_seeds",
    "energy_scale",
    "frequency_grid",
    "frequency_scan",
    "grid_size",
    "point_bytes",
]

#: p-value below which a convergence check raises its flag.  Over a 227-point scan
#: about two points are flagged by chance; a flag asks for a look, not a verdict.
P_FLAG = 0.01

#: Window of the Einstein fit, as fractions of t (docs/model.md: the long-time slope).
D_WINDOW = (0.5, 1.0)
#: Successive windows of D: N_WINDOWS equal pieces of [WINDOWS_START t, t].
N_WINDOWS = 4
WINDOWS_START = 0.2
#: MSD samples of a scan point (the default of diffusion_point).
N_SAMPLES = 201
#: Most frequencies in one scan: a larger grid is almost surely a slip in f_step.
MAX_POINTS = 100_000


def point_bytes(n_samples: int = N_SAMPLES) -> float:
    """Disk taken by one stored point of ``diffusion_point`` (.npz and .json), bytes.

    A fixed part (each output has its own zip entry and .npy header; the metadata) plus
    16 bytes per MSD sample (``msd`` and ``sample_times``); within 50 % of a stored point
    (tests/test_frequency_scan.py).
    """
    return 9_700.0 + 16.0 * n_samples


def _bytes_text(nbytes: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if nbytes >= size:
            return f"{nbytes / size:.3g} {unit}"
    return f"{nbytes:.3g} B"


def grid_size(f_start: float, f_stop: float, f_step: float) -> int:
    """Number of frequencies of ``frequency_grid(f_start, f_stop, f_step)``, without building it."""
    f_start, f_stop, f_step = float(f_start), float(f_stop), float(f_step)
    if not (math.isfinite(f_start) and f_start > 0):
        raise ValueError(f"f_start must be a finite frequency > 0 Hz, got {f_start}")
    if not (math.isfinite(f_stop) and f_stop >= f_start):
        raise ValueError(f"f_stop must be finite and >= f_start = {f_start} Hz, got {f_stop}")
    if not (math.isfinite(f_step) and f_step > 0):
        raise ValueError(f"f_step must be a finite step > 0 Hz, got {f_step}")
    return math.floor((f_stop - f_start) / f_step + 1e-9) + 1


def frequency_grid(f_start: float, f_stop: float, f_step: float) -> np.ndarray:
    """Frequencies ``f_start, f_start + f_step, ...`` up to ``f_stop`` (included), Hz.

    Rounded to 1e-9 Hz so that a grid point is the same number on every machine.
    A grid of more than ``MAX_POINTS`` frequencies is refused before it is built.

    Examples
    --------
    >>> g = frequency_grid(49.8, 95.0, 0.2)
    >>> g.size, float(g[-1])
    (227, 95.0)
    """
    count = grid_size(f_start, f_stop, f_step)
    if count > MAX_POINTS:
        disk = _bytes_text(count * point_bytes())
        raise ValueError(
            f"f_start={f_start}, f_stop={f_stop}, f_step={f_step} give {count:.3g} frequencies "
            f"(about {disk} of disk), more than the limit of {MAX_POINTS}: choose a larger "
            "f_step or a narrower range, or split the scan"
        )
    return np.round(float(f_start) + float(f_step) * np.arange(count), 9)


def _check_point_arguments(params: Params, n, t, transient, n_samples) -> int:
    """Validate the arguments of ``diffusion_point`` at ``params``; returns ``n`` as an int."""
    n = check_n(n)
    if int(n_samples) != n_samples or n_samples < 11:
        raise ValueError(f"n_samples must be an integer >= 11, got {n_samples}")
    check_run(params, t, float(t) / 5 if transient is None else transient)
    return n


def cpu_estimate(f_sum: float, n: int, t: float) -> float:
    """CPU time (s) of ``n`` particles for ``t`` s at frequencies summing to ``f_sum`` (Hz),
    from the ensemble's conservative event model (``bbdyn.runs.EVENTS_PER_PERIOD``
    events per period at ``EVENT_COST_S`` each): an upper bound for refusing oversized
    scans, tens of times the CPU time of typical scans (``scan_cpu_forecast`` forecasts it)."""
    return float(f_sum) * float(n) * float(t) * EVENTS_PER_PERIOD * EVENT_COST_S


#: Forecast of a scan's CPU time (``scan_cpu_forecast``), measured as process time of the
#: workers on this project's machine with one numba thread.  CPU time (s) per particle and
#: driving period of a ``diffusion_point`` or ``gk_point`` with compiled kernels: 0.43-0.67
#: us at the quick settings of S3, S9 and B6, 0.36 us for the full S3 scan (whose
#: ensembles fast-forward more of their stick-release cycles).  Particles that stick for
#: good cost nothing after they stick (Gamma <= 1): the forecast counts them all.
POINT_PERIOD_CPU_S = 0.5e-6
#: The same for a ``bbdyn.classify.classify`` point (scene B1: features per block, half the
#: run a transient): 1.3 us at B1's quick setting.
CLASSIFY_PERIOD_CPU_S = 1.3e-6
#: CPU time (s) a local worker takes to start (forked from the scan's server process) and
#: to load the compiled kernels of its points from numba's cache.
WORKER_START_CPU_S = 1.0
#: CPU time (s) a worker takes to compile the kernels of its points when numba's cache
#: lacks them (the first run after installing or changing bbdyn): 45-60 s per worker
#: (each worker compiles the kernels itself).
WORKER_COMPILE_CPU_S = 60.0


def scan_cpu_forecast(
    f_sum: float,
    n_points: int,
    n: int,
    t: float,
    *,
    period_cpu_s: float = POINT_PERIOD_CPU_S,
    workers: int | None = None,
) -> dict[str, float]:
    """Forecast of the CPU time (s) of a local scan of ``n_points`` frequencies summing to
    ``f_sum`` (Hz), ``n`` particles for ``t`` s each, summed over its worker processes
    (``bbdyn.scans.runner.local_workers``).

    Returns ``cpu_s``: the points (``period_cpu_s`` per particle and driving period) and the
    workers' start-up, with compiled kernels; and ``compile_cpu_s``: what the workers add
    when numba's cache lacks the kernels (``WORKER_COMPILE_CPU_S`` each), not included in
    ``cpu_s``.  A forecast, not a bound: within a factor of 2 of the measured CPU time for
    the scenes' quick and full scans (tests/test_cost_forecast.py).
    """
    procs = local_workers(workers, int(n_points))
    points = float(f_sum) * float(n) * float(t) * float(period_cpu_s)
    return {
        "cpu_s": points + procs * WORKER_START_CPU_S,
        "compile_cpu_s": procs * WORKER_COMPILE_CPU_S,
    }


def check_scan_size(
    f_lo: float,
    f_hi: float,
    n_points: int,
    *,
    n: int,
    t: float,
    transient: float | None = None,
    n_samples: int = N_SAMPLES,
) -> dict[str, float]:
    """Check the arguments of a scan of ``diffusion_point`` over ``n_points`` frequencies in
    ``[f_lo, f_hi]`` (Hz), estimate its CPU time and disk, and refuse it beyond the limits,
    before anything is allocated or written.

    CPU time follows the ensemble's conservative event model (``bbdyn.runs.check_size``;
    real runs are faster), disk ``point_bytes``.  Limits: ``MAX_POINTS`` frequencies, and
    every point within ``check_size``'s limits (checked at ``f_hi``, the costliest).
    Returns ``{"cpu_s", "bytes"}``; raises ValueError with the estimate and what to do.
    """
    for f in (f_lo, f_hi):
        n = _check_point_arguments(Params(f=f), n, t, transient, n_samples)
    t = float(t)
    cpu = cpu_estimate(n_points * 0.5 * (f_lo + f_hi), n, t)
    disk = n_points * point_bytes(n_samples)
    said = (
        f"{n_points:.3g} frequencies in [{f_lo:g}, {f_hi:g}] Hz with n={n} particles for "
        f"t={t:g} s take up to about {rough_duration(cpu, 3)} of CPU time "
        f"and {_bytes_text(disk)} of disk"
    )
    if n_points > MAX_POINTS:
        raise ValueError(
            f"scan too large: {said} (limit {MAX_POINTS} frequencies); choose a larger f_step "
            "or a narrower frequency range, or split the scan"
        )
    try:
        check_size(Params(f=f_hi), n, t, nbytes=8.0 * n * n_samples)
    except ValueError as err:
        raise ValueError(f"scan too large: {said}; one point: {err}") from None
    return {"cpu_s": cpu, "bytes": disk}


def _mean_err(values: np.ndarray) -> tuple[float, float]:
    n = values.size
    return float(values.mean()), float(values.std(ddof=1) / math.sqrt(n)) if n > 1 else math.nan


def _two_sided_p(mean: float, err: float) -> float:
    """p-value of ``mean = 0`` for a normal estimate with standard error ``err``."""
    if err == 0 or not math.isfinite(err):
        return 1.0 if mean == 0 else 0.0
    return math.erfc(abs(mean) / err / math.sqrt(2.0))


def diffusion_point(
    f: float,
    seed_sequence: np.random.SeedSequence,
    *,
    n: int = 1000,
    t: float = 200.0,
    transient: float | None = None,
    n_samples: int = N_SAMPLES,
    n_boot: int = 1000,
    A: float | None = None,
    alpha: float | None = None,
    beta: float | None = None,
    R: float | None = None,
    d: float | None = None,
    phi: float | None = None,
    eta: float | None = None,
) -> dict[str, float | np.ndarray]:
    """D and the steady-state energies of the reference ensemble at one frequency.

    Parameters
    ----------
    f : float
        Driving frequency (Hz).
    seed_sequence : numpy.random.SeedSequence
        The point's seed (``bbdyn.scans.runner.point_seed``): initial conditions and bootstrap.
    n : int
        Particles of the reference ensemble (docs/model.md §3), >= 2.
    t : float
        Simulated time (s).
    transient : float, optional
        Time (s) before the energy averages; default ``t / 5``.
    n_samples : int
        Equally spaced displacement samples in ``[0, t]`` (the MSD curve), >= 11.
    n_boot : int
        Bootstrap resamples of D.
    A, alpha, beta, R, d, phi, eta : float, optional
        Other parameters (default parameters (docs/model.md) if None); ``eta > 0``: random
        restitution, keyed by the point's seed.  With a tilt (``phi != 0``) every D and
        ``msd`` are about the drift (``bbdyn.diffusion.drift_removed``); the drift velocity
        ``v_d``, ``v_d_se`` (mm/s) is added.

    Returns
    -------
    dict
        Floats (flags as 0/1) and arrays, see the module docstring; energies in kg mm^2/s^2
        (E, E_x, E_y, E_pot, each with its standard error ``_se``; ``E_reference`` = A^2 w^2
        / 2), D in mm^2/s, ``msd`` (n_samples,) in mm^2, ``sample_times`` (s), ``gamma``,
        ``stuck_fraction``, ``collision_rate`` and ``jump_rate`` (per particle per s, in the
        averaging window), ``flight_periods`` (mean flight time in periods) and ``events``
        (all events of the run, for the cost profile).

    Examples
    --------
    >>> out = diffusion_point(49.0, np.random.SeedSequence(1), n=8, t=2.0)   # Gamma < 1
    >>> out["trapped"], out["D"], out["D_se"]
    (1, 0.0, 0.0)
    """
    given = (("A", A), ("alpha", alpha), ("beta", beta), ("R", R), ("d", d), ("phi", phi),
             ("eta", eta))
    changes = {k: v for k, v in given if v is not None}
    options = dict(n=n, t=t, transient=transient, n_samples=n_samples, n_boot=n_boot)
    return diffusion_points([f], [seed_sequence], **options, **changes)[0]


def diffusion_points(
    frequencies,
    seed_sequences,
    *,
    device: str = "cpu",
    n: int = 1000,
    t: float = 200.0,
    transient: float | None = None,
    n_samples: int = N_SAMPLES,
    n_boot: int = 1000,
    progress=None,
    **model,
) -> list[dict[str, float | np.ndarray]]:
    """``diffusion_point`` at each frequency with its seed sequence, the ensembles run
    together (``bbdyn.ensemble.ensembles``, ``progress`` its fraction done): on the GPU
    (``device="cuda"``) all of them in one or a few launches.  ``model``: ``A, alpha, beta,
    R, d, phi, eta`` (as ``diffusion_point``).  The batch form of ``diffusion_point`` for
    ``run_scan(..., device="cuda")``."""
    changes = {k: v for k, v in model.items() if v is not None}
    params = [Params(f=f, **changes) for f in frequencies]
    n = [_check_point_arguments(p, n, t, transient, n_samples) for p in params][0]
    seeds = [point_seeds(ss) for ss in seed_sequences]
    times = np.linspace(0.0, float(t), int(n_samples))
    results = ensembles(
        params, [ic for ic, _ in seeds], device=device, progress=progress, n=n, t=t,
        transient=transient, sample_times=times,
    )  # fmt: skip
    return [_point_outputs(res, p, boot, n_boot) for res, p, (_, boot) in
            zip(results, params, seeds, strict=True)]  # fmt: skip


def point_seeds(seed_sequence: np.random.SeedSequence) -> tuple[list[int], np.random.SeedSequence]:
    """The seeds of a scan point (``bbdyn.scans.runner.point_seed``): the ``seed`` its
    ensemble draws the initial conditions with (``ensemble()`` seeds
    ``np.random.SeedSequence(seed)``: the entropy words of the point's first child) and the
    bootstrap's seed sequence (the second child).  Spawns from ``seed_sequence``: call once."""
    ic, boot = seed_sequence.spawn(2)
    return ic.generate_state(4).tolist(), boot


diffusion_point.batch = diffusion_points


def _point_outputs(res, params: Params, boot_seed, n_boot: int) -> dict[str, float | np.ndarray]:
    """The outputs of ``diffusion_point`` from its ensemble ``res``."""
    f, t, n = params.f, res.meta["t"], res.meta["n"]
    times, disp = res["sample_times"], res["displacement"]
    out: dict[str, float | np.ndarray] = {"gamma": params.gamma}
    if params.phi != 0.0:
        out["v_d"], out["v_d_se"] = (float(v) for v in drift_velocity(times, disp, D_WINDOW))
        disp = drift_removed(disp)
    # stuck for good before the first D window: x is constant in every window, D = 0
    # exactly (a fit would return rounding noise, and a test of it noise about noise)
    stick_periods = res["final"][:, 0] + res["final"][:, 1] / (2 * math.pi)
    t_first = WINDOWS_START * float(t)
    stuck_early = (res["status"] == STUCK_FOREVER) & (stick_periods <= t_first * f)
    out["trapped"] = int(np.all(stuck_early))
    if out["trapped"]:
        zeros = np.zeros(N_WINDOWS)
        out.update(D=0.0, D_se=0.0, D_boot_se=0.0, D_boot_lo=0.0, D_boot_hi=0.0)
        out.update(D_windows=zeros, D_windows_se=zeros, D_windows_p=1.0, D_converged=1)
    else:
        out.update(diffusion_fit(times, disp, boot_seed, n_boot))
    out["msd"] = np.mean(disp**2, axis=0)
    out["sample_times"] = times

    for name in ("E", "E_x", "E_y", "E_pot", "stuck_fraction"):
        out[name], out[name + "_se"] = _mean_err(res[name])
    out["E_reference"] = 0.5 * (params.A * params.w) ** 2
    t_window = res.meta["window_s"]
    out["collision_rate"], out["collision_rate_se"] = _mean_err(res["collisions"] / t_window)
    out["jump_rate"], out["jump_rate_se"] = _mean_err(res["jumps"] / t_window)
    total = int(res["collisions"].sum())
    flying = (1 - out["stuck_fraction"]) * n * t_window * f  # particle-periods in flight
    out["flight_periods"] = float(flying / total) if total else 0.0
    out["events"] = int(res["events"].sum())

    out.update(_energy_drift(res, params))
    return out


def diffusion_fit(times, disp, boot_seed, n_boot: int = 1000) -> dict[str, float | np.ndarray]:
    """D of a scan point from displacements ``disp`` (n, m) in mm at ``times`` (m,) in s.

    ``D, D_se``: Einstein slope over the late window ``D_WINDOW`` = [t/2, t] (mm^2/s);
    ``D_boot_se, D_boot_lo, D_boot_hi``: its bootstrap (``n_boot`` resamples, seed
    ``boot_seed``); ``D_windows, D_windows_se, D_windows_p, D_converged``: the window
    consistency check (module docstring).
    """
    out: dict[str, float | np.ndarray] = {}
    out["D"], out["D_se"] = (float(v) for v in einstein_D(times, disp, D_WINDOW))
    se, lo, hi = einstein_D_bootstrap(times, disp, D_WINDOW, n_boot, boot_seed)
    out.update(D_boot_se=se, D_boot_lo=lo, D_boot_hi=hi)
    _, d_w, se_w = einstein_D_windows(times, disp, N_WINDOWS, WINDOWS_START)
    _, _, p = window_consistency(times, disp, N_WINDOWS, WINDOWS_START)
    out.update(D_windows=d_w, D_windows_se=se_w, D_windows_p=p)
    out["D_converged"] = int(p >= P_FLAG)
    return out


def _energy_drift(res, params: Params) -> dict[str, float]:
    """Late minus early half of the energy window over the particles that succeeded.

    ``res`` is the ensemble of the point (``E_halves``, ``E_x_halves``).  A drift within
    the rounding of the energy integrals (``_drift_rounding``) is no drift: it is not
    flagged, however small its standard error.  NaN drifts (and ``energy_stationary = 1``)
    if the window has no halves or fewer than two particles succeeded.
    """
    ok = res.ok
    p0, split, p1 = res.meta["halves_periods"]
    if np.count_nonzero(ok) < 2 or split <= p0:
        out = {name: math.nan for name in ("E_drift", "E_drift_se", "E_x_drift")}
        return {**out, "E_x_drift_se": math.nan, "energy_stationary": 1}
    out: dict[str, float] = {}
    stationary = True
    for name, scale in (("E", energy_scale(res["E"], params.g, params.A)), ("E_x", res["E_x"])):
        halves = res[name + "_halves"][ok]
        drift, err = _mean_err(halves[:, 1] - halves[:, 0])
        out[name + "_drift"], out[name + "_drift_se"] = drift, err
        rounding = _drift_rounding(res["events"][ok], scale[ok], (p0, split, p1))
        stationary &= abs(drift) <= rounding or _two_sided_p(drift, err) >= P_FLAG
    out["energy_stationary"] = int(stationary)
    return out


def energy_scale(E, g: float, A: float):
    """``E + 2 g A`` (kg mm^2/s^2): the time average of the absolute value of the energy's
    integrand, whose only negative part, the potential g y, is at least -g A (y >= -A)."""
    return E + 2.0 * g * A


def average_rounding(events, scale):
    """Bound on the rounding of a time average over the energy window (units of ``scale``).

    A particle's integral over the window is a sum of at most ``events + 1`` closed-form
    integrals over intervals (fast-forwarded cycles counted as their events), each exact
    to ``OBS_INTEGRAL_REL_TOL`` and added with ``SUM_ROUND_PER_TERM``
    (``bbdyn.core.tolerances``) relative to the time average of the integrand's absolute
    value, ``scale`` (``energy_scale`` for E, E_x itself); per particle, or per scan point
    with ``events`` per particle.
    """
    per_term = OBS_INTEGRAL_REL_TOL + SUM_ROUND_PER_TERM
    return (events + 1.0) * per_term * np.abs(scale)


def _drift_rounding(events: np.ndarray, scale: np.ndarray, cuts) -> float:
    """Bound on the rounding of a mean late-minus-early drift (units of ``scale``).

    The early average carries one ``average_rounding``, the late one (whole minus early)
    those of the whole window and the early half, over the late half's length;
    ``cuts = (p0, split, p1)`` periods.
    """
    p0, split, p1 = cuts
    gain = 1.0 + ((p1 - p0) + (split - p0)) / (p1 - split)
    return float(np.mean(average_rounding(events, scale)) * gain)


def _model_changes(model: dict) -> dict[str, float]:
    """The entries of ``model`` that differ from the ``Params`` defaults (ValueError for a
    name ``diffusion_point`` does not take)."""
    defaults = Params(f=1.0).to_dict()
    unknown = sorted(set(model) - {"A", "alpha", "beta", "R", "d", "phi", "eta"})
    if unknown:
        raise ValueError(f"model takes A, alpha, beta, R, d, phi, eta; got {', '.join(unknown)}")
    return {k: float(v) for k, v in model.items() if float(v) != defaults[k]}


def frequency_scan(
    frequencies,
    *,
    out_dir,
    seed: int = 0,
    n: int = 1000,
    t: float = 200.0,
    transient: float | None = None,
    resume: bool = True,
    workers: int | None = None,
    scheduler=None,
    progress=True,
    model: dict | None = None,
    device: str = "cpu",
):
    """Run ``diffusion_point`` over ``frequencies`` with ``bbdyn.scans.runner.run_scan``.

    ``device="cuda"``: on this machine's GPU, all frequencies together (``run_scan``).

    ``model`` sets parameters other than f (``A``, ``alpha``, ``beta``, ``R``, ``d``, ``phi``,
    ``eta``); only those that differ from the ``Params`` defaults become arguments of the
    scan, so a scan at the defaults is the same scan with or without them.

    The arguments are checked at every frequency, and the scan's size (``check_scan_size``),
    before anything is written.  Every finished frequency is stored in ``out_dir`` at once;
    run again with the same arguments to resume.  Returns the ``ScanResult`` (docs/scans.md).
    """
    freqs = [float(f) for f in frequencies]
    changes = _model_changes(model or {})
    if freqs:  # run_scan names an empty or non-finite list
        check_scan_size(min(freqs), max(freqs), len(freqs), n=n, t=t, transient=transient)
        for f in freqs:
            _check_point_arguments(Params(f=f, **changes), n, t, transient, N_SAMPLES)
    kwargs = {"n": int(n), "t": float(t), **changes}
    if transient is not None:
        kwargs["transient"] = float(transient)
    compute = functools.partial(diffusion_point, **kwargs)
    return run_scan(
        freqs,
        compute,
        out_dir=out_dir,
        seed=seed,
        resume=resume,
        workers=workers,
        scheduler=scheduler,
        progress=progress,
        device=device,
    )
