"""Per-trajectory features for attractor and regime classification (docs/model.md §5).

The particles are run by the one event loop of ``core/ensemble.py``
(``particle_loop``, driven here through ``core.ensemble.run_features``); this
module holds the feature accumulators it calls at each collision in the window
(``feature_collision``) and at the end (``feature_finish``), the thresholds
(``FeatureThresholds``) and the output arrays (``FeatureOut``).  The features are
accumulated on the way, after a transient, so memory is proportional to the
ensemble, not to the run.  The loop integrates energies and stuck time per block
with ``core.observables.accumulate_interval`` (exact over flights and stuck
intervals); the positions at given sample times (for the Einstein D) are the
loop's own displacement samples.

The averaging window ``[p0, p0 + nb L]`` (whole driving periods) is cut into
``nb`` blocks of ``L`` periods.  Per block (array ``blocks``, columns ``BF_*``):
the integrals of E_x, E_y, g y and the stuck time, the numbers of collisions,
tiny hops, trap changes (jumps) and locked flights.  Block values give each time
average its statistical fluctuation.

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

An impact after a flight shorter than ``hop_floor`` periods is not a collision for the
features: it belongs to the tail of a chattering sequence, whose bounces are infinitely many
and of which the kernel computes a number fixed by a numerical choice (``CHATTER_REL_TOL``)
before its closed-form sum takes over.  Only a trap change there is counted (``BF_JUMPS``).
The sequence's end (the STICK) is a collision, and the next flight starts at the impact.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import IMPACT
from bbdyn.core.tolerances import FMA

#: Columns of ``blocks`` (the first four are those of ``core.ensemble.ACC_*``).
BF_EX, BF_EY, BF_POT, BF_STUCK = 0, 1, 2, 3
BF_COLL, BF_TINY, BF_JUMPS, BF_LOCKED = 4, 5, 6, 7
BF_WIDTH = 8
#: Columns of ``glob``.
G_COS, G_SIN, G_TF, G_TF2, G_RUNS, G_RUNMAX = 0, 1, 2, 3, 4, 5
G_WIDTH = 6


class FeatureThresholds(NamedTuple):
    """Feature thresholds (kernel argument; ``bbdyn.classify.Thresholds`` holds them)."""

    tiny: float  # a flight shorter than tiny periods is a tiny hop
    k_tol: float  # a flight is locked to k when |T_flight / T - k| <= k_tol
    kmax: int  # largest locking number counted
    hist_width: float  # width (periods) of the flight-time histogram bins
    hop_floor: float  # an impact after a flight shorter than hop_floor periods is not counted


class FeatureOut(NamedTuple):
    """Output arrays of ``core.ensemble.run_features``, row ``i`` for particle ``i``.

    Filled in place; all but ``status`` must start at zero.  ``blocks`` has one row per
    block of the window; ``glob`` and ``counts`` are tables of sums (columns ``G_*`` and
    ``core.ensemble.CNT_*``).
    """

    displacement: np.ndarray  # (n, m): x(t_k) - x(0) (mm) at the sample times
    blocks: np.ndarray  # (n, nb, BF_WIDTH): block sums, columns BF_*
    counts: np.ndarray  # int64 (n, CNT_WIDTH): the loop's counts
    hist: np.ndarray  # (n, nbins): flight-time histogram
    kcount: np.ndarray  # (n, kmax + 1): flights locked to k
    glob: np.ndarray  # (n, G_WIDTH): sums over the window, columns G_*
    mismatch: np.ndarray  # (n, pmax): impact-sequence mismatch at lag p (index p - 1)
    status: np.ndarray  # int64 (n,): as in run_ensemble


class Collision(NamedTuple):
    """One collision in the window, as the features see it."""

    block: int  # block of the window it falls in
    phase: float  # impact phase (rad)
    vyrel: float  # relative vertical velocity after it (mm/s)
    kind: int  # IMPACT or STICK
    flight: float  # flight time before it (periods), from the last departure
    jumped: bool  # the trap changed at this collision


@njit(cache=True, fastmath=FMA)
def block_of(periods, p0, L, nb):
    """Block index (0..nb-1) of a time with ``periods`` whole periods (clamped)."""
    j = int(math.floor((periods - p0) / L))
    return min(max(j, 0), nb - 1)


@njit(cache=True, fastmath=FMA)
def feature_collision(out, i, ring, n_ring, run, hit, th, kp):
    """Add one collision in the window to the features of particle ``i``.

    Parameters
    ----------
    out : FeatureOut
        Row ``i`` of ``blocks``, ``hist``, ``kcount``, ``glob`` and ``mismatch`` is updated.
    i : int
        The particle.
    ring : array, shape (pmax, 3)
        The particle's last ``pmax`` collisions ``(phase, vyrel, kind)``, collision ``c`` in
        slot ``c % pmax``; ``n_ring`` collisions seen so far.
    run : int
        Length of the current run of tiny hops.
    hit : Collision
        The collision.
    th : FeatureThresholds
    kp : KernelParams

    Returns
    -------
    (n_ring, run) : int, int
        Updated ring count and tiny-hop run length.
    """
    blocks, hist, kcount = out.blocks[i], out.hist[i], out.kcount[i]
    glob, mism = out.glob[i], out.mismatch[i]
    j, phase, vyrel, kind, flight = hit.block, hit.phase, hit.vyrel, hit.kind, hit.flight
    nbins = hist.shape[0]
    pmax = mism.shape[0]
    if hit.jumped:
        blocks[j, BF_JUMPS] += 1.0
    if kind == IMPACT and flight < th.hop_floor:
        return n_ring, run  # a chattering sequence's tail: not a collision (module docstring)
    blocks[j, BF_COLL] += 1.0
    glob[G_COS] += math.cos(phase)
    glob[G_SIN] += math.sin(phase)
    glob[G_TF] += flight
    glob[G_TF2] += flight * flight
    hist[min(int(flight / th.hist_width), nbins - 1)] += 1.0
    k = int(math.floor(flight + 0.5))
    if 1 <= k <= th.kmax and abs(flight - k) <= th.k_tol:
        kcount[k] += 1.0
        blocks[j, BF_LOCKED] += 1.0
    if flight < th.tiny:
        blocks[j, BF_TINY] += 1.0
        run += 1
    elif run > 0:
        glob[G_RUNS] += 1.0
        glob[G_RUNMAX] = max(glob[G_RUNMAX], run)
        run = 0
    # periodicity of the vertical impact sequence: compare with p collisions back
    vscale = kp.g * kp.period
    for p in range(1, pmax + 1):
        if n_ring < p:
            continue
        r = ring[(n_ring - p) % pmax]
        if int(r[2]) != kind:
            mism[p - 1] = math.inf
            continue
        dph = abs(phase - r[0])
        dph = min(dph, TWO_PI - dph) / TWO_PI
        m = max(dph, abs(vyrel - r[1]) / vscale)
        if m > mism[p - 1]:
            mism[p - 1] = m
    slot = ring[n_ring % pmax]
    slot[0], slot[1], slot[2] = phase, vyrel, kind
    return n_ring + 1, run


@njit(cache=True, fastmath=FMA)
def feature_finish(glob, mism, n_ring, run):
    """Close the features of one particle at the end of its run.

    Ends the last tiny-hop run and marks the lags never compared (``mism`` inf: no
    evidence).
    """
    if run > 0:
        glob[G_RUNS] += 1.0
        glob[G_RUNMAX] = max(glob[G_RUNMAX], run)
    pmax = mism.shape[0]
    for p in range(min(max(n_ring - 1, 0), pmax), pmax):
        mism[p] = math.inf
