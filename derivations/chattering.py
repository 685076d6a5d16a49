"""Chattering: the closed-form sum of infinitely many ever smaller bounces.

Run ``python derivations/chattering.py`` to print the derivation step by step.
``flat_stick_time()``, ``arc_gravity()``, ``arc_stick_time()`` and
``arc_drift()`` return the results as sympy expressions, which the tests
compare with ``chatter_time`` (``bbdyn/core/flat.py``) and ``chatter_sum``
(``bbdyn/core/billiard.py``) and with a bounce-by-bounce sum.  The model is in
``docs/model.md``; units mm, s.

Over a chattering sequence (flights far shorter than a driving period) the
floor's acceleration hardly changes, so in the floor's frame the particle feels
a constant effective gravity ``g_eff = g + A w^2 sin(w t)`` (floor height
``-A sin(w t)``).

Flat plate
----------
1. A particle leaving the plate with relative velocity v comes back after
   ``tau_0 = 2 v / g_eff`` with relative velocity -v.
2. The impact returns ``alpha v``, so flight k lasts ``tau_k = tau_0 alpha^k``.
3. For ``alpha < 1`` the flights accumulate: ``tau_inf = sum_k tau_k =
   tau_0 / (1 - alpha)`` (inelastic collapse); after it the particle sticks.

Arc (radius R, contact at local coordinate xi, ``S = sqrt(R^2 - xi^2)``)
-------------------------------------------------------------------------
4. The normal is ``n = (xi, S)/R``, the tangent ``t = (S, -xi)/R`` (as in
   ``bbdyn/core/floor.py``).  The floor-frame gravity ``(0, -g_eff)`` has the
   normal part ``-g_eff S / R`` and the tangential part ``g_t = g_eff xi / R``.
5. A particle moving along the convex arc at tangential speed ``v_t`` needs the
   centripetal acceleration ``v_t^2 / R`` towards the centre, which the normal
   pull pays first: the hops feel ``g_n = (g_eff S - v_t^2) / R``.  The normal
   motion is then step 1-3 with ``g_n``: ``tau_0 = 2 v_n / g_n``,
   ``tau_inf = tau_0 / (1 - alpha)``.
6. Tangentially, flight k starts with velocity ``u_k`` and gains ``g_t tau_k``;
   the bounce multiplies by beta: ``u_{k+1} = beta (u_k + g_t tau_k)``, so
   ``u_k = beta^k v_t + g_t sum_{j<k} beta^(k-j) tau_j``.
7. The drift is ``ds = sum_k (u_k tau_k + g_t tau_k^2 / 2)``.  The double sum
   is reordered with ``k = j + m`` (m >= 1): ``sum_j alpha^(2j) sum_m
   (alpha beta)^m``, two geometric series.  Result:

       ds = v_t tau_0 / (1 - alpha beta)
            + g_t tau_0^2 [alpha beta / ((1 - alpha^2)(1 - alpha beta)) + 1 / (2 (1 - alpha^2))].

   ``u_k`` tends to zero (beta < 1): the particle comes to rest on the arc.
"""

from __future__ import annotations

import sympy as sp

alpha, beta = sp.symbols("alpha beta", positive=True)  # 0 < alpha, beta < 1
v, g_eff, R, xi, S, v_n, v_t = sp.symbols("v g_eff R xi S v_n v_t", positive=True)
tau_0, g_t = sp.symbols("tau_0 g_t", real=True)
k, j, m = sp.symbols("k j m", integer=True, nonnegative=True)


def geometric(term: sp.Expr, index: sp.Symbol, start: int = 0) -> sp.Expr:
    """``sum_{index >= start} term``: the convergent branch (ratios alpha, alpha beta < 1)."""
    total = sp.summation(term, (index, start, sp.oo))
    # sympy returns Piecewise((closed form, |ratio| < 1), (unevaluated Sum, True)): keep the first
    return sp.simplify(total.replace(lambda e: isinstance(e, sp.Piecewise), lambda e: e.args[0][0]))


def flat_stick_time() -> sp.Expr:
    """Step 1-3: ``tau_inf`` (s) of the flat plate in v, g_eff, alpha."""
    return geometric((2 * v / g_eff) * alpha**k, k)


def arc_gravity() -> tuple[sp.Expr, sp.Expr]:
    """Step 4-5: ``(g_n, g_t)`` (mm/s^2) at the contact point xi with tangential speed v_t."""
    n = sp.Matrix([xi, S]) / R
    t = sp.Matrix([S, -xi]) / R
    gravity = sp.Matrix([0, -g_eff])
    g_n = -gravity.dot(n) - v_t**2 / R
    return sp.simplify(g_n), sp.simplify(gravity.dot(t))


def arc_stick_time() -> sp.Expr:
    """Step 5: ``tau_inf`` (s) on the arc in v_n, g_eff, S, v_t, R, alpha."""
    g_n, _ = arc_gravity()
    return flat_stick_time().subs({v: v_n, g_eff: g_n})


def tangential_velocity(index: sp.Expr) -> sp.Expr:
    """Step 6: ``u_k`` at the start of flight k, with the inner sum left unevaluated."""
    return beta**index * v_t + g_t * sp.Sum(
        beta ** (index - j) * tau_0 * alpha**j, (j, 0, index - 1)
    )


def arc_drift() -> sp.Expr:
    """Step 7: the drift ``ds`` (mm) along the arc in v_t, g_t, tau_0, alpha, beta."""
    flight = tau_0 * alpha**k
    from_vt = geometric(beta**k * v_t * flight, k)
    from_free_fall = geometric(g_t * flight**2 / 2, k)
    # u_k tau_k from the g_t part: sum_k sum_{j<k} beta^(k-j) tau_j tau_k, with k = j + m
    inner = geometric(beta**m * alpha ** (j + m) * alpha**j, m, start=1)
    from_gained = g_t * tau_0**2 * geometric(inner, j)
    return from_vt + from_free_fall + from_gained


def drift_model_form() -> sp.Expr:
    """The drift as written in ``chatter_sum``'s docstring."""
    ab = alpha * beta
    return v_t * tau_0 / (1 - ab) + g_t * tau_0**2 * (
        ab / ((1 - alpha**2) * (1 - ab)) + 1 / (2 * (1 - alpha**2))
    )


def derivation_steps() -> list[tuple[str, sp.Basic]]:
    """The derivation as (explanation, sympy object) pairs, in order."""
    g_n, g_tan = arc_gravity()
    return [
        ("flat: flight k lasts tau_k", (2 * v / g_eff) * alpha**k),
        ("flat: stick time tau_inf = sum_k tau_k", flat_stick_time()),
        ("arc: effective normal gravity g_n", g_n),
        ("arc: tangential gravity g_t", g_tan),
        ("arc: stick time with v_n and g_n", arc_stick_time()),
        ("arc: tangential velocity u_k at the start of flight k", tangential_velocity(k)),
        ("arc: drift ds = sum_k (u_k tau_k + g_t tau_k^2/2)", sp.factor(arc_drift())),
    ]


if __name__ == "__main__":
    for text, expr in derivation_steps():
        print(f"{text}:\n    {expr}\n")
    print(
        "drift equals the form in chatter_sum's docstring:",
        sp.simplify(arc_drift() - drift_model_form()) == 0,
    )
