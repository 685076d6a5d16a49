"""A fixed-step event finder for the flat ball, like the reference paper's (B2).

The flight itself is exact (the parabola and the plate are evaluated in closed
form with ``bbdyn.core.search.flat_gap``): the only approximation is where the
impact is put.  The gap is sampled on the grid ``tau_k = k dt`` after each
impact; at the first sample with ``G <= 0`` the last step is halved (bisection,
keeping the half whose right end has ``G <= 0`` and whose left end has
``G > 0``) until it is at most ``dt_min``.  The impact is put at the right end
of that final bracket (the first sample found below the plate), so the impact
time is late by less than ``dt_min`` (first order in ``dt_min``) and the
velocity is the exact relative velocity at that late time.  The particle is
then put back on the plate and the impact law ``vrel+ = -alpha vrel-``
(docs/model.md §1) applied.  This is the most favourable version of such a
method: no integration error, only the event location.

What it cannot do:

* it misses a contact whose dip below the plate lasts less than ``dt`` (the
  gap is negative between two samples and positive at both);
* it has no chattering: a flight lasts at least one final bracket ``h <= dt_min``,
  so an accumulating bounce sequence turns into "micro-bounces" of ``m h``
  each, with ``vrel+ -> alpha g_eff m h / (1 + alpha)`` (the fixed point of
  ``v -> alpha (g_eff m h - v)``); every integer ``1 <= m < (1 + alpha) / (1 - alpha)``
  is self-consistent (the free flight ``2 vrel+ / g_eff`` ends in the m-th bracket),
  and history picks one.  This goes on until the plate accelerates downward
  faster than g and the particle flies off: sticking is emulated by about
  ``1 / (m h)`` impacts per second of contact.
"""

import math

from numba import njit

from bbdyn.core.plate import advance_phase
from bbdyn.core.search import flat_gap
from bbdyn.core.status import BAD_STATE, NON_FINITE, OK, ROOT_NOT_CONVERGED


@njit(cache=True)
def fixed_step_flight(phase, vrel, dt, dt_min, kp):
    """Flight time to the first sampled contact, and the relative velocity there.

    Parameters
    ----------
    phase : float
        Phase w t (rad) of the impact that starts the flight.
    vrel : float
        Relative velocity v - u (mm/s) just after it (>= 0).
    dt : float
        Sampling step of the flight (s), > 0.
    dt_min : float
        The bracket is halved until it is at most this long (s), 0 < dt_min.
    kp : KernelParams

    Returns
    -------
    tau : float
        Flight time (s), a multiple of ``dt`` plus bisection halves; late by < ``dt_min``.
    vrel_minus : float
        Relative velocity at ``tau`` (mm/s), clipped to <= 0.
    n_evals : int
        Number of gap evaluations (the cost).
    status : int
        ``OK``, ``BAD_STATE`` (negative vrel) or ``ROOT_NOT_CONVERGED`` (no sample
        below the plate by ``tau_max``, which only rounding could cause).
    """
    if not vrel >= 0.0:
        return 0.0, vrel, 0, BAD_STATE
    A, w, g = kp.A, kp.w, kp.g
    s0 = math.sin(phase)
    c0 = math.cos(phase)
    # After tau_max the free parabola is below -A, the plate's lowest point, so
    # the sampling loop ends by then (the gap at the last sample is <= 0).
    v_abs = vrel - A * w * c0
    tau_max = (v_abs + math.sqrt(v_abs * v_abs + 2.0 * g * (A - A * s0))) / g
    n_max = int(math.ceil(tau_max / dt)) + 1
    tau = -1.0
    n_evals = 0
    for k in range(1, n_max + 1):
        G, _ = flat_gap(vrel, g, A, w, s0, c0, k * dt)
        n_evals += 1
        if G <= 0.0:
            tau = (k - 1) * dt
            break
    if tau < 0.0:
        return n_max * dt, 0.0, n_evals, ROOT_NOT_CONVERGED
    h = dt
    while h > dt_min:
        h *= 0.5
        G, _ = flat_gap(vrel, g, A, w, s0, c0, tau + h)
        n_evals += 1
        if G > 0.0:
            tau += h
    tau += h
    _, Gp = flat_gap(vrel, g, A, w, s0, c0, tau)
    return tau, min(Gp, 0.0), n_evals, OK


@njit(cache=True)
def fixed_step_one_step(phases, vrels, dt, dt_min, kp, out_tau, out_vrel_minus):
    """``fixed_step_flight`` from each start state (phase, vrel) in turn, in place.

    Returns ``(n_evals, status)``: the total number of gap evaluations and the
    first failure status (``OK`` if none).
    """
    total = 0
    for i in range(phases.shape[0]):
        tau, vm, n_evals, status = fixed_step_flight(phases[i], vrels[i], dt, dt_min, kp)
        if status != OK:
            return total, status
        out_tau[i] = tau
        out_vrel_minus[i] = vm
        total += n_evals
    return total, OK


@njit(cache=True)
def fixed_step_run(periods, phase, vrel, dt, dt_min, kp, out_periods, out_phase, out_vrel):
    """Iterate fixed-step impacts, writing each into the ``out_*`` arrays (in place).

    Time is kept as (whole periods, phase) as in ``bbdyn.core.flat``; ``out_vrel``
    is the post-impact relative velocity (mm/s).  Returns ``(n_written, status)``.
    """
    w, alpha = kp.w, kp.alpha
    for i in range(out_phase.shape[0]):
        tau, vrel_minus, _, status = fixed_step_flight(phase, vrel, dt, dt_min, kp)
        if status != OK:
            return i, status
        periods, phase = advance_phase(periods, phase, w * tau)
        vrel = -alpha * vrel_minus
        if not math.isfinite(vrel):
            return i, NON_FINITE
        out_periods[i] = periods
        out_phase[i] = phase
        out_vrel[i] = vrel
    return out_phase.shape[0], OK
