"""Scene B3: statistical cost of D, its standard error against CPU time (``scans.statcost``).

At a few frequencies the reference ensemble runs with growing n (at ``t_fixed``) and
with growing t (at ``n_fixed``); the figure shows the standard error of D against the
CPU time of each run, with the fitted exponents.  CPU times are process times of one
numba thread, so on a loaded machine they are upper bounds.
"""

from __future__ import annotations

from bbdyn.results import Result
from bbdyn.scans.statcost import StatCostResult, statcost
from bbdyn.scenes import figure_axes

TITLE = "Statistical cost: standard error of D against CPU time, growing n and growing t"
QUICK = {"f": (66.0, 85.2, 90.0), "n": (25, 50, 100, 200), "t": (5.0, 10.0, 20.0, 40.0),
         "n_fixed": 50, "t_fixed": 10.0}  # fmt: skip
FULL = {"f": (58.0, 66.0, 85.2, 90.0), "n": (50, 100, 200, 400, 800),
        "t": (10.0, 20.0, 40.0, 80.0, 160.0), "n_fixed": 200, "t_fixed": 40.0}  # fmt: skip
#: The setting of docs/diffusion.md: 4 frequencies, n = 50..800 at t = 20 s, t = 5..80 s at n = 200
MEDIUM = {
    "f": (58.0, 66.0, 85.2, 90.0),
    "n": (50, 100, 200, 400, 800),
    "t": (5.0, 10.0, 20.0, 40.0, 80.0),
    "n_fixed": 200,
    "t_fixed": 20.0,
}

__all__ = ["TITLE", "QUICK", "MEDIUM", "FULL", "compute", "draw"]


def compute(settings: dict, seed: int = 0) -> StatCostResult:
    """``bbdyn.scans.statcost.statcost`` at ``settings``."""
    return statcost(settings, seed)


def draw(result: Result, ax=None):
    """Standard error of D against CPU time (log-log); returns the Figure."""
    fig, ax = figure_axes(ax, figsize=(6.5, 4.5))
    result.plot(ax=ax)
    return fig
