"""A generic high-order integrator with event detection as a yardstick: heyoka's Taylor method.

heyoka (https://bluescarni.github.io/heyoka.py/, the optional extra ``peers``) integrates
an ODE with an adaptive Taylor method (its order set by the tolerance, machine epsilon) and
finds the roots of an event function from the Taylor polynomial of that function over
every step, so a contact inside a step is found even when the gap does not change sign
at the step's ends.  Nothing here calls bbdyn's kernels: the flights are integrated
from the equations of docs/model.md, which makes them an independent check of
``bbdyn.core.flat`` and ``bbdyn.core.billiard`` (``tests/test_heyoka_cross_check.py``)
and a peer row of the work-precision benchmarks (scene B2).

Each class builds its integrator once (a JIT compilation) and sets time, state
and parameters for every flight, so timing a flight does not time the compilation.
Loads heyoka only when a class is instantiated (or ``heyoka_available`` is asked).
"""

import math

__all__ = [
    "heyoka_available",
    "heyoka_version",
    "missing_note",
    "fall_time",
    "clear_time",
    "FlatTaylor",
    "BilliardTaylor",
]


def heyoka_available() -> bool:
    """True if the optional package heyoka (extra ``peers``) can be imported."""
    try:
        import heyoka  # noqa: F401
    except ImportError:
        return False
    return True


def heyoka_version() -> str | None:
    """heyoka's version string, or None if it is not installed."""
    if not heyoka_available():
        return None
    import heyoka

    return heyoka.__version__


def missing_note(peers: dict | None) -> list[str]:
    """Table lines for a benchmark run without heyoka (``peers``: its ``meta["peers"]``)."""
    if peers is None or peers.get("heyoka") is not None:
        return []
    return ["heyoka not installed (pip install 'bbdyn[peers]'): no heyoka row"]


def fall_time(kp, phase: float, vyrel: float, height: float) -> float:
    """Time (s) after which a free flight is below -A, the floor's lowest point ever.

    The flight starts at phase ``phase`` (rad), ``height`` mm above the floor level
    ``y_p`` (a wedge's height) with vertical velocity ``vyrel`` (mm/s) relative to it.
    No contact can come later than this.
    """
    A, w, g = kp.A, kp.w, kp.g
    v_abs = vyrel - A * w * math.cos(phase)
    drop = height + A * (1.0 - math.sin(phase))  # start height above -A, >= 0
    return (v_abs + math.sqrt(v_abs * v_abs + 2.0 * g * drop)) / g


def clear_time(kp, phase: float, rate: float) -> float:
    """Time (s) during which a flight that leaves the floor stays clear of it.

    ``rate`` is the gap's rate at the start (mm/s), the gap being 0 there.  With
    ``G'' >= -M`` (``M = g + A w^2``; the arc's curvature only adds to ``G''``),
    ``G(tau) >= rate tau - M tau^2/2 > 0`` up to ``rate / M`` (half the zero of the
    bound).  A tangent start (``rate = 0``) inside the release window leaves because
    the floor accelerates downward faster than g (``G'' > 0``) until the window's end
    theta_e = 2 pi - asin(1/Gamma) (docs/model.md §1).  The integrator needs this:
    heyoka (7.13) reports no event root in a step whose event function is exactly
    zero at its start, so the search starts only after this time.
    """
    A, w, g = kp.A, kp.w, kp.g
    if rate > 0.0:
        return rate / (g + A * w * w)
    gamma = A * w * w / g
    theta = phase % (2.0 * math.pi)
    if rate == 0.0 and gamma > 1.0:
        theta_r, theta_e = math.pi + math.asin(1.0 / gamma), 2.0 * math.pi - math.asin(1.0 / gamma)
        if theta_r <= theta < theta_e:
            return (theta_e - theta) / w
    raise ValueError(
        f"a flight must leave the floor: gap rate {rate} mm/s must be > 0, or 0 inside the "
        f"release window (Gamma = {gamma:.4g} > 1), at phase {phase} rad; pass a state just "
        "after an impact or a release"
    )


def _event_index(outcome) -> int:
    """Index of the terminal event that stopped ``propagate_until``, or -1 if none did."""
    code = int(outcome[0])
    return -code - 1 if -(2**31) < code < 0 else -1


class FlatTaylor:
    """Flights of the flat ball with heyoka, relative to the plate.

    State ``(G, G')``: the gap above the plate (mm) and its rate (mm/s), with
    ``G'' = -g - A w^2 sin(phase + w tau)`` (docs/model.md §1); the terminal event is
    ``G = 0`` crossed downward.  ``tol`` is heyoka's relative and absolute tolerance
    (default: machine epsilon).
    """

    def __init__(self, kp, tol: float | None = None):
        import heyoka as hy

        G, Gp = hy.make_vars("G", "Gp")
        phase, aw2, g, w = (hy.par[i] for i in range(4))
        rhs = [(G, Gp), (Gp, -g - aw2 * hy.sin(phase + w * hy.time))]
        event = hy.t_event(G, direction=hy.event_direction.negative)
        options = {} if tol is None else {"tol": tol}
        pars = [0.0, kp.A * kp.w * kp.w, kp.g, kp.w]
        self.kp = kp
        self.ta = hy.taylor_adaptive(rhs, [0.0, 0.0], t_events=[event], pars=pars, **options)

    def flight(self, phase: float, vrel: float) -> tuple[float, float]:
        """Flight from an impact at ``phase`` (rad) with relative velocity ``vrel`` > 0 (mm/s).

        Returns ``(tau, vrel_minus)``: flight time (s) and relative velocity before
        the contact (mm/s); ``(inf, nan)`` if the integrator finds no contact before
        the flight is below the plate's lowest point.
        """
        ta = self.ta
        ta.time = 0.0
        ta.state[:] = (0.0, vrel)
        ta.pars[0] = phase
        ta.reset_cooldowns()
        t_end = fall_time(self.kp, phase, vrel, 0.0)
        for stop in (min(clear_time(self.kp, phase, vrel), t_end), t_end):
            if _event_index(ta.propagate_until(stop)) == 0:
                return float(ta.time), float(ta.state[1])
        return math.inf, math.nan


class BilliardTaylor:
    """Flights of the billiard with heyoka, over one tile at a time.

    State ``(Z, Z', X)``: the height gained since the start relative to the floor level
    ``y_p`` (mm), its rate (mm/s, the vertical velocity relative to the floor) and the
    horizontal displacement (mm), all zero at the start (so that tiny flights keep
    their relative accuracy), with ``Z'' = -g - A w^2 sin(phase + w tau)`` and
    ``X' = vx`` (docs/model.md §2).  Over tile offset ``k`` the local coordinate is
    ``xi = xi0 + X - k d`` and the terminal event is the gap to that tile's arc,

        Z - [b(xi) - b(xi0)] = Z - (k d - X)(xi0 + xi) / (sqrt(R^2 - xi^2) + S0)

    (``b(xi) = sqrt(R^2 - xi^2) - c0``, ``S0 = sqrt(R^2 - xi0^2)``), crossed downward.
    The flight is integrated up to the time at which ``xi`` reaches the tile's edge
    (``vx`` is constant, so that time is known); there ``k`` moves on by one.
    """

    def __init__(self, kp, tol: float | None = None):
        import heyoka as hy

        Z, Zp, X = hy.make_vars("Z", "Zp", "X")
        phase, aw2, g, w, vx, R, xi0, S0, shift = (hy.par[i] for i in range(9))
        rhs = [(Z, Zp), (Zp, -g - aw2 * hy.sin(phase + w * hy.time)), (X, vx)]
        xi = xi0 + X - shift
        drop = (shift - X) * (xi0 + xi) / (hy.sqrt((R - xi) * (R + xi)) + S0)
        event = hy.t_event(Z - drop, direction=hy.event_direction.negative)
        options = {} if tol is None else {"tol": tol}
        pars = [0.0, kp.A * kp.w * kp.w, kp.g, kp.w, 0.0, kp.R, 0.0, kp.R, 0.0]
        self.kp = kp
        self.ta = hy.taylor_adaptive(rhs, [0.0, 0.0, 0.0], t_events=[event], pars=pars, **options)

    def flight(
        self, phase: float, xi0: float, vx: float, vyrel: float
    ) -> tuple[float, int, float, float]:
        """Flight from a point ``xi0`` (mm) of the arc at ``phase`` (rad).

        ``vx, vyrel``: velocity just after the event (mm/s; ``vyrel`` relative to
        the floor).  Returns ``(tau, k, xi, vyrel_minus)``: flight time (s), tile
        offset of the contact, its local coordinate there (mm) and the vertical
        velocity relative to the floor before it (mm/s); ``(inf, k, nan, nan)`` if
        no contact is found before the flight is below the floor's lowest point.
        """
        kp = self.kp
        d, half = kp.d, 0.5 * kp.d
        S0 = math.sqrt((kp.R - xi0) * (kp.R + xi0))
        ta = self.ta
        ta.time = 0.0
        ta.state[:] = 0.0
        ta.pars[0], ta.pars[4], ta.pars[6], ta.pars[7] = phase, vx, xi0, S0
        ta.reset_cooldowns()
        t_end = fall_time(kp, phase, vyrel, (0.5 * d - xi0) * (0.5 * d + xi0) / (S0 + kp.c0))
        ta.state[1] = vyrel
        # The gap's rate at the start, Z' - b'(xi0) vx with b' = -xi / S.
        t_clear = min(clear_time(kp, phase, vyrel + vx * xi0 / S0), t_end)
        side = math.copysign(1.0, vx)
        k = 0
        if vx != 0.0 and side * xi0 >= half:  # on the edge, moving out: start on the neighbour
            k = int(side)
        # segments: the clear start, then one per tile the flight can reach
        n_segments = 3 + int(abs(vx) * t_end / d)
        reached = 0.0  # end of the last segment (ta.time may round it down)
        for _ in range(n_segments):
            ta.pars[8] = k * d
            # Time at which xi reaches the edge ahead (inf for vx = 0).
            edge = (side * half + k * d - xi0) / vx if vx != 0.0 else math.inf
            stop = min(edge, t_end, t_clear) if reached < t_clear else min(edge, t_end)
            if _event_index(ta.propagate_until(stop)) == 0:
                xi = xi0 + float(ta.state[2]) - k * d
                return float(ta.time), k, xi, float(ta.state[1])
            if stop == t_end:
                return math.inf, k, math.nan, math.nan
            if stop == edge:  # over to the neighbouring tile
                k += int(side)
            reached = stop
        raise RuntimeError(
            f"BilliardTaylor.flight did not end after {n_segments} segments "
            f"(phase {phase}, xi0 {xi0}, vx {vx}, vyrel {vyrel}): a bug in the tile bookkeeping"
        )
