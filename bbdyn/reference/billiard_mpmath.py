"""High-precision reference contact of one billiard flight (mpmath), the yardstick of B2.

``reference_flight`` solves the gap equation of one flight (docs/model.md §2) in
``MP_DPS`` decimal digits from the float64 inputs, so the exact kernel's contact time
and post-impact velocity can be compared with a root that is right to far below
float64 rounding.  Loads mpmath only when called.
"""

import math

__all__ = ["MP_DPS", "reference_flight"]

#: Digits of the mpmath reference (a contact time of ~1e-2 s to ~1e-40 s).
MP_DPS = 40


def reference_flight(kp, phase, xi0, vx, vyrel, k, tau_guess, dps: int = MP_DPS):
    """Contact time of one flight in mpmath, on tile offset ``k``, near ``tau_guess``.

    The gap (docs/model.md §2, ``Y(x, t)``) with every input the float64 value
    given (parameters of ``kp`` included):

        G(tau) = (vyrel + u) tau - g tau^2/2 - [y_p(t + tau) - y_p(t)]
                 - [sqrt(R^2 - xi(tau)^2) - sqrt(R^2 - xi0^2)],  xi(tau) = xi0 + vx tau - k d

    is bracketed around ``tau_guess`` (widening until it changes sign) and solved
    by bisection-safeguarded Anderson iteration.

    Returns
    -------
    tau, vx_plus, vy_plus : float
        Contact time (s) and absolute post-impact velocity (mm/s), rounded to float64.
    """
    import mpmath as mp

    with mp.workdps(dps):
        A, w, g, R, d = (mp.mpf(v) for v in (kp.A, kp.w, kp.g, kp.R, kp.d))
        al, be = mp.mpf(kp.alpha), mp.mpf(kp.beta)
        th, x0, ux, uy = mp.mpf(phase), mp.mpf(xi0), mp.mpf(vx), mp.mpf(vyrel)
        kk = mp.mpf(k)
        u0 = -A * w * mp.cos(th)
        S0 = mp.sqrt(R * R - x0 * x0)

        def gap(t):
            xi = x0 + ux * t - kk * d
            rise = -A * mp.sin(th + w * t) + A * mp.sin(th)
            return (uy + u0) * t - g * t * t / 2 - rise - (mp.sqrt(R * R - xi * xi) - S0)

        tg = mp.mpf(tau_guess)
        delta = max(tg * mp.mpf(2) ** -50, mp.mpf(10) ** -30)
        lo, hi = tg - delta, tg + delta
        for _ in range(200):
            if gap(lo) > 0 and gap(hi) <= 0:
                break
            delta *= 2
            lo, hi = max(tg - delta, mp.mpf(0)), tg + delta
        else:
            return math.nan, math.nan, math.nan
        tau = mp.findroot(gap, (lo, hi), solver="anderson")
        xi = x0 + ux * tau - kk * d
        S = mp.sqrt(R * R - xi * xi)
        vyr = uy - g * tau - (-A * w * mp.cos(th + w * tau) - u0)
        vn = (ux * xi + vyr * S) / R
        vt = (ux * S - vyr * xi) / R
        vn, vt = -al * vn, be * vt
        vx_p = (vn * xi + vt * S) / R
        vy_p = (vn * S - vt * xi) / R - A * w * mp.cos(th + w * tau)
        return float(tau), float(vx_p), float(vy_p)
