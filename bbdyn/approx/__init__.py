"""Random-walk and truncated Green-Kubo approximations (docs/model.md §4).

Input convention: ``JumpData``
------------------------------
The billiard simulator reports, per particle, the *jumps*: changes of trap
(trap = wedge, docs/model.md §4) between consecutive collisions, as integer
trap differences ``h / d`` (mostly +-1, never 0), with the time at which each
jump happened.  The particles of an ensemble are concatenated CSR style:

* ``jumps``   int64, shape (n_jumps,): trap differences, units of d;
* ``times``   float64, shape (n_jumps,): time of each jump in s, non-decreasing
  within a particle, in ``[0, t_total]``;
* ``offsets`` int64, shape (n_particles + 1,): particle ``i`` owns
  ``jumps[offsets[i]:offsets[i + 1]]`` (``offsets[0] == 0``,
  ``offsets[-1] == n_jumps``); a particle may have no jump at all;
* ``t_total`` float: simulated time per particle in s (the same for all);
* ``d``       float: tile width in mm, so a jump length is ``jumps * d`` mm.

Modules: ``random_walk`` (escape time, jump lengths, D_rw, analytic D_a, the
energy ratio r) and ``green_kubo`` (D_n from jump correlations and from symbol
sequence probabilities, ``GreenKuboResult``).
"""

from bbdyn.approx.green_kubo import GreenKuboResult, green_kubo
from bbdyn.approx.jumps import JumpData
from bbdyn.approx.random_walk import (
    analytic_diffusion,
    energy_ratio,
    escape_time,
    jump_length_distribution,
    random_walk_diffusion,
)

__all__ = [
    "GreenKuboResult",
    "JumpData",
    "analytic_diffusion",
    "energy_ratio",
    "escape_time",
    "green_kubo",
    "jump_length_distribution",
    "random_walk_diffusion",
]
