"""High-precision reference contact of one billiard flight (mpmath), the yardstick of B2.

``reference_flight`` solves the gap equation of one flight (docs/model.md §2) in
``MP_DPS`` decimal digits from the float64 inputs, so the exact kernel's contact time
and post-impact velocity can be compared with a root that is right to far below
float64 rounding.  Loads mpmath only when called.
"""

import math

__all__ = ["MP_DPS", "reference_chatter", "reference_flight"]

#: Digits of the mpmath reference (a contact time of ~1e-2 s to ~1e-40 s).
MP_DPS = 40


def _mp_constants(mp, kp):
    """The parameters of ``kp`` as mpmath numbers: ``A, w, g, R, d, alpha, beta``."""
    return tuple(mp.mpf(v) for v in (kp.A, kp.w, kp.g, kp.R, kp.d, kp.alpha, kp.beta))


def _mp_flight(mp, kp, th, x0, ux, uy, kk):
    """The gap ``G(tau)`` (mm) of a flight from phase ``th`` at ``x0`` with relative velocity
    ``(ux, uy)`` over tile offset ``kk`` (all mpmath numbers; formula in ``reference_flight``),
    and the position and relative velocity ``(xi, vx, vyrel)`` reached at ``tau``."""
    A, w, g, R, d, _, _ = _mp_constants(mp, kp)
    u0 = -A * w * mp.cos(th)
    S0 = mp.sqrt(R * R - x0 * x0)

    def gap(t):
        xi = x0 + ux * t - kk * d
        rise = -A * mp.sin(th + w * t) + A * mp.sin(th)
        return (uy + u0) * t - g * t * t / 2 - rise - (mp.sqrt(R * R - xi * xi) - S0)

    def state(t):
        return x0 + ux * t - kk * d, ux, uy - g * t - (-A * w * mp.cos(th + w * t) - u0)

    return gap, state


def _mp_bounce(mp, kp, xi, ux, vyr):
    """Relative velocity after the bounce at ``xi`` (docs/model.md §2) and its normal and
    tangential components before it: ``(vx, vyrel, vn_minus, vt_minus)``."""
    _, _, _, R, _, al, be = _mp_constants(mp, kp)
    S = mp.sqrt(R * R - xi * xi)
    vn = (ux * xi + vyr * S) / R
    vt = (ux * S - vyr * xi) / R
    vn_p, vt_p = -al * vn, be * vt
    return (vn_p * xi + vt_p * S) / R, (vn_p * S - vt_p * xi) / R, vn, vt


def _mp_contact(mp, gap, tau_guess):
    """Root of ``gap`` near ``tau_guess``: bracketed by widening, then solved; None if no sign
    change is found."""
    tg = mp.mpf(tau_guess)
    delta = max(tg * mp.mpf(2) ** -50, mp.mpf(10) ** -30)
    lo, hi = tg - delta, tg + delta
    for _ in range(200):
        if gap(lo) > 0 and gap(hi) <= 0:
            return mp.findroot(gap, (lo, hi), solver="anderson")
        delta *= 2
        lo, hi = max(tg - delta, mp.mpf(0)), tg + delta
    return None


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
        th = mp.mpf(phase)
        gap, state = _mp_flight(mp, kp, th, mp.mpf(xi0), mp.mpf(vx), mp.mpf(vyrel), mp.mpf(k))
        tau = _mp_contact(mp, gap, tau_guess)
        if tau is None:
            return math.nan, math.nan, math.nan
        xi, ux, vyr = state(tau)
        vx_p, vyr_p, _, _ = _mp_bounce(mp, kp, xi, ux, vyr)
        u = -mp.mpf(kp.A) * mp.mpf(kp.w) * mp.cos(th + mp.mpf(kp.w) * tau)
        return float(tau), float(vx_p), float(vyr_p + u)


def reference_chatter(kp, phase, xi0, vx, vyrel, tail: float = 1e-24, dps: int = 60):
    """Time (s) and place (mm) at which a chattering sequence on one arc comes to rest,
    bounce by bounce in mpmath.

    From an event at ``phase`` and ``xi0`` with relative velocity ``(vx, vyrel)`` leaving the
    arc, every hop's contact (``reference_flight``'s gap, state carried in ``dps`` digits
    from hop to hop, never rounded) and bounce is solved until the next hops sum to less
    than ``tail`` s (their closed-form flat sum ``2 V_n / (g_n (1 - alpha))`` is added).
    Independent of the kernel's closed-form chatter sum, which it checks.

    Returns
    -------
    t_rest, xi_rest : float
        Time from ``phase`` to the accumulation point (s) and local coordinate there (mm).
    hops : int
        Hops solved.
    """
    import mpmath as mp

    with mp.workdps(dps):
        A, w, g, R, d, al, _ = _mp_constants(mp, kp)
        th, x0, ux, uy = (mp.mpf(v) for v in (phase, xi0, vx, vyrel))
        total = mp.mpf(0)
        for hop in range(100 * dps):
            S = mp.sqrt(R * R - x0 * x0)
            vn = (ux * x0 + uy * S) / R
            vt = (ux * S - uy * x0) / R
            g_n = ((g + A * w * w * mp.sin(th)) * S - vt * vt) / R
            if not (vn > 0 and g_n > 0):
                raise ValueError(f"hop {hop} does not chatter: V_n = {vn}, g_n = {g_n}")
            guess = 2 * vn / g_n
            if guess / (1 - al) < tail:
                return float(total + guess / (1 - al)), float(x0), hop
            gap, state = _mp_flight(mp, kp, th, x0, ux, uy, mp.mpf(0))
            tau = _mp_contact(mp, gap, guess)
            if tau is None or abs(state(tau)[0]) >= d / 2:
                raise ValueError(f"hop {hop} has no contact on the arc near {float(guess)} s")
            total += tau
            x0, ux, vyr = state(tau)
            th += w * tau
            ux, uy, _, _ = _mp_bounce(mp, kp, x0, ux, vyr)
        raise ValueError(f"no rest after {100 * dps} hops")
