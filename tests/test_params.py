"""Parameters: defaults (docs/model.md), derived quantities, and refusal of invalid values."""

import itertools
import math
import re

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.params import LIMITS


def test_derived_quantities_match_model_md():
    p = Params(f=58.0)
    assert p.w == pytest.approx(2 * math.pi * 58.0, rel=1e-15)
    assert p.gamma == pytest.approx(0.1 * p.w**2 / 9800.0, rel=1e-15)
    # docs/model.md quotes h ~ 0.020008 mm, s_max ~ 2.000534 mm, Gamma = 1 at 49.823 Hz.
    assert p.h == pytest.approx(0.020008, abs=5e-7)
    assert p.s_max == pytest.approx(2.000534, abs=5e-7)
    assert p.f_gamma_one == pytest.approx(49.823, abs=5e-4)
    assert Params(f=p.f_gamma_one).gamma == pytest.approx(1.0, rel=1e-14)


def test_kernel_params_are_consistent():
    p = Params(f=70.0, A=0.2, R=10.0)
    kp = p.kernel()
    assert kp.gamma == pytest.approx(p.gamma)
    assert kp.curv_bound == pytest.approx(p.g * (1 + p.gamma))
    assert kp.R - kp.c0 == pytest.approx(p.h)
    assert kp.period == pytest.approx(2 * math.pi / kp.w)


@pytest.mark.parametrize("f", [30.0, 49.8, 49.9, 58.0, 95.0, 1e4])
def test_kernel_release_window_is_where_the_floor_falls_faster_than_g(f):
    # sin(phase) < -1/Gamma between pi + asin(1/Gamma) and 2 pi - asin(1/Gamma); none for Gamma <= 1
    p = Params(f=f)
    kp = p.kernel()
    if p.gamma <= 1.0:
        assert (kp.release_r, kp.release_e) == (-1.0, -1.0)
        return
    a = math.asin(1.0 / p.gamma)
    assert kp.release_r == pytest.approx(math.pi + a, rel=1e-15)
    assert kp.release_e == pytest.approx(2 * math.pi - a, rel=1e-15)
    for phase in np.linspace(0.0, 2 * math.pi, 2001, endpoint=False):
        inside = kp.release_r <= phase < kp.release_e
        if abs(p.gamma * math.sin(phase) + 1.0) > 1e-9:  # away from the edges' rounding
            assert inside == (p.gamma * math.sin(phase) < -1.0)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("A", -0.1, "A must be in [0, 1e+06] mm"),
        ("g", 0.0, "g must be in [1e-06, 1e+12] mm/s^2"),
        ("alpha", 1.2, "alpha must be in [0, 1], got 1.2"),
        ("alpha", -0.01, "alpha must be in [0, 1]"),
        ("beta", 1.5, "beta must be in [0, 1]"),
        ("R", 0.5, "R must be > d/2"),
        ("d", 0.0, "d must be in [1e-06, 1e+06] mm"),
        ("f", -1.0, "f must be in [1e-06, 1e+06] Hz"),
        ("f", math.nan, "f must be finite"),
        ("A", math.inf, "A must be finite"),
    ],
)
def test_invalid_values_are_refused_with_the_parameter_named(field, value, message):
    kwargs = {"f": 58.0, field: value}
    with pytest.raises(ValueError, match=re.escape(message)):
        Params(**kwargs)


def test_params_are_immutable():
    p = Params(f=58.0)
    with pytest.raises(AttributeError):
        p.alpha = 0.3  # type: ignore[misc]
    assert p.replace(alpha=0.3).alpha == 0.3


def test_non_numbers_are_refused():
    with pytest.raises(TypeError, match="alpha must be a real number"):
        Params(f=58.0, alpha="half")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("field", "value"),
    [("f", True), ("alpha", False), ("f", "58"), ("A", "0.1"), ("R", b"25"), ("d", None)],
)
def test_bools_and_numeric_strings_are_refused_as_numbers(field, value):
    kwargs = {"f": 58.0, field: value}
    with pytest.raises(TypeError, match=f"^{field} must be a real number"):
        Params(**kwargs)


def test_numpy_scalars_are_numbers():
    p = Params(f=np.float64(58.0), A=np.float32(0.25), d=np.int64(2))
    assert (p.f, p.A, p.d) == (58.0, 0.25, 2.0)
    assert all(type(v) is float for v in p.to_dict().values())


@pytest.mark.parametrize(
    ("field", "value"),
    [("f", 1e300), ("R", 1e300), ("A", 1e300), ("g", 1e-300), ("f", 5e-324), ("d", 1e300)],
)
def test_values_whose_derived_quantities_overflow_are_refused(field, value):
    kwargs = {"f": 58.0, field: value}
    low, high = LIMITS[field]
    with pytest.raises(ValueError, match=re.escape(f"{field} must be in [{low:g}, {high:g}]")):
        Params(**kwargs)


def _corner(f, A, g, d, R):
    return Params(f=f, A=A, g=g, d=d, R=max(R, 1.5 * d / 2))


@pytest.mark.parametrize("corner", list(itertools.product(*LIMITS.values())))
def test_derived_quantities_stay_below_1e30_on_every_corner_of_the_range(corner):
    """The LIMITS comment promises w^2, A w^2, Gamma, 1/f and R^2 below 1e30 everywhere."""
    p = _corner(*corner)
    kp = p.kernel()
    for value in (p.w**2, p.A * p.w**2, p.gamma, p.period, p.R**2, kp.curv_bound, kp.c0):
        assert math.isfinite(value) and abs(value) < 1e30
    # h and s_max are bounded by the geometry: h <= d/2 <= s_max <= pi d/2
    assert 0 <= p.h <= p.d / 2 <= p.s_max <= math.pi * p.d / 2


@pytest.mark.parametrize("d", [2.0, 0.5, 1e-6])
def test_R_equal_to_half_d_is_refused_and_just_above_it_is_a_near_semicircle(d):
    with pytest.raises(ValueError, match=re.escape(f"R must be > d/2 = {d / 2:g} mm")):
        Params(f=58.0, d=d, R=d / 2)
    p = Params(f=58.0, d=d, R=math.nextafter(d / 2, math.inf))
    # semicircle limit: the bump is as high as it is half wide, its arc is half a circle
    assert p.h == pytest.approx(d / 2, rel=1e-7)
    assert p.s_max == pytest.approx(math.pi * d / 2, rel=1e-7)
