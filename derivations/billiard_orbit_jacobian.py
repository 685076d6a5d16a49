"""A periodic orbit of the billiard and its Jacobian in closed form (sympy).

Run ``python derivations/billiard_orbit_jacobian.py`` to print each step.  The
functions return sympy expressions; ``tests/test_derivations_billiard_jacobian.py``
compares them with the tangent dynamics of ``bbdyn/core/billiard_tangent.py``
(the event Jacobian on the orbit, entry by entry, and the largest Lyapunov
exponent of a run along it).  Model and units: ``docs/model.md`` (mm, s).

The orbit.  A particle on the top of an arc (``xi = 0``, where the normal is
vertical) moving straight up (``vx = 0``) comes down on the same top: its
vertical motion is the flat ball's on a floor raised by the constant ``h``, so
the flat k/1 orbit (every flight ``k`` driving periods, ``v* = g pi k / w``,
``cos theta* = -pi k (1 - alpha) / ((1 + alpha) Gamma)``; ``derivations/flat_tongues.py``)
is an exact periodic orbit of the billiard.

The event map.  Section coordinates just after an impact are
``(theta, xi, vx, vyrel)`` (phase, position on the arc, horizontal velocity,
vertical velocity relative to the floor).  With ``x = w tau`` the phase advance
of the flight and ``b(xi) = sqrt(R^2 - xi^2)`` (up to a constant), the contact is
(on the arc of the tile ``shift / d`` tiles away) where the **gap**

    G = y_p(theta) + (vyrel + u(theta)) x / w - g x^2 / (2 w^2) - y_p(theta + x)
        + b(xi) - b(xi + vx x / w - shift)

vanishes, and the **impact** at ``xi' = xi + vx x / w`` (local ``xi' - shift``) with
the velocity relative to the floor ``W = (vx, vyrel + u(theta) - g x / w - u(theta + x))`` gives

    (vx', vyrel') = -alpha (W . n) n + beta (W . t) t,
    n = (xi' - shift, S') / R,   t = (S', shift - xi') / R.

The Jacobian follows from the implicit function theorem, ``dx/dz = -G_z / G_x``
(no approximation).

On the orbit.  By the mirror symmetry ``xi -> -xi`` the Jacobian splits into the
flat ball's ``(theta, vyrel)`` block and a *curvature block* for ``(xi, vx)``:

    [[1, tau], [kappa, beta + kappa tau]],   tau = 2 pi k / w,   kappa = (alpha + beta) V / R,

with ``V = 2 v* / (1 + alpha)`` the speed of the fall onto the top: a particle
landing at ``xi`` is kicked sideways by the tilted normal, ``vx' = beta vx +
(alpha + beta) V xi' / R``.  The block has determinant ``beta`` and trace
``1 + beta + kappa tau > 1 + beta``, so one multiplier exceeds 1:

    mu = (T + sqrt(T^2 - 4 beta)) / 2,   T = 1 + beta + kappa tau,
    kappa tau = 4 pi^2 k^2 g (alpha + beta) / ((1 + alpha) w^2 R).

Where the flat k/1 orbit is stable (inside its Arnold tongue) the top orbit is a
saddle whose largest Lyapunov exponent is ``log mu`` per collision and
``log(mu) / tau`` per second.
"""

import importlib.util
from pathlib import Path

import sympy as sp

theta, xi, vx, vy, x = sp.symbols("theta xi v_x v_yrel x", real=True)
A, w, g, R, Gamma = sp.symbols("A w g R Gamma", positive=True)
shift = sp.symbols("shift", real=True)  # tile offset l d of the arc hit (mm): xi' - shift is local
alpha, beta = sp.symbols("alpha beta", nonnegative=True)  # as in flat_tongues.py: one symbol
k = sp.symbols("k", integer=True, positive=True)
sin_star = sp.symbols("s_star", real=True)  # sin(theta*) on the orbit
STATE = (theta, xi, vx, vy)


def _flat_tongues():
    """The flat ball's derivation (``derivations/flat_tongues.py``), for its k/1 orbit."""
    path = Path(__file__).resolve().parent / "flat_tongues.py"
    spec = importlib.util.spec_from_file_location("derivation_flat_tongues", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def plate_height(phase):
    """y_p = -A sin(phase) (mm)."""
    return -A * sp.sin(phase)


def plate_velocity(phase):
    """u = -A w cos(phase) (mm/s)."""
    return -A * w * sp.cos(phase)


def arc(position):
    """b = sqrt(R^2 - xi^2): the arc's height up to a constant (mm)."""
    return sp.sqrt(R**2 - position**2)


def gap():
    """G(theta, xi, vx, vyrel; x): particle height minus floor height after a phase advance x."""
    v_abs = vy + plate_velocity(theta)
    return (
        plate_height(theta) + v_abs * x / w - g * x**2 / (2 * w**2) - plate_height(theta + x)
        + arc(xi) - arc(xi + vx * x / w - shift)
    )  # fmt: skip


def event_map():
    """(theta', xi', vx', vyrel') as functions of the state and x (x from G = 0).

    ``xi'`` is lifted (``xi + vx x / w``); the arc hit is that of the tile ``shift / d``
    tiles away, so ``xi' - shift`` is the local coordinate of the contact."""
    xi_new = xi + vx * x / w
    W = sp.Matrix([vx, vy + plate_velocity(theta) - g * x / w - plate_velocity(theta + x)])
    local = xi_new - shift
    S = arc(local)
    n = sp.Matrix([local, S]) / R
    t = sp.Matrix([S, -local]) / R
    v_new = -alpha * (W.dot(n)) * n + beta * (W.dot(t)) * t
    return [theta + x, xi_new, v_new[0], v_new[1]]


def event_jacobian():
    """d(theta', xi', vx', vyrel') / d(theta, xi, vx, vyrel): implicit function theorem on G."""
    G = gap()
    dx = {z: -sp.diff(G, z) / sp.diff(G, x) for z in STATE}
    return sp.Matrix([[sp.diff(o, z) + sp.diff(o, x) * dx[z] for z in STATE] for o in event_map()])


def top_orbit():
    """The k/1 orbit on an arc top: the point (x = 2 pi k, xi = vx = 0, vrel*) and cos theta*."""
    orbit = _flat_tongues().k1_orbit()
    return {x: 2 * sp.pi * k, xi: 0, vx: 0, vy: orbit["vrel"], shift: 0}, orbit["cos_theta"]


def top_orbit_jacobian():
    """The event Jacobian on the top orbit, in Gamma, alpha, beta, R, g, w, k, s* = sin theta*."""
    point, cos_star = top_orbit()
    J = event_jacobian().subs(point)
    J = J.subs(sp.cos(theta), cos_star.subs(Gamma, A * w**2 / g)).subs(sp.sin(theta), sin_star)
    return sp.simplify(J.subs(A, Gamma * g / w**2))


def curvature_block():
    """The (xi, vx) block on the orbit: [[1, tau], [kappa, beta + kappa tau]]."""
    tau = 2 * sp.pi * k / w
    V = 2 * (g * sp.pi * k / w) / (1 + alpha)  # fall speed onto the top, 2 v* / (1 + alpha)
    kappa = (alpha + beta) * V / R
    return sp.Matrix([[1, tau], [kappa, beta + kappa * tau]])


def largest_multiplier():
    """The multiplier > 1 of the curvature block, (T + sqrt(T^2 - 4 beta)) / 2."""
    B = curvature_block()
    T, D = B.trace(), B.det()
    return (T + sp.sqrt(T**2 - 4 * D)) / 2


if __name__ == "__main__":
    sp.init_printing(use_unicode=True)
    print("Gap G(theta, xi, vx, vyrel; x) = 0:")
    sp.pprint(gap())
    point, cos_star = top_orbit()
    print("\nTop orbit:", point, "  cos theta* =", cos_star)
    J = top_orbit_jacobian()
    print("\nEvent Jacobian on the top orbit (rows/columns theta, xi, vx, vyrel):")
    sp.pprint(J)
    print("\nCurvature block [[1, tau], [kappa, beta + kappa tau]]:")
    sp.pprint(curvature_block())
    print("det =", sp.simplify(curvature_block().det()))
    print("kappa tau =", sp.simplify(curvature_block()[1, 0] * 2 * sp.pi * k / w))
    print("\nLargest multiplier mu =")
    sp.pprint(sp.simplify(largest_multiplier()))
