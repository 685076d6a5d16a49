"""JumpData validation, escape time, D_rw, D_a and the energy ratio r on synthetic data."""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.approx import JumpData
from bbdyn.approx.random_walk import (
    analytic_diffusion,
    energy_ratio,
    escape_time,
    jump_length_distribution,
    random_walk_diffusion,
)
from bbdyn.core.tolerances import CLOSED_FORM_REL, FD_AGREE_REL, FD_STEP_REL


def poisson_walk(rate, n_particles, t_total, rng, d=2.0):
    """Uncorrelated +-1 jumps at Poisson times of the given rate (1/s): tau = 1 / rate."""
    counts = rng.poisson(rate * t_total, n_particles)
    jumps = [rng.choice((-1, 1), n) for n in counts]
    times = [np.sort(rng.uniform(0, t_total, n)) for n in counts]
    return JumpData.from_particles(jumps, times, t_total, d)


# ---- JumpData --------------------------------------------------------------------------


def _arrays():
    return {
        "jumps": np.array([1, -1, 2, 1]),
        "times": np.array([0.1, 0.5, 0.2, 0.3]),
        "offsets": np.array([0, 2, 4]),
        "t_total": 1.0,
        "d": 2.0,
    }


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"jumps": np.array([1, 0, 2, 1])}, "jumps must be nonzero"),
        ({"jumps": np.array([1.0, -1.0, 2.0, 1.0])}, "jumps must be a 1-D integer"),
        ({"times": np.array([0.1, 0.5, 0.2])}, "times must have the shape"),
        ({"offsets": np.array([0, 2, 3])}, "offsets must be non-decreasing from 0"),
        ({"offsets": np.array([0, 3, 2, 4])}, "offsets must be non-decreasing from 0"),
        ({"times": np.array([0.5, 0.1, 0.2, 0.3])}, "non-decreasing within a particle"),
        ({"times": np.array([0.1, 0.5, 0.2, 1.5])}, r"times must be finite and in \[0"),
        ({"times": np.array([0.1, np.nan, 0.2, 0.3])}, "times must be finite"),
        ({"t_total": 0.0}, "t_total must be finite and > 0"),
        ({"d": -2.0}, "d must be finite and > 0"),
    ],
    ids=[
        "zero-jump",
        "float-jumps",
        "times-length",
        "offsets-end",
        "offsets-decreasing",
        "times-decreasing",
        "time-after-end",
        "time-nan",
        "no-time",
        "negative-d",
    ],
)
def test_bad_jump_data_is_refused(change, message):
    with pytest.raises(ValueError, match=message):
        JumpData(**(_arrays() | change))


def test_jump_data_allows_time_reset_between_particles_and_empty_particles():
    data = JumpData.from_particles([[1, -1], [], [2, 1]], [[0.1, 0.5], [], [0.2, 0.3]], 1.0, 2.0)
    assert data.counts.tolist() == [2, 0, 2]
    assert data.particle_index.tolist() == [0, 0, 2, 2]
    with pytest.raises(ValueError):
        data.jumps[0] = 5  # frozen arrays


# ---- escape time and D_rw --------------------------------------------------------------


def test_escape_time_is_exact_for_equal_counts():
    """tau = t_total / n for n jumps per particle; the counts do not scatter, so no error."""
    jumps = [np.ones(7, dtype=int)] * 3
    times = [np.linspace(0.1, 0.9, 7)] * 3
    esc = escape_time(JumpData.from_particles(jumps, times, t_total=1.4, d=2.0))
    assert esc.tau == pytest.approx(0.2, rel=1e-15) and esc.tau_err == 0.0
    assert (esc.n_jumps, esc.n_particles) == (21, 3)


def test_escape_time_counts_the_time_of_particles_that_never_jump():
    """One particle jumps 4 times in 2 s, one never jumps: 4 jumps in 4 particle-seconds.

    tau is the inverse of the ensemble's jump rate, so the quiet particle's time counts:
    tau = 1 s (averaging over the jumping particle only would give 0.5 s).
    """
    data = JumpData.from_particles([[1, -1, 1, 1], []], [[0.2, 0.7, 1.1, 1.9], []], 2.0, 2.0)
    est = random_walk_diffusion(data)
    assert est.tau == 1.0 and (escape_time(data).n_jumps, escape_time(data).n_particles) == (4, 2)
    assert est.D_rw == data.d**2 / 2.0
    # the rate is a count per particle-second: adding quiet particles lowers it in proportion
    quiet = JumpData.from_particles([[1, -1, 1, 1], [], [], []], [[0.2, 0.7, 1.1, 1.9], [], [], []],
                                    2.0, 2.0)
    assert escape_time(quiet).tau == 2.0 * escape_time(data).tau


def test_escape_time_error_covers_the_true_tau():
    """Poisson jumps at rate 5/s: |tau - 0.2 s| < tau_err in ~68 % of 200 ensembles (3 sd band)."""
    hits = []
    for child in np.random.SeedSequence(77).spawn(200):
        esc = escape_time(poisson_walk(5.0, 30, 4.0, np.random.default_rng(child)))
        hits.append(abs(esc.tau - 0.2) < esc.tau_err)
    assert abs(np.mean(hits) - 0.683) < 3 * math.sqrt(0.683 * 0.317 / 200)


def test_random_walk_diffusion_is_d2_over_2tau():
    data = poisson_walk(8.0, 100, 10.0, np.random.default_rng(1), d=2.0)
    est = random_walk_diffusion(data)
    assert est.D_rw == pytest.approx(data.d**2 / (2 * est.tau), rel=1e-15)
    assert est.D_rw_err / est.D_rw == pytest.approx(est.tau_err / est.tau, rel=1e-12)
    assert abs(est.D_rw - 4.0 * 8.0 / 2) < 4 * est.D_rw_err  # D_rw = d^2 rate / 2


def test_no_jump_means_infinite_escape_time_and_no_diffusion():
    data = JumpData.from_particles([[], []], [[], []], t_total=3.0, d=2.0)
    est = random_walk_diffusion(data)
    assert est.tau == math.inf and est.D_rw == 0.0
    assert math.isnan(est.jump_lengths.fraction_long)


def test_jump_length_distribution_counts_every_jump():
    data = JumpData.from_particles([[1, -1, 2, 1], [-3, 1]], [[0.1] * 4, [0.2] * 2], 1.0, 2.0)
    dist = jump_length_distribution(data)
    assert dist.lengths.tolist() == [-3, -1, 1, 2]
    assert dist.counts.tolist() == [1, 1, 3, 1]
    assert dist.probabilities.sum() == pytest.approx(1.0, abs=1e-15)
    assert dist.fraction_long == pytest.approx(2 / 6, rel=1e-15)
    assert dist.mean_square == pytest.approx((9 + 1 + 3 + 4) / 6, rel=1e-15)


# ---- analytic D_a ----------------------------------------------------------------------


@pytest.mark.parametrize("f", [65.6, 70.0], ids=["S9-lower-edge", "just-below-Gamma-2"])
def test_D_a_is_nan_with_reason_below_gamma_2(f):
    res = analytic_diffusion(Params(f=f), r=1.0)
    assert math.isnan(res.D_a) and "Gamma" in res.reason and "< 2" in res.reason


def test_D_a_vanishes_like_sqrt_gamma_minus_2_and_scales_with_r():
    """A^2 w^2 - 2 g A = g A (Gamma - 2): D_a -> 0 like sqrt(Gamma - 2); D_a ~ 1/sqrt(1 + r)."""
    p0 = Params(f=85.0)
    for excess in (1e-2, 1e-4, 1e-6):
        near = Params(f=85.0, A=2 * p0.g / p0.w**2 * (1 + excess))
        expected = near.d / 2 * math.sqrt(near.g * near.A * (near.gamma - 2) / 1.5)
        # the difference A^2 w^2 - 2 g A cancels about log10(1/excess) digits
        assert analytic_diffusion(near, r=0.5).D_a == pytest.approx(
            expected, rel=CLOSED_FORM_REL / excess
        )
    base = analytic_diffusion(p0, r=0.0).D_a
    for r in (0.3, 1.0, 4.0):
        assert analytic_diffusion(p0, r=r).D_a == pytest.approx(
            base / math.sqrt(1 + r), rel=CLOSED_FORM_REL
        )


def test_D_a_error_is_the_linear_propagation_of_r_err():
    params, r = Params(f=90.0), 0.8
    h = FD_STEP_REL * r
    slope = (analytic_diffusion(params, r + h).D_a - analytic_diffusion(params, r - h).D_a) / (
        2 * h
    )
    assert analytic_diffusion(params, r, r_err=0.1).D_a_err == pytest.approx(
        abs(slope) * 0.1, rel=FD_AGREE_REL
    )


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"r": -0.1}, "r must be finite and >= 0"), ({"r": 1.0, "r_err": -1.0}, "r_err must")],
    ids=["negative-r", "negative-r-err"],
)
def test_D_a_bad_r_is_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        analytic_diffusion(Params(f=85.0), **kwargs)


# ---- energy ratio r --------------------------------------------------------------------


def test_energy_ratio_exact_for_proportional_energies():
    e_x = np.linspace(10.0, 50.0, 20)
    res = energy_ratio(e_x, 1.7 * e_x)
    assert res.r == pytest.approx(1.7, rel=1e-14) and res.r_err == pytest.approx(0.0, abs=1e-14)


def test_energy_ratio_error_covers_true_ratio():
    """Correlated per-particle energies with E[E_y] / E[E_x] = 0.6: ~68 % coverage over 200 sets."""
    hits = []
    for child in np.random.SeedSequence(5).spawn(200):
        rng = np.random.default_rng(child)
        e_x = rng.gamma(4.0, 100.0, 50)
        e_y = 0.6 * e_x * rng.gamma(10.0, 0.1, 50)  # mean factor 1, correlated with e_x
        res = energy_ratio(e_x, e_y)
        hits.append(abs(res.r - 0.6) < res.r_err)
    assert abs(np.mean(hits) - 0.683) < 3 * math.sqrt(0.683 * 0.317 / 200)


def test_energy_ratio_from_means_matches_monte_carlo_spread():
    """Independent Gaussian means, 0.5 % errors: the propagated error is the spread of E_y/E_x."""
    rng = np.random.default_rng(3)
    res = energy_ratio(400.0, 300.0, E_x_err=2.0, E_y_err=1.5)
    samples = rng.normal(300.0, 1.5, 200_000) / rng.normal(400.0, 2.0, 200_000)
    assert res.r == 0.75
    assert res.r_err == pytest.approx(np.std(samples), rel=0.01)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((np.ones(3), np.ones(4)), "equal length"),
        ((1.0, 2.0), "give either per-particle arrays"),
        ((0.0, 2.0, 0.1, 0.1), "E_x must be > 0"),
        ((np.ones(3), -np.ones(3)), "E_y must be >= 0"),
    ],
    ids=["lengths-differ", "means-without-errors", "zero-E_x", "negative-E_y"],
)
def test_energy_ratio_bad_input_is_refused(args, message):
    with pytest.raises(ValueError, match=message):
        energy_ratio(*args)
