"""Parameters: MODEL.md defaults, derived quantities, and refusal of invalid values."""

import math

import pytest

from bbdyn import Params


def test_derived_quantities_match_model_md():
    p = Params(f=58.0)
    assert p.w == pytest.approx(2 * math.pi * 58.0, rel=1e-15)
    assert p.gamma == pytest.approx(0.1 * p.w**2 / 9800.0, rel=1e-15)
    # MODEL.md quotes h ~ 0.020008 mm, s_max ~ 2.000534 mm, Gamma = 1 at 49.823 Hz.
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


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("A", -0.1, "A must be >= 0"),
        ("g", 0.0, "g must be > 0"),
        ("alpha", 1.2, "alpha must be in [0, 1], got 1.2"),
        ("alpha", -0.01, "alpha must be in [0, 1]"),
        ("beta", 1.5, "beta must be in [0, 1]"),
        ("R", 0.5, "R must be >= d/2"),
        ("d", 0.0, "d must be > 0"),
        ("f", -1.0, "f must be > 0"),
        ("f", math.nan, "f must be finite"),
        ("A", math.inf, "A must be finite"),
    ],
)
def test_invalid_values_are_refused_with_the_parameter_named(field, value, message):
    kwargs = {"f": 58.0, field: value}
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        Params(**kwargs)


def test_params_are_immutable():
    p = Params(f=58.0)
    with pytest.raises(AttributeError):
        p.alpha = 0.3  # type: ignore[misc]
    assert p.replace(alpha=0.3).alpha == 0.3


def test_non_numbers_are_refused():
    with pytest.raises(TypeError, match="alpha must be a real number"):
        Params(f=58.0, alpha="half")  # type: ignore[arg-type]
