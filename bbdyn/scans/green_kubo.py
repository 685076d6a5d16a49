"""Random-walk and Green-Kubo approximations at one frequency and as scan points (docs/model.md §4).

``gk_run`` simulates the reference ensemble (docs/model.md §3) recording the
jumps between traps, and evaluates at the same parameters

* the Einstein D with its standard error (``EnsembleResult.D``, late-window MSD slope);
* the escape time tau, ``D_rw = d^2 / (2 tau)`` and the truncated Green-Kubo ``D_n``
  with bootstrap errors (``bbdyn.approx.green_kubo``);
* the measured energy ratio ``r = E_y / E_x`` (period-averaged steady-state kinetic
  energies, ``bbdyn.approx.energy_ratio``) and the analytic ``D_a`` with it
  (``bbdyn.approx.analytic_diffusion``; NaN with a reason where Gamma < 2).

``gk_numbers`` flattens that into plain numbers; ``gk_point`` is the compute
function of ``bbdyn.scans.runner.run_scan`` and ``gk_scan`` runs it over frequencies
(scenes S9, S10), resumable like ``bbdyn.scans.frequency.frequency_scan``.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from bbdyn.approx import analytic_diffusion, energy_ratio, green_kubo
from bbdyn.approx.random_walk import AnalyticDiffusion
from bbdyn.ensemble import ensemble
from bbdyn.params import Params
from bbdyn.results import make_meta
from bbdyn.runs import check_n, check_run
from bbdyn.scans.runner import run_scan
from bbdyn.schema import standard_key

__all__ = ["gk_run", "gk_numbers", "gk_point", "gk_scan"]

#: First guess of the stored jumps per particle per simulated second.  Measured jump rates
#: at the defaults stay below 7 /s (65-95 Hz); a run that overflows is repeated with
#: the exact capacity (same seed, same numbers), so this only sets the memory/cost balance.
JUMPS_PER_S_GUESS = 8.0


#: ``D_a_reason`` of ``gk_run`` when no particle moves after the transient.
NO_MOTION = "no kinetic energy after the transient (E_x = E_y = 0): r = E_y / E_x is 0 / 0"


def gk_run(
    params: Params,
    *,
    n: int = 1000,
    t: float = 200.0,
    nmax: int = 10,
    seed=0,
    boot_seed: int = 0,
    n_boot: int = 1000,
    transient: float | None = None,
    threads: int | None = None,
    progress=None,
):
    """Simulate the reference ensemble and evaluate every approximation of docs/model.md §4.

    Parameters
    ----------
    params : Params
    n : int
        Particles of the reference ensemble.
    t : float
        Simulated time per particle (s); jumps, energies and tau use the window after
        ``transient`` (default ``t / 5``).
    nmax : int
        Highest Green-Kubo order (>= 1).
    seed : int or sequence of int
        Seed of the initial conditions (``np.random.SeedSequence(seed)``).
    boot_seed : int
        Seed of the bootstrap over particles (errors of ``D_n``, ``p_w``).
    n_boot : int
        Bootstrap resamples.
    threads : int, optional
        numba threads of the ensemble run (results do not depend on it).
    progress : callable, optional
        Told the fraction of the simulated time done (``bbdyn.ensemble.ensemble``).

    Returns
    -------
    GreenKuboResult
        ``D_n`` etc. as in ``bbdyn.approx.green_kubo``; its ``meta`` adds ``D``, ``D_err``
        (Einstein, mm^2/s), ``r``, ``r_err``, ``D_a``, ``D_a_err`` (mm^2/s), ``D_a_reason``
        (empty if defined), ``E``, ``E_x``, ``E_y`` (kg mm^2/s^2), ``jumps_per_s``,
        ``sim_wall_s`` and the simulation's parameters and seed.  The Einstein band of
        the plot is set only when ``D >= 0`` (a slope estimate can be negative when
        nothing diffuses; ``D`` keeps it).

    Examples
    --------
    >>> gk = gk_run(Params(f=85.2), n=50, t=20.0, nmax=4)   # doctest: +SKIP
    >>> gk.D_n, gk.meta["D"], gk.meta["r"]                  # doctest: +SKIP
    """
    if not isinstance(params, Params):
        raise ValueError(f"params must be a bbdyn.Params, got {type(params).__name__}")
    t = float(t)
    if not (math.isfinite(t) and t > 0):
        raise ValueError(f"t must be a finite time > 0 s, got {t}")
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 2:
        raise ValueError(f"n must be an integer >= 2 (errors need two particles), got {n!r}")

    def run(capacity: int):
        return ensemble(
            params,
            n=int(n),
            t=t,
            seed=seed,
            transient=transient,
            threads=threads,
            observables=("displacement", "energy", "jumps"),
            jump_capacity=capacity,
            progress=progress,
        )

    res = run(int(math.ceil(JUMPS_PER_S_GUESS * t)) + 16)
    if res["jumps"].max() > res["jump_len"].shape[1]:
        res = run(int(res["jumps"].max()))
    D, D_err = res.D()
    summary = res.summary()
    ratio = energy_ratio(res["E_x"], res["E_y"])
    if math.isnan(ratio.r):  # E_x = E_y = 0: nothing moves (e.g. A = 0), r is 0 / 0
        analytic = AnalyticDiffusion(math.nan, math.nan, math.nan, NO_MOTION)
    else:
        analytic = analytic_diffusion(params, ratio.r, ratio.r_err)
    meta = make_meta(
        params,
        seed=seed,
        n=int(n),
        t=t,
        transient=res.meta["transient"],
        D=float(D),
        D_err=float(D_err),
        r=ratio.r,
        r_err=ratio.r_err,
        D_a=analytic.D_a,
        D_a_err=analytic.D_a_err,
        D_a_reason=analytic.reason,
        E=summary["E"],
        E_x=summary["E_x"],
        E_y=summary["E_y"],
        jumps_per_s=summary["jumps_per_particle_per_s"],
        sim_wall_s=res.meta["wall_s"],
        threads=res.meta["threads"],
    )
    return green_kubo(
        res.jump_data(),
        nmax,
        n_boot=n_boot,
        seed=boot_seed,
        D_einstein=D,
        D_einstein_err=D_err,
        meta=meta,
    )


def gk_numbers(gk) -> dict:
    """The numbers of ``gk_run`` as floats and float arrays (units as in ``gk_run``).

    Keys of the result schema (``bbdyn.schema``, docs/schema.md): ``tau``, ``tau_se`` (s);
    ``D_rw``, ``D_rw_se``, ``D_a``, ``D_a_se``, ``D``, ``D_se`` (mm^2/s); ``r``, ``r_se``;
    ``p_f``, ``p_f_se``, ``p_b``, ``p_b_se``; ``fraction_long`` (jumps longer than d);
    ``jump_rate`` (1/s); ``E``, ``E_x``, ``E_y``; ``D_n``, ``D_n_se`` (arrays, n =
    0..nmax).  Undefined values are NaN (``tau`` is inf when nothing jumped).
    """
    m = gk.meta
    out = {k: float(m[k]) for k in ("tau", "tau_err", "D_rw", "D_rw_err")}
    for k in ("D_a", "D_a_err", "r", "r_err", "D", "D_err", "E", "E_x", "E_y", "jumps_per_s"):
        out[k] = float(m[k])
    for word in ("f", "b"):
        out[f"p_{word}"], out[f"p_{word}_err"] = gk.p(word)
    out["fraction_long"] = float(m["fraction_long"])
    out["D_n"] = np.asarray(gk.D_n, dtype=float)
    out["D_n_err"] = np.asarray(gk.D_n_err, dtype=float)
    return {standard_key(k): v for k, v in out.items()}  # the object's names -> the schema's


def gk_point(
    f: float,
    seed_sequence: np.random.SeedSequence,
    *,
    n: int = 1000,
    t: float = 200.0,
    nmax: int = 10,
    n_boot: int = 1000,
    transient: float | None = None,
) -> dict:
    """Compute function of a scan (``bbdyn.scans.runner.run_scan``):
    ``gk_numbers(gk_run(Params(f=f), ...))``.

    The ensemble and the bootstrap draw independent streams spawned from
    ``seed_sequence`` (so a point depends only on the scan seed and f).
    """
    ens_seq, boot_seq = seed_sequence.spawn(2)
    # green_kubo takes an int seed: 63 bits of the bootstrap stream
    boot_seed = int(boot_seq.generate_state(1, np.uint64)[0] >> np.uint64(1))
    gk = gk_run(
        Params(f=f),
        n=n,
        t=t,
        nmax=nmax,
        seed=ens_seq.generate_state(4).tolist(),
        boot_seed=boot_seed,
        n_boot=n_boot,
        transient=transient,
    )
    return gk_numbers(gk)


def gk_scan(
    frequencies,
    *,
    out_dir,
    seed: int = 0,
    n: int = 1000,
    t: float = 200.0,
    nmax: int = 10,
    n_boot: int = 1000,
    resume: bool = True,
    workers: int | None = None,
    progress=True,
):
    """Run ``gk_point`` over ``frequencies`` (Hz) with ``bbdyn.scans.runner.run_scan``.

    Every finished frequency is stored in ``out_dir`` at once; the same call resumes an
    interrupted scan (docs/scans.md); n and t are checked at every frequency before
    anything is written.  Returns the ``ScanResult``: ``f`` and every output
    of ``gk_numbers`` stacked over frequencies (``D_n`` has shape (n_f, nmax + 1)).
    """
    freqs = [float(f) for f in frequencies]
    for f in freqs:  # before anything is written: a refused scan leaves no folder
        check_run(Params(f=f), t, float(t) / 5)
    kwargs = {"n": check_n(n), "t": float(t), "nmax": int(nmax), "n_boot": int(n_boot)}
    return run_scan(
        freqs,
        functools.partial(gk_point, **kwargs),
        out_dir=out_dir,
        seed=seed,
        resume=resume,
        workers=workers,
        progress=progress,
    )
