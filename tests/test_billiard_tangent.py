"""Tangent dynamics of the billiard (bbdyn.core.billiard_tangent) against independent facts.

* the reference trajectory is bitwise that of the event kernel ``billiard_event``;
* the product of the event Jacobians equals central finite differences of whole
  trajectories of ``billiard_event`` (several step sizes, converging as h^2) through
  ordinary impacts, a cluster of impacts next to a steep wedge, and a stick and release;
* the wedge rule's Jacobian (all reflections in one event) is the limit of the
  near-wedge clusters as the contact approaches the wedge;
* determinants: ``log |det J|`` telescopes to ``log (alpha^2 beta)`` per impact plus
  ``log hdot+_0 / hdot+_N`` (flux of the section); on the static elastic floor
  (A = 0, alpha = beta = 1, a Hamiltonian system) the flux measure is preserved,
  the energy's differential is invariant and a time shift stays a time shift;
* at a stick the velocity rows vanish (the tangent space collapses onto the floor),
  and the release keeps only the position.
"""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.billiard import billiard_event
from bbdyn.core.billiard_tangent import billiard_tangent_event
from bbdyn.core.floor import arc_root
from bbdyn.core.status import IMPACT, OK, RELEASE, STICK

START = (0.0, 1.0, 0.0, 0.3, 10.0, 50.0, IMPACT)  # (periods, phase, tile, xi, vx, vyrel, kind)


def section(state, d):
    """Section coordinates (lifted theta, lifted x, vx, vyrel) of an event state."""
    periods, phase, tile, xi, vx, vyrel = state[:6]
    return np.array([2 * math.pi * periods + phase, tile * d + xi, vx, vyrel])


def run(kp, state, n):
    """``n`` events of ``billiard_event``: the last state and the list of event kinds."""
    kinds = []
    for _ in range(n):
        *state, status = billiard_event(*state, kp)
        assert status == OK
        kinds.append(state[6])
    return tuple(state), kinds


def tangent(kp, state, n):
    """``n`` events of ``billiard_tangent_event``: the states and the event Jacobians."""
    J, W, T = np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4))
    states, jacs = [state], []
    for _ in range(n):
        *state, status = billiard_tangent_event(*state, kp, (J, W, T))
        assert status == OK
        states.append(tuple(state))
        jacs.append(J.copy())
    return states, jacs


def product(jacs):
    P = np.eye(4)
    for J in jacs:
        P = J @ P
    return P


def central_differences(kp, state, n, h):
    """d(section after n events) / d(section of ``state``) by central differences, step h
    relative to each coordinate's size; the event kinds must not change."""
    _, kinds = run(kp, state, n)
    base = np.array([state[1], state[3], state[4], state[5]])  # phase, xi, vx, vyrel
    cols = []
    for j in range(4):
        step = h * max(1.0, abs(base[j]))
        out = []
        for sign in (1.0, -1.0):
            b = base.copy()
            b[j] += sign * step
            moved = (state[0], b[0], state[2], b[1], b[2], b[3], state[6])
            end, k = run(kp, moved, n)
            assert k == kinds, "a step changed the sequence of events; take a smaller one"
            out.append(section(end, kp.d))
        cols.append((out[0] - out[1]) / (2 * step))
    return np.array(cols).T


def fd_errors(kp, state, n, steps):
    """Relative max-norm error of the tangent product against central differences, per step."""
    _, jacs = tangent(kp, state, n)
    P = product(jacs)
    scale = np.max(np.abs(P))
    return [np.max(np.abs(central_differences(kp, state, n, h) - P)) / scale for h in steps]


def advance(kp, state, n):
    return run(kp, state, n)[0]


def hdot(state, kp):
    """Gap rate just after an event, vyrel + xi vx / S = R V_n / S (mm/s)."""
    xi, vx, vyrel = state[3], state[4], state[5]
    return vyrel + xi * vx / arc_root(xi, kp)


def test_reference_trajectory_is_the_event_kernel_bitwise():
    for p in (Params(f=85.2), Params(f=58.0), Params(f=70.0, R=1.05)):
        kp = p.kernel()
        a = b = START
        J, W, T = np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4))
        kinds = set()
        for _ in range(1500):
            a = tuple(billiard_event(*a, kp))[:7]
            b = tuple(billiard_tangent_event(*b, kp, (J, W, T)))[:7]
            assert a == b
            kinds.add(a[6])
        assert kinds == {IMPACT, STICK, RELEASE}  # every kind of event was carried


def test_finite_differences_through_ordinary_impacts_converge_as_h_squared():
    kp = Params(f=70.0).kernel()
    err = fd_errors(kp, START, 3, (1e-4, 1e-5, 1e-6))
    # truncation error O(h^2): a tenth of the step gives about a hundredth of the error
    assert err[0] / err[1] > 50 and err[1] / err[2] > 50, err
    assert err[2] < 1e-6, err


def test_finite_differences_through_a_cluster_of_impacts_at_a_steep_wedge():
    # R = 1.05 mm, d = 2 mm: the arcs meet at a steep wedge.  A vertical fall 1e-4 mm
    # left of it bounces between the two arcs six times within 1e-5 s.
    kp = Params(f=70.0, R=1.05).kernel()
    state = (0.0, 1.0, 0.0, 1.0 - 1e-4, 0.0, 30.0, IMPACT)
    _, kinds = run(kp, state, 7)
    assert kinds == [IMPACT] * 7
    states, _ = tangent(kp, state, 7)
    assert [s[2] for s in states[1:]] == [0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0]
    err = fd_errors(kp, state, 7, (1e-5, 1e-6, 1e-7))
    assert err[0] / err[1] > 50, err
    assert min(err) < 1e-7, err


def test_wedge_rule_is_the_limit_of_the_near_wedge_clusters():
    """A contact snapped onto the wedge is resolved in one event by ``wedge_reflect``; its
    Jacobian (a chain of saltation matrices at one point) is the limit of the six separate
    impacts of a fall at distance delta from the wedge, with an error O(delta)."""
    kp = Params(f=70.0, R=1.05).kernel()

    def after_cluster(delta, n):
        states, jacs = tangent(kp, (0.0, 1.0, 0.0, 1.0 - delta, 0.0, 30.0, IMPACT), n)
        return section(states[-1], kp.d), product(jacs)

    q_wedge, P_wedge = after_cluster(0.0, 1)  # starts on the wedge's left arc, falls on it
    scale = np.max(np.abs(P_wedge))
    errors = []
    for delta in (1e-6, 1e-8, 1e-10, 1e-12):
        q, P = after_cluster(delta, 6)
        # the end states differ at first order in delta (by about the Jacobian times delta)
        assert np.allclose(q[1:], q_wedge[1:], rtol=0, atol=4 * scale * delta)
        errors.append(np.max(np.abs(P - P_wedge)) / scale)
    assert errors[0] / errors[1] > 30 and errors[1] / errors[2] > 30, errors
    assert errors[3] < 1e-8, errors  # linear in delta down to 1e-12 mm


def stick_segment():
    """A state at 58 Hz whose next 12 events include a chattering stick on an arc, then release."""
    kp = Params(f=58.0).kernel()
    state = advance(kp, START, 15)
    _, kinds = run(kp, state, 12)
    assert kinds[6:8] == [STICK, RELEASE]
    return kp, state, kinds


def test_finite_differences_through_a_stick_and_release():
    kp, state, _ = stick_segment()
    err = fd_errors(kp, state, 12, (1e-5, 1e-6, 1e-7))
    assert max(err) < 1e-7, err  # the event map is nearly linear here: the floor of the error


def test_stick_collapses_the_tangent_space_onto_the_floor():
    kp, state, kinds = stick_segment()
    states, jacs = tangent(kp, state, 12)
    J_stick, J_release = jacs[6], jacs[7]
    assert abs(states[7][3]) < 0.5 * kp.d  # the stick is on an arc, not at a wedge
    assert np.all(J_stick[2:] == 0.0)  # no velocity rows: the particle rests on the floor
    assert np.any(J_stick[1] != 0.0)  # the stick point depends on the state
    assert np.array_equal(J_release, np.diag([0.0, 1.0, 0.0, 0.0]))  # release time fixed
    # the whole segment has rank 1: everything after the release depends on x_s alone
    sv = np.linalg.svd(product(jacs), compute_uv=False)
    assert sv[1] < 1e-12 * sv[0]


@pytest.mark.parametrize("f", [70.0, 85.2])
def test_log_det_telescopes_to_restitution_and_flux(f):
    """det S = -alpha beta hdot+ / hdot- per reflection and hdot- = -hdot+ / alpha at an
    impact, while det E = hdot+ / w and det C = w / hdot+: over n ordinary impacts
    sum log |det J| = n log(alpha^2 beta) + log(hdot+_0 / hdot+_n) (the flux
    |hdot| dt dx dvx dvy through the section, times the restitution)."""
    p = Params(f=f)
    kp = p.kernel()
    states, jacs = tangent(kp, START, 25)
    assert all(s[6] == IMPACT and abs(s[3]) < 0.5 * kp.d for s in states)  # no wedge chains
    total = sum(math.log(abs(np.linalg.det(J))) for J in jacs)
    expected = 25 * math.log(p.alpha**2 * p.beta) + math.log(
        hdot(states[0], kp) / hdot(states[-1], kp)
    )
    assert total == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_static_elastic_floor_is_hamiltonian():
    """A = 0, alpha = beta = 1: energy is conserved, so its differential is carried by J;
    the system is autonomous, so a time shift stays a time shift; the flux measure
    |hdot| dt dx dvx dvy of the section is preserved (det J = hdot+_n / hdot+_{n+1})."""
    p = Params(f=50.0, A=0.0, alpha=1.0, beta=1.0)
    kp = p.kernel()
    states, jacs = tangent(kp, START, 60)
    for s0, s1, J in zip(states, states[1:], jacs, strict=False):
        assert s1[6] == IMPACT

        def grad_energy(s):
            xi, vx, vy = s[3], s[4], s[5]
            return np.array([0.0, p.g * (-xi / arc_root(xi, kp)), vx, vy])

        assert np.allclose(grad_energy(s1) @ J, grad_energy(s0), rtol=1e-9, atol=1e-9)
        assert np.allclose(J[:, 0], [1.0, 0.0, 0.0, 0.0], atol=1e-9)
        assert abs(np.linalg.det(J)) == pytest.approx(hdot(s0, kp) / hdot(s1, kp), rel=1e-9)


# ---- the exponent (bbdyn.lyapunov.billiard_lyapunov) ---------------------------------------
def test_gamma_below_one_gives_no_positive_exponent():
    """Gamma < 1: every particle chatters, sticks and never leaves (the floor never pulls
    away), so after the transient nothing moves: no exponent is positive."""
    from bbdyn.core.status import STUCK_FOREVER
    from bbdyn.lyapunov import billiard_lyapunov

    p = Params(f=45.0)
    assert p.gamma < 1
    res = billiard_lyapunov(p, 8, t=2.0, transient=3.0, seed=4)
    assert np.all(res["status"] == STUCK_FOREVER)
    for per in ("second", "collision"):
        lam = res.exponents(per)
        assert not np.any(np.isnan(lam)) and np.all(lam <= 0.0), lam
    assert res.summary()["lam1_per_s"] <= 0.0


def test_a_particle_stuck_for_good_during_the_measurement_rests_until_its_end():
    """Gamma < 1 without a transient: each particle bounces, sticks for good within the
    measured 2 s, and rests there until the end: its windows cover the whole 2 s."""
    from bbdyn.core.status import STUCK_FOREVER
    from bbdyn.lyapunov import billiard_lyapunov

    res = billiard_lyapunov(Params(f=45.0), 4, t=2.0, transient=0.0, windows=1, seed=4)
    assert np.all(res["status"] == STUCK_FOREVER) and np.all(res["collisions"].sum(axis=1) > 0)
    assert np.allclose(res["duration"].sum(axis=1), 2.0, rtol=0, atol=1e-9)


def test_same_seed_same_numbers_and_windows_add_up():
    from bbdyn.lyapunov import billiard_lyapunov

    p = Params(f=85.2)
    a = billiard_lyapunov(p, 4, t=1.0, transient=0.5, windows=3, seed=7)
    b = billiard_lyapunov(p, 4, t=1.0, transient=0.5, windows=3, seed=7)
    for key in ("log_growth", "collisions", "duration", "initial"):
        assert np.array_equal(a[key], b[key])
    # the windows tile the measured second: their durations add up to it within a flight
    assert np.all(np.abs(a["duration"].sum(axis=1) - 1.0) < 0.1)
    total = a["log_growth"].sum(axis=1) / a["duration"].sum(axis=1)
    assert np.array_equal(a.exponents("second"), total)


def test_cli_json_equals_the_api(capsys):
    import json

    from bbdyn.commands.cli import main
    from bbdyn.lyapunov import billiard_lyapunov

    argv = ["lyapunov", "--f", "70", "--R", "20", "--n", "3", "--t", "1", "--no-classify"]
    assert main([*argv, "--json"]) == 0
    out = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(c))
    s = billiard_lyapunov(Params(f=70.0, R=20.0), 3, t=1.0, transient=2.0, seed=0).summary()
    assert out["model"] == "billiard" and out["per"] == "ensemble"
    for key in ("lam1_per_s", "lam1_per_s_se", "lam1_per_collision", "lam1_per_collision_se"):
        assert out[key] == s[key]


def test_locked_attractor_at_58_hz_has_the_top_orbits_exponent(capsys):
    """At 58 Hz the classifier finds a trapped cycle and a 1/1-locked attractor.  On the locked
    one every flight lasts one period and lands nearly vertically; the arcs' curvature is
    the same everywhere, so its exponent is that of the closed-form top orbit, log(mu) / T
    (derivations/billiard_orbit_jacobian.py), to within the tilt of the flights."""
    import json

    from derivation_loader import load_derivation

    from bbdyn.commands.cli import main

    assert main(["lyapunov", "--f", "58", "--n", "20", "--t", "10", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["per"] == "attractor"
    locked = [a for a in out["attractors"] if a["character"] == "locked"]
    assert len(locked) == 1
    D = load_derivation("billiard_orbit_jacobian")
    p = Params(f=58.0)
    mu = float(D.largest_multiplier().subs({D.alpha: p.alpha, D.beta: p.beta, D.R: p.R,
                                            D.g: p.g, D.w: p.w, D.k: 1}))  # fmt: skip
    assert locked[0]["lam1_per_collision"] == pytest.approx(math.log(mu), rel=0.01)
    assert locked[0]["lam1_per_s"] == pytest.approx(math.log(mu) * p.f, rel=0.01)
