"""Buffer layouts of the event loops: flags, array columns and the named tuples of arrays.

``core.ensemble`` (the particle loop), ``core.fast_forward`` and ``core.observables`` read
and write the same arrays; their shapes and columns are defined here once.  The loop state
of a particle between chunks is a row of ``carry.state`` (``C_*`` columns), its
integrals a row of ``blocks`` (``ACC_*``), its counts a row of ``counts`` (``CNT_*``).
"""

from typing import NamedTuple

import numpy as np

#: Bit flags selecting the observables an ensemble computes.
OBS_DISPLACEMENT = 1
OBS_ENERGY = 2
OBS_JUMPS = 4
OBS_RECORD = 8
#: Fast-forward of exactly periodic stick-release cycles (``fast_forward``); ignored
#: for recorded particles (and never made with features).
OBS_FAST_FORWARD = 32
#: With OBS_FAST_FORWARD: skip also cycles converged to within FF_DRIFT_TOL that do not
#: repeat bit for bit (``converged_cycle``).
OBS_FF_CONVERGED = 64
#: Releases remembered to detect a cycle: lags 1 .. FF_LAGS (converged cycles: lags up to
#: FF_LAGS / 2, two cycles are compared).
FF_LAGS = 12

#: Columns of the per-particle integrals ``acc``: int E_x, int E_y, int g y, stuck time
#: (kg mm^2/s and s), all over the energy window.
ACC_EX, ACC_EY, ACC_POT, ACC_STUCK = 0, 1, 2, 3
#: Columns of the per-particle counts: events in the run, collisions, STICKs and
#: jumps in the energy window, collisions in the record window, events skipped by
#: ``fast_forward`` (included in CNT_EVENTS).
CNT_EVENTS, CNT_COLLISIONS, CNT_STICKS, CNT_JUMPS, CNT_RECORD, CNT_SKIPPED = 0, 1, 2, 3, 4, 5
CNT_WIDTH = 6
#: Columns of the collision record: periods, phase, tile, xi, vx, vyrel, kind.
REC_WIDTH = 7
#: Status of a particle that has not reached the end yet (between chunks); the finished
#: ones carry a ``core.status`` code (>= 0).
RUNNING = -1
#: Columns of a particle's loop state ``carry.state`` (``bbdyn.runs.Carry``; everything
#: ``particle_loop`` keeps between events): the last event ``periods, phase, tile, xi, vx,
#: vyrel, kind``, the start ``tile0, xi0``, the next sample index, the trap, the last
#: departure ``(periods, phase)``, the feature ring count and tiny-hop run, the releases
#: remembered, the last multiplier of ``converged_cycle``: its lag, release point and
#: ``abs(lam)``; and the random restitution's counter (``core.noise``): the run's key (two
#: 32-bit words), the particle's index and the flights that drew so far (integers, exact
#: in a float below 2^53).
C_TILE0, C_XI0, C_K, C_TRAP, C_DEP_P, C_DEP_PH = 7, 8, 9, 10, 11, 12
C_NRING, C_RUN, C_NREL = 13, 14, 15
C_LAM_P, C_LAM_XI, C_LAM = 16, 17, 18
C_KEY0, C_KEY1, C_PARTICLE, C_DRAWS = 19, 20, 21, 22
CARRY_WIDTH = 23


class Window(NamedTuple):
    """The averaging window: ``nb`` blocks of ``L`` whole periods from ``p0`` (phase 0)."""

    p0: float
    L: float
    nb: int


class RunTimes(NamedTuple):
    """When a run ends and when it measures (kernel argument); times as ``(periods, phase)``.

    ``end_periods, end_phase``: the end of the run.  The window starts at ``p0`` whole
    periods (phase 0) and is cut into ``nb`` blocks of ``L`` whole periods (the ensemble's
    energy window is one block).  ``sample_periods, sample_phase``, shape (m,): the
    displacement's sample times, sorted, within ``[0, end]`` (m = 0: none).
    """

    end_periods: float
    end_phase: float
    p0: float
    L: float
    nb: int
    sample_periods: np.ndarray
    sample_phase: np.ndarray


class Observables(NamedTuple):
    """What ``run_ensemble`` observes (kernel argument).

    ``flags``: OR of the ``OBS_*`` flags.  ``record_periods, record_phase``, shape (2,):
    start and end of the window of the collision record (with ``OBS_RECORD``).
    ``split_periods``: whole periods (phase 0) in ``[p0, p0 + L]`` that end the first
    part of the energy window, row 1 of ``EnsembleOut.blocks``.
    """

    flags: int
    record_periods: np.ndarray
    record_phase: np.ndarray
    split_periods: float


class EnsembleOut(NamedTuple):
    """Output arrays of ``run_ensemble``, row ``i`` for particle ``i`` (kernel argument).

    Filled in place; all but ``status`` must start at zero.  ``counts`` stays a table
    (``fast_forward`` differences whole rows).  ``blocks``: row 0 the energy window
    ``[p0, p0 + L]``, row 1 its first part ``[p0, split]`` (``Observables.split_periods``;
    row 1 is written once the particle passes the split, see ``split_row``).
    """

    displacement: np.ndarray  # (n, m): x(t_k) - x(0) (mm) at the sample times
    blocks: np.ndarray  # (n, 2, 4): integrals over the energy window and its first part, ACC_*
    counts: np.ndarray  # int64 (n, CNT_WIDTH): columns CNT_*
    jump_len: np.ndarray  # int64 (n, cap): trap changes in the window (units of d)
    jump_time: np.ndarray  # (n, cap): their times (s)
    record: np.ndarray  # (n_rec, cap_rec, REC_WIDTH): collisions of the first n_rec particles
    final: np.ndarray  # (n, 7): the last event before the end (``EventState`` fields)
    status: np.ndarray  # int64 (n,): RUNNING on entry to advance; then a core.status code


#: Columns of ``PointTable.times``: end of the run (periods, phase), start ``p0`` and length
#: ``L`` of the energy window (whole periods), and the end of its first part (the split).
T_END_P, T_END_PH, T_P0, T_L, T_SPLIT = 0, 1, 2, 3, 4
TIMES_WIDTH = 5


class PointTable(NamedTuple):
    """The points of a launch (kernel argument): rows indexed by point, ``point`` by particle."""

    params: np.ndarray  # (P, number of KernelParams fields): KernelParams of each point
    times: np.ndarray  # (P, TIMES_WIDTH): columns T_*
    sample_periods: np.ndarray  # (P, m): the displacement's sample times, whole periods
    sample_phase: np.ndarray  # (P, m): and phases
    record: np.ndarray  # (2,): the (empty) record window, periods and phase
    point: np.ndarray  # int64 (n,): the point of each particle
