"""Einstein estimator (bbdyn/diffusion.py) on synthetic random walks with known D."""

import numpy as np
import pytest

from bbdyn.diffusion import einstein_D, einstein_D_windows


def _walk(rng, n, D, times, offset_sd=0.0):
    """Brownian paths sampled at ``times`` (exact Gaussian increments), plus a transient offset."""
    dt = np.diff(times, prepend=0.0)
    x = np.cumsum(rng.normal(0.0, 1.0, (n, times.size)) * np.sqrt(2 * D * dt), axis=1)
    # a random initial jump: the MSD gets an offset, the slope does not
    return x + rng.normal(0.0, offset_sd, (n, 1))


def test_known_D_is_recovered_within_its_error():
    rng = np.random.default_rng(11)
    times = np.linspace(0.5, 50.0, 100)
    D_true = 2.5
    D, se = einstein_D(times, _walk(rng, 4000, D_true, times, offset_sd=3.0))
    assert abs(D - D_true) < 4 * se
    # the error is that of a slope from n independent particles: a few per cent here
    assert 0.005 < se / D_true < 0.05


def test_error_bars_cover_the_truth_at_the_expected_rate():
    # 95 % intervals over 400 independent ensembles: the hit count is binomial(400, 0.95),
    # sd 4.4; accept +-4 sd.  Too narrow (or too wide) error bars fail this.
    rng = np.random.default_rng(2024)
    times = np.linspace(0.2, 20.0, 40)
    hits = 0
    for _ in range(400):
        D, se = einstein_D(times, _walk(rng, 300, 1.0, times, offset_sd=1.0))
        hits += abs(D - 1.0) <= 1.96 * se
    assert abs(hits - 380) <= 4 * np.sqrt(400 * 0.95 * 0.05)


def test_slope_equals_the_least_squares_slope_of_the_ensemble_msd():
    rng = np.random.default_rng(5)
    times = np.linspace(1.0, 10.0, 30)
    x = _walk(rng, 50, 0.7, times)
    D, _ = einstein_D(times, x, window=(0.0, 1.0))
    slope = np.polyfit(times, np.mean(x**2, axis=0), 1)[0]
    assert D == pytest.approx(slope / 2, rel=1e-12)


def test_successive_windows_agree_for_a_stationary_walk_and_detect_a_trend():
    rng = np.random.default_rng(3)
    times = np.linspace(0.1, 40.0, 400)
    centres, D, se = einstein_D_windows(times, _walk(rng, 3000, 1.5, times), n_windows=4)
    assert centres.shape == D.shape == se.shape == (4,)
    assert np.all(np.abs(D - 1.5) < 4 * se)
    # superdiffusive x ~ t: the MSD slope grows, so later windows give larger "D"
    ballistic = rng.normal(0, 1, (3000, 1)) * times
    _, D_b, se_b = einstein_D_windows(times, ballistic, n_windows=4)
    assert np.all(np.diff(D_b) > 4 * np.hypot(se_b[1:], se_b[:-1]))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"window": (0.8, 0.5)}, "window must satisfy"),
        ({"window": (0.99, 1.0)}, "the window holds"),
    ],
    ids=["reversed_window", "window_too_short"],
)
def test_bad_windows_are_refused(kwargs, message):
    times = np.linspace(1.0, 10.0, 10)
    with pytest.raises(ValueError, match=message):
        einstein_D(times, np.ones((5, 10)), **kwargs)


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError, match="displacements must have shape"):
        einstein_D(np.arange(1.0, 5.0), np.ones((3, 5)))
    with pytest.raises(ValueError, match="at least 2 particles"):
        einstein_D(np.arange(1.0, 5.0), np.ones((1, 4)))


# ---- the scan point fits the late window [t/2, t] (issue 10) ---------------------------------
def _changing_walk(rng, n, times, D_early, D_late, t_switch):
    """Brownian paths with diffusion D_early before t_switch and D_late after it."""
    dt = np.diff(times, prepend=0.0)
    local = np.where(times <= t_switch, D_early, D_late)
    return np.cumsum(rng.normal(0.0, 1.0, (n, times.size)) * np.sqrt(2 * local * dt), axis=1)


def test_scan_point_fits_the_late_half_of_a_walk_with_a_transient():
    """A walk diffusing 4x faster before t/2: the scan point's D is the late D, many errors
    away from the early one (the MSD slope over [0, t/2] would be 4.0)."""
    from bbdyn.scans.frequency import diffusion_fit

    rng = np.random.default_rng(21)
    times = np.linspace(0.0, 20.0, 201)
    x = _changing_walk(rng, 3000, times, D_early=4.0, D_late=1.0, t_switch=10.0)
    out = diffusion_fit(times, x, np.random.SeedSequence(1), n_boot=50)
    assert abs(out["D"] - 1.0) < 4 * out["D_se"]
    assert abs(out["D"] - 4.0) > 20 * out["D_se"]
    # the early window would find the early D: the walk is what it claims to be
    D_early, se_early = einstein_D(times, x, window=(0.0, 0.5))
    assert abs(D_early - 4.0) < 4 * se_early


def test_scan_point_D_is_einstein_D_over_the_late_window_of_its_own_data():
    """diffusion_point's D equals einstein_D over [t/2, t] of the same ensemble, rebuilt from
    the point's seed (a particle's trajectory depends only on the seed and its index)."""
    from bbdyn import Params
    from bbdyn.ensemble import ensemble
    from bbdyn.scans.frequency import diffusion_point

    f, n, t = 85.2, 40, 4.0
    seq = np.random.SeedSequence(7)
    out = diffusion_point(f, seq, n=n, t=t, n_boot=10)
    seed = np.random.SeedSequence(7).spawn(2)[0].generate_state(4).tolist()
    times = np.linspace(0.0, t, 201)
    res = ensemble(Params(f=f), n=n, t=t, seed=seed, sample_times=times)
    D, se = einstein_D(times, res["displacement"], window=(0.5, 1.0))
    assert out["trapped"] == 0
    assert (out["D"], out["D_se"]) == (D, se)
    np.testing.assert_array_equal(out["msd"], np.mean(res["displacement"] ** 2, axis=0))
