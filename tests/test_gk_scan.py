"""Random walk and Green-Kubo at one frequency (bbdyn.scans.green_kubo), the `bbdyn gk` command."""

import json
import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.commands.cli import main
from bbdyn.scans.green_kubo import gk_numbers, gk_point, gk_run, gk_scan
from bbdyn.scans.runner import point_seed

#: Pulls (differences over combined standard errors) for statistical checks: a correct
#: estimator exceeds 3 with probability 0.3 %.
PULL_AGREE = 3.0


def _pull(a, a_err, b, b_err):
    return (a - b) / math.hypot(a_err, b_err)


@pytest.fixture(scope="module")
def gk852():
    """85.2 Hz, 400 particles, 60 s: about 120 jumps per particle, D to about 14 %."""
    return gk_run(Params(f=85.2), n=400, t=60.0, nmax=20, seed=3, n_boot=300)


def test_D_n_approaches_einstein_D_at_85_2_Hz(gk852):
    """At 85.2 Hz consecutive jumps are strongly persistent (p_f ~ 0.8) and <h_0 h_k>
    decays roughly like 0.7^k, so D_0 = D_rw is several errors below the Einstein D,
    while by n = 20 the neglected tail is a few % of D, well inside its error: the series
    must climb from a clear disagreement to agreement."""
    D, D_err = gk852.meta["D"], gk852.meta["D_err"]
    pulls = np.array([_pull(d, e, D, D_err) for d, e in zip(gk852.D_n, gk852.D_n_err, strict=True)])
    assert pulls[0] < -PULL_AGREE, "the random walk D_0 should be far below D here"
    assert abs(pulls[-1]) < PULL_AGREE
    # positive correlations: the partial sums increase for the first orders
    assert np.all(np.diff(gk852.D_n[:6]) > 0)


def test_identities_of_the_numbers(gk852):
    """D_rw = d^2 / 2 tau; D_0 = D_rw when every jump is +-d; p_f + p_b = 1; D_a is the
    energy-balance formula with the measured r."""
    out = gk_numbers(gk852)
    p = Params(f=85.2)
    assert out["D_rw"] == pytest.approx(p.d**2 / (2 * out["tau"]), rel=1e-12)
    if out["fraction_long"] == 0:
        assert out["D_n"][0] == pytest.approx(out["D_rw"], rel=1e-12)
    assert out["p_f"] + out["p_b"] == pytest.approx(1.0, abs=1e-12)
    surplus = (p.A * p.w) ** 2 - 2 * p.g * p.A
    assert out["D_a"] == pytest.approx(0.5 * p.d * math.sqrt(surplus / (1 + out["r"])), rel=1e-12)
    assert out["D_n"].shape == out["D_n_se"].shape == (21,)


def test_D_a_undefined_below_gamma_2():
    """At 68 Hz (Gamma = 1.86 < 2) the balance leaves no kinetic energy: D_a is NaN with
    the reason, while r, tau and D are still measured."""
    gk = gk_run(Params(f=68.0), n=20, t=10.0, nmax=2, n_boot=20)
    out = gk_numbers(gk)
    assert math.isnan(out["D_a"]) and "Gamma" in gk.meta["D_a_reason"]
    assert math.isfinite(out["r"]) and out["r"] > 0 and math.isfinite(out["D"])


def test_scan_points_are_the_single_runs(tmp_path):
    """A scan at frequencies sharing their integer part stores distinct points, each equal
    to gk_point with the scan's seed rule."""
    freqs = [85.0, 85.2]
    scan = gk_scan(freqs, out_dir=tmp_path, seed=5, n=10, t=5.0, nmax=2, n_boot=10, progress=False)
    np.testing.assert_array_equal(scan["f"], freqs)
    for i, f in enumerate(freqs):
        direct = gk_point(f, point_seed(5, f), n=10, t=5.0, nmax=2, n_boot=10)
        assert scan["D"][i] == direct["D"] and scan["tau"][i] == direct["tau"]
        np.testing.assert_array_equal(scan["D_n"][i], direct["D_n"])
    assert scan["D"][0] != scan["D"][1]


def _strict_json(text):
    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.parametrize("f", [85.2, 68.0], ids=["gamma_above_2", "gamma_below_2"])
def test_gk_command_json(f, capsys):
    assert main(["gk", "--f", str(f), "--n", "20", "--t", "10", "--nmax", "3", "--json"]) == 0
    out = _strict_json(capsys.readouterr().out)
    for key in ("tau", "D_rw", "D_a", "r", "D", "D_se", "p_f", "p_b", "D_a_reason"):
        assert key in out
    assert len(out["D_n"]) == len(out["D_n_se"]) == 4
    assert out["params"]["f"] == f and out["nmax"] == 3
    if f < 70.46:
        assert out["D_a"] is None and "Gamma" in out["D_a_reason"]
    else:
        assert out["D_a"] > 0 and out["D_a_reason"] == ""


def test_gk_command_text(capsys):
    assert main(["gk", "--f", "85.2", "--n", "10", "--t", "5", "--nmax", "2"]) == 0
    text = capsys.readouterr().out
    assert "Einstein D" in text and "D_rw" in text and "p_f, p_b" in text


@pytest.mark.parametrize(
    "kwargs, match",
    [({"n": 1}, "n must"), ({"t": 0.0}, "t must"), ({"t": 0.01}, "no room")],
    ids=["one-particle", "no-time", "no-whole-period"],
)
def test_refused_scan_writes_nothing(tmp_path, kwargs, match):
    """Bad arguments are refused before the scan folder is created (issue 10)."""
    args = {"n": 10, "t": 5.0, "nmax": 2, "n_boot": 10} | kwargs
    with pytest.raises(ValueError, match=match):
        gk_scan([85.0, 85.2], out_dir=tmp_path / "s", seed=0, progress=False, **args)
    assert not (tmp_path / "s").exists()
