"""Kernels of the high-bounce approximation (dissipative standard map); see
``bbdyn.flat.highbounce``.

    theta' = theta + V,     V' = alpha V - 2 (1 + alpha) Gamma cos(theta'),

with ``V = 2 w v / g`` the flight's phase advance.
"""

import math

from numba import njit

from bbdyn.core.plate import TWO_PI
from bbdyn.core.tolerances import FMA


@njit(cache=True, fastmath=FMA)
def hb_step(phase, V, gamma, alpha):
    """One bounce of the dissipative standard map; returns ``(phase' mod 2 pi, V')``."""
    phase_new = (phase + V) % TWO_PI
    return phase_new, alpha * V - 2.0 * (1.0 + alpha) * gamma * math.cos(phase_new)


@njit(cache=True, fastmath=FMA)
def hb_run(phase, V, gamma, alpha, out_phase, out_V):
    """Iterate ``hb_step`` and write the phases and velocities into ``out_*`` (in place).

    Stops early (returns the count written) when ``V <= 0``: the ball would not
    leave the plate, which the approximation cannot describe.
    """
    for i in range(out_phase.shape[0]):
        phase, V = hb_step(phase, V, gamma, alpha)
        if not V > 0.0:
            return i
        out_phase[i] = phase
        out_V[i] = V
    return out_phase.shape[0]
