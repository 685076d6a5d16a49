"""Impact times of bbdyn's exact kernels against an independent integrator (heyoka).

heyoka (optional extra ``peers``) integrates the flights of docs/model.md with an
adaptive Taylor method and finds the contacts as roots of the gap's Taylor polynomial
(``bbdyn.reference.heyoka_flight``); it shares no code with ``bbdyn.core``.

Tolerance.  Both methods evaluate the gap relative to its start, as a sum of terms of
at most ``S = tau (|vy0| + g tau/2 + A w + |vx| d / 2 c0)`` mm over a flight of ``tau`` s
(rise, fall, the floor's motion and the arc's drop), with rounding errors of order
eps S (a few operations per step, a few steps); a gap error dG moves a
transversal contact by dG / |G'| (``G'``: the gap's rate at the contact).  The exact
kernel may also stop up to ``ROOT_STEP_REL tau`` early.  So the flight times must agree
within ``2 ROOT_STEP_REL tau + GAP_ULPS eps S / |G'|`` (``GAP_ULPS = 64``): its median
over the flights is below ``1e-13`` of the flight (asserted), far below any wrong contact
(a different root differs by a sizeable part of the flight).
"""

import math

import numpy as np
import pytest
from extras import require
from scipy.optimize import brentq

from bbdyn.core.billiard import billiard_flight
from bbdyn.core.flat import FlatArrays, FlatState, flat_flight, flat_run
from bbdyn.core.status import IMPACT, OK, STICK
from bbdyn.core.tolerances import EPS, ROOT_STEP_REL
from bbdyn.params import Params
from bbdyn.reference import heyoka_flight
from bbdyn.reference.billiard_mpmath import reference_flight
from bbdyn.scenes import b2_billiard, b2_flat

require("heyoka", "peers")

#: Rounding allowance of the gap, in units of eps times its largest term.
GAP_ULPS = 64.0

#: Flights compared per family.
N_FLIGHTS = 300


def time_tolerance(kp, tau, vy0, gap_rate, vx=0.0):
    """Largest expected |tau_heyoka - tau_exact| (s) (module docstring)."""
    scale = tau * (abs(vy0) + 0.5 * kp.g * tau + kp.A * kp.w + abs(vx) * 0.5 * kp.d / kp.c0)
    return 2.0 * ROOT_STEP_REL * tau + GAP_ULPS * EPS * scale / abs(gap_rate)


def _arc_rate(kp, xi, vx, vyrel):
    """Rate of the gap to the arc at ``xi`` (mm/s): vyrel - b'(xi) vx, b' = -xi / S."""
    return vyrel + vx * xi / math.sqrt((kp.R - xi) * (kp.R + xi))


def _compare_billiard(kp, starts):
    """Both methods from every start ``(phase, xi0, vx, vyrel)``; returns arrays per flight."""
    taylor = heyoka_flight.BilliardTaylor(kp)
    out = {key: np.empty(len(starts)) for key in ("tau", "k", "tau_h", "k_h", "tol")}
    for i, (phase, xi0, vx, vyrel) in enumerate(starts):
        tau, k, xi, vym, _, status = billiard_flight(phase, xi0, vx, vyrel, kp)
        assert status == OK
        tau_h, k_h, _, _ = taylor.flight(phase, xi0, vx, vyrel)
        out["tau"][i], out["k"][i], out["tau_h"][i], out["k_h"][i] = tau, k, tau_h, k_h
        out["tol"][i] = time_tolerance(kp, tau, vyrel, _arc_rate(kp, xi, vx, vym), vx)
    return out


#: The tolerance's median, relative to the flight, must stay below this (a tight check).
MEDIAN_TOL_REL = 1e-13


def _assert_agree(out):
    """Same contact tile everywhere, flight times within the tolerance."""
    np.testing.assert_array_equal(out["k_h"], out["k"])
    excess = np.abs(out["tau_h"] - out["tau"]) / out["tol"]
    worst = int(np.argmax(excess))
    assert excess[worst] <= 1.0, (worst, out["tau"][worst], out["tau_h"][worst])


def test_flat_ball_impact_times_agree_on_the_b2_attractor():
    """300 flights of the chaotic B2-FLAT case: the same impact times within the tolerance."""
    params = b2_flat.case_params()
    kp = params.kernel()
    arrays = [np.empty(N_FLIGHTS) for _ in range(3)] + [np.empty(N_FLIGHTS, dtype=np.int64)]
    start = (0.0, b2_flat.CASE["phase0"], b2_flat.CASE["vrel0"], IMPACT)
    _, n_done, status = flat_run(FlatState(*start), kp, N_FLIGHTS, FlatArrays(*arrays))
    assert status == OK and n_done == N_FLIGHTS
    impacts = arrays[3] == IMPACT
    assert impacts.sum() >= N_FLIGHTS - 5  # the window is chaotic, nearly stick-free
    taylor = heyoka_flight.FlatTaylor(kp)
    worst = 0.0
    tol_rel = []
    for phase, vrel in zip(arrays[1][impacts], arrays[2][impacts], strict=True):
        tau, vm, status = flat_flight(phase, vrel, kp)
        assert status == OK
        tau_h, vm_h = taylor.flight(phase, vrel)
        tol = time_tolerance(kp, tau, vrel, vm)
        worst = max(worst, abs(tau_h - tau) / tol)
        tol_rel.append(tol / tau)
        # |d vrel / d tau| <= g + A w^2: the velocities follow the times
        assert vm_h == pytest.approx(vm, abs=kp.curv_bound * tol + 64 * EPS * abs(vrel))
    assert worst <= 1.0 and np.median(tol_rel) < MEDIAN_TOL_REL


def test_billiard_impact_times_agree_on_the_b2_attractor():
    """Moving floor (B2-BILLIARD case, f = 85.2 Hz): every flight from the attractor."""
    params = Params(f=b2_billiard.CASE["f"])
    kp = params.kernel()
    states = b2_billiard.attractor_states(params, N_FLIGHTS)
    keep = states["kind"] != STICK  # a STICK is followed by a release, not a flight
    starts = np.column_stack([states[k][keep] for k in ("phase", "xi", "vx", "vyrel")])
    out = _compare_billiard(kp, starts)
    _assert_agree(out)
    # The tightness check on the flights that are not chattering hops (a tenth of a period
    # or longer): a hop's tolerance is set by the rounding of the floor's motion A w tau
    # against its tiny landing speed, not by the flight, and more than half of these
    # flights are hops.
    flights = out["tau"] >= 0.1 * kp.period
    assert flights.sum() >= 100
    assert np.median(out["tol"][flights] / out["tau"][flights]) < MEDIAN_TOL_REL


STATIC = Params(f=50.0, A=0.0)


def _static_starts(kp, n, seed=12):
    """``n`` random departures ``(phase, xi0, vx, vyrel)`` that leave the arc."""
    rng = np.random.default_rng(seed)
    starts = []
    while len(starts) < n:
        xi0 = rng.uniform(-0.5 * kp.d, 0.5 * kp.d)
        vx, vyrel = rng.uniform(-400.0, 400.0), rng.uniform(1.0, 150.0)
        if _arc_rate(kp, xi0, vx, vyrel) > 0.0:  # leaves the arc
            starts.append((rng.uniform(0.0, 2.0 * math.pi), xi0, vx, vyrel))
    return starts


def test_static_floor_flights_landing_on_other_tiles():
    """Random departures from a floor at rest: contact tile and time agree, many tiles away."""
    kp = STATIC.kernel()
    out = _compare_billiard(kp, _static_starts(kp, N_FLIGHTS))
    _assert_agree(out)
    assert np.median(out["tol"] / out["tau"]) < MEDIAN_TOL_REL
    # The tile bookkeeping is exercised: many flights end on another tile, some far away.
    assert np.mean(out["k"] != 0) > 0.5 and np.abs(out["k"]).max() >= 5


def test_heyoka_alone_against_the_mpmath_references():
    """heyoka's contact times against 40-digit roots, without the exact kernels in between."""
    params = b2_flat.case_params()
    kp = params.kernel()
    states = b2_flat.start_states(params, 8)  # mpmath one-step references on the orbit
    taylor = heyoka_flight.FlatTaylor(kp)
    for phase, vrel, tau_ref in zip(states["phase"], states["vrel"], states["tau"], strict=True):
        tau, vm = taylor.flight(float(phase), float(vrel))
        assert abs(tau - tau_ref) <= time_tolerance(kp, tau_ref, vrel, vm)
    kp = STATIC.kernel()
    taylor = heyoka_flight.BilliardTaylor(kp)
    for phase, xi0, vx, vyrel in _static_starts(kp, 8, seed=3):
        tau, k, xi, vym = taylor.flight(phase, xi0, vx, vyrel)
        tau_ref = reference_flight(kp, phase, xi0, vx, vyrel, k, tau)[0]
        assert abs(tau - tau_ref) <= time_tolerance(
            kp, tau_ref, vyrel, _arc_rate(kp, xi, vx, vym), vx
        )


def _apex_over_next_top(kp, side, clearance):
    """Start on tile 0 whose parabola (vx = 700 side mm/s) peaks over the top of tile ``side``.

    The apex is ``clearance`` mm above that top (floor at rest), at ``t_top`` s.  Since
    g / vx^2 < 1 / R the parabola is flatter than the arc there, so the gap over that
    tile is ``clearance + kappa u^2 + O(u^4)`` (u: horizontal distance to the top,
    ``kappa = (1/R - g/vx^2) / 2``): no contact near the top if ``clearance > 0``, else
    the first contact at ``u = -side sqrt(-clearance / kappa)``.
    Returns ``(start, t_top, kappa)``.
    """
    vx = 700.0 * side
    h = (0.5 * kp.d) ** 2 / (kp.R + kp.c0)  # R - c0 without cancellation

    def b(xi):
        return (0.5 * kp.d - xi) * (0.5 * kp.d + xi) / (math.sqrt(kp.R**2 - xi * xi) + kp.c0)

    def vy(xi0):
        return math.sqrt(2.0 * kp.g * (h + clearance - b(xi0)))

    # Apex at x = side d (top of the neighbour): xi0 + vx vy / g = side d.  Bracket: from
    # where b(xi0) < h + clearance (b <= h - xi0^2 / 2R) to the wedge.
    low = side * 2.0 * math.sqrt(2.0 * kp.R * max(-clearance, 0.0))
    xi0 = brentq(lambda x: x + vx * vy(x) / kp.g - side * kp.d, low, side * 0.5 * kp.d, xtol=1e-15)
    kappa = 0.5 * (1.0 / kp.R - kp.g / vx**2)
    return (0.0, xi0, vx, vy(xi0)), vy(xi0) / kp.g, kappa


@pytest.mark.parametrize("side", [1, -1], ids=["right", "left"])
@pytest.mark.parametrize("clearance", [1e-6, 1e-9, 1e-12, -1e-12, -1e-9, -1e-6])
def test_near_grazing_top_of_the_neighbouring_tile(side, clearance):
    """A flight that skims the neighbour's top: a near miss flies on, a slight overlap lands there.

    This would catch a wrong contact tile (or a contact missed between two steps): both
    methods must put the contact on tile ``side`` just before the top when the parabola
    dips below it, and after the top when it clears it.
    """
    kp = STATIC.kernel()
    start, t_top, kappa = _apex_over_next_top(kp, side, clearance)
    out = _compare_billiard(kp, [start])
    _assert_agree(out)
    tau_h, k_h = out["tau_h"][0], out["k_h"][0]
    if clearance > 0.0:
        assert tau_h > t_top and out["tau"][0] > t_top  # flies on past the top
    else:
        assert k_h == side  # lands on the neighbour, before its top, as predicted
        lead = math.sqrt(-clearance / kappa) / abs(start[2])
        # rel: the clearance is built to ~eps h, 4e-6 of 1e-12 mm (lead ~ sqrt(clearance))
        assert t_top - tau_h == pytest.approx(lead, rel=1e-4)
