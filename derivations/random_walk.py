"""Analytic random-walk diffusion coefficient D_a from the energy balance (docs/model.md, sec. 4).

Run ``python derivations/random_walk.py`` to print the derivation step by step;
``analytic_diffusion_expr()`` returns the result as a sympy expression, which
the tests compare with ``bbdyn.approx.random_walk.analytic_diffusion``.

The argument, in four steps (units: mm, s, mass 1 kg):

1. Energy balance.  In the nonequilibrium steady state the vibrating floor
   keeps the particle's energy per mass near the floor's kinetic energy scale,
   ``E ~ A^2 w^2 / 2``.  It splits into horizontal and vertical kinetic energy
   and the potential energy of hops of height about A:
   ``E = E_x + E_y + E_pot`` with ``E_pot ~ g A``.
2. Closure.  The ratio of vertical to horizontal kinetic energy is a number r,
   ``E_y = r E_x``, taken from simulation (the paper fixes it; bbdyn measures it).
3. Speed.  Solving 1-2 for ``E_x`` gives the typical horizontal speed
   ``v_x = sqrt(2 E_x)``.
4. Random walk.  A particle moving at ``v_x`` crosses one tile of width d in
   ``tau = d / v_x``; jumps of +-d every tau in random directions diffuse with
   ``D = d^2 / (2 tau) = d v_x / 2``.

The result, ``D_a = (d/2) sqrt((A^2 w^2 - 2 g A) / (1 + r))``, is real only for
``A^2 w^2 >= 2 g A``, i.e. Gamma = A w^2 / g >= 2: below, the balance of step 1
has no kinetic energy left over.
"""

from __future__ import annotations

import sympy as sp

A, w, g, d, r = sp.symbols("A w g d r", positive=True)
E_x, E_y, E_pot, E = sp.symbols("E_x E_y E_pot E", positive=True)


def derivation_steps() -> list[tuple[str, sp.Basic]]:
    """The derivation as (explanation, sympy object) pairs, in order."""
    balance = sp.Eq(E, E_x + E_y + E_pot)
    closed = balance.subs({E: A**2 * w**2 / 2, E_pot: g * A, E_y: r * E_x})
    (e_x,) = sp.solve(closed, E_x)
    v_x = sp.sqrt(2 * e_x)
    tau = d / v_x
    D_a = sp.simplify(d**2 / (2 * tau))
    return [
        ("energy balance", balance),
        ("with E = A^2 w^2/2, E_pot = g A, E_y = r E_x", closed),
        ("horizontal kinetic energy E_x", sp.Eq(E_x, sp.factor(e_x))),
        ("typical horizontal speed v_x = sqrt(2 E_x)", v_x),
        ("time to cross one tile, tau = d / v_x", tau),
        ("random walk D_a = d^2 / (2 tau)", D_a),
    ]


def analytic_diffusion_expr() -> sp.Expr:
    """``D_a(A, w, g, d, r)`` in mm^2/s as a sympy expression (symbols of this module)."""
    return derivation_steps()[-1][1]


if __name__ == "__main__":
    for text, expr in derivation_steps():
        print(f"{text}:\n    {expr}\n")
    target = d / 2 * sp.sqrt((A**2 * w**2 - 2 * g * A) / (1 + r))
    print(
        "equals the model's (d/2) sqrt((A^2 w^2 - 2 g A)/(1 + r)):",
        sp.simplify(analytic_diffusion_expr() - target) == 0,
    )
