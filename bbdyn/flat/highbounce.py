"""High-bounce approximation of the flat ball: the dissipative standard map (docs/model.md §1).

If the plate's displacement is neglected against the flight height, a ball
leaving at phase ``theta`` with absolute upward velocity ``v`` lands after
``tau = 2 v / g`` with velocity ``-v``.  In the dimensionless velocity
``V = 2 w v / g`` (the flight's phase advance) the impact law
``v' = (1 + alpha) u(theta') + alpha v`` gives

    theta' = theta + V,     V' = alpha V - 2 (1 + alpha) Gamma cos(theta').

Its Jacobian ``[[1, 1], [2 (1+alpha) Gamma sin theta', alpha + 2 (1+alpha) Gamma sin theta']]``
has determinant ``alpha``; the exact map's is ``alpha vrel+ / (-vrel-)`` (``alpha^2`` on
a k/1 orbit), because the flux through a *moving* plate is lost here.

Error against the exact map (``bbdyn.flat.tongues``), all in closed form:

* the k/1 orbits are the same (``V = 2 pi k``, ``cos theta* = -pi k (1-alpha) / ((1+alpha)
  Gamma)``), so the lower tongue edge and the impact phases of k/1 orbits are exact;
* the upper edge is ``Gamma_hi^hb = sqrt(Gamma_lo^2 + 1)`` instead of
  ``sqrt(Gamma_lo^2 + b^2)``, ``b = 2 (1 + alpha^2) / (1 + alpha)^2 >= 1``: too low, by a
  relative ``(b^2 - 1) / (2 Gamma_lo^2)`` ~ 1/k^2 for large k, and by ~ ``(1 - alpha)^2``
  as alpha -> 1 (-5.2 % for k = 1, alpha = 0.5);
* one flight's phase advance is off by ``2 Gamma (sin(theta + x) - sin theta) / V + O(V^-2)``.

The dynamics depends on ``(Gamma, alpha)`` only: at fixed Gamma, A -> 0 is a rescaling
of lengths and velocities and does *not* make the approximation better.  The
approximation is good where the ball flies high above the plate's stroke
(``V >> Gamma``: large k, or alpha near 1 where the plate is at rest at impact).
"""

from __future__ import annotations

import math

import numpy as np

from bbdyn.core.flat import flat_flight
from bbdyn.core.highbounce import hb_run, hb_step
from bbdyn.core.plate import plate_velocity
from bbdyn.core.status import OK, STATUS_MESSAGES
from bbdyn.flat.tongues import tongue_gamma_hi, tongue_gamma_lo
from bbdyn.params import Params

__all__ = [
    "flight_phase_error",
    "hb_gamma_hi",
    "hb_jacobian",
    "hb_run",
    "hb_step",
    "tongue_errors",
]


def hb_jacobian(phase_next: float, gamma: float, alpha: float) -> np.ndarray:
    """Jacobian d(theta', V') / d(theta, V) (2, 2) at the landing phase ``phase_next``."""
    s = 2.0 * (1.0 + alpha) * gamma * math.sin(phase_next)
    return np.array([[1.0, 1.0], [s, alpha + s]])


def hb_gamma_hi(k, alpha, xp=math):
    """Upper k/1 edge of the high-bounce map: multiplier -1 at ``Gamma sin theta* = -1``."""
    return xp.sqrt(tongue_gamma_lo(k, alpha, xp) ** 2 + 1)


def tongue_errors(k: int, alpha: float) -> dict[str, float]:
    """Relative error of the high-bounce tongue edges against the exact map's.

    ``gamma_lo`` is exact (same fold); ``gamma_hi`` returns
    ``hb_gamma_hi / tongue_gamma_hi - 1`` (<= 0).  Frequencies scale as sqrt(Gamma).
    """
    rel = hb_gamma_hi(k, alpha) / tongue_gamma_hi(k, alpha) - 1.0
    return {"gamma_lo": 0.0, "gamma_hi": rel, "f_hi": math.sqrt(1.0 + rel) - 1.0}


def flight_phase_error(params: Params, phase: float, vrel: float) -> float:
    """High-bounce minus exact phase advance (rad) of one flight from ``(phase, vrel)``.

    ``vrel`` is the relative velocity after an impact (mm/s); the high-bounce
    flight uses the absolute velocity ``v = vrel + u(phase)``.
    """
    tau, _, status = flat_flight(float(phase), float(vrel), params.kernel())
    if status != OK:
        raise ValueError(
            f"no exact flight from phase {phase}, vrel {vrel}: {STATUS_MESSAGES[status]}"
        )
    v = vrel + plate_velocity(params.A, params.w, phase)
    return 2.0 * params.w * v / params.g - params.w * tau
