"""High-precision reference for the flat bouncing ball (docs/model.md §1), with mpmath.

An independent check of the numba kernel ``bbdyn.core.flat``: it uses the
absolute-time form of the gap, a different root bracketing argument, and
``dps`` decimal digits.  It is slow (milliseconds per impact) and follows every
bounce, so it has no chattering: it refuses sequences that reach a stick.

First-root guarantee.  After an impact at time t0 with relative velocity
``vrel > 0`` the gap is ``G(tau) = y(t0 + tau) - y_p(t0 + tau)`` with

    G''(tau) = -g - A w^2 sin(w (t0 + tau))  in  [-(g + A w^2), A w^2 - g].

* Lower bound ``G'' >= -M`` (``M = g + A w^2``): ``G(tau) >= vrel tau - M tau^2/2 > 0``
  for ``0 < tau < 2 vrel / M``, so sampling starts at ``vrel / M``.
* Upper bound ``G'' <= K = A w^2 - g``: on a sampling interval [a, b] of width h,
  ``G - (linear interpolant)`` is >= ``-K h^2 / 8`` (it plus ``K (x-a)(b-x)/2`` is
  concave and vanishes at the ends).  So if ``min(G(a), G(b)) > K h^2 / 8``
  the interval holds no root; otherwise it is bisected, recursively.  For
  Gamma <= 1, K <= 0 and positive ends already exclude a root.
* ``G <= 0`` at ``tau_max``, when the free parabola is below -A, the plate's lowest point.

The first interval with ``G(b) <= 0`` is narrowed by the same guarded bisection
(the left half is kept whenever it may hold a root) and the root polished with
``mpmath.findroot`` (bracketing Illinois solver) inside that bracket.

Parameters are the float64 values the kernel receives (``Params.kernel()``),
converted exactly, so that any difference is the kernel's error.
"""

from __future__ import annotations

import numpy as np

from bbdyn.params import Params

__all__ = ["reference_impacts"]

#: Initial number of sampling intervals of one flight (refined where needed).
_N_SAMPLES = 64
#: Relative width (of the flight) of the bracket handed to findroot.
_BRACKET_REL = 1e-12
#: A post-impact relative velocity below this many g-periods means chattering,
#: which the reference does not follow (flights shorter than ~2e-9 periods).
_CHATTER_VREL = 1e-9


def reference_impacts(
    params: Params, phase0: float, vrel0: float, n_impacts: int, dps: int = 40
) -> dict[str, np.ndarray]:
    """Impact sequence of the flat ball computed with mpmath at ``dps`` digits.

    The particle leaves the plate at ``t0 = phase0 / w`` (relative velocity
    ``vrel0 > 0`` mm/s) and bounces with ``vrel+ = -alpha vrel-`` (docs/model.md, impact law).

    Parameters
    ----------
    params : Params
    phase0 : float
        Phase w t0 (rad) of the start.
    vrel0 : float
        Relative velocity v - u (mm/s) at the start, > 0.
    n_impacts : int
        Number of impacts to compute (>= 1).
    dps : int
        Decimal digits of the mpmath arithmetic (>= 20).

    Returns
    -------
    dict of float64 arrays, each of shape (n_impacts,)
        ``'t'`` absolute impact times (s), ``'phase'`` (w t mod 2 pi, rad),
        ``'v'`` absolute post-impact velocity (mm/s), ``'vrel'`` post-impact
        velocity relative to the plate (mm/s); all rounded from mpmath.

    Raises
    ------
    ValueError
        For invalid arguments, or if the sequence reaches a stick (chattering).

    Examples
    --------
    >>> ref = reference_impacts(Params(f=85.2), 0.3, 60.0, 3)
    >>> ref["t"].shape
    (3,)
    """
    import mpmath

    if not isinstance(n_impacts, int | np.integer) or n_impacts < 1:
        raise ValueError(f"n_impacts must be an integer >= 1, got {n_impacts!r}")
    if not isinstance(dps, int | np.integer) or dps < 20:
        raise ValueError(f"dps must be an integer >= 20, got {dps!r}")
    if not np.isfinite(phase0):
        raise ValueError(f"phase0 must be finite, got {phase0}")
    if not (np.isfinite(vrel0) and vrel0 > 0):
        raise ValueError(f"vrel0 must be a finite velocity > 0 mm/s, got {vrel0}")

    kp = params.kernel()
    out = {k: np.empty(n_impacts) for k in ("t", "phase", "v", "vrel")}
    with mpmath.workdps(dps):
        mpf = mpmath.mpf
        A, w, g, alpha = mpf(kp.A), mpf(kp.w), mpf(kp.g), mpf(kp.alpha)
        M = g + A * w * w
        K = A * w * w - g
        two_pi = 2 * mpmath.pi
        t0 = mpf(phase0) / w
        y0 = -A * mpmath.sin(w * t0)
        v0 = mpf(vrel0) - A * w * mpmath.cos(w * t0)  # absolute: vrel + u
        for n in range(n_impacts):
            vrel = v0 + A * w * mpmath.cos(w * t0)
            t0_, y0_, v0_ = t0, y0, v0

            def gap(tau, t0_=t0_, y0_=y0_, v0_=v0_):
                return y0_ + v0_ * tau - g * tau * tau / 2 + A * mpmath.sin(w * (t0_ + tau))

            tau = _first_root(gap, vrel, M, K, A, g, y0, v0, mpmath)
            t0 = t0 + tau
            w_minus = v0 - g * tau
            u = -A * w * mpmath.cos(w * t0)
            v0 = (1 + alpha) * u - alpha * w_minus
            y0 = -A * mpmath.sin(w * t0)
            vrel_plus = v0 - u
            if vrel_plus < _CHATTER_VREL * g / params.f:
                raise ValueError(
                    f"the sequence reaches a stick (chattering) at impact {n}: "
                    f"vrel+ = {float(vrel_plus):.3g} mm/s; the reference follows every "
                    "bounce and does not sum chattering"
                )
            out["t"][n] = float(t0)
            out["phase"][n] = float(mpmath.fmod(w * t0, two_pi))
            out["v"][n] = float(v0)
            out["vrel"][n] = float(vrel_plus)
    return out


def _first_root(gap, vrel, M, K, A, g, y0, v0, mpmath):
    """First root tau > 0 of ``gap`` (see the module docstring for the guarantee)."""
    a = vrel / M  # no root in (0, 2 vrel / M)
    # Free parabola below -A (the plate's lowest point) at tau_max: gap <= 0 there.
    tau_max = (v0 + mpmath.sqrt(v0 * v0 + 2 * g * (y0 + A))) / g
    if tau_max <= a:
        tau_max = 2 * a
    width_min = _BRACKET_REL * tau_max
    h = (tau_max - a) / _N_SAMPLES
    ga = gap(a)
    for i in range(1, _N_SAMPLES + 1):
        b = tau_max if i == _N_SAMPLES else a + h
        gb = gap(b)
        bracket = _bracket_in(gap, a, b, ga, gb, K, width_min)
        if bracket is not None:
            lo, hi = bracket
            root = mpmath.findroot(gap, (lo, hi), solver="illinois")
            if not lo <= root <= hi:  # a bracketing solver stays inside; check it
                root = (lo + hi) / 2
            return root
        a, ga = b, gb
    raise RuntimeError("no contact before tau_max: contradicts gap(tau_max) <= 0")


def _bracket_in(gap, a, b, ga, gb, K, width_min):
    """Narrow bracket [lo, hi] of the first root in [a, b] (ga > 0), or None if none.

    Recursive: an interval is excluded only if ``gb > 0`` and
    ``min(ga, gb) > K h^2 / 8`` (the curvature bound); the left half is searched first.
    """
    h = b - a
    if gb > 0 and (K <= 0 or min(ga, gb) > K * h * h / 8):
        return None
    if h <= width_min:
        # A dip narrower than this is deeper than -K h^2 / 8 (~1e-24 of the flight
        # scale squared times K): below any float64 resolution, treated as a miss.
        return (a, b) if gb <= 0 else None
    m = (a + b) / 2
    gm = gap(m)
    left = _bracket_in(gap, a, m, ga, gm, K, width_min)
    if left is not None:
        return left
    return _bracket_in(gap, m, b, gm, gb, K, width_min)
