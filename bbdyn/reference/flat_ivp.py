"""A general-purpose ODE solver as a yardstick for the flat ball: scipy's ``solve_ivp``.

``ivp_flight`` integrates one flight with an explicit Runge-Kutta method and a terminal
event, in the lab frame or relative to the plate; the work-precision benchmark
(scene B2-FLAT) compares it with the exact map.  Loads scipy only when called.
"""

import math

__all__ = ["ivp_flight"]


def ivp_flight(
    kp, phase: float, vrel: float, method: str, frame: str, rtol: float, max_step: float = math.inf
):
    """One flight with ``scipy.integrate.solve_ivp`` and a terminal event.

    Parameters
    ----------
    kp : KernelParams
    phase, vrel : float
        Start phase (rad) and relative velocity (mm/s); local time starts at 0.
    method : {"RK45", "DOP853"}
    frame : {"lab", "plate"}
        ``lab``: state (y, v) with y'' = -g and event y - y_p; ``plate``: state
        (G, G') with G'' = -g - A w^2 sin(phase + w tau) and event G.
    rtol : float
        Relative tolerance; the absolute tolerance is ``rtol`` times the scales
        (A mm, A w mm/s).
    max_step : float
        Largest step, in driving periods (scipy's default: no limit).

    Returns
    -------
    (tau, vrel_minus): flight time (s) and relative velocity before impact (mm/s);
    ``(inf, nan)`` if no event was found before the parabola falls below -A.
    """
    from scipy.integrate import solve_ivp

    A, w, g = kp.A, kp.w, kp.g
    aw2 = A * w * w
    if frame == "lab":
        y0 = [-A * math.sin(phase), vrel - A * w * math.cos(phase)]

        def rhs(t, y):
            return [y[1], -g]

        def event(t, y):
            return y[0] + A * math.sin(phase + w * t)

    elif frame == "plate":
        y0 = [0.0, vrel]

        def rhs(t, y):
            return [y[1], -g - aw2 * math.sin(phase + w * t)]

        def event(t, y):
            return y[0]

    else:
        raise ValueError(f"frame must be 'lab' or 'plate', got {frame!r}")
    event.terminal = True
    event.direction = -1
    v_abs = vrel - A * w * math.cos(phase)
    tau_max = (v_abs + math.sqrt(v_abs * v_abs + 2.0 * g * (A - A * math.sin(phase)))) / g
    sol = solve_ivp(
        rhs,
        (0.0, 1.01 * tau_max),
        y0,
        method=method,
        rtol=rtol,
        atol=[rtol * A, rtol * A * w],
        events=event,
        max_step=max_step * kp.period,
    )
    if sol.t_events[0].size == 0:
        return math.inf, math.nan
    tau = float(sol.t_events[0][0])
    rate = float(sol.y_events[0][0][1])
    if frame == "lab":
        rate += A * w * math.cos(phase + w * tau)  # v - u
    return tau, rate
