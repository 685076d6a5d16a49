"""Scene S7: (s, vx+) at collisions at 85.2 Hz, with the creeps (runs of tiny hops) apart.

Same computation as S6 (``bbdyn.poincare.poincare``) at 85.2 Hz, where flights
and creeps alternate; tiny hops (flight < ``TINY_HOP_PERIODS``) are orange.
"""

from __future__ import annotations

from bbdyn.poincare import PoincareResult
from bbdyn.scenes.s6_phase_space_58 import compute as _compute_s6
from bbdyn.scenes.s6_phase_space_58 import draw

TITLE = "Phase space (s, vx+) at collisions at 85.2 Hz, showing creeps"
QUICK = {"f": 85.2, "n": 100, "transient": 10.0, "particles": 20, "n_events": 1500}
FULL = {"f": 85.2, "n": 1000, "transient": 40.0, "particles": 200, "n_events": 5000}

__all__ = ["TITLE", "QUICK", "FULL", "compute", "draw"]


def compute(settings: dict, seed: int = 0) -> PoincareResult:
    """Collisions of ``particles`` ensemble particles after ``transient`` seconds (as S6)."""
    return _compute_s6(settings, seed)
