"""The billiard's tangent dynamics against derivations/billiard_orbit_jacobian.py (sympy).

* the closed form of the event Jacobian on the top orbit splits into the flat ball's
  block (trace and determinant of derivations/flat_tongues.py) and the curvature block;
* the kernel's event Jacobian (``core.billiard_tangent``, built from saltation matrices)
  equals the derived one (implicit function theorem on the billiard's gap) at random
  states and on the top orbit;
* a tangent run along the top orbit has the largest exponent log(mu) of the derived
  multiplier, per collision and per second.
"""

import math

import numpy as np
import pytest
from derivation_loader import load_derivation
from extras import require

from bbdyn import Params
from bbdyn.core.billiard_tangent import billiard_tangent_event
from bbdyn.core.status import IMPACT, OK
from bbdyn.flat.tongues import k1_orbit
from bbdyn.lyapunov import billiard_lyapunov_from

sp = require("sympy", "derivations")

D = load_derivation("billiard_orbit_jacobian")
FLAT = load_derivation("flat_tongues")
SYMBOLS = (D.theta, D.xi, D.vx, D.vy, D.x, D.shift, D.A, D.w, D.g, D.alpha, D.beta, D.R)


def test_top_orbit_jacobian_splits_into_flat_and_curvature_blocks():
    J = D.top_orbit_jacobian()
    flat_idx, curv_idx = [0, 3], [1, 2]
    assert all(sp.simplify(J[i, j]) == 0 for i in flat_idx for j in curv_idx)
    assert all(sp.simplify(J[i, j]) == 0 for i in curv_idx for j in flat_idx)
    assert sp.simplify(J.extract(curv_idx, curv_idx) - D.curvature_block()) == sp.zeros(2, 2)
    flat = J.extract(flat_idx, flat_idx)
    tr, det = FLAT.k1_trace_det()
    s = {FLAT.alpha: D.alpha, FLAT.Gamma: D.Gamma, FLAT.sin_star: D.sin_star}
    assert sp.simplify(flat.trace() - tr.subs(s)) == 0
    assert sp.simplify(flat.det() - det.subs(s)) == 0
    assert sp.simplify(D.curvature_block().det() - D.beta) == 0


def one_event(kp, state):
    J, W, T = np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4))
    *out, status = billiard_tangent_event(*state, kp, (J, W, T))
    assert status == OK
    return out, J


def test_kernel_event_jacobian_equals_the_derived_one_at_random_states():
    jac = sp.lambdify(SYMBOLS, D.event_jacobian().tolist(), "math")
    rng = np.random.default_rng(5)
    checked = 0
    for f in (60.0, 85.2):
        p = Params(f=f)
        kp = p.kernel()
        while checked < 10 * (1 + (f > 60)):
            phase = rng.uniform(0, 2 * math.pi)
            state = (0.0, phase, 0.0, rng.uniform(-0.9, 0.9), rng.uniform(-30, 30),
                     rng.uniform(5, 60), IMPACT)  # fmt: skip
            out, J = one_event(kp, state)
            if out[6] != IMPACT or abs(out[3]) == 0.5 * p.d:
                continue  # a stick or a wedge chain: not the single-arc formula
            x = 2 * math.pi * out[0] + out[1] - phase
            expected = np.array(
                jac(phase, state[3], state[4], state[5], x, out[2] * p.d, p.A, p.w, p.g,
                    p.alpha, p.beta, p.R), dtype=float,
            )  # fmt: skip
            scale = np.max(np.abs(expected))
            assert np.max(np.abs(J - expected)) < 1e-8 * scale
            checked += 1


def orbit_state(p, k):
    o = k1_orbit(p, k)
    return (0.0, o.phase_stable, 0.0, 0.0, 0.0, o.vrel, IMPACT), o


@pytest.mark.parametrize(("f", "k"), [(58.0, 1), (89.5, 3)])
def test_kernel_jacobian_on_the_top_orbit_is_the_closed_form(f, k):
    p = Params(f=f)
    kp = p.kernel()
    state, o = orbit_state(p, k)
    out, J = one_event(kp, state)
    assert out[2:5] == [0.0, 0.0, 0.0]  # back on the same top, still vertical
    assert 2 * math.pi * out[0] + out[1] - o.phase_stable == pytest.approx(2 * math.pi * k)
    closed = sp.lambdify(
        (D.Gamma, D.alpha, D.beta, D.R, D.g, D.w, D.k, D.sin_star),
        D.top_orbit_jacobian().tolist(),
        "math",
    )
    expected = np.array(
        closed(p.gamma, p.alpha, p.beta, p.R, p.g, p.w, k, math.sin(o.phase_stable)), dtype=float
    )
    assert np.max(np.abs(J - expected)) < 1e-8 * np.max(np.abs(expected))


@pytest.mark.parametrize(("f", "k"), [(58.0, 1), (89.5, 3)])
def test_largest_exponent_along_the_top_orbit_is_log_mu(f, k):
    """The QR (one vector) estimate over n collisions is within 2 log cond(V) / n of
    log(mu) for a periodic orbit with eigenvector matrix V."""
    p = Params(f=f)
    kp = p.kernel()
    state, o = orbit_state(p, k)
    _, J = one_event(kp, state)
    mu = float(
        D.largest_multiplier().subs({D.alpha: p.alpha, D.beta: p.beta, D.R: p.R, D.g: p.g,
                                     D.w: p.w, D.k: k})
    )  # fmt: skip
    assert mu > 1.0
    assert np.max(np.abs(np.linalg.eigvals(J))) == pytest.approx(mu, rel=1e-9)
    n = 400
    res = billiard_lyapunov_from(p, [state], t=(n * k + 0.5) / p.f, windows=1)
    log, collisions = res["log_growth"][0], res["collisions"][0]
    assert res["status"][0] == OK and collisions[0] == n and res["collapses"].sum() == 0
    cond = np.linalg.cond(np.linalg.eig(J)[1])
    bound = 2 * math.log(cond) / n
    per_collision = log[0] / collisions[0]
    assert abs(per_collision - math.log(mu)) < bound
    duration = res["duration"][0, 0]  # s
    assert log[0] / duration == pytest.approx(math.log(mu) / o.tau, abs=bound / o.tau)


def top_orbit_log_multipliers(p, k, sin_star):
    """log |mu| of all four multipliers of the top orbit, largest first, in closed form: the
    flat ball's block (trace and determinant of derivations/flat_tongues.py) and the
    curvature block (derivations/billiard_orbit_jacobian.py)."""
    tr, det = FLAT.k1_trace_det()
    flat = {FLAT.alpha: p.alpha, FLAT.Gamma: p.gamma, FLAT.sin_star: sin_star, FLAT.k: k}
    curv = {D.alpha: p.alpha, D.beta: p.beta, D.R: p.R, D.g: p.g, D.w: p.w, D.k: k}
    blocks = (
        np.roots([1.0, -float(tr.subs(flat)), float(det.subs(flat))]),
        np.linalg.eigvals(np.array(D.curvature_block().subs(curv), dtype=float)),
    )
    return np.sort(np.log(np.abs(np.concatenate(blocks))))[::-1]


@pytest.mark.parametrize(("f", "k", "qr_every"), [(58.0, 1, 1), (89.5, 3, 1), (89.5, 3, 5)])
def test_all_four_exponents_along_the_top_orbit_are_the_closed_form_multipliers(f, k, qr_every):
    """The whole spectrum (four vectors, QR every ``qr_every`` events) on the top orbit:
    each exponent per collision within the QR bound 2 log cond(V) / n of the closed-form
    log |mu_i|, and their sum is log (alpha^2 beta) per collision (det of one period)."""
    p = Params(f=f)
    state, o = orbit_state(p, k)
    _, J = one_event(p.kernel(), state)
    mu = top_orbit_log_multipliers(p, k, math.sin(o.phase_stable))
    n = 400
    res = billiard_lyapunov_from(
        p, [state], t=(n * k + 0.5) / p.f, windows=1, spectrum=True, qr_every=qr_every
    )
    assert res.free()[0] and res["carried"].sum() == n
    lam = res.spectrum("collision")[0]
    bound = 2 * math.log(np.linalg.cond(np.linalg.eig(J)[1])) / n
    assert np.all(np.abs(lam - mu) < bound), (lam, mu, bound)
    assert lam.sum() == pytest.approx(math.log(p.alpha**2 * p.beta), rel=1e-9)


def test_top_orbit_exponent_of_bbdyn_is_the_derived_multiplier():
    from bbdyn.lyapunov import top_orbit_exponent

    for f, k, R, beta in ((58.0, 1, 25.0, 0.99), (75.0, 2, 10.0, 0.9), (89.5, 3, 40.0, 0.5)):
        p = Params(f=f, R=R, beta=beta)
        mu = D.largest_multiplier().subs({D.alpha: p.alpha, D.beta: p.beta, D.R: p.R,
                                          D.g: p.g, D.w: p.w, D.k: k})  # fmt: skip
        assert top_orbit_exponent(p, k) == pytest.approx(float(sp.log(mu)) * f / k, rel=1e-12)
