"""Arnold tongues of the bouncing ball, derived from the exact impact map (sympy).

Run ``python derivations/flat_tongues.py`` to print each step.  The functions
return the sympy expressions; ``tests/test_derivations.py`` checks that
``bbdyn/flat/tongues.py`` uses exactly these.

The model (docs/model.md, section 1).  A ball bounces on a plate at height
``y_p(t) = -A sin(w t)``, velocity ``u(t) = -A w cos(w t)``.  Let an impact
happen at phase ``theta = w t`` with upward velocity ``v`` just after it, and let
the next one come after a phase advance ``x = w tau``.  Between them the ball
flies freely, so ``x`` solves the **gap equation**

    F(theta, v, x) = y_p(theta) + v x / w - g x^2 / (2 w^2) - y_p(theta + x) = 0,

and at the new impact the restitution law ``v+ - u = alpha (u - v-)`` with
``v- = v - g x / w`` gives the **exact impact map**

    theta' = theta + x,    v' = (1 + alpha) u(theta + x) - alpha (v - g x / w).

No approximation is made: ``x`` is a function of ``(theta, v)`` defined only
implicitly (there is no closed form for a general flight), but its derivatives
follow from the implicit function theorem, ``dx/dtheta = -F_theta / F_x`` and
``dx/dv = -F_v / F_x``.  That is all one needs for linear stability.

Steps:

1. the Jacobian of the exact map for any flight;
2. the k/1 orbit (``x = 2 pi k``) in closed form: ``v*`` and ``cos theta*``;
3. trace and determinant of the Jacobian on it;
4. the tongue edges: multiplier +1 (birth in a saddle-node) and -1 (period doubling).
"""

import sympy as sp

# Symbols.  k is a positive integer so that sympy reduces sin(theta + 2 pi k) = sin(theta).
theta, x = sp.symbols("theta x", real=True)
v, A, w, g, Gamma = sp.symbols("v A w g Gamma", positive=True)
alpha = sp.symbols("alpha", nonnegative=True)
k = sp.symbols("k", integer=True, positive=True)
vrel = sp.symbols("v_rel", positive=True)
sin_star = sp.symbols("s_star", real=True)  # sin(theta*) on the orbit


def plate_height(phase):
    """y_p = -A sin(phase) (mm)."""
    return -A * sp.sin(phase)


def plate_velocity(phase):
    """u = -A w cos(phase) (mm/s)."""
    return -A * w * sp.cos(phase)


def gap_equation():
    """F(theta, v, x): ball height minus plate height after a phase advance x (mm)."""
    return plate_height(theta) + v * x / w - g * x**2 / (2 * w**2) - plate_height(theta + x)


def exact_map():
    """(theta', v') of the exact map, as functions of (theta, v, x) with x from F = 0."""
    v_minus = v - g * x / w
    return theta + x, (1 + alpha) * plate_velocity(theta + x) - alpha * v_minus


def jacobian_absolute():
    """d(theta', v') / d(theta, v) (2x2 sympy Matrix in theta, v, x), implicit function theorem."""
    F = gap_equation()
    dx = {z: -sp.diff(F, z) / sp.diff(F, x) for z in (theta, v)}
    rows = []
    for out in exact_map():
        # total derivative: direct dependence plus dependence through x
        rows.append([sp.diff(out, z) + sp.diff(out, x) * dx[z] for z in (theta, v)])
    return sp.Matrix(rows)


def jacobian_relative():
    """The same Jacobian in the simulator's variables (theta, vrel = v - u(theta)).

    With ``C = d(theta, vrel)/d(theta, v) = [[1, 0], [-u'(theta), 1]]`` the map in
    the new variables has Jacobian ``C(theta') J C(theta)^-1``; ``v`` is replaced by
    ``vrel + u(theta)``.  Conjugation leaves trace, determinant and multipliers unchanged.
    """
    du = sp.diff(plate_velocity(theta), theta)
    C_in = sp.Matrix([[1, 0], [-du, 1]])
    C_out = sp.Matrix([[1, 0], [-du.subs(theta, theta + x), 1]])
    J = C_out * jacobian_absolute() * C_in.inv()
    return J.subs(v, vrel + plate_velocity(theta))


def k1_orbit():
    """The k/1 orbit: ``x = 2 pi k``, same height at both impacts, v' = v.

    Returns a dict with ``v`` (post-impact velocity), ``vrel`` (relative to the
    plate) and ``cos_theta`` (of the impact phase), Gamma = A w^2 / g eliminated for A.
    """
    F = gap_equation().subs(x, 2 * sp.pi * k)
    v_star = sp.solve(sp.simplify(F), v)[0]  # y_p(theta + 2 pi k) = y_p(theta): v x = g x^2 / 2w
    v_next = exact_map()[1].subs({x: 2 * sp.pi * k, v: v_star})
    c = sp.symbols("c", real=True)
    cos_star = sp.solve(sp.Eq(v_next.subs(sp.cos(theta), c), v_star), c)[0]
    cos_star = sp.simplify(cos_star.subs(A, Gamma * g / w**2))
    vrel_star = sp.simplify(v_star + A * w * cos_star.subs(Gamma, A * w**2 / g))
    return {"v": v_star, "vrel": vrel_star, "cos_theta": cos_star}


def k1_trace_det():
    """(trace, det) of the Jacobian on the k/1 orbit, in Gamma, alpha and s* = sin theta*."""
    orbit = k1_orbit()
    J = jacobian_absolute().subs({x: 2 * sp.pi * k, v: orbit["v"]})
    J = J.subs(sp.cos(theta), orbit["cos_theta"].subs(Gamma, A * w**2 / g))
    J = J.subs(sp.sin(theta), sin_star).subs(A, Gamma * g / w**2)
    return sp.simplify(J.trace()), sp.simplify(J.det())


def edge_conditions():
    """``det(J - I)`` and ``det(J + I)`` on the k/1 orbit: zero at multiplier +1 and -1."""
    tr, det = k1_trace_det()
    return sp.factor(1 - tr + det), sp.factor(1 + tr + det)


def gamma_lo():
    """Lower edge: multiplier +1 needs sin theta* = 0, i.e. cos theta* = -1 (it is < 0)."""
    plus_one, _ = edge_conditions()
    assert sp.solve(plus_one, sin_star) == [0]
    return sp.solve(sp.Eq(k1_orbit()["cos_theta"], -1), Gamma)[0]


def gamma_hi():
    """Upper edge: multiplier -1; then sin theta* < 0, and sin^2 + cos^2 = 1 gives Gamma."""
    _, minus_one = edge_conditions()
    s_hi = sp.solve(minus_one, sin_star)[0]  # Gamma s* = -2 (1 + alpha^2) / (1 + alpha)^2
    unit = sp.Eq(s_hi**2 + k1_orbit()["cos_theta"] ** 2, 1)
    roots = [r for r in sp.solve(unit, Gamma) if r.is_positive is not False]
    return sp.simplify(roots[-1])


if __name__ == "__main__":
    sp.init_printing(use_unicode=True)
    print("Gap equation F(theta, v, x) = 0:")
    sp.pprint(gap_equation())
    print("\nExact map (theta', v'):")
    sp.pprint(exact_map())
    print("\nJacobian d(theta', v')/d(theta, v) by the implicit function theorem:")
    sp.pprint(sp.simplify(jacobian_absolute()))
    orbit = k1_orbit()
    print("\nk/1 orbit (x = 2 pi k):")
    for name, expr in orbit.items():
        print(f"  {name} =", expr)
    tr, det = k1_trace_det()
    print("\nOn the orbit: trace =", tr, "   det =", det)
    plus_one, minus_one = edge_conditions()
    print("det(J - I) =", plus_one, "  (zero: multiplier +1)")
    print("det(J + I) =", minus_one, "  (zero: multiplier -1)")
    print(
        "\nStable where both are positive: sin theta* < 0 and Gamma sin theta* > -2(1+a^2)/(1+a)^2"
    )
    print("\nGamma_lo =", gamma_lo())
    print("Gamma_hi =", gamma_hi())
