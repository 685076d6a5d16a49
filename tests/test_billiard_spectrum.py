"""The whole Lyapunov spectrum of the billiard (bbdyn.core.billiard_tangent, bbdyn.lyapunov)
against independent facts.

* the sum of the four exponents over impact-to-impact events is the closed-form
  ``log |det J|`` of those events (``alpha^2 beta`` per reflection and the flux
  ``hdot+_0 / hdot+_1``, from the event states alone), through wedge chains and between
  sticks, within the rounding of the gap rates of tiny hops;
* the flat floor (R = 1e12 mm): along a vertical orbit on an arc top the spectrum is the
  flat ball's pair (its own kernel's Jacobians and QR) plus 0 and log beta per impact (the
  horizontal position is neutral, vx shrinks by beta);
* the top orbit's four closed-form multipliers: tests/test_derivations_billiard_jacobian.py;
  here their convergence as 1/n under longer runs;
* the QR interval does not change the exponents (the R factors of a product multiply);
* the frame's first vector is bitwise the one-vector run (the largest exponent);
* a stick leaves one direction: three exponents -inf, the largest finite.
"""

import json
import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.billiard import billiard_event
from bbdyn.core.billiard_tangent import (
    SpectrumWindows,
    billiard_tangent_run,
    billiard_tangent_step,
    gap_rate,
)
from bbdyn.core.flat_jacobian import flat_map_jacobian_entries
from bbdyn.core.floor import arc_root
from bbdyn.core.plate import TWO_PI
from bbdyn.core.status import IMPACT, OK
from bbdyn.core.tangent import TangentWindows, gram_schmidt_2
from bbdyn.ensemble import initial_conditions, kernel_states
from bbdyn.flat.tongues import k1_orbit
from bbdyn.lyapunov import billiard_lyapunov, billiard_lyapunov_from

EPS = np.finfo(float).eps


def run_frame(kp, state, t_end, frame, qr_every=1):
    """One window up to ``t_end`` periods with ``frame`` (4, m): (TangentWindows,
    SpectrumWindows, last state, status)."""
    m = frame.shape[1]
    out = TangentWindows(np.zeros(1), np.zeros(1, np.int64), np.zeros(1, np.int64), np.zeros(1))
    spec = SpectrumWindows(np.zeros((1, m)), np.zeros(1), np.zeros(1, np.int64), np.zeros(1),
                           np.zeros(1, np.int64))  # fmt: skip
    state = (*state[:6], int(state[6]))
    end, status = billiard_tangent_run(state, kp, np.array([t_end]), frame, qr_every, out, spec)
    return out, spec, end, status


def closed_form_along(kp, state, t_end):
    """The closed-form log |det J| summed over the impact-to-impact events up to ``t_end``
    periods (as ``billiard_tangent_run`` stops: at the first event after it), computed here
    from the event states, the number of wedge chains, and the rounding of the Jacobians:
    ``J = C S Phi E`` is a product whose factors ``E`` and ``C`` have norms up to
    ``s = (|vyrel| + |xi vx / S|) / hdot`` at the event they belong to (``1 / hdot`` in the
    rows of the event time), so ``J`` and its ``log |det|`` are known to ``eps (1 + s_0)
    (1 + s_1)``: rounding level for ordinary impacts, more for the tiny hops of a chattering
    sequence (hdot ~ 1e-8 mm/s, tau ~ 1e-10 s)."""
    mats = (np.empty((4, 4)), np.empty((4, 4)), np.empty((4, 4)))
    s = (*state[:6], int(state[6]))
    total, rounding, carried, chains = 0.0, 0.0, 0, 0
    restitution = math.log(kp.alpha**2 * kp.beta)

    def scale(xi, vx, vy):
        return (abs(vy) + abs(xi * vx / arc_root(xi, kp))) / gap_rate(xi, vx, vy, kp)

    while True:
        *nxt, status, reflections = billiard_tangent_step(*s, kp, mats)
        assert status == OK
        if s[6] == IMPACT and nxt[6] == IMPACT:
            h0, h1 = gap_rate(*s[3:6], kp), gap_rate(*nxt[3:6], kp)
            total += reflections * restitution + math.log(h0) - math.log(h1)
            rounding += EPS * (1 + scale(*s[3:6])) * (1 + scale(*nxt[3:6]))
            carried += 1
            chains += reflections > 1
        s = tuple(nxt)
        if s[0] + s[1] / TWO_PI > t_end:
            return total, rounding, carried, chains


def start_frame():
    from bbdyn.lyapunov import _start_frame

    return _start_frame(4)


@pytest.mark.parametrize(("f", "R"), [(85.2, 25.0), (85.2, 1.05)])
def test_sum_of_the_spectrum_is_the_closed_form_determinant(f, R):
    """QR sum of log R_ii over the impact-to-impact events = sum of the closed-form
    log |det J| (not the determinant of the same matrices), within 16 times the rounding of
    the Jacobians (``closed_form_along``: a handful of operations on each factor).  85.2 Hz
    sticks between the carried stretches; at R = 1.05 mm some events are wedge chains
    (several reflections)."""
    p = Params(f=f, R=R)
    kp = p.kernel()
    t_end = 300.0  # periods
    sticks = chains = 0
    for state in kernel_states(p, initial_conditions(p, 3, 0)):
        _, spec, _, status = run_frame(kp, state, t_end, start_frame())
        assert status == OK
        closed, rounding, carried, n_chains = closed_form_along(kp, state, t_end)
        assert spec.carried[0] == carried
        assert abs(spec.log.sum() - closed) <= 16 * rounding
        assert spec.log_det[0] == pytest.approx(closed, rel=1e-12, abs=1e-12)
        sticks += spec.sticks[0]
        chains += n_chains
    assert sticks > 0 and (chains > 0 or R > 2)  # restarts after sticks; wedge chains


def test_flat_floor_limit_is_the_flat_balls_pair_plus_the_horizontal_ones():
    """R = 1e12 mm, a vertical orbit on an arc top (xi = vx = 0 stay 0 exactly): the
    Jacobian splits into the flat ball's (theta, vyrel) block and the horizontal block
    [[1, tau], [kappa, beta + kappa tau]], kappa = (alpha + beta) V / R.  With the frame
    started on (theta, vyrel, x, vx) the QR keeps the blocks apart: the first two logs
    are the flat ball's QR of its own kernel's Jacobians along the same impacts, the
    last two 0 and log beta per impact, up to kappa tau / (1 - beta) per impact."""
    p = Params(f=120.0, alpha=0.8, R=1e12)  # a chaotic flat ball (tests/test_lyapunov.py)
    kp = p.kernel()
    rng = np.random.default_rng(3)
    checked = 0
    for phase, vrel in zip(TWO_PI * rng.random(12), 1.0 + 30.0 * rng.random(12), strict=True):
        start = (0.0, phase, 0.0, 0.0, 0.0, vrel, IMPACT)
        t_end = 200.0
        frame = np.eye(4)[:, [0, 3, 1, 2]]
        _, spec, _, status = run_frame(kp, start, t_end, frame)
        if status != OK or spec.sticks[0] > 0:
            continue
        # the flat ball's own Jacobians and QR at the billiard's impacts
        s, q, flat, n, curvature = start, (1.0, 0.0, 0.0, 1.0), np.zeros(2), 0, 0.0
        while s[0] + s[1] / TWO_PI <= t_end:
            *_, j00, j01, j10, j11, st = flat_map_jacobian_entries(s[1], s[5], kp)
            assert st == OK
            *q, l0, l1 = gram_schmidt_2(*q, j00, j01, j10, j11)
            flat += (l0, l1)
            nxt = billiard_event(*s, kp)[:7]
            assert nxt[6] == IMPACT and nxt[3] == 0.0 and nxt[4] == 0.0
            tau = (TWO_PI * (nxt[0] - s[0]) + nxt[1] - s[1]) / p.w
            fall = nxt[5] / p.alpha  # the speed of the fall, V = vyrel+ / alpha
            curvature += (p.alpha + p.beta) * fall * tau / p.R / (1 - p.beta)
            s, n = nxt, n + 1
        assert spec.carried[0] == n
        assert spec.log[0, :2] == pytest.approx(flat, rel=1e-9)
        assert flat[0] > 0 > flat[1]  # chaotic
        assert abs(spec.log[0, 2]) <= curvature
        assert abs(spec.log[0, 3] - n * math.log(p.beta)) <= curvature
        checked += 1
    assert checked >= 3


def test_top_orbit_spectrum_converges_as_one_over_n():
    """Longer runs on the 58 Hz top orbit: n times the error of each exponent per collision
    against the closed-form multipliers stays below the same 2 log cond(V) (V: the
    eigenvectors of the orbit's Jacobian; the frame's start and end, spread over the run),
    so the error falls as 1/n; the rotating pair of the flat block (complex multipliers of
    modulus alpha) oscillates inside it."""
    from test_derivations_billiard_jacobian import one_event, top_orbit_log_multipliers

    p = Params(f=58.0)
    o = k1_orbit(p, 1)
    state = (0.0, o.phase_stable, 0.0, 0.0, 0.0, o.vrel, IMPACT)
    mu = top_orbit_log_multipliers(p, 1, math.sin(o.phase_stable))
    _, J = one_event(p.kernel(), state)
    bound = 2 * math.log(np.linalg.cond(np.linalg.eig(J)[1]))
    for n in (100, 400, 1600):
        res = billiard_lyapunov_from(p, [state], t=(n + 0.5) / p.f, windows=1, spectrum=True)
        assert res["collisions"].sum() == n
        assert np.max(np.abs(res.spectrum("collision")[0] - mu)) * n < bound


def test_qr_interval_does_not_change_the_exponents():
    """QR every event, every 3 or every 7 impact-to-impact events: the R factors of a
    product of Jacobians are the products of the R factors, so the logs agree to rounding
    where the products are well conditioned: the particles that do not stick (58 Hz, the
    locked attractor).  (Across the tiny hops of a chattering sequence the product's
    singular values spread over many decades and the smallest exponent loses digits: QR
    every event is the default.)"""
    p = Params(f=58.0)
    runs = [billiard_lyapunov(p, 6, t=2.0, transient=2.0, seed=0, spectrum=True, qr_every=q)
            for q in (1, 3, 7)]  # fmt: skip
    free = runs[0].free()
    assert free.any() and all(np.array_equal(r.free(), free) for r in runs)
    logs = [r["spectrum_growth"][free] for r in runs]
    for other in logs[1:]:
        assert np.max(np.abs(other - logs[0])) < 1e-9 * np.max(np.abs(logs[0]))


def test_the_first_vector_of_the_frame_is_the_largest_exponent_run_bitwise():
    p = Params(f=85.2)
    one = billiard_lyapunov(p, 3, t=2.0, transient=0.5, seed=2)
    four = billiard_lyapunov(p, 3, t=2.0, transient=0.5, seed=2, spectrum=True)
    for key in ("log_growth", "collisions", "collapses", "duration"):
        assert np.array_equal(one[key], four[key]), key
    assert np.array_equal(four.spectrum()[:, 0], one.exponents())


def test_a_stick_leaves_one_direction():
    """At 58 Hz the trapped cycle sticks every period: the largest exponent stays finite
    (the stick point is carried), the other three are -inf; the frame is orthonormal after
    the restarts and the sum between sticks is still the closed form."""
    p = Params(f=58.0)
    res = billiard_lyapunov(p, 6, t=2.0, transient=2.0, seed=0, spectrum=True)
    stuck = ~res.free()
    assert stuck.any() and (~stuck).any()  # the trapped cycle and the locked attractor
    lam = res.spectrum()
    assert np.all(np.isfinite(lam[:, 0]))
    assert np.all(lam[stuck, 1:] == -math.inf) and np.all(np.isfinite(lam[~stuck]))
    s = res.summary()
    assert s["inf_exponents"] == 3 and s["spectrum_per_s"][1] is not None
    assert s["spectrum_per_s"][1] == -math.inf and s["stick_event_fraction"] > 0
    qr, closed = res.determinant_check()
    assert np.allclose(qr, closed, rtol=1e-9, atol=0)
    # the free particles (locked, chaotic): one growing direction; per collision their
    # four exponents add up to the closed form (every collision is carried)
    free = lam[~stuck]
    assert np.all(free[:, 0] > 0) and np.all(free[:, 1:] < 0)
    per_collision = res.spectrum("collision")[~stuck].sum(axis=1)
    assert per_collision == pytest.approx(closed[~stuck], rel=1e-9)
    # after the restarts at the sticks the frame is still orthonormal
    frame = start_frame()
    state = kernel_states(p, res["initial"][stuck][:1])[0]
    _, spec, _, status = run_frame(p.kernel(), state, 200.0, frame)
    assert status == OK and spec.sticks[0] > 100
    assert np.allclose(frame.T @ frame, np.eye(4), rtol=0, atol=1e-12)


def test_spectrum_cli_json_equals_the_api(capsys):
    from bbdyn.commands.cli import main

    argv = ["lyapunov", "--f", "88.4", "--n", "3", "--t", "1", "--transient", "0.5",
            "--no-classify", "--spectrum", "--qr-every", "2", "--json"]  # fmt: skip
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    res = billiard_lyapunov(Params(f=88.4), 3, t=1.0, transient=0.5, seed=0, spectrum=True,
                            qr_every=2)  # fmt: skip
    s = res.summary()
    assert out["qr_every"] == 2
    for key in ("free_spectrum_per_s", "free_spectrum_per_event", "log_det_per_event",
                "spectrum_sum_per_event", "stick_event_fraction", "inf_exponents"):  # fmt: skip
        assert out[key] == s[key], key
    assert out["spectrum_per_s"] == [None if x == -math.inf else x for x in s["spectrum_per_s"]]
