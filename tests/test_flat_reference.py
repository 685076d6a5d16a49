"""The numba flat map against the mpmath reference (bbdyn.reference.flat_mpmath)."""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.flat import FlatArrays, FlatState, flat_run
from bbdyn.core.status import IMPACT, OK
from bbdyn.core.tolerances import EPS, IMPACT_TIME_TOL
from bbdyn.reference.flat_mpmath import reference_impacts


def _kernel_run(kp, phase0, vrel0, n):
    out = (np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64))
    _, n_done, status = flat_run(FlatState(0.0, phase0, vrel0, IMPACT), kp, n, FlatArrays(*out))
    assert (n_done, status) == (n, OK)
    return out


@pytest.mark.parametrize("f", [85.2, 95.0, 58.0], ids=["chaotic_85.2Hz", "95Hz", "tongue_58Hz"])
def test_one_step_map_agrees_with_mpmath(f):
    """Every impact -> impact step of a few hundred: time within IMPACT_TIME_TOL.

    The post-impact velocity vrel+ = -alpha (vrel-) inherits the time error
    through G'' (|G''| <= M) and rounding of the velocities (a few ulp of
    |vrel-| + 2 A w + g tau, the terms that sum to it): we allow
    alpha (M IMPACT_TIME_TOL + 16 eps (|vrel-| + 2 A w + g tau)).
    """
    p = Params(f=f)
    kp = p.kernel()
    periods, phase, vrel, kind = _kernel_run(kp, 0.5, 100.0, 300)
    n_checked = 0
    for i in range(len(phase) - 1):
        if not (kind[i] == IMPACT and kind[i + 1] == IMPACT):
            continue  # the reference does not sum chattering
        ref = reference_impacts(p, phase[i], vrel[i], 1)
        tau_kernel = ((periods[i + 1] - periods[i]) * 2 * math.pi + phase[i + 1] - phase[i]) / kp.w
        tau_ref = ref["t"][0] - phase[i] / kp.w
        assert abs(tau_kernel - tau_ref) <= IMPACT_TIME_TOL, i
        vrel_minus = vrel[i + 1] / kp.alpha
        scale = abs(vrel_minus) + 2 * kp.A * kp.w + kp.g * tau_ref
        tol_v = kp.alpha * (kp.curv_bound * IMPACT_TIME_TOL + 16 * EPS * scale)
        assert abs(vrel[i + 1] - ref["vrel"][0]) <= tol_v, i
        n_checked += 1
    assert n_checked >= 250


def _near_one_one_orbit(kp):
    """Phase and vrel of the 1/1 orbit (flight = one period, v+ = g T / 2), vrel raised 0.1 %."""
    T, A, w, g, a = kp.period, kp.A, kp.w, kp.g, kp.alpha
    # v+ = (1 + a) u - a v-, v- = -v+, u = -A w cos(theta): the stable branch (sin theta < 0).
    theta = 2 * math.pi - math.acos(-g * T * (1 - a) / (2 * A * w * (1 + a)))
    return theta, 1.001 * (g * T / 2 + A * w * math.cos(theta))


@pytest.mark.parametrize(
    ("f", "n_agree"), [(85.2, 6), (58.0, 300)], ids=["chaotic_85.2Hz", "tongue_58Hz"]
)
def test_orbit_agrees_with_mpmath(f, n_agree):
    """The whole orbit (not one step at a time) agrees to IMPACT_TIME_TOL.

    Near the stable 1/1 orbit at 58 Hz for 300 impacts.  In the chaotic case at
    85.2 Hz the kernel's ~1e-17 s per-step rounding is amplified by a factor
    ~4-10 per impact, so orbits of *any* float64 method separate after a few
    impacts: the one-step test above is the check of the event finder there.
    """
    p = Params(f=f)
    kp = p.kernel()
    phase0, vrel0 = (0.5, 100.0) if f == 85.2 else _near_one_one_orbit(kp)
    periods, phase, _, kind = _kernel_run(kp, phase0, vrel0, n_agree)
    assert np.all(kind == IMPACT)
    ref = reference_impacts(p, phase0, vrel0, n_agree)
    t_kernel = (periods * 2 * math.pi + phase - phase0) / kp.w
    assert np.max(np.abs(t_kernel - (ref["t"] - phase0 / kp.w))) <= IMPACT_TIME_TOL


def test_reference_is_converged_in_dps():
    """40 and 60 digits agree to float64 rounding: the reference's own error is negligible."""
    p = Params(f=85.2)
    a = reference_impacts(p, 0.5, 100.0, 30, dps=40)
    b = reference_impacts(p, 0.5, 100.0, 30, dps=60)
    for key in ("t", "v", "vrel"):
        np.testing.assert_allclose(a[key], b[key], rtol=4 * EPS, atol=0)


def test_reference_refuses_chattering():
    p = Params(f=85.2)
    with pytest.raises(ValueError, match="chattering"):
        reference_impacts(p, 0.5, 100.0, 300)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [({"n_impacts": 0}, "n_impacts"), ({"vrel0": -1.0}, "vrel0"), ({"dps": 10}, "dps")],
)
def test_reference_validates(kwargs, name):
    args = {"phase0": 0.5, "vrel0": 100.0, "n_impacts": 3} | kwargs
    with pytest.raises(ValueError, match=name):
        reference_impacts(Params(f=85.2), **args)
