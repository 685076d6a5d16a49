"""Statistical cost of D (B3): the scaling laws on synthetic walks, and a tiny real run."""

import math

import numpy as np
import pytest

from bbdyn.diffusion import einstein_D
from bbdyn.results import load_result
from bbdyn.scans.statcost import StatCostResult, loglog_slope, statcost


def brownian(rng, n, t_max, m=50, D=1.0):
    t = np.linspace(t_max / m, t_max, m)
    dt = np.diff(t, prepend=0.0)
    return t, np.cumsum(rng.normal(0.0, np.sqrt(2 * D * dt), (n, m)), axis=1)


def test_loglog_slope_of_a_power_law():
    x = np.array([1.0, 2.0, 4.0, 8.0])
    assert loglog_slope(x, 3.0 * x**-0.5) == pytest.approx(-0.5, rel=1e-12)
    assert math.isnan(loglog_slope([1.0], [1.0]))


def test_error_of_D_falls_as_inverse_sqrt_n_and_not_with_t():
    """The module's claim: D_err ~ n^-1/2 t^0 for a diffusive walk (averaged over replicas)."""
    rng = np.random.default_rng(21)
    reps = 40
    ns = np.array([100, 400, 1600])
    ts = np.array([1.0, 4.0, 16.0])
    err_n = [np.mean([einstein_D(*brownian(rng, n, 4.0))[1] for _ in range(reps)]) for n in ns]
    err_t = [np.mean([einstein_D(*brownian(rng, 400, t))[1] for _ in range(reps)]) for t in ts]
    # the mean of a standard error over 40 replicas is known to ~1 %: slopes to ~0.02
    assert loglog_slope(ns, err_n) == pytest.approx(-0.5, abs=0.05)
    assert loglog_slope(ts, err_t) == pytest.approx(0.0, abs=0.05)


def test_statcost_tiny_run(tmp_path):
    settings = {"f": (85.2,), "n": (4, 8), "t": (1.0, 2.0), "n_fixed": 4, "t_fixed": 1.0}
    res = statcost(settings, seed=1)
    assert res["D_err_n"].shape == (1, 2) and res["D_err_t"].shape == (1, 2)
    assert np.all(res["cpu_n"] > 0) and np.all(res["D_err_n"] > 0)
    # the run with n = 4, t = 1 appears in both series: the same particles, the same D
    assert res["D_n"][0, 0] == res["D_t"][0, 0]
    assert res.table().count("\n") == 2 + 4 - 1
    loaded = load_result(res.save(tmp_path / "b3"))
    assert isinstance(loaded, StatCostResult)
    np.testing.assert_array_equal(loaded["D_err_t"], res["D_err_t"])
    loaded.plot()


@pytest.mark.parametrize(
    "bad, match", [({"n": (1, 4)}, "n must"), ({"t": (0.0, 1.0)}, "t must")], ids=["n1", "t0"]
)
def test_statcost_refuses_bad_settings(bad, match):
    settings = {"f": (85.2,), "n": (4, 8), "t": (1.0, 2.0), "n_fixed": 4, "t_fixed": 1.0}
    with pytest.raises(ValueError, match=match):
        statcost(settings | bad)
