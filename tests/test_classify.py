"""Attractors, basins, ergodicity and regime: the flat ball, where the answers are known.

The flat ball is the billiard with R = 1e9 mm (tests/test_billiard_limits.py shows it
reproduces the flat map's impact sequence); the k/1 tongue edges come from bbdyn.tongues.
"""

import json
import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.classify import Thresholds, classify, classify_features, trajectory_features
from bbdyn.cli import main
from bbdyn.tongues import k1_orbit, params_at_gamma, tongue_gamma_hi, tongue_gamma_lo

FLAT_R = 1e9


def _near_k1_orbit(params, n=16, spread=0.01, seed=0):
    """Initial conditions on the floor at the stable 1/1 orbit's phase, velocities +-1%."""
    o = k1_orbit(params, 1)
    rng = np.random.default_rng(seed)
    vy = o.v * (1 + spread * rng.standard_normal(n))
    ini = np.column_stack([np.full(n, params.s_max / 2), np.zeros(n), vy])
    return ini, o.phase_stable


def _fractions_sum_to_one(summary):
    total = sum(a["fraction"] for a in summary["attractors"]) + summary["unsettled_fraction"]
    return math.isclose(total, 1.0, rel_tol=1e-12)


def test_gamma_below_one_is_trapped():
    """Gamma < 1: every particle lands, sticks and never leaves: regime (a), at rest."""
    c = classify(Params(f=45.0, R=FLAT_R), t=2.0, n=20, seed=1)
    s = c.summary
    assert s["regime"] == "a"
    assert [a["character"] for a in s["attractors"]] == ["at rest"]
    assert s["attractors"][0]["stuck_fraction"] == 1.0
    assert _fractions_sum_to_one(s)


@pytest.mark.parametrize(
    ("name", "gamma_of", "period"),
    [
        ("inside-1/1-tongue", lambda a: 0.5 * (tongue_gamma_lo(1, a) + tongue_gamma_hi(1, a)), 1),
        ("just-inside-upper-edge", lambda a: 0.97 * tongue_gamma_hi(1, a), 1),
        ("beyond-period-doubling", lambda a: 1.03 * tongue_gamma_hi(1, a), 2),
    ],
)
def test_flat_ball_near_the_1_1_orbit(name, gamma_of, period):
    """One attractor, locked k = 1; period 1 inside the tongue, 2 past its flip edge."""
    params = params_at_gamma(gamma_of(0.5), alpha=0.5).replace(R=FLAT_R)
    ini, phase = _near_k1_orbit(params)
    s = classify(params, t=4.0, initial=ini, start_phase=phase).summary
    assert s["n_attractors"] == 1, s["reason"]
    (att,) = s["attractors"]
    assert att["fraction"] == 1.0 and s["unsettled_fraction"] == 0.0
    assert att["locking_k"] == 1
    assert att["period"] == period
    assert att["character"] == "locked"
    assert s["ergodic"]


def test_basin_fractions_sum_to_one_with_two_boxes():
    """Two boxes together; every label counted once; per-box fractions also in [0, 1]."""
    from bbdyn.ensemble import Box, reference_box

    params = Params(f=58.0, R=FLAT_R)
    high = Box(s=(0.0, params.s_max), vx=(0.0, 0.0), vy=(60.0, 120.0))
    c = classify(params, t=3.0, n=30, seed=2, boxes=[reference_box(params), high])
    s = c.summary
    assert _fractions_sum_to_one(s)
    assert c["labels"].size == 60
    for att in s["attractors"]:
        assert all(0.0 <= v <= 1.0 for v in att["box_fractions"])
        assert math.isclose(np.mean(att["box_fractions"]), att["fraction"])


def test_verdict_is_stable_under_a_change_of_seed():
    """58 Hz billiard: same regime and attractors; fractions agree within 4 binomial sigma."""
    params = Params(f=58.0)
    runs = [classify(params, t=8.0, n=150, seed=s).summary for s in (11, 12)]
    assert runs[0]["regime"] == runs[1]["regime"]
    assert runs[0]["n_attractors"] == runs[1]["n_attractors"]
    for a, b in zip(runs[0]["attractors"], runs[1]["attractors"], strict=True):
        assert a["character"] == b["character"]
        p = 0.5 * (a["fraction"] + b["fraction"])
        assert abs(a["fraction"] - b["fraction"]) <= 4 * math.sqrt(p * (1 - p) * 2 / 150) + 1e-12


def test_reclassify_with_other_thresholds_needs_no_run_but_keeps_measurement():
    params = Params(f=58.0, R=FLAT_R)
    ini, phase = _near_k1_orbit(params, n=8)
    feat = trajectory_features(params, t=2.0, initial=ini, start_phase=phase)
    strict = classify_features(feat, Thresholds(min_members=9))
    assert strict.summary["n_attractors"] == 0 and strict.summary["unsettled_fraction"] == 1.0
    assert strict.summary["regime"] == "other"
    with pytest.raises(ValueError, match="tiny"):
        classify_features(feat, Thresholds(tiny=0.2))


@pytest.mark.parametrize(
    ("field", "value"), [("z", 0.0), ("kmax", 2.5), ("k_tol", 0.5), ("abs_tol", math.nan)]
)
def test_thresholds_are_validated(field, value):
    with pytest.raises(ValueError, match=field):
        Thresholds(**{field: value})


def test_classify_command_json(capsys):
    assert main(["classify", "45", "--n", "8", "--t", "1", "--R", "1e9", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["regime"] == "a" and isinstance(out["ergodic"], bool)
    for key in ("fraction", "locking_k", "period", "stuck_fraction", "jump_rate", "D"):
        assert key in out["attractors"][0]
    assert "unsettled_fraction" in out
