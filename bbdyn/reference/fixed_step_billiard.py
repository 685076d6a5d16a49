"""A fixed-step event finder for the billiard, like the reference paper's (B2, billiard part).

As for the flat ball (``fixed_step.py``) the flight itself is exact: the gap to
the arc under the particle is evaluated in closed form (``segment_gap`` of the
exact kernel, the tile found from the position).  Only the event location is
approximated: the gap is sampled at ``tau_k = k dt`` after each collision; at the
first sample with ``G <= 0`` the last step is halved (keeping the half whose
right end has ``G <= 0``) until it is at most ``dt_min``, and the collision is
put at the right end of the final bracket, late by less than ``dt_min``.  There
the particle is put back on the floor (same ``x``) and the restitution law of
docs/model.md §2 is applied with the exact normal at that point and the wedge
rule of the exact kernel (``snap_to_wedge``, ``wedge_reflect``).

What it cannot do (as for the flat ball): it misses a contact whose dip below
the floor lasts less than ``dt`` (here also a bump clipped between two samples),
and it has no chattering or sticking: a flight lasts at least one final bracket,
so an accumulating sequence becomes micro-bounces of a few ``dt_min`` until the
floor pulls away faster than g.  A normal velocity that is not approaching at
the late contact point (a graze found late) is set to zero before the bounce.

``fixed_step_ensemble`` runs an ensemble with this method and returns D and the
period-averaged energies with the same estimators as ``bbdyn.ensemble``, so that
the method's effect on the observables can be compared with the exact kernel.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from bbdyn.core.billiard import EventState, segment_gap, snap_to_wedge, tile_offset, wedge_reflect
from bbdyn.core.ensemble import initial_states
from bbdyn.core.floor import arc_root, floor_height_rel, from_normal_velocity, normal_velocity
from bbdyn.core.layout import ACC_EX, ACC_EY, ACC_POT
from bbdyn.core.observables import accumulate_interval, displacement, is_before, time_between
from bbdyn.core.plate import advance_phase, sin_cos
from bbdyn.core.status import IMPACT, NON_FINITE, OK, ROOT_NOT_CONVERGED, raise_for_status
from bbdyn.diffusion import einstein_D
from bbdyn.ensemble import initial_conditions
from bbdyn.runs import periods_phase

__all__ = [
    "fixed_step_billiard_flight",
    "fixed_step_bounce",
    "fixed_step_billiard_event",
    "fixed_step_billiard_one_step",
    "fixed_step_ensemble",
]


@njit(cache=True)
def fixed_step_billiard_flight(phase, xi0, vx, vyrel, dt, dt_min, kp):
    """Flight time to the first sampled contact, and the state there.

    Parameters
    ----------
    phase : float
        Phase w t (rad) of the collision that starts the flight.
    xi0, vx, vyrel : float
        Local coordinate (mm) and velocity relative to the floor (mm/s) just after it.
    dt, dt_min : float
        Sampling step (s) and final bracket (s), ``0 < dt_min``.
    kp : KernelParams

    Returns
    -------
    tau : float
        Flight time (s), late by less than ``dt_min``.
    k : float
        Tile offset of the contact (integer-valued).
    xi : float
        Local coordinate of the contact point (mm).
    vyrel_minus : float
        Vertical velocity relative to the floor there (mm/s).
    n_evals : int
        Gap evaluations (the cost).
    status : int
        ``OK`` or ``ROOT_NOT_CONVERGED`` (no sample below the floor, only by rounding).
    """
    A, w, g, d = kp.A, kp.w, kp.g, kp.d
    sn = math.sin(phase)
    cs = math.cos(phase)
    S0 = arc_root(xi0, kp)
    # After tau_max the free parabola is below -A, under the floor's lowest point.
    v_abs = vyrel - A * w * cs
    b0 = floor_height_rel(xi0, kp)
    tau_max = (v_abs + math.sqrt(v_abs * v_abs + 2.0 * g * (A - A * sn + b0))) / g
    n_max = int(math.ceil(tau_max / dt)) + 1
    tau = -1.0
    n_evals = 0
    for j in range(1, n_max + 1):
        t = j * dt
        k = tile_offset(xi0, vx, t, d)
        G = segment_gap(t, k, sn, cs, xi0, S0, vx, vyrel, kp)[0]
        n_evals += 1
        if G <= 0.0:
            tau = (j - 1) * dt
            break
    if tau < 0.0:
        return n_max * dt, 0.0, xi0, 0.0, n_evals, ROOT_NOT_CONVERGED
    h = dt
    while h > dt_min:
        h *= 0.5
        t = tau + h
        G = segment_gap(t, tile_offset(xi0, vx, t, d), sn, cs, xi0, S0, vx, vyrel, kp)[0]
        n_evals += 1
        if G > 0.0:
            tau = t
    tau += h
    k = tile_offset(xi0, vx, tau, d)
    _, _, _, vyrel_minus, xi = segment_gap(tau, k, sn, cs, xi0, S0, vx, vyrel, kp)
    return tau, k, xi, vyrel_minus, n_evals, OK


@njit(cache=True)
def fixed_step_bounce(xi_c, vx, vy_minus, kp):
    """Restitution law at the late contact point (snapped to a wedge within ``WEDGE_TOL``).

    A normal velocity that is not approaching (a graze found late) is set to zero.
    Returns ``(xi, vx, vyrel, vn, vt)`` just after the first reflection (mm, mm/s).
    """
    xi_c = snap_to_wedge(xi_c, kp)
    S = arc_root(xi_c, kp)
    vn, vt = normal_velocity(xi_c, S, vx, vy_minus, kp.R)
    vn = -kp.alpha * min(vn, 0.0)
    vt = kp.beta * vt
    vx_new, vy_new = from_normal_velocity(xi_c, S, vn, vt, kp.R)
    return xi_c, vx_new, vy_new, vn, vt


@njit(cache=True)
def fixed_step_billiard_event(periods, phase, tile, xi, vx, vyrel, dt, dt_min, kp):
    """One fixed-step collision: flight, late contact, restitution and wedge rule.

    Returns ``(periods, phase, tile, xi, vx, vyrel, n_evals, status)`` just after
    the collision (docs/model.md §2 law; ``vx, vyrel`` relative to the floor).
    """
    tau, k, xi_c, vy_minus, n_evals, status = fixed_step_billiard_flight(
        phase, xi, vx, vyrel, dt, dt_min, kp
    )
    if status != OK:
        return periods, phase, tile, xi, vx, vyrel, n_evals, status
    periods, phase = advance_phase(periods, phase, kp.w * tau)
    xi_c, vx_new, vy_new, vn, vt = fixed_step_bounce(xi_c, vx, vy_minus, kp)
    tile, xi_c, vx_new, vy_new, vn, vt, ok = wedge_reflect(
        tile + k, xi_c, vx_new, vy_new, vn, vt, kp
    )
    if not ok:
        # collapsed into the wedge: leaves with the floor (no sticking in this method)
        vx_new, vy_new = 0.0, 0.0
    if not (math.isfinite(vx_new) and math.isfinite(vy_new)):
        return periods, phase, tile, xi_c, vx_new, vy_new, n_evals, NON_FINITE
    return periods, phase, tile, xi_c, vx_new, vy_new, n_evals, OK


@njit(cache=True)
def fixed_step_billiard_one_step(starts, dt, dt_min, kp, out_tau, out_k, out_xi, out_vx, out_vy):
    """Fixed-step flight and first reflection from each start (rows ``phase, xi, vx, vyrel``).

    Writes the flight time (s), tile offset, contact ``xi`` (mm) and the absolute
    post-impact velocity (mm/s) in place; returns ``(n_evals, status)`` (total gap
    evaluations, first failure or ``OK``).
    """
    total = 0
    for i in range(starts.shape[0]):
        phase, vx = starts[i, 0], starts[i, 2]
        tau, k, xi, vym, n_evals, status = fixed_step_billiard_flight(
            phase, starts[i, 1], vx, starts[i, 3], dt, dt_min, kp
        )
        if status != OK:
            return total, status
        xi, vx_new, vy_new, _, _ = fixed_step_bounce(xi, vx, vym, kp)
        out_tau[i] = tau
        out_k[i] = k
        out_xi[i] = xi
        out_vx[i] = vx_new
        out_vy[i] = vy_new - kp.A * kp.w * math.cos(phase + kp.w * tau)
        total += n_evals
    return total, OK


@njit(cache=True)
def _fixed_particle(i, state, dt, dt_min, kp, end, window, s_periods, s_phase, disp, acc, counts):
    """One particle of ``fixed_step_ensemble`` up to ``end``; rows ``i`` written in place.

    Same bookkeeping as ``bbdyn.core.ensemble.particle_loop`` (energy integrals over
    whole periods of the window, displacement at the sample times) with flights only.
    """
    periods, phase, tile, xi, vx, vyrel = state[0], state[1], state[2], state[3], state[4], state[5]
    tile0, xi0 = tile, xi
    w0 = (window[0], 0.0)
    w1 = (window[1], 0.0)
    k = 0
    n_samples = s_periods.shape[0]
    while True:
        nxt = fixed_step_billiard_event(periods, phase, tile, xi, vx, vyrel, dt, dt_min, kp)
        status = nxt[7]
        if status != OK:
            for kk in range(k, n_samples):
                disp[i, kk] = math.nan
            return status
        counts[i, 0] += 1
        counts[i, 1] += nxt[6]
        last = not is_before(nxt[0], nxt[1], end[0], end[1])
        hi = (end[0], end[1]) if last else (nxt[0], nxt[1])
        lo = (periods, phase)
        if is_before(lo[0], lo[1], w0[0], w0[1]):
            lo = w0
        if is_before(w1[0], w1[1], hi[0], hi[1]):
            hi = w1
        if is_before(lo[0], lo[1], hi[0], hi[1]):
            b = floor_height_rel(xi, kp)
            flight = EventState(periods, phase, tile, xi, vx, vyrel, IMPACT)
            accumulate_interval(acc, i, flight, sin_cos(phase), b, lo, hi, kp, True)
        while k < n_samples and (last or is_before(s_periods[k], s_phase[k], nxt[0], nxt[1])):
            x = xi + vx * time_between(s_periods[k], s_phase[k], periods, phase, kp.w, kp.period)
            disp[i, k] = displacement(tile, x, tile0, xi0, kp.d)
            k += 1
        if last:
            return OK
        periods, phase, tile, xi, vx, vyrel = nxt[0], nxt[1], nxt[2], nxt[3], nxt[4], nxt[5]


@njit(cache=True, parallel=True)
def _fixed_ensemble(states, dt, dt_min, kp, end, window, s_periods, s_phase, disp, acc, counts, st):
    for i in prange(states.shape[0]):
        st[i] = _fixed_particle(
            i, states[i], dt, dt_min, kp, end, window, s_periods, s_phase, disp, acc, counts
        )


def fixed_step_ensemble(params, *, t, n, seed, dt, dt_min, transient=None, n_samples=101):
    """Ensemble run with the fixed-step method: D and period-averaged energies.

    Parameters
    ----------
    params : Params
    t : float
        Simulated time (s).
    n : int
        Particles, drawn from the reference box (docs/model.md §3) with ``seed``
        exactly as ``bbdyn.ensemble.ensemble`` draws them.
    seed : int
    dt, dt_min : float
        Sampling step and final bracket (s).
    transient : float, optional
        Time (s) discarded before the energy averages; default ``t / 5``.
    n_samples : int
        Equally spaced displacement samples in ``[0, t]``.

    Returns
    -------
    dict
        ``D``, ``D_se`` (mm^2/s, ``bbdyn.diffusion.einstein_D``), ``E``, ``E_x``,
        ``E_y``, ``E_pot`` and their standard errors ``*_se`` (kg mm^2/s^2, mean
        over particles of the window average), ``collisions_per_particle_per_s``
        (whole run), ``gap_evals_per_collision``, ``wall_s``.
    """
    import time

    for name, value in (("t", t), ("dt", dt), ("dt_min", dt_min)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite time > 0 s, got {value}")
    kp = params.kernel()
    ics = initial_conditions(params, int(n), seed)
    states = np.empty((ics.shape[0], 7))
    bad = initial_states(ics, kp, states)
    if bad >= 0:
        raise ValueError(f"initial condition {bad} must leave the floor, got {tuple(ics[bad])}")
    transient = t / 5 if transient is None else float(transient)
    window = np.array([math.ceil(transient * params.f), math.floor(t * params.f)], dtype=float)
    times = np.linspace(0.0, t, n_samples)
    s_periods, s_phase = periods_phase(times, params.f)
    end_periods, end_phase = periods_phase(np.array([t]), params.f)
    end = np.array([end_periods[0], end_phase[0]])
    disp = np.zeros((ics.shape[0], n_samples))
    acc = np.zeros((ics.shape[0], 4))
    counts = np.zeros((ics.shape[0], 2), dtype=np.int64)
    status = np.zeros(ics.shape[0], dtype=np.int64)
    wall = time.perf_counter()
    _fixed_ensemble(
        states, dt, dt_min, kp, end, window, s_periods, s_phase, disp, acc, counts, status
    )
    wall = time.perf_counter() - wall
    for s in status:
        raise_for_status(int(s), f"fixed-step ensemble (dt={dt:g}, dt_min={dt_min:g})")
    D, D_se = einstein_D(times, disp)
    t_window = (window[1] - window[0]) / params.f
    per = {
        "E_x": acc[:, ACC_EX] / t_window,
        "E_y": acc[:, ACC_EY] / t_window,
        "E_pot": acc[:, ACC_POT] / t_window,
    }
    per["E"] = per["E_x"] + per["E_y"] + per["E_pot"]
    out = {"D": float(D), "D_se": float(D_se)}
    for name, values in per.items():
        out[name] = float(values.mean())
        out[name + "_se"] = float(values.std(ddof=1) / math.sqrt(values.size))
    out["collisions_per_particle_per_s"] = float(counts[:, 0].mean() / t)
    out["gap_evals_per_collision"] = float(counts[:, 1].sum() / max(counts[:, 0].sum(), 1))
    out["wall_s"] = wall
    return out
