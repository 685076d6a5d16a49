"""The expressions bbdyn/flat/tongues.py uses equal the ones derived in
derivations/flat_tongues.py."""

import math

import numpy as np
import pytest
from derivation_loader import load_derivation
from extras import require

from bbdyn import Params
from bbdyn.core.flat_jacobian import flat_map_jacobian
from bbdyn.flat.tongues import (
    k1_cos_phase,
    k1_trace,
    k1_velocity,
    tongue_gamma_hi,
    tongue_gamma_lo,
)

sp = require("sympy", "derivations")

D = load_derivation("flat_tongues")


def _same(a, b):
    assert sp.simplify(a - b) == 0, (a, b)
    rng = np.random.default_rng(7)
    free = sorted(a.free_symbols | b.free_symbols, key=str)
    for _ in range(5):
        values = {
            s: (int(rng.integers(1, 6)) if s == D.k else rng.uniform(0.05, 0.95)) for s in free
        }
        assert float(a.subs(values)) == pytest.approx(float(b.subs(values)), rel=1e-13)


def test_tongue_edges_used_by_bbdyn_are_the_derived_ones():
    _same(tongue_gamma_lo(D.k, D.alpha, xp=sp), D.gamma_lo())
    _same(tongue_gamma_hi(D.k, D.alpha, xp=sp), D.gamma_hi())


def test_derived_upper_edge_is_the_form_written_in_model_md():
    a, k = D.alpha, D.k
    model_md = sp.pi * sp.sqrt(
        (k * (1 - a) / (1 + a)) ** 2 + (2 * (1 + a**2) / (sp.pi * (1 + a) ** 2)) ** 2
    )
    _same(model_md, D.gamma_hi())


def test_k1_orbit_used_by_bbdyn_is_the_derived_one():
    orbit = D.k1_orbit()
    _same(k1_cos_phase(D.k, D.Gamma, D.alpha, xp=sp), orbit["cos_theta"])
    v, vrel = k1_velocity(D.k, D.w, D.g, D.alpha, xp=sp)
    _same(v, orbit["v"])
    _same(vrel, orbit["vrel"])


def test_k1_trace_and_determinant_are_the_derived_ones():
    tr, det = D.k1_trace_det()
    _same(k1_trace(D.Gamma, D.alpha, D.sin_star), tr)
    assert sp.simplify(det - D.alpha**2) == 0


def test_kernel_jacobian_equals_the_derived_general_jacobian_at_random_states():
    symbols = (D.theta, D.vrel, D.x, D.A, D.w, D.g, D.alpha)
    J = sp.lambdify(symbols, D.jacobian_relative().tolist(), "math")
    rng = np.random.default_rng(3)
    for f in (55.0, 75.0, 90.0):
        p = Params(f=f, alpha=float(rng.uniform(0.1, 1.0)))
        kp = p.kernel()
        for _ in range(10):
            phase, vrel = rng.uniform(0, 2 * math.pi), p.g / p.w * rng.uniform(0.5, 6.0)
            dphase, _, jac, status = flat_map_jacobian(phase, vrel, kp)
            assert status == 0
            expected = np.array(J(phase, vrel, dphase, p.A, p.w, p.g, p.alpha), dtype=float)
            scale = np.array([[1.0, p.g / p.w], [p.w / p.g, 1.0]])  # compare dimensionless
            assert np.allclose(
                jac / scale,
                expected / scale,
                rtol=0,
                atol=1e-11 * max(1.0, np.max(np.abs(expected / scale))),
            )
