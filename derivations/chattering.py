"""Chattering: the closed-form sum of infinitely many ever smaller bounces.

Run ``python derivations/chattering.py`` to print the derivation step by step.
``flat_stick_time()``, ``arc_gravity()``, ``arc_stick_time_term()``,
``arc_drift_vt_term()`` and ``arc_drift_gt()`` return the results as sympy
expressions (the eps^m terms of series in eps), which the tests
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
   pull pays first: a hop feels ``g_n = (g_eff S - v_t^2) / R``.  Each bounce
   multiplies the tangential speed by beta (step 6, without the small gain from
   ``g_t``), so hop k feels ``g_0 (1 - eps beta^(2k))`` with ``g_0 = g_eff S / R``
   and ``eps = v_t^2 / (g_eff S) < 1``, and lasts
   ``tau_k = alpha^k tau_0 / (1 - eps beta^(2k))``, ``tau_0 = 2 v_n / g_0``.
   Expanding ``1 / (1 - x) = sum_m x^m`` and summing over k first (a geometric
   series for every m):

       tau_inf = tau_0 sum_m eps^m / (1 - alpha beta^(2m)).

   Its first term is the flat sum ``tau_0 / (1 - alpha)``; taking the first hop's
   ``g_n`` for every hop instead would give ``tau_0 / ((1 - eps)(1 - alpha))``, too
   long by ``tau_0 sum_(m>=1) eps^m [1/(1 - alpha) - 1/(1 - alpha beta^(2m))]``.
6. Tangentially, flight k starts with velocity ``u_k`` and gains ``g_t tau_k``;
   the bounce multiplies by beta: ``u_{k+1} = beta (u_k + g_t tau_k)``, so
   ``u_k = beta^k v_t + g_t sum_{j<k} beta^(k-j) tau_j``.
7. The drift is ``ds = sum_k (u_k tau_k + g_t tau_k^2 / 2)``.  The part of
   ``beta^k v_t`` is ``v_t tau_0 sum_m eps^m / (1 - alpha beta^(2m+1))`` (as in
   step 5); the parts of ``g_t`` are taken with the flat ``tau_k = tau_0 alpha^k``
   (each of their terms is a product of two flights, so this is off by at most
   ``eps (2 - eps) / (1 - eps)^2`` of their size), the double sum reordered
   with ``k = j + m`` (m >= 1): ``sum_j alpha^(2j) sum_m (alpha beta)^m``, two
   geometric series.  Result:

       ds = v_t tau_0 sum_m eps^m / (1 - alpha beta^(2m+1))
            + g_t tau_0^2 [alpha beta / ((1 - alpha^2)(1 - alpha beta)) + 1 / (2 (1 - alpha^2))].

   ``u_k`` tends to zero (beta < 1): the particle comes to rest on the arc.
"""

from __future__ import annotations

import sympy as sp

alpha, beta = sp.symbols("alpha beta", positive=True)  # 0 < alpha, beta < 1
v, g_eff, R, xi, S, v_n, v_t = sp.symbols("v g_eff R xi S v_n v_t", positive=True)
eps = sp.Symbol("eps", positive=True)  # v_t^2 / (g_eff S) < 1
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


def hop_time(index: sp.Expr) -> sp.Expr:
    """Step 5: flight ``index`` on the arc (s), its centrifugal term shrunk by beta^(2 index)."""
    return alpha**index * tau_0 / (1 - eps * beta ** (2 * index))


def geometric_in(term: sp.Expr, ratio: sp.Expr) -> sp.Expr:
    """``sum_{k >= 0} term`` for a ``term`` that is ``ratio^k`` (checked), 0 < ratio < 1."""
    q = sp.Symbol("q", positive=True)
    difference = sp.expand_power_base(term, force=True) - sp.expand_power_base(ratio**k, force=True)
    assert sp.simplify(difference) == 0, (term, ratio)
    return geometric(q**k, k).subs(q, ratio)


def arc_stick_time_term() -> sp.Expr:
    """Step 5: the eps^m term of ``tau_inf``, summed over the flights k first."""
    return tau_0 * eps**m * geometric_in(alpha**k * beta ** (2 * m * k), alpha * beta ** (2 * m))


def tangential_velocity(index: sp.Expr) -> sp.Expr:
    """Step 6: ``u_k`` at the start of flight k, with the inner sum left unevaluated."""
    return beta**index * v_t + g_t * sp.Sum(
        beta ** (index - j) * tau_0 * alpha**j, (j, 0, index - 1)
    )


def arc_drift_vt_term() -> sp.Expr:
    """Step 7: the eps^m term of the drift (mm) carried by ``beta^k v_t``."""
    term = (alpha * beta) ** k * beta ** (2 * m * k)
    return v_t * tau_0 * eps**m * geometric_in(term, alpha * beta ** (2 * m + 1))


def arc_drift_gt() -> sp.Expr:
    """Step 7: the drift (mm) from the tangential pull ``g_t``, with the flat flights."""
    flight = tau_0 * alpha**k
    from_free_fall = geometric(g_t * flight**2 / 2, k)
    # u_k tau_k from the g_t part: sum_k sum_{j<k} beta^(k-j) tau_j tau_k, with k = j + m
    inner = geometric(beta**m * alpha ** (j + m) * alpha**j, m, start=1)
    return from_free_fall + g_t * tau_0**2 * geometric(inner, j)


def drift_model_form() -> sp.Expr:
    """The ``g_t`` part of the drift as written in ``chatter_sum``'s docstring."""
    ab = alpha * beta
    return g_t * tau_0**2 * (ab / ((1 - alpha**2) * (1 - ab)) + 1 / (2 * (1 - alpha**2)))


def truncated(term: sp.Expr, terms: int) -> sp.Expr:
    """``sum_{m < terms}`` of an eps^m term (eps < 1: the rest is below eps^terms / (1 - eps)
    times the largest coefficient)."""
    return sp.Add(*(term.subs(m, i) for i in range(terms)))


def derivation_steps() -> list[tuple[str, sp.Basic]]:
    """The derivation as (explanation, sympy object) pairs, in order."""
    g_n, g_tan = arc_gravity()
    return [
        ("flat: flight k lasts tau_k", (2 * v / g_eff) * alpha**k),
        ("flat: stick time tau_inf = sum_k tau_k", flat_stick_time()),
        ("arc: effective normal gravity g_n of one hop", g_n),
        ("arc: tangential gravity g_t", g_tan),
        ("arc: flight k, centrifugal term shrunk by beta^(2k)", hop_time(k)),
        ("arc: stick time tau_inf = sum_m of", arc_stick_time_term()),
        ("arc: tangential velocity u_k at the start of flight k", tangential_velocity(k)),
        ("arc: drift from beta^k v_t = sum_m of", arc_drift_vt_term()),
        ("arc: drift from g_t", sp.factor(arc_drift_gt())),
    ]


if __name__ == "__main__":
    for text, expr in derivation_steps():
        print(f"{text}:\n    {expr}\n")
    print(
        "g_t drift equals the form in chatter_sum's docstring:",
        sp.simplify(arc_drift_gt() - drift_model_form()) == 0,
    )
