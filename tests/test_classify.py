"""Attractors, basins, ergodicity and regime: the flat ball, where the answers are known.

The flat ball is the billiard with R = 1e9 mm (tests/test_billiard_limits.py shows it
reproduces the flat map's impact sequence); the k/1 tongue edges come from bbdyn.flat.tongues.
"""

import json
import math
from dataclasses import asdict

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.classify import (
    FeatureResult,
    Thresholds,
    attractor_D,
    classify,
    classify_features,
    trajectory_features,
)
from bbdyn.commands.cli import main
from bbdyn.core import features as core
from bbdyn.flat.tongues import k1_orbit, params_at_gamma, tongue_gamma_hi, tongue_gamma_lo
from bbdyn.results import make_meta

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
    with pytest.raises(ValueError, match="hop_floor"):
        classify_features(feat, Thresholds(hop_floor=0.0))


@pytest.mark.parametrize(
    ("field", "value"),
    [("z", 0.0), ("kmax", 2.5), ("k_tol", 0.5), ("abs_tol", math.nan), ("hop_floor", -1e-4)],
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


# ---- constructed features: known attractors, known D --------------------------------------
def _constructed(times, disp, unsettled=(), nb=16, L=10.0, counts=None, hotter=()):
    """Features of ``disp.shape[0]`` trajectories that all agree on every compared average,
    except ``unsettled`` ones, whose collision rate triples from the first to the second half
    of the window (so they fail the settling test), and ``hotter`` ones, whose E_x is 600
    instead of 300 kg mm^2/s^2 (a second attractor).  Window ``[t / 2, t]``.  Every block of
    ``L`` periods holds 10 collisions, all locked flights, and 2 jumps, unless ``counts``
    (``{BF_* column: per-block value}``, a value of shape (n, 1) per trajectory) says
    otherwise."""
    params = Params(f=50.0)
    n = disp.shape[0]
    block_s = L / params.f
    blocks = np.zeros((n, nb, core.BF_WIDTH))
    for col, value in ((core.BF_EX, 300.0), (core.BF_EY, 500.0), (core.BF_POT, 200.0)):
        blocks[..., col] = value * block_s  # time averages in kg mm^2/s^2
    blocks[..., core.BF_COLL] = 10.0
    blocks[..., core.BF_LOCKED] = 10.0
    blocks[..., core.BF_JUMPS] = 2.0
    for col, value in (counts or {}).items():
        blocks[..., col] = value
    blocks[list(unsettled), nb // 2 :, core.BF_COLL] = 30.0
    blocks[list(hotter), :, core.BF_EX] = 600.0 * block_s
    th = Thresholds()
    arrays = {
        "blocks": blocks,
        "hist": np.zeros((n, int(round(10.0 / th.hist_width)) + 1)),
        "kcount": np.zeros((n, th.kmax + 1)),
        "glob": np.zeros((n, core.G_WIDTH)),
        "mismatch": np.full((n, th.pmax), np.inf),
        "initial": np.zeros((n, 3)),
        "box_index": np.zeros(n, dtype=int),
        "status": np.zeros(n, dtype=np.int64),
        "sample_times": times,
        "displacement": disp,
    }
    t = float(times[-1])
    meta = make_meta(
        params, seed=0, wall_s=0.0, t=t, n=n, transient=t / 2, window_periods=[0.0, nb * L],
        block_periods=L, thresholds=asdict(th),
    )  # fmt: skip
    return FeatureResult(arrays, meta)


def _persistent_walk(n, steps, p, d, tau, seed=0, samples=101):
    """Persistent random walks: jumps of +-d every tau, the same direction again with
    probability p; stationary start.  Sample times (s) and displacements (mm)."""
    rng = np.random.default_rng(seed)
    flips = np.where(rng.random((n, steps)) < p, 1, -1)
    flips[:, 0] = rng.choice((-1, 1), n)
    x = np.concatenate([np.zeros((n, 1)), d * np.cumsum(np.cumprod(flips, axis=1), axis=1)], axis=1)
    k = np.linspace(0, steps, samples).round().astype(int)
    return k * tau, x[:, k]


def test_attractor_D_of_a_persistent_walk_is_the_long_time_D():
    """Jumps d every tau, persistence p: D_inf = D_0 (1 + q) / (1 - q), q = 2 p - 1, D_0 =
    d^2 / (2 tau); the attractor's D (and each convergence window) finds D_inf, not D_0."""
    p, d, tau = 0.8, 1.5, 0.25
    q = 2 * p - 1
    D_0 = d**2 / (2 * tau)
    D_inf = D_0 * (1 + q) / (1 - q)
    times, disp = _persistent_walk(n=1500, steps=2000, p=p, d=d, tau=tau)
    s = classify_features(_constructed(times, disp)).summary
    (att,) = s["attractors"]
    assert att["fraction"] == 1.0
    assert abs(att["D"] - D_inf) <= 4 * att["D_se"]
    assert abs(att["D"] - D_0) > 4 * att["D_se"]
    w = att["D_windows"]
    for D, se in zip(w["D"], w["D_se"], strict=True):
        assert abs(D - D_inf) <= 4 * se
    assert att == {**att, **attractor_D(times, disp)}


def test_each_attractor_has_the_D_of_its_own_members():
    """Two attractors (E_x 300 and 600) and unsettled trajectories of both kinds: each
    attractor's D is the long-time D of its own walks (closed form, persistence p = 0.8
    against uncorrelated jumps, D_inf 18 against 4.5 mm^2/s), not the D of all trajectories,
    and the mean of its members' own slopes."""
    d, tau = 1.5, 0.25
    D_0 = d**2 / (2 * tau)
    walks = {p: _persistent_walk(n=500, steps=2000, p=p, d=d, tau=tau, seed=s)
             for p, s in ((0.8, 3), (0.5, 4))}  # fmt: skip
    times = walks[0.8][0]
    disp = np.concatenate([walks[0.8][1], walks[0.5][1]])
    unsettled = [*range(490, 500), *range(990, 1000)]
    c = classify_features(_constructed(times, disp, unsettled, hotter=range(500, 1000)))
    s = c.summary
    assert s["unsettled_fraction"] == 0.02 and len(s["attractors"]) == 2
    for a, (p, first) in enumerate(((0.8, 0), (0.5, 500))):
        members = np.flatnonzero(c["labels"] == a)
        assert members.tolist() == list(range(first, first + 490))
        att = s["attractors"][a]
        q = 2 * p - 1
        assert abs(att["D"] - D_0 * (1 + q) / (1 - q)) <= 4 * att["D_se"]
        assert att["D"] == pytest.approx(np.mean(c["D"][members]), rel=1e-9)


def test_basin_fractions_count_unsettled_trajectories():
    """Fractions are members / n (not / settled): with 5 of 20 unsettled, one attractor of
    15 has fraction 0.75, and fractions + unsettled fraction = 1."""
    times, disp = _persistent_walk(n=20, steps=200, p=0.5, d=1.0, tau=0.1, seed=1)
    c = classify_features(_constructed(times, disp, unsettled=range(5)))
    s = c.summary
    assert np.array_equal(c["labels"], [-1] * 5 + [0] * 15)
    (att,) = s["attractors"]
    assert att["members"] == 15 and att["fraction"] == 0.75
    assert s["unsettled_fraction"] == 0.25
    assert _fractions_sum_to_one(s)


def test_attractor_energies_are_physical_time_averages():
    """E, E_x, E_y, E_pot in kg mm^2/s^2 (the constructed blocks hold 300, 500, 200),
    E_kin = E_x + E_y, E = E_kin + E_pot, with units named in the summary."""
    times, disp = _persistent_walk(n=10, steps=200, p=0.5, d=1.0, tau=0.1, seed=2)
    s = classify_features(_constructed(times, disp)).summary
    (att,) = s["attractors"]
    expected = {"E_x": 300.0, "E_y": 500.0, "E_pot": 200.0, "E_kin": 800.0, "E": 1000.0}
    for name, value in expected.items():
        assert att[name] == pytest.approx(value, rel=1e-12)
        assert att[name + "_se"] == pytest.approx(0.0, abs=1e-9)
        assert s["units"][name] == "kg mm^2/s^2"
    assert s["units"]["D"] == "mm^2/s"


def test_attractor_D_is_simulates_D_of_its_members():
    """85.2 Hz: the features run and simulate's ensemble move the same particles bit for bit,
    and each attractor's D and its windows are simulate's estimator on its members, whether
    or not every particle has settled within the short run."""
    from bbdyn.ensemble import ensemble

    params = Params(f=85.2)
    feat = trajectory_features(params, t=4.0, n=16, seed=1, threads=1)
    c = classify_features(feat)
    sim = ensemble(params, n=16, t=4.0, seed=1, transient=feat.meta["transient"], threads=1,
                   observables=("displacement", "energy"))  # fmt: skip
    np.testing.assert_array_equal(sim["sample_times"], feat["sample_times"])
    np.testing.assert_array_equal(sim["displacement"], feat["displacement"])
    assert c.summary["attractors"]
    for a, att in enumerate(c.summary["attractors"]):
        members = sim["displacement"][c["labels"] == a]
        expected = attractor_D(sim["sample_times"], members, feat.D_window())
        assert (att["D"], att["D_se"], att["D_windows"]) == (
            expected["D"], expected["D_se"], expected["D_windows"]
        )  # fmt: skip


def test_classify_and_simulate_commands_agree(capsys):
    """The same through the commands, where one attractor holds the whole ensemble (8 s: in 4
    s one of these 16 particles may not have settled): classify's D and windows are
    simulate's; energies agree within errors (simulate over the same window)."""
    args = ["--n", "16", "--t", "8", "--seed", "1", "--json", "--threads", "1"]
    assert main(["classify", "85.2", *args]) == 0
    c = json.loads(capsys.readouterr().out)
    assert main(["simulate", "--f", "85.2", *args, "--transient", "4"]) == 0
    s = json.loads(capsys.readouterr().out)
    (att,) = c["attractors"]
    assert att["fraction"] == 1.0, "not every particle settled: see the test above"
    assert (att["D"], att["D_se"]) == (s["D"], s["D_se"])
    assert att["D_windows"] == s["D_windows"]
    for name in ("E", "E_x", "E_y", "E_pot"):
        assert abs(att[name] - s[name]) <= math.hypot(att[name + "_se"], s[name + "_se"])


def test_classify_command_hop_floor(capsys):
    """At 70 Hz particles chatter: counting every impact (--hop-floor 0) counts more
    collisions, and more of them tiny hops, than the default floor; the same runs otherwise."""
    common = ["classify", "--f", "70", "--n", "6", "--t", "4", "--json"]
    runs = []
    for extra in ([], ["--hop-floor", "0"]):
        assert main(common + extra) == 0
        out = json.loads(capsys.readouterr().out)
        runs.append((out["thresholds"]["hop_floor"], out["attractors"][0], out))
    (floor, a, out_a), (zero, b, out_b) = runs
    assert floor == Thresholds().hop_floor and zero == 0.0
    assert b["collision_rate"] > a["collision_rate"] and b["tiny_fraction"] > a["tiny_fraction"]
    for key in ("D", "E", "E_x", "stuck_fraction"):  # the same trajectories
        assert a[key] == b[key]


# ---- every regime label and attractor character ---------------------------------------------
#: Block sums (per block of 10 driving periods at 50 Hz, ``_constructed``) of the motions
#: that docs/model.md section 5 defines; stuck time in s.
BLOCK_S = 10.0 / 50.0
REST = {core.BF_COLL: 0.0, core.BF_LOCKED: 0.0, core.BF_JUMPS: 0.0, core.BF_STUCK: BLOCK_S}
#: every period: chatter (5 tiny hops), stick, release, one flight; never a trap change
TRAPPED_CYCLE = {core.BF_COLL: 60.0, core.BF_TINY: 50.0, core.BF_LOCKED: 0.0,
                 core.BF_JUMPS: 0.0, core.BF_STUCK: 0.3 * BLOCK_S}  # fmt: skip
#: one flight per period, locked to the drive, kicked into a neighbouring trap now and then
LOCKED = {core.BF_COLL: 10.0, core.BF_LOCKED: 10.0, core.BF_JUMPS: 2.0}
#: mostly tiny hops (long creeps), with jumps
CREEP = {core.BF_COLL: 60.0, core.BF_TINY: 50.0, core.BF_LOCKED: 5.0, core.BF_JUMPS: 2.0}
#: resonant flights and creeps alternate, neither dominating
INTERMITTENT = {core.BF_COLL: 20.0, core.BF_TINY: 6.0, core.BF_LOCKED: 10.0, core.BF_JUMPS: 2.0}
#: flights of no particular length, no tiny hops
IRREGULAR = {core.BF_COLL: 10.0, core.BF_TINY: 0.0, core.BF_LOCKED: 0.0, core.BF_JUMPS: 2.0}


def _two_motions(first, second, n):
    """Counts of the first motion for trajectories [0, n/2), of the second for the rest."""
    half = (np.arange(n) < n // 2)[:, None]
    return {col: np.where(half, first.get(col, 0.0), second.get(col, 0.0))
            for col in set(first) | set(second)}  # fmt: skip


@pytest.mark.parametrize(
    ("motion", "characters", "regime"),
    [
        (REST, ["at rest"], "a"),
        (TRAPPED_CYCLE, ["trapped cycle"], "a"),
        (LOCKED, ["locked"], "b(ii)"),
        (CREEP, ["creeping"], "c"),
        (INTERMITTENT, ["intermittent"], "d"),
        (IRREGULAR, ["irregular"], "other"),
        ("locked and trapped cycle", ["locked", "trapped cycle"], "b(i)"),
        ("locked and creeping", ["locked", "creeping"], "b(i)"),
    ],
    ids=["a-at-rest", "a-trapped-cycle", "b(ii)-locked", "c-creeping", "d-intermittent",
         "other-irregular", "b(i)-locked-and-trapped", "b(i)-locked-and-creeping"],
)  # fmt: skip
def test_every_regime_label_from_its_definition(motion, characters, regime):
    """Each regime of docs/model.md section 5 (and each attractor character) from block
    features built by its definition: no trap change -> (a); two coexisting attractors ->
    (b)(i); one locked -> (b)(ii); one of creeps -> (c); one where locked flights and creeps
    alternate -> (d); one irregular -> other.  Two motions go in equal halves."""
    n = 20
    times, disp = _persistent_walk(n=n, steps=200, p=0.5, d=1.0, tau=0.1, seed=3)
    if isinstance(motion, str):
        motion = _two_motions(LOCKED, TRAPPED_CYCLE if "trapped" in motion else CREEP, n)
    s = classify_features(_constructed(times, disp, counts=motion)).summary
    assert sorted(a["character"] for a in s["attractors"]) == sorted(characters), s["reason"]
    assert s["regime"] == regime, s["reason"]
    assert all(math.isclose(a["fraction"], 1 / len(characters)) for a in s["attractors"])


def test_inside_the_1_1_tongue_the_billiard_is_phase_locked_and_diffuses():
    """58 Hz is inside the flat 1/1 tongue (closed form); started near the 1/1 orbit over a
    bump top, the billiard's particles stay locked (every flight one period), while the
    curvature of the top, unstable for the horizontal motion (its exponent is positive in
    closed form), kicks them from trap to trap: one locked attractor that jumps, (b)(ii)."""
    from bbdyn.lyapunov import top_orbit_exponent

    params = Params(f=58.0)
    assert tongue_gamma_lo(1, params.alpha) < params.gamma < tongue_gamma_hi(1, params.alpha)
    assert top_orbit_exponent(params, 1) > 0
    ini, phase = _near_k1_orbit(params, n=12)
    ini[:, 1] = 0.1 * np.random.default_rng(4).standard_normal(12)  # vx (mm/s)
    s = classify(params, t=4.0, initial=ini, start_phase=phase, threads=1).summary
    assert s["regime"] == "b(ii)", s["reason"]
    (att,) = s["attractors"]
    assert att["character"] == "locked" and att["locking_k"] == 1
    assert att["jump_rate"] > 0 and not att["trapped"]


@pytest.mark.parametrize("min_members", [3, 9], ids=["one-attractor", "no-attractor"])
def test_classify_plot_has_no_empty_panel(min_members):
    """``bbdyn classify --plot``: every panel of the figure shows data, with one attractor
    (overview and its two phase-space panels) and with none (the overview alone)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bbdyn.commands.classify import attractor_figure

    params = Params(f=58.0, R=FLAT_R)
    ini, phase = _near_k1_orbit(params, n=8)
    feat = trajectory_features(params, t=2.0, initial=ini, start_phase=phase)
    res = classify_features(feat, Thresholds(min_members=min_members))
    fig = attractor_figure(res)
    n_att = res.summary["n_attractors"]
    assert n_att == (1 if min_members == 3 else 0)
    assert len(fig.axes) == 1 + 2 * n_att
    empty = [ax.get_title() for ax in fig.axes if not ax.has_data()]
    plt.close(fig)
    assert not empty, empty
