"""Per-trajectory features for attractor and regime classification (MODEL.md section 5).

Each particle is run event by event with ``billiard_event`` (the ladder of
``core/billiard.py``); the features are accumulated on the way, after a
transient, so memory is proportional to the ensemble, not to the run.  The
energy and stuck-time integrals reuse ``core.ensemble.accumulate_interval`` (exact over
flights and stuck intervals), traps and displacements ``core/observables.py``.

The averaging window ``[p0, p0 + nb L]`` (whole driving periods) is cut into
``nb`` blocks of ``L`` periods.  Per block (array ``blocks``, columns ``BF_*``):
the integrals of E_x, E_y, g y and the stuck time, the numbers of collisions,
tiny hops, trap changes (jumps) and locked flights, and the displacement over
the block.  Block values give each time average its statistical fluctuation.

Per particle, over the window:

* ``hist``: histogram of flight times in periods (bins of ``hist_width``, the
  last bin collects longer flights).  A *flight* runs from a departure (an
  IMPACT or a RELEASE) to the next collision (IMPACT or STICK);
* ``glob``: sums of cos and sin of the impact phases (coherence), of the flight
  times and their squares (periods), the number of creep runs (maximal runs of
  consecutive tiny hops) and the longest run;
* ``mismatch[p - 1]``: the largest difference, over the window, between
  collision ``n`` and collision ``n - p`` of the vertical impact sequence,
  ``max(|phase diff| / 2 pi, |vyrel diff| / (g T))`` (T the driving period), or
  inf if the kinds differ or fewer than ``p + 1`` collisions were seen.  The
  impact sequence has period ``p`` to tolerance ``tol`` when ``mismatch <= tol``.

A flight is *locked* to k (1 <= k <= kmax) when ``|T_flight / T - k| <= k_tol``
and a *tiny hop* when ``T_flight / T < tiny``.
"""

import math

import numpy as np
from numba import njit, prange

from bbdyn.core.billiard import billiard_event
from bbdyn.core.ensemble import accumulate_interval
from bbdyn.core.floor import floor_height_rel
from bbdyn.core.observables import displacement, is_before, time_between, trap_of
from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import OK, RELEASE, STICK, STUCK_FOREVER

#: Columns of ``blocks`` (the first four are those of ``core.ensemble.ACC_*``).
BF_EX, BF_EY, BF_POT, BF_STUCK = 0, 1, 2, 3
BF_COLL, BF_TINY, BF_JUMPS, BF_LOCKED, BF_DISP = 4, 5, 6, 7, 8
BF_WIDTH = 9
#: Columns of ``glob``.
G_COS, G_SIN, G_TF, G_TF2, G_RUNS, G_RUNMAX = 0, 1, 2, 3, 4, 5
G_WIDTH = 6


@njit(cache=True)
def _block_of(periods, p0, L, nb):
    """Block index (0..nb-1) of a time with ``periods`` whole periods (clamped)."""
    j = int(math.floor((periods - p0) / L))
    return min(max(j, 0), nb - 1)


@njit(cache=True)
def feature_particle(
    i, state, kp, end, p0, L, nb, tiny, k_tol, kmax, hist_width, blocks, hist, kcount, glob, mism
):
    """Run particle ``i`` from ``state`` to ``end``; write its rows of the feature arrays.

    Parameters
    ----------
    i : int
        Particle index.
    state : array, shape (7,)
        ``periods, phase, tile, xi, vx, vyrel, kind`` of the initial event.
    kp : KernelParams
    end : array, shape (2,)
        End of the run ``(periods, phase)``; at or after ``p0 + nb L`` periods.
    p0, L : float
        Window start and block length (whole periods).
    nb : int
        Number of blocks.
    tiny, k_tol : float
        Tiny-hop bound and locking tolerance (in periods).
    kmax : int
        Largest locking number counted.
    hist_width : float
        Width (periods) of the flight-time histogram bins.
    blocks, hist, kcount, glob, mism : arrays
        Outputs, shapes (n, nb, BF_WIDTH), (n, nbins), (n, kmax + 1), (n, G_WIDTH),
        (n, pmax); zero on entry except ``mism`` (any value).

    Returns
    -------
    status : int
        ``OK``, ``STUCK_FOREVER`` or the kernel's failure status.
    """
    period, w = kp.period, kp.w
    periods, phase, tile, xi, vx, vyrel = state[0], state[1], state[2], state[3], state[4], state[5]
    kind = int(state[6])
    p1 = p0 + nb * L
    nbins = hist.shape[1]
    pmax = mism.shape[1]
    # ring buffer of the last pmax collisions (phase, vyrel, kind)
    ring = np.zeros((pmax, 3))
    n_ring = 0
    for p in range(pmax):
        mism[i, p] = 0.0
    pos = np.zeros(nb + 1)  # x(t) - x(0) at the block boundaries
    tile0, xi0 = tile, xi
    kb = 0  # next block boundary to sample
    dep_periods, dep_phase = periods, phase  # last departure
    trap = trap_of(tile, xi)
    run = 0
    status = OK
    while True:
        nxt = billiard_event(periods, phase, tile, xi, vx, vyrel, kind, kp)
        status = nxt[7]
        if status == STUCK_FOREVER:
            n_periods, n_phase = math.inf, 0.0
        elif status != OK:
            return status
        else:
            n_periods, n_phase = nxt[0], nxt[1]
        last = not is_before(n_periods, n_phase, end[0], end[1])
        stuck = kind == STICK

        # energy and stuck-time integrals of [event, next event] inside the window, per block
        lo_p, lo_ph = periods, phase
        if is_before(lo_p, lo_ph, p0, 0.0):
            lo_p, lo_ph = p0, 0.0
        hi_p, hi_ph = (end[0], end[1]) if last else (n_periods, n_phase)
        if is_before(p1, 0.0, hi_p, hi_ph):
            hi_p, hi_ph = p1, 0.0
        if is_before(lo_p, lo_ph, hi_p, hi_ph):
            b = floor_height_rel(xi, kp)
            for j in range(_block_of(lo_p, p0, L, nb), _block_of(hi_p, p0, L, nb) + 1):
                a_p, a_ph = lo_p, lo_ph
                if is_before(a_p, a_ph, p0 + j * L, 0.0):
                    a_p, a_ph = p0 + j * L, 0.0
                z_p, z_ph = hi_p, hi_ph
                if is_before(p0 + (j + 1) * L, 0.0, z_p, z_ph):
                    z_p, z_ph = p0 + (j + 1) * L, 0.0
                if is_before(a_p, a_ph, z_p, z_ph):
                    accumulate_interval(
                        blocks[i], j, stuck, periods, phase, b, vx, vyrel,
                        (a_p, a_ph), (z_p, z_ph), kp, True,
                    )  # fmt: skip

        # positions at the block boundaries inside this interval
        while kb <= nb and (last or is_before(p0 + kb * L, 0.0, n_periods, n_phase)):
            x = xi
            if not stuck:
                x += vx * time_between(p0 + kb * L, 0.0, periods, phase, w, period)
            pos[kb] = displacement(tile, x, tile0, xi0, kp.d)
            kb += 1
        if last:
            break

        periods, phase, tile, xi, vx, vyrel = nxt[0], nxt[1], nxt[2], nxt[3], nxt[4], nxt[5]
        kind = nxt[6]
        if kind == RELEASE:
            dep_periods, dep_phase = periods, phase
            continue
        flight = time_between(periods, phase, dep_periods, dep_phase, w, period) / period
        dep_periods, dep_phase = periods, phase  # an IMPACT departs at once; a STICK releases later
        new_trap = trap_of(tile, xi)
        jumped = new_trap != trap
        trap = new_trap
        if is_before(periods, phase, p0, 0.0) or not is_before(periods, phase, p1, 0.0):
            continue
        # a collision in the window
        j = _block_of(periods, p0, L, nb)
        blocks[i, j, BF_COLL] += 1.0
        if jumped:
            blocks[i, j, BF_JUMPS] += 1.0
        glob[i, G_COS] += math.cos(phase)
        glob[i, G_SIN] += math.sin(phase)
        glob[i, G_TF] += flight
        glob[i, G_TF2] += flight * flight
        hist[i, min(int(flight / hist_width), nbins - 1)] += 1.0
        k = int(math.floor(flight + 0.5))
        if 1 <= k <= kmax and abs(flight - k) <= k_tol:
            kcount[i, k] += 1.0
            blocks[i, j, BF_LOCKED] += 1.0
        if flight < tiny:
            blocks[i, j, BF_TINY] += 1.0
            run += 1
        elif run > 0:
            glob[i, G_RUNS] += 1.0
            glob[i, G_RUNMAX] = max(glob[i, G_RUNMAX], run)
            run = 0
        # periodicity of the vertical impact sequence: compare with p collisions back
        vscale = kp.g * period
        for p in range(1, pmax + 1):
            if n_ring < p:
                continue
            r = ring[(n_ring - p) % pmax]
            if int(r[2]) != kind:
                mism[i, p - 1] = math.inf
                continue
            dph = abs(phase - r[0])
            dph = min(dph, TWO_PI - dph) / TWO_PI
            m = max(dph, abs(vyrel - r[1]) / vscale)
            if m > mism[i, p - 1]:
                mism[i, p - 1] = m
        slot = ring[n_ring % pmax]
        slot[0], slot[1], slot[2] = phase, vyrel, kind
        n_ring += 1
    if run > 0:
        glob[i, G_RUNS] += 1.0
        glob[i, G_RUNMAX] = max(glob[i, G_RUNMAX], run)
    for p in range(min(max(n_ring - 1, 0), pmax), pmax):
        mism[i, p] = math.inf  # lag p + 1 never compared: no evidence
    for j in range(nb):
        blocks[i, j, BF_DISP] = pos[j + 1] - pos[j]
    return status


@njit(cache=True, parallel=True)
def run_features(
    states, kp, end, p0, L, nb, tiny, k_tol, kmax, hist_width, blocks, hist, kcount, glob, mism,
    status,
):  # fmt: skip
    """Run every particle (prange over particles) and fill the feature arrays in place.

    Arguments as in ``feature_particle``; ``status`` (int64, shape (n,)) receives each
    particle's status.  Each particle writes only its own rows: the numbers do not
    depend on the number of threads.
    """
    for i in prange(states.shape[0]):
        status[i] = feature_particle(
            i, states[i], kp, end, p0, L, nb, tiny, k_tol, kmax, hist_width,
            blocks, hist, kcount, glob, mism,
        )  # fmt: skip
