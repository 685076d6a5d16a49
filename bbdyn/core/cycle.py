"""The release map of a stick-release cycle and its multiplier (tangent dynamics).

A RELEASE at ``theta_r = pi + asin(1/Gamma)`` (``stick_release``) leaves with the floor's
velocity, whatever came before: the state after it is the point ``x = tile d + xi`` alone
(mm).  The events up to the p-th release after it define the *release map* ``x -> F(x)``,
smooth while the sequence of events (tiles, kinds, wedge reflections) stays the same.  Its
derivative, the *multiplier* ``lam = F'(x)``, is carried along by the tangent dynamics of
``billiard_tangent`` (``billiard_tangent_event``, bitwise the events of ``billiard_event``):
a tangent vector ``e_x`` at the first release, multiplied by each event's Jacobian, ends at
the last release as ``lam e_x`` (that release's Jacobian keeps only the ``x`` component).

What it is for (``core.ensemble.fast_forward``): where ``|lam| < 1`` the cycle contracts onto
a fixed point ``x*`` of F, and by the mean value theorem ``|x - x*| <= |F(x) - x| / (1 -
|lam|)`` to first order in ``x - x*``: a proven bound on how far the releases still drift.
"""

import numpy as np
from numba import njit

from bbdyn.core.billiard_tangent import billiard_tangent_event
from bbdyn.core.status import OK, RELEASE
from bbdyn.core.tolerances import FMA


@njit(cache=True, fastmath=FMA)
def release_map(periods, phase, tile, xi, releases, max_events, kp):
    """Run ``releases`` stick-release cycles from a RELEASE at ``theta_r`` with its tangent.

    Parameters
    ----------
    periods, phase, tile, xi : float
        The release (it leaves at rest relative to the floor).
    releases : int
        Releases to reach (the lag p of the cycle).
    max_events : int
        Events at most (the caller's cycle length: more means another sequence).
    kp : KernelParams

    Returns
    -------
    (lam, periods, phase, tile, xi, events, ok)
        The multiplier ``dF/dx``, the release reached, the events taken; ``ok = False``
        when the kernel fails, ``max_events`` pass first, or the last release is not one at
        ``theta_r`` (a release at once inside the window carries its phase too).
    """
    J = np.empty((4, 4))
    W = np.empty((4, 4))
    T = np.empty((4, 4))
    v0, v1, v2, v3 = 0.0, 1.0, 0.0, 0.0  # d(theta, x, vx, vyrel) per dx at the start
    # kind as a plain int64, not the literal RELEASE: numba would compile the tangent event
    # twice, once for each type (3 s)
    vx, vyrel, kind = 0.0, 0.0, np.int64(RELEASE)
    left = releases
    for n in range(1, max_events + 1):
        out = billiard_tangent_event(periods, phase, tile, xi, vx, vyrel, kind, kp, J, W, T)
        if out[7] != OK:
            break
        periods, phase, tile, xi, vx, vyrel, kind = out[:7]
        v0, v1, v2, v3 = (
            J[0, 0] * v0 + J[0, 1] * v1 + J[0, 2] * v2 + J[0, 3] * v3,
            J[1, 0] * v0 + J[1, 1] * v1 + J[1, 2] * v2 + J[1, 3] * v3,
            J[2, 0] * v0 + J[2, 1] * v1 + J[2, 2] * v2 + J[2, 3] * v3,
            J[3, 0] * v0 + J[3, 1] * v1 + J[3, 2] * v2 + J[3, 3] * v3,
        )
        if kind == RELEASE:
            left -= 1
            if left == 0:
                ok = J[0, 0] == 0.0  # released at theta_r, not at once inside the window
                return v1, periods, phase, tile, xi, n, ok
    return np.nan, periods, phase, tile, xi, max_events, False
