"""Continuation of periodic orbits of the exact flat map (bbdyn.flat.continuation)."""

import math

import numpy as np
import pytest

from bbdyn.core.flat import FlatArrays, FlatState, flat_run
from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import IMPACT, OK
from bbdyn.flat.continuation import (
    FEIGENBAUM_DELTA,
    cascade,
    continue_branch,
    km_orbit_guesses,
    orbit_chain,
    unit_kernel,
)
from bbdyn.flat.tongues import (
    k1_cos_phase,
    map_jacobian,
    params_at_gamma,
    tongue_gamma_hi,
    tongue_gamma_lo,
)

#: Accuracy the brief asks of a located bifurcation, in Gamma.
EDGE_TOL = 1e-10


@pytest.mark.parametrize("alpha", [0.3, 0.5, 0.8])
@pytest.mark.parametrize("k", [1, 2, 3])
def test_k1_branch_folds_and_flips_at_the_closed_form_edges(k, alpha):
    """From the saddle branch (sin theta > 0) down through the fold and up to the flip."""
    gamma = 1.2 * tongue_gamma_lo(k, alpha)
    theta = math.acos(k1_cos_phase(k, gamma, alpha))
    V = 2 * alpha * math.pi * k / (1 + alpha)
    branch, _ = continue_branch((theta, V, gamma), k, 1, alpha, direction=-1, stop_at_flip=True)
    assert branch.meta["status"] == "flip"
    (kind_lo, lo), (kind_hi, hi) = branch.bifurcations
    assert (kind_lo, kind_hi) == ("fold", "flip")
    assert abs(lo - tongue_gamma_lo(k, alpha)) < EDGE_TOL
    assert abs(hi - tongue_gamma_hi(k, alpha)) < EDGE_TOL


def test_gamma_column_is_the_derivative_of_the_residual():
    """The implicit-function Gamma column against central differences of the residual."""
    theta, V, gamma, alpha = 4.0, 1.7, 2.3, 0.5
    ch = orbit_chain(theta, V, gamma, 2, 3, alpha)
    h = 1e-6
    plus = orbit_chain(theta, V, gamma + h, 2, 3, alpha).residual
    minus = orbit_chain(theta, V, gamma - h, 2, 3, alpha).residual
    np.testing.assert_allclose(ch.d_gamma, (plus - minus) / (2 * h), rtol=1e-7, atol=1e-8)


def _iterate(theta, V, gamma, alpha, n):
    """The last impacts (phase, V) of n iterates of the simulator's exact map."""
    kp = unit_kernel(gamma, alpha)
    out = [np.zeros(n) for _ in range(3)] + [np.zeros(n, dtype=np.int64)]
    _, n_done, status = flat_run(FlatState(0.0, theta, V, IMPACT), kp, n, FlatArrays(*out))
    assert status == OK and n_done == n and np.all(out[3] == IMPACT)
    return out[1], out[2]


def _period(theta, V, tol=1e-8):
    """Least p such that the last 64 impacts repeat after p (0 if none up to 32)."""
    for p in (1, 2, 4, 8, 16, 32):
        d = np.abs(np.angle(np.exp(1j * (theta[-64:] - theta[-64 - p : -p]))))
        if np.max(d) < tol and np.max(np.abs(V[-64:] - V[-64 - p : -p])) < tol:
            return p
    return 0


@pytest.mark.parametrize("k", [1, 2])
def test_doubled_orbits_are_what_direct_iteration_converges_to(k):
    """Just past the n-th doubling the exact map settles on the 2^n orbit found by
    continuation (point by point), just before it on a 2^(n-1) orbit (n = 1, 2:
    periods 2 and 4)."""
    from bbdyn.flat.continuation import _correct_at_gamma

    alpha = 0.5
    gammas, status, _, branches = cascade(k, alpha, 3)
    assert status == "done"
    edges = [tongue_gamma_lo(k, alpha), *gammas]  # the k/1 orbit is born at Gamma_lo
    for n in (1, 2):
        past = edges[n] + 0.05 * (edges[n + 1] - edges[n])
        before = edges[n] - 0.05 * (edges[n] - edges[n - 1])
        br = branches[n]  # the branch of 2^n impacts
        i = int(np.argmin(np.abs(br["gamma"] - past)))
        orbit = _correct_at_gamma(br["theta"][i][0], br["V"][i][0], past, k * 2**n, 2**n, alpha)
        # start next to the continued orbit, at the test's Gamma
        theta, V = _iterate(orbit.chain.theta[0] + 1e-3, orbit.chain.V[0], past, alpha, 40000)
        assert _period(theta, V) == 2**n
        np.testing.assert_allclose(np.sort(theta[-(2**n) :]), np.sort(orbit.chain.theta), atol=1e-8)
        np.testing.assert_allclose(np.sort(V[-(2**n) :]), np.sort(orbit.chain.V), rtol=1e-8)
        theta_b, V_b = _iterate(orbit.chain.theta[0] + 1e-3, orbit.chain.V[0], before, alpha, 40000)
        assert _period(theta_b, V_b) == 2 ** (n - 1)


def test_feigenbaum_ratios_converge():
    """Ratio estimates of the k = 1 cascade approach 4.6692.

    The estimates' error falls geometrically, by about 1/delta per level (next-order
    scaling): from 6e-2 at the first ratio, 1/delta^5 gives ~1e-4 at the seventh, so
    the deepest (seventh) estimate must be within 1e-3 and the errors of the last
    four must decrease.
    """
    gammas, status, _, _ = cascade(1, 0.5, 9)
    assert status == "done"
    d = np.diff(gammas)
    ratios = d[:-1] / d[1:]
    err = np.abs(ratios - FEIGENBAUM_DELTA)
    assert err[-1] < 1e-3 * FEIGENBAUM_DELTA
    assert np.all(np.diff(err[-4:]) < 0)


@pytest.mark.parametrize(
    ("k", "m", "gamma"),
    [(1, 2, 1.5), (3, 2, 3.0), (5, 3, 4.5), (2, 3, 4.0), (3, 4, 2.5), (5, 4, 5.0)],
)
def test_km_multipliers_are_the_eigenvalues_of_the_jacobian_product(k, m, gamma):
    """Multipliers of a k/m orbit (dimensionless chain) against the product of
    ``bbdyn.flat.tongues.map_jacobian`` in mm and s along it, and det = alpha^(2m)."""
    alpha = 0.5
    orbits = km_orbit_guesses(k, m, alpha, [gamma], n_phase=24)
    assert orbits, f"no {k}/{m} orbit found at Gamma = {gamma}"
    params = params_at_gamma(gamma, alpha=alpha)
    for p in orbits:
        jac = np.eye(2)
        for theta, V in zip(p.chain.theta, p.chain.V, strict=True):
            jac = map_jacobian(params, theta, V * params.g / params.w) @ jac
        mine = np.sort_complex(np.linalg.eigvals(p.chain.monodromy).astype(complex))
        theirs = np.sort_complex(np.linalg.eigvals(jac).astype(complex))
        np.testing.assert_allclose(mine, theirs, rtol=1e-7, atol=1e-9)
        # det of a product is exact up to rounding of its entries: a few m eps ||J||^2
        det = alpha ** (2 * m)
        for mat in (jac, p.chain.monodromy):
            tol = max(1e-12, 64 * m * np.finfo(float).eps * np.sum(mat**2) / det)
            assert np.linalg.det(mat) == pytest.approx(det, rel=tol)
        assert sum(p.chain.flight) == pytest.approx(TWO_PI * k, rel=1e-12)


def test_stored_cascades_are_what_the_cascade_computes():
    """docs/data/flat_tables.json (the doubling table of docs/higher_tongues.md): every
    Gamma_n and ratio of the stored cascades, recomputed."""
    import json
    from pathlib import Path

    from bbdyn.flat.continuation import doubling_cascade

    path = Path(__file__).parents[1] / "docs" / "data" / "flat_tables.json"
    stored = json.loads(path.read_text())["doublings"]
    levels = len(stored[0]["gamma_doublings"])
    table = doubling_cascade(0.5, len(stored), levels)
    for i, stored_k in enumerate(stored):
        assert stored_k["k"] == i + 1 and stored_k["status"] == "done"
        assert stored_k["gamma_doublings"] == pytest.approx(table["gamma_doubling"][i], abs=1e-12)
        ratios = stored_k["feigenbaum_ratios"]
        assert ratios == pytest.approx(table["ratio"][i, 1 : 1 + len(ratios)], abs=1e-9)
        assert not np.isfinite(table["ratio"][i, 0])
        # the first doubling is the closed-form upper tongue edge
        assert stored_k["gamma_doublings"][0] == pytest.approx(tongue_gamma_hi(i + 1, 0.5),
                                                              abs=1e-12)  # fmt: skip


def _cli(argv):
    """Exit status of ``bbdyn argv`` (SystemExit caught)."""
    from bbdyn.commands.cli import main

    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--alpha", "1"], "alpha must be in (0, 1)"),
        (["--alpha", "0"], "alpha must be in (0, 1)"),
        (["--levels", "0"], "levels must be an integer in [1, 14]"),
        (["--kmax", "0"], "kmax must be an integer in [1, 20]"),
    ],
)
def test_doublings_command_refuses_bad_input(argv, words, capsys):
    assert _cli(["doublings", *argv]) == 2
    assert words in capsys.readouterr().err


def test_doublings_command_json_is_the_cascade(capsys):
    """``bbdyn doublings --json``: the Gammas of ``doubling_cascade``, and the ratios
    recomputed from those Gammas."""
    import json

    assert _cli(["doublings", "--alpha", "0.4", "--kmax", "2", "--levels", "4", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["doublings"]
    assert [r["k"] for r in rows] == [1, 2]
    for r in rows:
        gammas, status, _, _ = cascade(r["k"], 0.4, 4)
        assert r["status"] == status == "done"
        assert r["gamma_doublings"] == gammas
        d = np.diff(gammas)
        np.testing.assert_allclose(r["feigenbaum_ratios"], d[:-1] / d[1:], rtol=1e-12)
        assert r["gamma_doublings"][0] == pytest.approx(tongue_gamma_hi(r["k"], 0.4), abs=1e-12)


def test_scene_b4_quick_agrees_with_closed_forms_and_iteration():
    """Scene B4 (quick): first doublings are the closed-form Gamma_hi at every alpha, and
    the direct-iteration diagram has 1 phase below Gamma_hi, 2 between the first two
    doublings, 4 between the second and third (the continuation's values)."""
    from bbdyn.scenes import b4_higher_tongues as b4

    r = b4.compute(b4.QUICK)
    ks = r["k"][:, None]
    np.testing.assert_allclose(
        r["doublings"][:, :, 0], tongue_gamma_hi(ks, r["alphas"][None, :], np), atol=1e-10
    )
    g1, g2, g3 = r["diag_doublings"][0, :3]
    for lo, hi, count in ((b4.QUICK["diagram_gamma"][0], g1, 1), (g1, g2, 2), (g2, g3, 4)):
        inside = (r["diag_gamma"] > lo + 0.1 * (hi - lo)) & (r["diag_gamma"] < hi - 0.1 * (hi - lo))
        assert inside.any()
        for phases in r["diag_phase"][inside]:
            assert len(np.unique(np.round(phases, 6))) == count
    assert np.all(r["km_lo"] < r["km_hi"])


def test_replay_reports_a_stick_as_chatter_and_a_wrong_orbit_as_replay():
    """A launch at 1e-9 g/w where the plate holds the ball chatters and sticks (status
    "chatter"); a point that is not on its claimed orbit is reported as "replay"."""
    from bbdyn.flat.continuation import Chain, _replay_ok

    def chain(theta, V):
        z = np.zeros(2)
        return Chain(z, np.eye(2), z, np.array([theta, theta]), np.array([V, V]), z, 1.0)

    kind, why = _replay_ok(chain(0.5, 1e-9), 1.5, 0.5, 1, 2)
    assert kind == "chatter" and "sticks" in why
    kind, _ = _replay_ok(chain(4.0, 2.0), 1.5, 0.5, 1, 2)
    assert kind == "replay"
    # the stable 1/1 orbit replays cleanly
    gamma = 1.3
    theta = TWO_PI - math.acos(k1_cos_phase(1, gamma, 0.5))
    p = orbit_chain(theta, 2 * 0.5 * math.pi / 1.5, gamma, 1, 1, 0.5)
    assert _replay_ok(p, gamma, 0.5, 1, 1) == ("", "")
