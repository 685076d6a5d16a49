"""Limits of the billiard with independent answers: flat floor, elastic static floor."""

import math

import numpy as np
import pytest
from billiard_checks import run_arrays
from scipy.integrate import quad

from bbdyn import Params
from bbdyn.core.flat import flat_event
from bbdyn.core.floor import floor_height_rel
from bbdyn.core.status import IMPACT, OK

TWO_PI = 2.0 * math.pi


# ---- flat limit -----------------------------------------------------------------------


@pytest.mark.parametrize("vx0", [0.0, 100.0], ids=["vx-zero", "vx-nonzero"])
def test_flat_limit_reproduces_flat_map(vx0):
    """R = 1e9 mm: the billiard's events are the flat map's, vx+ = beta vx- at impacts.

    The floor deviates from flat by slopes <= d/2R = 1e-9 and heights <= h = 5e-10 mm;
    at 58 Hz (inside the stable 1/1 tongue) these perturbations do not grow, so
    phases and velocities agree to 1e3 d / 2R (vx = 0 at the tile centre: no slope
    at all, agreement to rounding).
    """
    params = Params(f=58.0, R=1e9)
    kp = params.kernel()
    tol = 1e3 * params.d / (2 * params.R)
    flat = (0.0, 0.0, 84.0, IMPACT)
    bill = (0.0, 0.0, 0.0, 0.0, vx0, 84.0, IMPACT)
    tiles = set()
    vx_expected = vx0
    for n in range(1, 200):
        flat = flat_event(*flat[:4], kp)
        assert flat[4] == OK
        bill = billiard_event_checked(bill, kp)
        t_flat = flat[0] * TWO_PI + flat[1]
        t_bill = bill[0] * TWO_PI + bill[1]
        assert abs(t_flat - t_bill) <= tol * (1 + t_flat), n
        assert bill[6] == flat[3]
        assert abs(bill[5] - flat[2]) <= tol * 50.0, n
        # flat limit: vx+ = beta vx- at an impact; a stick ends the horizontal motion
        vx_expected = vx_expected * params.beta if bill[6] == IMPACT else 0.0
        assert abs(bill[4] - vx_expected) <= tol * (1 + abs(vx0)), n
        tiles.add(bill[2])
    if vx0:
        assert len(tiles) > 20  # the flights do cross tiles


def billiard_event_checked(state, kp):
    from bbdyn.core.billiard import billiard_event

    out = billiard_event(*state[:7], kp)
    assert out[7] == OK
    return out[:7]


# ---- elastic static floor -------------------------------------------------------------

ELASTIC = Params(f=50.0, A=0.0, alpha=1.0, beta=1.0)
EKP = ELASTIC.kernel()


def _energy(xi, vx, vy):
    return 0.5 * (vx**2 + vy**2) + ELASTIC.g * np.array([floor_height_rel(v, EKP) for v in xi])


def test_elastic_static_energy_conserved():
    """alpha = beta = 1, A = 0: E = v^2/2 + g y is conserved to 1e-10 over 1e5 collisions."""
    state0 = (0.0, 0.0, 0.0, 0.37, 23.0, 31.0, IMPACT)
    (periods, phase, tile, xi, vx, vy, kind), status = run_arrays(EKP, state0, 100_000)
    assert status == OK and len(kind) == 100_001
    assert np.all(kind == IMPACT)
    E = _energy(xi, vx, vy)
    drift = np.max(np.abs(E - E[0])) / E[0]
    assert drift <= 1e-10, drift
    assert np.ptp(tile) > 10  # it really travels


def _reflect_back(xi, vx, vy):
    """Velocity that retraces the flight that ended here: -(v-) = -reflect(v+)."""
    S = math.sqrt(ELASTIC.R**2 - xi**2)
    nx, ny = xi / ELASTIC.R, S / ELASTIC.R
    vn = vx * nx + vy * ny
    return -(vx - 2 * vn * nx), -(vy - 2 * vn * ny)


def test_elastic_static_time_reversal():
    """Reversing the velocity after N collisions retraces the path back to the start.

    The error grows like the trajectory's sensitivity: it is bounded by 1e3 times
    the spread of two forward runs started 1 ulp apart (an independent measure of
    the amplification), plus a few ulp.
    """
    n = 12
    state0 = (0.0, 0.0, 0.0, 0.37, 23.0, 31.0, IMPACT)
    fwd, _ = run_arrays(EKP, state0, n)
    nudged, _ = run_arrays(EKP, (*state0[:3], np.nextafter(0.37, 1.0), *state0[4:]), n)
    spread = abs((nudged[2][-1] - fwd[2][-1]) * ELASTIC.d + nudged[3][-1] - fwd[3][-1])
    xi_n, vx_n, vy_n = fwd[3][-1], fwd[4][-1], fwd[5][-1]
    back0 = (0.0, 0.0, fwd[2][-1], xi_n, *_reflect_back(xi_n, vx_n, vy_n), IMPACT)
    back, status = run_arrays(EKP, back0, n)
    assert status == OK
    x_err = abs((back[2][-1] - state0[2]) * ELASTIC.d + back[3][-1] - state0[3])
    assert x_err <= 1e3 * spread + 1e-13, (x_err, spread)
    vx_b, vy_b = _reflect_back(back[3][-1], back[4][-1], back[5][-1])
    assert math.isclose(vx_b, state0[4], rel_tol=1e-6) and math.isclose(
        vy_b, state0[5], rel_tol=1e-6
    )
    t_fwd = (fwd[0][-1] * TWO_PI + fwd[1][-1]) / EKP.w
    t_back = (back[0][-1] * TWO_PI + back[1][-1]) / EKP.w
    assert math.isclose(t_fwd, t_back, rel_tol=1e-9)


@pytest.mark.parametrize("height", [0.5, 5.0], ids=["low", "high-many-tiles"])
def test_kac_mean_flight_time(height):
    """Kac's lemma for the static elastic billiard at energy E = g (h + height).

    The billiard flow on the energy shell preserves the Liouville measure
    dx dy dphi (phi the direction of v, |v| fixed by E); on one tile (the flow is
    periodic in x) its total mass is 2 pi times the area between the floor and
    y = E/g.  The induced invariant measure on the section "leaving the floor" is
    the flux |v| cos(theta) ds dtheta (theta from the normal), whose mass is the
    integral over the arc of 2 |v(s)| = 2 sqrt(2 (E - g Y(s))).  Kac / Santalo:
    the mean return time (flight time) under the flux measure is the ratio.
    Sampling s with density ~ |v(s)| and sin(theta) uniform in (-1, 1), the mean
    flight time must agree within 4 standard errors.
    """
    p, kp = ELASTIC, EKP
    E = p.g * (p.h + height)
    half = p.d / 2
    c0 = math.sqrt(p.R**2 - half**2)
    area = p.d * E / p.g - (p.R**2 * math.asin(half / p.R) - half * c0)
    s_max = p.s_max

    def speed(s):
        xi = p.R * math.sin(s / p.R - math.asin(half / p.R))
        return math.sqrt(2 * (E - p.g * floor_height_rel(xi, kp)))

    flux, _ = quad(lambda s: 2 * speed(s), 0.0, s_max, epsabs=0, epsrel=1e-13)
    kac = TWO_PI * area / flux

    rng = np.random.default_rng(2004)
    n = 20_000
    v_max = math.sqrt(2 * E)
    taus = []
    while len(taus) < n:
        s = rng.uniform(0, s_max)
        v = speed(s)
        if rng.uniform(0, v_max) > v:
            continue
        sin_t = rng.uniform(-1, 1)
        cos_t = math.sqrt(1 - sin_t**2)
        xi = p.R * math.sin(s / p.R - math.asin(half / p.R))
        S = math.sqrt(p.R**2 - xi**2)
        nx, ny, tx, ty = xi / p.R, S / p.R, S / p.R, -xi / p.R
        vx = v * (cos_t * nx + sin_t * tx)
        vy = v * (cos_t * ny + sin_t * ty)
        if not vx * nx + vy * ny > 0:
            continue
        (periods, phase, *_), status = run_arrays(kp, (0.0, 0.0, 0.0, xi, vx, vy, IMPACT), 1)
        assert status == OK
        taus.append((periods[1] * TWO_PI + phase[1]) / kp.w)
    taus = np.array(taus)
    se = taus.std(ddof=1) / math.sqrt(n)
    assert abs(taus.mean() - kac) <= 4 * se, (taus.mean(), kac, se)
