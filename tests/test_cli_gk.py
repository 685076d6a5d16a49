"""`bbdyn gk` where nothing diffuses (Gamma <= 1) and with orders beyond the jump sequences.

At Gamma <= 1 a particle that lands never leaves the floor: after the transient no
particle changes trap, nothing moves sideways (E_x = 0), tau is infinite and every
D_n is 0.  The command must report that trapped result, not fail on the undefined
ratio r = E_y / E_x.  The pieces it relies on are checked directly too: the energy
ratio of an ensemble without horizontal motion, ``D_a`` at r = inf, and Green-Kubo
orders beyond the longest jump sequence.
"""

import math

import numpy as np
import pytest
from test_cli_bad_inputs import run_main, strict_json

from bbdyn import Params
from bbdyn.approx import JumpData, analytic_diffusion, energy_ratio, green_kubo

#: Gamma = 1 exactly at the default A and g.
F_GAMMA_ONE = Params(f=1.0).f_gamma_one
#: |D| (mm^2/s) of an ensemble whose displacements are constant in the fit window: the
#: least-squares slope is zero up to rounding (diffusive runs give D of order 10 mm^2/s).
ZERO_D = 1e-12


@pytest.mark.parametrize("f", [45.0, F_GAMMA_ONE], ids=["gamma_0.82", "gamma_1"])
def test_gk_at_gamma_at_most_one_reports_the_trapped_result(f, capsys):
    assert Params(f=f).gamma <= 1.0
    assert run_main(["gk", "--f", repr(f), "--n", "6", "--t", "3", "--nmax", "4", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert out["n_jumps"] == 0
    assert out["tau"] is None and out["r"] is None  # both infinite: null in JSON
    assert out["D_n"] == [0.0] * 5 and out["D_rw"] == 0.0
    assert abs(out["D"]) < ZERO_D
    assert out["D_a"] is None and "Gamma" in out["D_a_reason"]
    assert out["gamma"] == Params(f=f).gamma
    assert out["trapped"] is True
    assert "trapped" in out["trapped_reason"] and "never leaves the floor" in out["trapped_reason"]


def test_gk_text_at_gamma_below_one_says_trapped_and_tau_infinite(capsys):
    assert run_main(["gk", "--f", "45", "--n", "6", "--t", "3", "--nmax", "2"]) == 0
    text = capsys.readouterr().out
    assert "regime (a), trapped" in text
    assert "tau            = inf s  (0 jumps" in text


def test_gk_above_gamma_one_is_not_called_trapped(capsys):
    assert run_main(["gk", "--f", "85.2", "--n", "6", "--t", "3", "--nmax", "2", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert out["n_jumps"] > 0 and out["trapped"] is False and out["trapped_reason"] == ""


def test_energy_ratio_without_horizontal_motion_is_infinite():
    """r = mean(E_y) / mean(E_x) with every E_x = 0: inf if E_y > 0, undefined if both vanish."""
    res = energy_ratio(np.zeros(5), np.full(5, 200.0))
    assert res.r == math.inf and math.isnan(res.r_err)
    both = energy_ratio(np.zeros(5), np.zeros(5))
    assert math.isnan(both.r) and math.isnan(both.r_err)
    with pytest.raises(ValueError, match="E_x must be >= 0"):
        energy_ratio(np.array([1.0, -1.0]), np.ones(2))


def test_D_a_at_infinite_r_is_the_limit_of_large_r():
    """D_a ~ (d/2) sqrt(surplus / r) -> 0 as r -> inf (Gamma > 2); below Gamma = 2 NaN as for
    any r."""
    p = Params(f=85.0)
    assert analytic_diffusion(p, math.inf).D_a == 0.0
    assert analytic_diffusion(p, 1e30).D_a < 1e-12
    below = analytic_diffusion(Params(f=45.0), math.inf)
    assert math.isnan(below.D_a) and "Gamma" in below.reason
    with pytest.raises(ValueError, match="r must be"):
        analytic_diffusion(p, math.nan)
    unknown_err = analytic_diffusion(p, 1.0, math.nan)  # the error of r unknown: D_a stands
    assert unknown_err.D_a == analytic_diffusion(p, 1.0).D_a and math.isnan(unknown_err.D_a_err)


def test_green_kubo_orders_beyond_the_longest_sequence_are_undefined():
    """Orders n >= the jump count of every particle have no pair of jumps n apart: NaN, while
    the lower orders are those of a short series (a truncation never changes earlier terms)."""
    data = JumpData.from_particles(
        [[1, 1, -1, -1, 1], [-1, 1, 1]], [[1.0, 2.0, 3.0, 4.0, 5.0], [1.0, 2.0, 3.0]],
        t_total=6.0, d=1.0,
    )  # fmt: skip
    short = green_kubo(data, nmax=3, n_boot=20)
    long = green_kubo(data, nmax=40, n_boot=20)
    np.testing.assert_array_equal(long.D_n[:4], short.D_n)
    assert np.all(np.isfinite(long.D_n[:5])) and np.all(np.isnan(long.D_n[5:]))


def test_gk_command_with_nmax_beyond_the_jumps(capsys):
    assert run_main(["gk", "--f", "85.2", "--n", "4", "--t", "1", "--nmax", "1000", "--json"]) == 0
    out = strict_json(capsys.readouterr().out)
    assert len(out["D_n"]) == 1001 and out["D_n"][-1] is None and out["D_n"][0] is not None
