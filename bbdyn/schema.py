"""The result schema: one key, one unit and one meaning for each quantity bbdyn reports.

Every command's ``--json`` output, every scan of bbdyn's compute functions loaded with
``bbdyn.scans.runner.load_scan`` and its exports (``ScanResult.to_xarray``,
``to_netcdf``, ``to_dataframe``) use the keys of ``QUANTITIES``; docs/schema.md is
generated from it (``markdown_table``).

* A standard error (over particles, or from a bootstrap) is the key of its quantity with
  ``SE`` appended (``D_se``), in the quantity's unit.
* Older names are read as their schema names (``standard_key``): ``X_err`` is ``X_se``,
  and the keys of ``ALIASES`` (``collisions_per_particle_per_s`` is ``collision_rate``).
* A JSON output is one object (``document``) with ``version``, ``params``, ``seed`` (runs
  that draw random numbers), ``cpu_s`` (CPU time of the processes that did the work),
  ``wall_s`` (wall-clock time) and ``units`` (the unit of each key in it that has one).
* Keys in ``MAPS`` hold mappings whose keys are names, not quantities (status names,
  thresholds, benchmark rows).

Examples
--------
>>> standard_key("D_err"), standard_key("collisions_per_particle_per_s")
('D_se', 'collision_rate')
>>> unit("E_x_se")
'kg mm^2/s^2'
"""

from __future__ import annotations

import math
from typing import Any

from bbdyn import __version__

__all__ = [
    "ALIASES",
    "DIMENSIONS",
    "MAPS",
    "QUANTITIES",
    "SE",
    "check",
    "describe",
    "document",
    "is_quantity",
    "markdown_table",
    "standard_key",
    "standardise",
    "unit",
    "units_of",
]

#: Suffix of a standard error: ``D_se`` is the standard error of ``D``, in D's unit.
SE = "_se"
#: Suffix of standard errors in results saved by earlier versions (read as ``SE``).
LEGACY_SE = "_err"

E_UNIT = "kg mm^2/s^2"  # energy per unit mass, as every energy of docs/model.md

#: key -> (unit, meaning).  Unit "" for dimensionless numbers, counts, flags and text.
QUANTITIES: dict[str, tuple[str, str]] = {
    # ---- every output
    "version": ("", "bbdyn version that computed the numbers"),
    "params": ("", "model parameters of the run (the keys below: f, A, g, alpha, beta, R, d, "
               "phi, eta)"),
    "seed": ("", "seed of numpy's SeedSequence that drew the initial conditions (and keyed the "
             "random restitution, eta > 0)"),
    "cpu_s": ("s", "CPU time of the processes that did the work (kernel compilation on first "
              "use included)"),
    "wall_s": ("s", "wall-clock time of the run"),
    "units": ("", "the unit of each key of the output that has one"),
    # ---- model parameters (docs/model.md)
    "f": ("Hz", "driving frequency"),
    "A": ("mm", "floor amplitude"),
    "g": ("mm/s^2", "gravity"),
    "alpha": ("", "normal restitution"),
    "beta": ("", "tangential restitution"),
    "R": ("mm", "scatterer radius"),
    "d": ("mm", "scatterer width"),
    "phi": ("degrees", "tilt of the floor, +x downhill for phi > 0 (docs/model.md, Tilt)"),
    "eta": ("", "noise amplitude of the restitution coefficients drawn per collision"),
    "gamma": ("", "Gamma = A w^2 / g, the dimensionless driving"),
    # ---- run settings
    "n": ("", "number of particles (per box for classify)"),
    "t": ("s", "simulated time"),
    "transient": ("s", "time before the averages begin"),
    "threads": ("", "numba threads of the run"),
    "fast_forward": ("", "fast-forward mode of repeating stick-release cycles"),
    "device": ("", "where the particles ran: 'cpu' or 'cuda' (docs/gpu.md)"),
    "device_name": ("", "the model of the CPU or GPU they ran on"),
    "nmax": ("", "highest order n of the truncated Green-Kubo sum D_n"),
    "model": ("", "'billiard' or 'flat' (the flat ball)"),
    "per": ("", "'attractor' or 'ensemble': how the Lyapunov exponents are grouped"),
    "out": ("", "folder of the scan"),
    "boxes": ("", "boxes of initial conditions: ranges s (mm), vx, vy (mm/s)"),
    "s": ("mm", "arc length along the scatterer (box of initial conditions)"),
    "vx": ("mm/s", "horizontal velocity after an impact (box of initial conditions)"),
    "vy": ("mm/s", "vertical velocity relative to the floor after an impact (box)"),
    "target": ("", "benchmark target"),
    "setting": ("", "'quick' or 'full' setting of a benchmark"),
    # ---- outcome of the particles
    "n_ok": ("", "particles that reached the end of the run"),
    "n_failed": ("", "particles whose kernel failed (left out of every estimate)"),
    "failures": ("", "failed particles by status name"),
    "failed_fraction": ("", "fraction of the particles whose kernel failed"),
    "collisions": ("", "collisions of all particles in the averaging window"),
    "events": ("", "events of all particles in the whole run (the cost)"),
    "note": ("", "a remark on the numbers (e.g. exponents -inf)"),
    # ---- diffusion
    "D": ("mm^2/s", "Einstein diffusion coefficient, late-window MSD slope / 2"),
    "D_windows": ("", "D in successive time windows: t_centre, D, D_se"),
    "v_d": ("mm/s", "drift velocity, late-window slope of the mean displacement"),
    "t_centre": ("s", "centre of a time window"),
    "D_converged": ("", "1 if D agrees in every window (p >= 0.01), else 0"),
    "D_windows_p": ("", "p-value of 'D is the same in every window'"),
    "D_boot": ("mm^2/s", "bootstrap of D over particles (its standard error D_boot_se)"),
    "D_boot_lo": ("mm^2/s", "2.5 % point of the bootstrap of D"),
    "D_boot_hi": ("mm^2/s", "97.5 % point of the bootstrap of D"),
    "msd": ("mm^2", "mean squared displacement at the sample times"),
    "sample_times": ("s", "times of the displacement samples"),
    "flight_periods": ("", "mean flight time in driving periods"),
    "trapped": ("", "regime (a): no particle left its trap (1 or true; else 0 or false)"),
    "trapped_reason": ("", "why the run counts as trapped (empty when it does not)"),
    "D_rw": ("mm^2/s", "random-walk approximation d^2 / (2 tau)"),
    "D_a": ("mm^2/s", "analytic approximation with the measured r"),
    "D_a_reason": ("", "why D_a is undefined (empty when it is defined)"),
    "D_n": ("mm^2/s", "truncated Green-Kubo sum of order n = 0..nmax"),
    "tau": ("s", "escape time from a trap"),
    "r": ("", "energy ratio E_y / E_x"),
    "p_f": ("", "probability of a forward jump"),
    "p_b": ("", "probability of a backward jump"),
    "fraction_long": ("", "fraction of the jumps longer than d"),
    "n_jumps": ("", "jumps of all particles in the averaging window"),
    # ---- correlations and distributions (docs/distributions.md)
    "cutoff": ("s", "upper limit T of the Green-Kubo integral of C(tau)"),
    "D_GK": ("mm^2/s", "Green-Kubo integral of the velocity autocorrelation up to the cutoff"),
    "D_GK_mean": ("mm^2/s", "Green-Kubo integral averaged over the cutoffs in [T/2, T]"),
    "z": ("", "(D_GK - D) / sqrt(D_GK_se^2 + D_se^2), independent ensembles"),
    "z_mean": ("", "z of D_GK_mean"),
    "C0_binned": ("mm^2/s^2", "velocity autocorrelation of the bin-averaged vx at lag 0"),
    "kurtosis_max": ("", "largest excess kurtosis of x(s + tau) - x(s) over the lags"),
    "kurtosis_max_lag": ("s", "lag tau of kurtosis_max"),
    "flights": ("", "flights between recorded collisions"),
    "jump_counts": ("", "flights by the number of tiles crossed: 0, 1, 2, ..."),
    # ---- energies (docs/model.md, section 3), period-averaged
    "E": (E_UNIT, "total energy per unit mass"),
    "E_x": (E_UNIT, "horizontal kinetic energy"),
    "E_y": (E_UNIT, "vertical kinetic energy"),
    "E_kin": (E_UNIT, "kinetic energy E_x + E_y"),
    "E_pot": (E_UNIT, "potential energy g y"),
    "E_reference": (E_UNIT, "A^2 w^2 / 2, the floor's kinetic energy scale"),
    "energy_stationary": ("", "1 if the energies do not drift between the window's halves"),
    "E_drift": (E_UNIT, "late minus early half of the averaging window, E"),
    "E_x_drift": (E_UNIT, "late minus early half of the averaging window, E_x"),
    # ---- rates, per particle
    "collision_rate": ("1/s", "collisions per particle per second"),
    "jump_rate": ("1/s", "jumps to a neighbouring trap per particle per second"),
    "impact_rate": ("1/s", "impacts per particle per second (flat ball)"),
    "stuck_fraction": ("", "fraction of the time (or of the particles) stuck on the floor"),
    # ---- classification (docs/classification.md)
    "regime": ("", "regime of docs/model.md, section 5"),
    "regime_meaning": ("", "what the regime means"),
    "reason": ("", "why: the evidence of the verdict"),
    "ergodic": ("", "true if one attractor holds every settled particle"),
    "ergodicity": ("", "the ergodicity test: n_attractors, reduced_chi2, ..."),
    "n_attractors": ("", "number of attractors found"),
    "reduced_chi2": ("", "reduced chi^2 of each feature between the groups"),
    "max_reduced_chi2": ("", "largest reduced chi^2 of an ergodic ensemble"),
    "unsettled_fraction": ("", "fraction of the particles in no attractor"),
    "attractors": ("", "one object per attractor, with the keys of the whole ensemble"),
    "attractor": ("", "label of the attractor"),
    "fraction": ("", "fraction of the particles in the attractor (basin fraction)"),
    "members": ("", "particles in the attractor"),
    "character": ("", "kind of motion of the attractor (locked, creeping, ...)"),
    "tiny_fraction": ("", "fraction of the collisions after tiny hops"),
    "locked_fraction": ("", "fraction of the flights locked to k periods"),
    "coherence": ("", "impact-phase coherence, the modulus of the mean of exp(i phase)"),
    "flight_mean": ("", "mean flight time in driving periods"),
    "creep_run_mean": ("", "mean run of tiny hops (collisions)"),
    "creep_run_max": ("", "longest run of tiny hops (collisions)"),
    "period": ("", "period of the attractor in driving periods (null if none)"),
    "locking_k": ("", "locking number k of a locked attractor (null if not locked)"),
    "dominant_k": ("", "most frequent locking number of the flights"),
    "representative": ("", "one member: its index and initial condition (s, vx, vy)"),
    "index": ("", "index of a particle"),
    "initial": ("", "initial condition (s mm, vx mm/s, vy mm/s)"),
    "thresholds": ("", "the classifier's thresholds (bbdyn.classify.Thresholds)"),
    "feature_wall_s": ("s", "wall-clock time of the feature run"),
    # ---- Lyapunov exponents (docs/lyapunov.md)
    "lam1_per_s": ("1/s", "largest Lyapunov exponent per second"),
    "lam2_per_s": ("1/s", "second Lyapunov exponent per second (flat ball)"),
    "cond_lam1_per_s": ("1/s", "largest exponent from the growth between sticks or collapses"),
    "cond_lam2_per_s": ("1/s", "second conditional exponent (flat ball)"),
    "lam1_per_collision": ("", "largest exponent per collision"),
    "cond_lam1_per_collision": ("", "conditional largest exponent per collision"),
    "lam1_per_impact": ("", "largest exponent per impact (flat ball)"),
    "lam2_per_impact": ("", "second exponent per impact (flat ball)"),
    "cond_lam1_per_impact": ("", "conditional largest exponent per impact (flat ball)"),
    "cond_lam2_per_impact": ("", "conditional second exponent per impact (flat ball)"),
    "collapse_fraction": ("", "fraction of the particles whose tangent vector collapsed"),
    "window_cond_lam1_per_s": ("1/s", "conditional largest exponent of each time window"),
    "window_chi2": ("", "chi^2 of the windows' mean exponents about their weighted mean"),
    "window_dof": ("", "degrees of freedom of window_chi2 (windows - 1)"),
    "window_p": ("", "p-value of window_chi2 (null if untested)"),
    "windows_agree": ("", "whether window_p >= bbdyn.lyapunov.WINDOW_P_MIN: no drift detected"),
    "spectrum_per_s": ("1/s", "all Lyapunov exponents of the billiard's section map, largest "
                       "first (-inf: a direction collapsed by a stick)"),
    "spectrum_per_collision": ("", "the billiard's Lyapunov exponents per collision"),
    "free_spectrum_per_s": ("1/s", "the billiard's exponents from the growth between sticks, "
                            "per second of the impact-to-impact events"),
    "free_spectrum_per_event": ("", "the billiard's exponents between sticks, per "
                                "impact-to-impact event"),
    "spectrum_sum_per_event": ("", "sum of the billiard's exponents between sticks per "
                               "impact-to-impact event (QR)"),
    "log_det_per_event": ("", "mean closed-form log of the absolute determinant of the "
                          "one-event Jacobian over the same events"),
    "spectrum_sum_deviation": ("", "largest difference of the QR sum and the closed form per "
                               "event over the particles"),
    "stick_event_fraction": ("", "sticks per collision"),
    "carried_fraction": ("", "impact-to-impact events (carried by all tangent vectors) per "
                         "collision"),
    "inf_exponents": ("", "most exponents -inf of a particle (3 after a stick, 4 after a "
                      "collapse)"),
    "qr_every": ("", "impact-to-impact events between two QR steps of the tangent frame"),
    # ---- flat ball: tongues and period doublings
    "tongues": ("", "one object per k: the k/1 tongue's edges"),
    "doublings": ("", "one object per k: the period-doubling cascade"),
    "k": ("", "k of the k/1 orbit"),
    "kmax": ("", "largest k computed"),
    "levels": ("", "period doublings computed per cascade"),
    "gamma_lo": ("", "lower Gamma edge of the tongue, closed form"),
    "gamma_hi": ("", "upper Gamma edge of the tongue, closed form"),
    "gamma_lo_numeric": ("", "lower edge from the exact map's multipliers (null if not run)"),
    "gamma_hi_numeric": ("", "upper edge from the exact map's multipliers (null if not run)"),
    "f_lo": ("Hz", "lower frequency edge of the tongue"),
    "f_hi": ("Hz", "upper frequency edge of the tongue"),
    "status": ("", "how the cascade ended"),
    "gamma_doublings": ("", "Gamma of each period doubling"),
    "feigenbaum_ratios": ("", "ratios of successive doubling intervals"),
    # ---- scans
    "points": ("", "one object per frequency of the scan"),
    "rows": ("", "benchmark table, one object per method and setting (docs/benchmarks.md)"),
}  # fmt: skip

#: Keys of earlier outputs and of the Python objects -> their schema key.
ALIASES = {
    "collisions_per_particle_per_s": "collision_rate",
    "collisions_per_s": "collision_rate",
    "jumps_per_particle_per_s": "jump_rate",
    "jumps_per_s": "jump_rate",
    "impacts_per_s": "impact_rate",
    "f_lo_hz": "f_lo",
    "f_hi_hz": "f_hi",
}

#: Trailing dimensions of the array outputs of a scan point (``ScanResult.to_xarray``).
DIMENSIONS = {
    "msd": ("sample",), "sample_times": ("sample",),
    "D_windows": ("window",), "D_windows_se": ("window",),
    "D_n": ("order",), "D_n_se": ("order",),
}  # fmt: skip

#: Keys whose value maps names (not schema quantities) to values.
MAPS = frozenset({"failures", "reduced_chi2", "thresholds", "units", "rows"})


def standard_key(key: str) -> str:
    """The schema key of ``key``: ``ALIASES``, and ``X_err`` read as ``X_se``."""
    if key in ALIASES:
        return ALIASES[key]
    if key.endswith(LEGACY_SE):
        return standard_key(key[: -len(LEGACY_SE)]) + SE
    return key


def standardise(value: Any) -> Any:
    """``value`` with every dict key renamed by ``standard_key`` (through dicts and lists;
    the names inside ``MAPS`` are kept)."""
    if isinstance(value, dict):
        return {standard_key(k): v if k in MAPS else standardise(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [standardise(v) for v in value]
    return value


def is_quantity(key: str) -> bool:
    """Whether ``key`` is in the schema: a key of ``QUANTITIES`` or its standard error."""
    return key in QUANTITIES or (key.endswith(SE) and key[: -len(SE)] in QUANTITIES)


def _base(key: str) -> str:
    """The quantity whose standard error ``key`` is, or ``key`` itself."""
    return key[: -len(SE)] if key.endswith(SE) and key not in QUANTITIES else key


def unit(key: str) -> str:
    """The unit of ``key`` ("" if dimensionless); KeyError for a key outside the schema."""
    return QUANTITIES[_base(key)][0]


def describe(key: str) -> str:
    """The meaning of ``key``; KeyError for a key outside the schema."""
    base = _base(key)
    meaning = QUANTITIES[base][1]
    return meaning if base == key else f"standard error of {base} ({meaning})"


def _keys(value: Any) -> set[str]:
    """Every dict key in ``value``, through dicts and lists (not inside ``MAPS``)."""
    if isinstance(value, dict):
        found = set(value)
        for k, v in value.items():
            if k not in MAPS:
                found |= _keys(v)
        return found
    if isinstance(value, list | tuple):
        return set().union(*(_keys(v) for v in value)) if value else set()
    return set()


def units_of(out: dict) -> dict[str, str]:
    """The ``units`` entry of an output: the unit of each schema key in ``out`` (at any
    depth) that has one, in the order of ``QUANTITIES``."""
    keys = {k for k in _keys(out) if is_quantity(k)}
    keys |= {k[: -len(SE)] for k in keys if k.endswith(SE)}
    return {k: u for k, (u, _) in QUANTITIES.items() if k in keys and u}


def document(
    body: dict, *, params: dict, cpu_s: float, wall_s: float, seed: int | None = None
) -> dict:
    """One JSON output: ``version``, ``params``, ``seed`` (if given), the ``body`` with its
    keys standardised, ``cpu_s``, ``wall_s`` and ``units``."""
    out: dict[str, Any] = {"version": __version__, "params": dict(params)}
    if seed is not None:
        out["seed"] = seed
    out.update(standardise(body))
    out["cpu_s"], out["wall_s"] = float(cpu_s), float(wall_s)
    out["units"] = units_of(out)
    return out


def markdown_table() -> str:
    """The vocabulary as a Markdown table (key, unit, meaning) for docs/schema.md."""
    lines = ["| key | unit | meaning |", "| --- | --- | --- |"]
    for key, (u, meaning) in QUANTITIES.items():
        lines.append(f"| `{key}` | {u or '-'} | {meaning} |")
    return "\n".join(lines)


def check(out: Any, *, random: bool) -> list[str]:
    """What in the JSON output ``out`` does not follow the schema (an empty list if all
    does): a top-level object with the common keys, every key a schema quantity, no
    ``_err`` key, ``units`` as ``units_of`` gives, finite numbers or null."""
    if not isinstance(out, dict):
        return [f"the output must be one JSON object, got {type(out).__name__}"]
    problems = []
    required = ["version", "params", "cpu_s", "wall_s", "units"] + (["seed"] if random else [])
    problems += [f"no {k!r}" for k in required if k not in out]
    problems += [f"{k!r} is not in the schema" for k in sorted(_keys(out)) if not is_quantity(k)]
    if "units" in out and out["units"] != units_of(out):
        problems.append(f"units {out['units']} differ from the schema's {units_of(out)}")
    for k in ("cpu_s", "wall_s"):
        if not (isinstance(out.get(k), float) and math.isfinite(out[k]) and out[k] >= 0):
            problems.append(f"{k} must be a number >= 0 s, got {out.get(k)!r}")
    return problems


if __name__ == "__main__":  # the table of docs/schema.md
    print(markdown_table())
