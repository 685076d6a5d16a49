"""The end of a descending flight from the Taylor polynomial of its gap
(core.taylor.taylor_finish).

Once the safe-step search is near a transversal contact (the gap falling, ``G / |G'|``
below half a radian of the drive), the contact is solved by Newton on the gap's Taylor
polynomial instead of more steps.  Checked against the independent quadratic-step search
and mpmath, on the flights of runs at 50-85 Hz and on random flights over hard floors; and
directly, from points just before a known contact, on what it must solve and refuse.

The error measure: near the contact the gap is a sum of terms of order ``A + |vyrel| tau +
(g + A w^2) tau^2 / 2`` and the arc's height ``R - c0`` (mm), each rounded, so every
method's root moves by eps times that over ``|G'|`` there, besides the eps tau at which the
search stops (``_scale``).
"""

import math

import numpy as np
import pytest
from flight_rules import both_rules, flight_starts, random_starts
from numba import njit

from bbdyn import Params
from bbdyn.core.billiard import crossing_time, segment_gap_phase, tile_offset
from bbdyn.core.floor import arc_root
from bbdyn.core.plate import sin_cos
from bbdyn.core.status import OK
from bbdyn.core.taylor import TilePoint, drive_tail, tail_terms, taylor_finish
from bbdyn.core.tolerances import EPS

FREQS = (50.2, 70.2, 85.2)


def _starts(f, n_max=3000):
    kp, starts = flight_starts(f, False, n_max, 100 * n_max)
    assert len(starts) == n_max
    return kp, starts


def _scale(kp, tau, xi, vx, vyrel, vyrel_minus):
    """``eps (tau + terms / |G'|)`` at the contact: the resolution of its time (s)."""
    S = np.sqrt((kp.R - xi) * (kp.R + xi))
    rate = np.abs(vyrel_minus + vx * xi / S)  # |G'| at the contact
    drive = 2 * kp.A + np.abs(vyrel) * tau + 0.5 * (kp.g + kp.A * kp.w**2) * tau**2
    terms = drive + (kp.R - kp.c0)  # and the floor's height on the arc, b(xi) - b(xi0)
    return EPS * (tau + terms / rate)


def _check_against_quadratic_search(kp, starts, out):
    """Same tiles; times, points and velocities within rounding; the widest four in mpmath."""
    from bbdyn.reference.billiard_mpmath import reference_flight

    assert np.all(out[:, 5] == OK) and np.all(out[:, 10] == OK)
    assert np.array_equal(out[:, 1], out[:, 7])
    phase, xi0, vx, vyrel = starts.T
    scale = _scale(kp, out[:, 6], out[:, 8], vx, vyrel, out[:, 9])
    excess = np.abs(out[:, 0] - out[:, 6]) / scale
    assert excess.max() <= 4.0
    assert np.all(np.abs(out[:, 2] - out[:, 8]) <= 8 * EPS * kp.d + np.abs(vx) * 4 * scale)
    curv = kp.g + kp.A * kp.w**2 + kp.R**2 * vx**2 / kp.c0**3
    v_scale = np.abs(vyrel) + curv * out[:, 6]
    assert np.all(np.abs(out[:, 3] - out[:, 9]) <= curv * 4 * scale + 64 * EPS * v_scale)
    for i in np.argsort(-excess)[:4]:
        ref = reference_flight(kp, phase[i], xi0[i], vx[i], vyrel[i], out[i, 1], out[i, 0])[0]
        assert abs(out[i, 0] - ref) <= 4 * scale[i]


@pytest.mark.parametrize("f", FREQS)
def test_searched_flights_agree_with_the_quadratic_search_and_mpmath(f):
    kp, starts = _starts(f)
    out = np.zeros((len(starts), 11))
    both_rules(starts, kp, out)
    _check_against_quadratic_search(kp, starts, out)


@njit(cache=True)
def _finish_before(starts, taus, ks, before, kp, out):
    """``taylor_finish`` from ``before[j]`` s ahead of the contact ``taus[j]`` of flight j (on
    its contact tile ``ks[j]``).  Columns of ``out``: solved, tau_a + u, xi, vyrel^-;
    solved = -1 where that point is not on the contact tile or not before it."""
    for j in range(starts.shape[0]):
        phase, xi0, vx, vyrel = starts[j, 0], starts[j, 1], starts[j, 2], starts[j, 3]
        tau = taus[j] - before[j]
        if not tau > 0.0 or tile_offset(xi0, vx, tau, kp.d) != ks[j]:
            out[j, 0] = -1.0
            continue
        sn, cs = sin_cos(phase)
        G, Gp, _, Fp, xi, S, sn_t, cn_t = segment_gap_phase(
            tau, ks[j], sn, cs, xi0, arc_root(xi0, kp), vx, vyrel, kp
        )
        if not (G > 0.0 and Gp < 0.0):
            out[j, 0] = -1.0
            continue
        point = TilePoint(xi, S, vx, crossing_time(xi0, ks[j], vx, kp.d) - tau)
        u, xi_c, Fp_c, ok = taylor_finish(tau, G, Gp, Fp, sn_t, cn_t, point, kp)
        out[j, 0], out[j, 1], out[j, 2], out[j, 3] = 1.0 if ok else 0.0, tau + u, xi_c, Fp_c


@pytest.mark.parametrize("f", FREQS)
def test_finish_from_points_before_a_known_contact(f):
    """From 0.005 to 0.2 rad of phase before the contact the quadratic search finds, the
    finish lands on it (a wrong coefficient of degree 3 moves it by ~1e-6 s)."""
    kp, starts = _starts(f)
    both = np.zeros((len(starts), 11))
    both_rules(starts, kp, both)
    on_arc = np.abs(starts[:, 1]) < 0.5 * kp.d
    starts, both = starts[on_arc], both[on_arc]
    before = np.random.default_rng(1).uniform(0.005, 0.2, len(starts)) / kp.w
    out = np.zeros((len(starts), 4))
    _finish_before(starts, both[:, 6], both[:, 7], before, kp, out)
    tried = out[:, 0] >= 0
    solved = out[:, 0] == 1
    # solved from most points (measured: 31 % at 50.2 Hz, where many flights are shorter
    # than 2 G / |G'|, and over 70 % above), and right wherever solved
    assert solved.sum() > max(100, 0.25 * tried.sum())
    vx, vyrel = starts[solved, 2], starts[solved, 3]
    tau_q, xi_q, v_q = both[solved, 6], both[solved, 8], both[solved, 9]
    scale = _scale(kp, tau_q, xi_q, vx, vyrel, v_q)
    assert np.all(np.abs(out[solved, 1] - tau_q) <= 4 * scale)
    assert np.all(np.abs(out[solved, 2] - xi_q) <= 8 * EPS * kp.d + np.abs(vx) * 4 * scale)
    curv = kp.g + kp.A * kp.w**2 + kp.R**2 * vx**2 / kp.c0**3
    v_scale = np.abs(vyrel) + curv * tau_q
    assert np.all(np.abs(out[solved, 3] - v_q) <= curv * 4 * scale + 64 * EPS * v_scale)


def test_taylor_finish_refuses_what_it_cannot_prove():
    kp = Params(f=70.0).kernel()
    sn, cs = math.sin(1.0), math.cos(1.0)

    def attempt(tau, G, Gp, room=1.0, phase_sin=sn, phase_cos=cs, vx=0.5):
        return taylor_finish(
            tau, G, Gp, Gp, phase_sin, phase_cos, TilePoint(0.2, arc_root(0.2, kp), vx, room), kp
        )[3]

    assert attempt(0.01, 1e-3, -20.0)  # a transversal landing well on the arc: solved
    assert not attempt(0.01, 1e-3, -20.0, room=4e-5)  # a wedge before G / |G'|: refused
    assert not attempt(0.01, 0.5, -20.0)  # far from the floor (w G / |G'| = 11 rad): refused
    assert not attempt(4e-5, 1e-3, -20.0)  # G / |G'| longer than the flight so far
    # w G / |G'| = 0.4 rad: solved where the gap is concave up to G / |G'| (u_max = G / |G'|),
    # refused where the floor falls faster than g (u_max = 2 G / |G'|, 0.8 rad, too far)
    G_far = 0.4 / kp.w * 20.0
    assert attempt(0.01, G_far, -20.0)
    # the floor falling faster than g (sin < -1/Gamma): G'' > 0 may turn a slow descent
    # around before the floor is reached, refused; a fast one is still solved
    down = -0.99, math.sqrt(1 - 0.99**2)
    assert not attempt(0.01, 1e-5, -0.5, phase_sin=down[0], phase_cos=down[1])
    assert attempt(0.01, 1e-3, -50.0, phase_sin=down[0], phase_cos=down[1])
    assert not attempt(0.01, G_far, -20.0, phase_sin=down[0], phase_cos=down[1])


@pytest.mark.parametrize(
    "params",
    [Params(f=70.0, R=1.2), Params(f=70.0, R=1e9), Params(f=45.0), Params(f=90.0, A=1.0)],
    ids=["steep_arcs", "flat_limit", "gamma_below_1", "large_amplitude"],
)
def test_random_flights_on_hard_floors(params):
    """Random flights (vertical velocities 0.1 to 300 mm/s, horizontal 1e-6 to 1e2 mm/s, any
    phase, 200 from next to a wedge) agree with the quadratic search and mpmath."""
    kp = params.kernel()
    n = 4000
    starts = random_starts(kp, 7, n, (-1, 2.5))
    out = np.zeros((n, 11))
    both_rules(starts, kp, out)
    _check_against_quadratic_search(kp, starts, out)


@pytest.mark.parametrize("K", [0, 2, 6])
def test_drive_tail_is_the_sum_it_stands_for(K):
    """``drive_tail`` with K terms per chain against its definition summed in mpmath to degree
    ``N = 2 K + 4``, ``T = sum_{n=5..N} s_n y^(n-5) / n!`` and ``T' = sum s_n y^(n-5) /
    (n-1)!``, to a few ulp of their first terms (1/120 and 1/24; K = 0: no tail, both 0)."""
    import mpmath

    mpmath.mp.dps = 40
    N = 2 * K + 4
    rng = np.random.default_rng(N)
    derivs = [mpmath.sin, mpmath.cos, lambda t: -mpmath.sin(t), lambda t: -mpmath.cos(t)]
    for _ in range(100):
        theta, y = rng.uniform(0.0, 2 * math.pi), rng.uniform(-0.6, 0.6)
        T, Tp = drive_tail.py_func(y, math.sin(theta), math.cos(theta), K)
        s = [derivs[n % 4](mpmath.mpf(theta)) for n in range(N + 1)]
        y_mp = mpmath.mpf(y)
        T_ref = sum(s[n] * y_mp ** (n - 5) / mpmath.factorial(n) for n in range(5, N + 1))
        Tp_ref = sum(s[n] * y_mp ** (n - 5) / mpmath.factorial(n - 1) for n in range(5, N + 1))
        assert abs(T - float(T_ref)) <= 8 * EPS / 120
        assert abs(Tp - float(Tp_ref)) <= 8 * EPS / 24


def test_tail_terms_picks_the_lowest_degree_whose_remainder_is_within_budget():
    """``tail_terms(A w, x, budget)`` returns the fewest terms K (degree N = 2 K + 4 of 4, 8,
    16) for which the drive's rate beyond degree N, ``A w (cos(theta + y) - sum_{n<N} s_{n+1}
    y^n / n!)`` for ``|y| <= x``, is at most ``budget`` (checked in mpmath, at 17 phases), and
    the next lower degree's bound ``A w x^N / N!`` exceeds it; -1 when degree 16 does not
    suffice."""
    import mpmath

    mpmath.mp.dps = 50
    aw = 51.5
    derivs = [mpmath.sin, mpmath.cos, lambda t: -mpmath.sin(t), lambda t: -mpmath.cos(t)]

    def rest(N, x):  # the largest |rate beyond degree N| over the phases, at y = +-x
        worst = mpmath.mpf(0)
        for theta in np.linspace(0.0, 2 * math.pi, 17):
            th = mpmath.mpf(theta)
            for y in (mpmath.mpf(x), -mpmath.mpf(x)):
                terms = (derivs[(n + 1) % 4](th) * y**n / mpmath.factorial(n) for n in range(N))
                worst = max(worst, abs(aw * (mpmath.cos(th + y) - sum(terms))))
        return worst

    seen = set()
    for x in (1e-4, 1e-3, 0.01, 0.05, 0.2, 0.5, 0.9):
        for budget in (1e-14, 1e-12, 1e-9):
            K = tail_terms.py_func(aw, x, budget)
            seen.add(K)
            if K < 0:
                assert aw * x**16 / math.factorial(16) > budget
                continue
            N = 2 * K + 4
            assert rest(N, x) <= budget
            if K > 0:
                lower = {2: 4, 6: 8}[K]
                assert aw * x**lower / math.factorial(lower) > budget
    assert seen == {-1, 0, 2, 6}
