"""The D_a code equals the sympy derivation in derivations/random_walk.py."""

import math

import numpy as np
import pytest
from derivation_loader import load_derivation
from extras import require

from bbdyn import Params
from bbdyn.approx.random_walk import analytic_diffusion
from bbdyn.core.tolerances import CLOSED_FORM_REL

sp = require("sympy", "derivations")


@pytest.fixture(scope="module")
def derivation():
    return load_derivation("random_walk")


def test_derivation_gives_the_model_md_formula(derivation):
    m = derivation
    target = m.d / 2 * sp.sqrt((m.A**2 * m.w**2 - 2 * m.g * m.A) / (1 + m.r))
    assert sp.simplify(m.analytic_diffusion_expr() - target) == 0


def test_code_equals_derivation_on_a_parameter_grid(derivation):
    m = derivation
    d_a = sp.lambdify((m.A, m.w, m.g, m.d, m.r), m.analytic_diffusion_expr(), "math")
    rng = np.random.default_rng(0)
    for _ in range(200):
        params = Params(
            f=rng.uniform(71.0, 200.0),
            A=rng.uniform(0.1, 0.3),
            g=rng.uniform(9000.0, 10000.0),
            d=rng.uniform(0.5, 4.0),
        )
        r = rng.uniform(0.0, 5.0)
        expected = d_a(params.A, params.w, params.g, params.d, r)
        got = analytic_diffusion(params, r).D_a
        assert got == pytest.approx(expected, rel=CLOSED_FORM_REL)


@pytest.mark.parametrize("f", [50.0, 65.6, 70.4], ids=["Gamma-1", "S9-lower-edge", "Gamma-2-"])
def test_code_is_nan_where_the_derivation_is_not_real(derivation, f):
    m = derivation
    params = Params(f=f)
    value = m.analytic_diffusion_expr().subs(
        {m.A: params.A, m.w: params.w, m.g: params.g, m.d: params.d, m.r: 1}
    )
    assert not sp.sympify(value).is_real
    assert math.isnan(analytic_diffusion(params, 1.0).D_a)
