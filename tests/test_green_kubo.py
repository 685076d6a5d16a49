"""Truncated Green-Kubo series on synthetic jump sequences with known correlations.

Persistent walk with forward probability p: h_0 = +-d equally, h_k = h_{k-1} with
probability p, else -h_{k-1}.  Then h_0 h_k = d^2 q^k in the mean, q = 2p - 1, so

    D_n = D_0 (1 + 2 sum_{k=1..n} q^k),   D_inf = D_0 (1 + q) / (1 - q),   D_0 = d^2 / (2 tau),

(the geometric series; p = 1/2 is the uncorrelated walk, D_n = D_0).  Symbols
relative to h_0: p_f = p, p_ff = p^2, p_fb = p (1 - p), p_bf = (1 - p)^2, p_bb = (1 - p) p.
"""

import numpy as np
import pytest

from bbdyn.approx import JumpData, green_kubo
from bbdyn.approx.green_kubo import GreenKuboResult
from bbdyn.core.tolerances import GK_ROUTES_REL
from bbdyn.results import load_result

D = 2.0  # mm
RATE = 10.0  # jumps per second, tau = 0.1 s


def persistent_walk(p, n_particles, t_total, rng, n_jumps=None, long_fraction=0.0):
    """Persistent +-1 walk (see module docstring), Poisson jump times of rate RATE.

    ``n_jumps`` fixes the number of jumps per particle (then tau is exact);
    ``long_fraction`` doubles that fraction of the jumps (|h| = 2 d).
    """
    if n_jumps is None:
        counts = rng.poisson(RATE * t_total, n_particles)
    else:
        counts = np.full(n_particles, n_jumps)
    jumps, times = [], []
    for n in counts:
        steps = np.where(rng.random(n) < p, 1, -1)
        if n:
            steps[0] = rng.choice((-1, 1))
        h = np.cumprod(steps) * np.where(rng.random(n) < long_fraction, 2, 1)
        jumps.append(h)
        times.append(np.sort(rng.uniform(0.0, t_total, n)))
    return JumpData.from_particles(jumps, times, t_total, D)


def exact_series(p, tau, nmax):
    q = 2.0 * p - 1.0
    return D**2 / (2 * tau) * (1.0 + 2.0 * np.cumsum(np.r_[0.0, q ** np.arange(1, nmax + 1)]))


@pytest.mark.parametrize(
    "p", [0.5, 0.75, 0.3], ids=["uncorrelated", "persistent", "antipersistent"]
)
def test_errors_cover_exact_series_over_many_seeds(p):
    """|D_n - exact| < err in ~68 % and < 2 err in ~95 % of 120 independent ensembles.

    Bands: 3 binomial standard deviations (0.043 and 0.019) around 0.683 and 0.954.
    """
    n_seeds, nmax = 120, 10
    z = np.empty((n_seeds, nmax + 1))
    for i, child in enumerate(np.random.SeedSequence(2024).spawn(n_seeds)):
        rng = np.random.default_rng(child)
        res = green_kubo(persistent_walk(p, 40, 30.0, rng), nmax, n_boot=200, seed=i)
        z[i] = (res.D_n - exact_series(p, 1 / RATE, nmax)) / res.D_n_err
    for n in (0, 1, 2, 5, 10):
        within1 = np.mean(np.abs(z[:, n]) < 1)
        within2 = np.mean(np.abs(z[:, n]) < 2)
        assert 0.683 - 0.13 < within1 < 0.683 + 0.13, (n, within1)
        assert within2 > 0.954 - 0.057, (n, within2)
        # no bias: the mean z is within 3 standard errors of zero
        assert abs(z[:, n].mean()) < 3 / np.sqrt(n_seeds), (n, z[:, n].mean())


def test_uncorrelated_walk_keeps_D_0():
    """p = 1/2: all correlations vanish, D_n = D_0 = D_rw for every n, within errors."""
    res = green_kubo(persistent_walk(0.5, 400, 50.0, np.random.default_rng(7)), 10, seed=1)
    assert res.D_n[0] == pytest.approx(res.meta["D_rw"], rel=1e-12)
    increments = res.D_n[1:] - res.D_n[0]
    assert np.all(np.abs(increments) < 4 * res.D_n_err[1:])
    assert np.all(np.abs(res["corr"][1:]) < 4 * res["corr_err"][1:])


@pytest.mark.parametrize("p", [0.7, 0.3], ids=["persistent", "antipersistent"])
def test_converges_to_closed_form_and_to_einstein_displacement(p):
    """D_n at large n equals D_0 (1 + q)/(1 - q) and the Einstein D of the same walks.

    Fixed jump counts make tau exact; the Einstein D is <x(T)^2> / (2 T) with
    x(T) = sum of the jumps of a particle (its finite-N correction, of relative
    size 2 q / ((1 - q^2) N) ~ 1e-3, is far below the errors).
    """
    q = 2 * p - 1
    data = persistent_walk(p, 2000, 60.0, np.random.default_rng(11), n_jumps=600)
    res = green_kubo(data, 40, n_boot=500, seed=2)
    d_inf = D**2 / (2 * data.t_total / 600) * (1 + q) / (1 - q)
    assert abs(res.D_n[-1] - d_inf) < 3 * res.D_n_err[-1]
    x = np.add.reduceat(data.jumps * D, data.offsets[:-1]).astype(float)
    d_e = np.mean(x**2) / (2 * data.t_total)
    d_e_err = np.std(x**2, ddof=1) / np.sqrt(x.size) / (2 * data.t_total)
    assert abs(res.D_n[-1] - d_e) < 3 * np.hypot(res.D_n_err[-1], d_e_err)
    assert res.D_n_err[0] == pytest.approx(0.0, abs=1e-12 * res.D_n[0])  # tau exact, h^2 = d^2


@pytest.mark.parametrize(
    ("p", "n_particles", "t_total"),
    [(0.7, 300, 20.0), (0.97, 50, 30.0), (0.5, 400, 0.4)],
    ids=["persistent", "nearly-ballistic", "short-sequences-shorter-than-nmax"],
)
def test_correlation_and_symbol_routes_agree_to_rounding(p, n_particles, t_total):
    """On +-1 jumps both routes are the same sum: equal up to rounding, errors included."""
    data = persistent_walk(p, n_particles, t_total, np.random.default_rng(3))
    res = green_kubo(data, 10, n_boot=300)
    scale = res.D_n[0] * (2 * res["n"] + 1)
    ok = np.isfinite(res.D_n)
    assert np.array_equal(ok, np.isfinite(res["D_n_symbols"]))
    assert np.all(np.abs(res.D_n - res["D_n_symbols"])[ok] <= GK_ROUTES_REL * scale[ok])
    has_err = np.isfinite(res.D_n_err)  # NaN when a resample has no long enough sequence
    assert np.array_equal(has_err, np.isfinite(res["D_n_symbols_err"]))
    diff_err = np.abs(res.D_n_err - res["D_n_symbols_err"])[has_err]
    assert np.all(diff_err <= GK_ROUTES_REL * scale[has_err])
    assert res.meta["fraction_long"] == 0.0


def test_short_sequences_use_only_particles_long_enough():
    """A particle with at most k jumps has no lag-k pair and is left out of <h_0 h_k>."""
    data = persistent_walk(0.5, 400, 0.4, np.random.default_rng(3))  # ~4 jumps each
    res = green_kubo(data, 10, n_boot=50)
    expected = [np.sum(data.counts > k) for k in range(11)]
    assert res["n_particles_used"].tolist() == expected


def test_symbol_probabilities_of_the_persistent_walk():
    """Word probabilities match the Markov products within 4 errors; each length sums to 1."""
    p = 0.7
    res = green_kubo(persistent_walk(p, 500, 40.0, np.random.default_rng(5)), 4, table_len=4)
    words, probs, errs = res["words"], res["p_words"], res["p_words_err"]
    for k in range(1, 5):
        assert np.sum(probs[np.char.str_len(words) == k]) == pytest.approx(1.0, abs=1e-12)
    for w, pw, err in zip(words, probs, errs, strict=True):
        # the symbol of step m is b iff the direction flipped an odd number of times up to m
        flips = np.diff(np.r_[0, [c == "b" for c in w]]) != 0
        exact = np.prod(np.where(flips, 1 - p, p))
        assert abs(pw - exact) < 4 * err, (w, pw, exact, err)
    assert res.conditional("ff") == pytest.approx(p, abs=0.02)
    assert res.p("f")[0] - res.p("b")[0] == pytest.approx(res["corr"][1] / D**2, rel=1e-12)


def test_symbols_are_relative_to_h_0_not_to_the_jump_before():
    """+1 +1 -1 -1: from h_0 = +1 the pairs (h_1, h_2) are (+1, -1) -> fb and (-1, -1) -> bb.

    Relative to the jump before, the second would read bf; the table must say bb.
    """
    data = JumpData.from_particles([[1, 1, -1, -1]], [[1.0, 2.0, 3.0, 4.0]], 4.0, D)
    res = green_kubo(data, 2, n_boot=2)
    assert [res.p(w)[0] for w in ("ff", "fb", "bf", "bb")] == [0.0, 0.5, 0.0, 0.5]
    assert [res.p(w)[0] for w in ("f", "b")] == pytest.approx([2 / 3, 1 / 3], rel=1e-15)


def test_escape_time_of_the_series_counts_particles_that_never_jump():
    """Two persistent walkers plus two that never jump: tau doubles, so D_0 halves."""
    walkers = persistent_walk(0.7, 2, 20.0, np.random.default_rng(6), n_jumps=50)
    quiet = JumpData(
        walkers.jumps, walkers.times, np.r_[walkers.offsets, [100, 100]], walkers.t_total, D
    )
    a, b = green_kubo(walkers, 3, n_boot=20), green_kubo(quiet, 3, n_boot=20)
    assert a.tau == pytest.approx(20.0 / 50, rel=1e-15) and b.tau == pytest.approx(2 * a.tau)
    np.testing.assert_allclose(b.D_n, a.D_n / 2, rtol=1e-14)


def test_long_jumps_correlation_route_exact_symbol_route_on_directions():
    """With |h| = 2d jumps D_0 = <h^2> / (2 tau) (correlation route) but D_rw = d^2 / (2 tau)."""
    data = persistent_walk(
        0.5, 200, 20.0, np.random.default_rng(9), n_jumps=200, long_fraction=0.25
    )
    res = green_kubo(data, 10, n_boot=100)
    tau = data.t_total / 200
    assert res.D_n[0] == pytest.approx(np.mean(data.jumps**2) * D**2 / (2 * tau), rel=1e-12)
    assert res["D_n_symbols"][0] == pytest.approx(D**2 / (2 * tau), rel=1e-12)
    assert res.meta["fraction_long"] == pytest.approx(np.mean(np.abs(data.jumps) > 1), abs=0)


def test_bootstrap_is_reproducible_from_the_seed():
    data = persistent_walk(0.7, 100, 20.0, np.random.default_rng(4))
    a, b = green_kubo(data, 10, seed=42), green_kubo(data, 10, seed=42)
    c = green_kubo(data, 10, seed=43)
    for key in ("D_n_err", "D_n_symbols_err", "corr_err", "p_words_err"):
        np.testing.assert_array_equal(a[key], b[key])
    assert not np.array_equal(a.D_n_err, c.D_n_err)
    np.testing.assert_array_equal(a.D_n, c.D_n)  # estimates do not depend on the seed


def test_errors_shrink_as_one_over_sqrt_particles():
    """Bootstrap error ratio for 4x the particles is 1/2 (slope -1/2), within 15 %."""
    rng = np.random.default_rng(8)
    small = green_kubo(persistent_walk(0.7, 250, 20.0, rng), 10, n_boot=2000)
    large = green_kubo(persistent_walk(0.7, 1000, 20.0, rng), 10, n_boot=2000)
    ratio = large.D_n_err[1:] / small.D_n_err[1:]
    assert np.all(np.abs(ratio - 0.5) < 0.15 * 0.5), ratio


def test_trapped_ensemble_has_no_diffusion():
    data = JumpData.from_particles([[], []], [[], []], t_total=5.0, d=D)
    res = green_kubo(data, 10, n_boot=10)
    assert res.tau == np.inf
    np.testing.assert_array_equal(res.D_n, 0.0)
    np.testing.assert_array_equal(res["D_n_symbols"], 0.0)


def test_result_round_trip_and_plot(tmp_path):
    data = persistent_walk(0.7, 50, 10.0, np.random.default_rng(6))
    res = green_kubo(data, 12, D_einstein=6.0, D_einstein_err=0.3, meta={"note": "synthetic"})
    loaded = load_result(res.save(tmp_path / "gk"))
    assert isinstance(loaded, GreenKuboResult)
    np.testing.assert_array_equal(loaded.D_n, res.D_n)
    assert loaded.p("fb") == res.p("fb")
    assert loaded.meta["note"] == "synthetic" and loaded.meta["D_einstein"] == 6.0
    assert np.all(np.isnan(res["D_n_symbols"][11:]))  # symbol route stops at SYMBOL_MAX_LEN
    ax = loaded.plot()
    assert ax.get_xlabel() == "truncation order $n$"
    assert "fb" in res.symbol_table() and len(res.table().splitlines()) == 14


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"nmax": 0}, "nmax must be in"),
        ({"nmax": 2.5}, "nmax must be an integer"),
        ({"n_boot": 1}, "n_boot must be in"),
        ({"nmax": 3, "table_len": 4}, "table_len must be in"),
        ({"D_einstein": float("nan")}, "D_einstein must be finite"),
    ],
    ids=["nmax-zero", "nmax-float", "one-resample", "table-longer-than-nmax", "nan-D"],
)
def test_bad_arguments_are_refused(kwargs, message):
    data = persistent_walk(0.5, 5, 2.0, np.random.default_rng(0))
    with pytest.raises(ValueError, match=message):
        green_kubo(data, **kwargs)


def test_unknown_word_is_refused():
    res = green_kubo(persistent_walk(0.5, 5, 2.0, np.random.default_rng(0)), 2, n_boot=10)
    with pytest.raises(ValueError, match="word must be"):
        res.p("fx")
