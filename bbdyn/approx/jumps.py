"""Jump sequences of an ensemble, the input of the approximations (docs/model.md §4).

``JumpData`` holds, per particle, the changes of trap between consecutive collisions
and their times; the convention is described in ``bbdyn.approx``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["JumpData"]


@dataclass(frozen=True, eq=False)
class JumpData:
    """Jump sequences of an ensemble, validated once (see the module docstring).

    Examples
    --------
    >>> data = JumpData.from_particles([[1, 1, -1], [2]], [[0.1, 0.3, 0.4], [0.2]],
    ...                                t_total=1.0, d=2.0)
    >>> data.n_particles, data.counts.tolist()
    (2, [3, 1])
    """

    jumps: np.ndarray
    times: np.ndarray
    offsets: np.ndarray
    t_total: float
    d: float

    def __post_init__(self) -> None:
        jumps = np.asarray(self.jumps)
        if jumps.ndim != 1 or not (jumps.size == 0 or np.issubdtype(jumps.dtype, np.integer)):
            raise ValueError(f"jumps must be a 1-D integer array, got {jumps.dtype} {jumps.shape}")
        jumps = jumps.astype(np.int64)
        if np.any(jumps == 0):
            raise ValueError(
                f"jumps must be nonzero trap differences, got 0 at index "
                f"{int(np.flatnonzero(jumps == 0)[0])}"
            )
        times = np.asarray(self.times, dtype=np.float64)
        if times.shape != jumps.shape:
            raise ValueError(f"times must have the shape of jumps {jumps.shape}, got {times.shape}")
        offsets = np.asarray(self.offsets)
        if offsets.ndim != 1 or offsets.size < 2 or not np.issubdtype(offsets.dtype, np.integer):
            raise ValueError(
                "offsets must be a 1-D integer array of length n_particles + 1 >= 2, "
                f"got {offsets.dtype} {offsets.shape}"
            )
        offsets = offsets.astype(np.int64)
        if offsets[0] != 0 or offsets[-1] != jumps.size or np.any(np.diff(offsets) < 0):
            raise ValueError(
                f"offsets must be non-decreasing from 0 to len(jumps) = {jumps.size}, "
                f"got {offsets.tolist()[:5]}{' ...' if offsets.size > 5 else ''}"
            )
        t_total = float(self.t_total)
        if not (math.isfinite(t_total) and t_total > 0):
            raise ValueError(f"t_total must be finite and > 0 s, got {self.t_total}")
        d = float(self.d)
        if not (math.isfinite(d) and d > 0):
            raise ValueError(f"d must be finite and > 0 mm, got {self.d}")
        if not np.all(np.isfinite(times)) or np.any(times < 0) or np.any(times > t_total):
            raise ValueError(f"times must be finite and in [0, t_total = {t_total}] s")
        # Times may only decrease where a new particle starts.
        starts = np.zeros(jumps.size, dtype=bool)
        starts[offsets[1:-1][offsets[1:-1] < jumps.size]] = True
        bad = np.flatnonzero((np.diff(times) < 0) & ~starts[1:])
        if bad.size:
            raise ValueError(
                f"times must be non-decreasing within a particle, not at index {bad[0] + 1}"
            )
        for name, value in (("jumps", jumps), ("times", times), ("offsets", offsets)):
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        object.__setattr__(self, "t_total", t_total)
        object.__setattr__(self, "d", d)

    @classmethod
    def from_particles(
        cls,
        jumps: Sequence[Sequence[int]],
        times: Sequence[Sequence[float]],
        t_total: float,
        d: float,
    ) -> JumpData:
        """Build from one jump list and one time list per particle."""
        if len(jumps) != len(times):
            raise ValueError(
                f"jumps and times must list the same particles, got {len(jumps)} and {len(times)}"
            )
        counts = [len(j) for j in jumps]
        offsets = np.concatenate(([0], np.cumsum(counts, dtype=np.int64)))
        flat_jumps = np.concatenate([np.asarray(j, dtype=np.int64) for j in jumps] or [[]])
        flat_times = np.concatenate([np.asarray(t, dtype=np.float64) for t in times] or [[]])
        return cls(flat_jumps.astype(np.int64), flat_times, offsets, t_total, d)

    @property
    def n_particles(self) -> int:
        """Number of particles."""
        return self.offsets.size - 1

    @property
    def counts(self) -> np.ndarray:
        """Number of jumps of each particle, shape (n_particles,)."""
        return np.diff(self.offsets)

    @property
    def particle_index(self) -> np.ndarray:
        """Owner particle of each jump, shape (n_jumps,)."""
        return np.repeat(np.arange(self.n_particles), self.counts)
