"""On-the-fly trajectory features (core/features.py) against a stored collision record.

Ensemble and features share one event loop (core.ensemble.particle_loop) but not their
accumulators: the ensemble's collision record, energy integrals and counts are recomputed
here into the features, by a plain-Python reading of the record, and must agree.
"""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.classify import Thresholds, trajectory_features
from bbdyn.core import features as core
from bbdyn.core.observables import trap_of
from bbdyn.core.plate import TWO_PI, release_window
from bbdyn.core.status import IMPACT, STICK
from bbdyn.core.tolerances import OBS_INTEGRAL_REL_TOL
from bbdyn.ensemble import ensemble

# f * t and f * transient whole, and the window divisible into the blocks, so that
# the ensemble's energy window and the features' window coincide
F, T, TRANSIENT, N, BLOCKS = 85.0, 2.0, 0.4, 12, 17


@pytest.fixture(scope="module")
def runs():
    params = Params(f=F)
    feat = trajectory_features(params, t=T, n=N, seed=3, transient=TRANSIENT, blocks=BLOCKS)
    ens = ensemble(
        params, t=T, n=N, seed=3, transient=TRANSIENT, observables=("energy", "jumps", "record"),
        record_particles=N, record_capacity=100_000,
    )  # fmt: skip
    return params, feat, ens


def _from_record(params, rec, th, p0, p1, nb):
    """Features of one particle from its collision record (periods, phase, tile, xi, vx, vyrel,
    kind), with release times reconstructed from the STICK phases."""
    theta_r, _ = release_window(params.gamma)
    L = (p1 - p0) / nb
    hist = np.zeros(int(round(10.0 / th.hist_width)) + 1)
    out = dict(coll=np.zeros(nb), tiny=np.zeros(nb), jumps=np.zeros(nb), locked=np.zeros(nb))
    out["floored"] = 0
    cos = sin = 0.0
    seq = []
    dep = 0.0  # the initial condition departs at t = 0 (in periods)
    trap = None  # the first jump can only be in the transient: no trap before the record
    for periods, phase, tile, xi, _vx, vyrel, kind in rec:
        t = periods + phase / TWO_PI
        flight = t - dep
        dep = t
        if kind == STICK:
            dep = periods + (theta_r if phase <= theta_r else TWO_PI + theta_r) / TWO_PI
        new_trap = trap_of(tile, xi)
        jumped = trap is not None and new_trap != trap
        trap = new_trap
        if not p0 <= t < p1:
            continue
        j = int((periods - p0) // L)
        out["jumps"][j] += jumped
        if kind == IMPACT and flight < th.hop_floor:
            out["floored"] += 1  # a chattering sequence's tail: not a collision
            continue
        out["coll"][j] += 1
        k = math.floor(flight + 0.5)
        out["locked"][j] += 1 <= k <= th.kmax and abs(flight - k) <= th.k_tol
        out["tiny"][j] += flight < th.tiny
        hist[min(int(flight / th.hist_width), hist.size - 1)] += 1
        cos += math.cos(phase)
        sin += math.sin(phase)
        seq.append((phase, vyrel, kind))
    mism = np.full(th.pmax, -np.inf)
    for p in range(1, th.pmax + 1):
        for n in range(p, len(seq)):
            a, b = seq[n], seq[n - p]
            dph = abs(a[0] - b[0])
            dph = min(dph, TWO_PI - dph) / TWO_PI
            m = math.inf if a[2] != b[2] else max(dph, abs(a[1] - b[1]) / (params.g / params.f))
            mism[p - 1] = max(mism[p - 1], m)
        if len(seq) <= p:
            mism[p - 1] = math.inf
    return out, hist, cos, sin, mism


def test_record_is_complete_and_covers_the_hard_cases(runs):
    """Every collision recorded, and the run has sticks, tiny hops, locked flights, jumps,
    and impacts below the hop floor."""
    params, feat, ens = runs
    assert np.all(ens["record_n"] <= ens["record"].shape[1])
    assert np.any(ens["record"][..., 6] == STICK)
    b = feat["blocks"].sum(axis=(0, 1))
    assert min(b[core.BF_TINY], b[core.BF_LOCKED], b[core.BF_JUMPS]) > 0
    th = Thresholds(**feat.meta["thresholds"])
    p0, p1 = feat.meta["window_periods"]
    records = [ens["record"][i, : ens["record_n"][i]] for i in range(N)]
    floored = sum(_from_record(params, r, th, p0, p1, BLOCKS)[0]["floored"] for r in records)
    assert floored > 0  # chattering tails below hop_floor occur and are left out


def test_counts_and_sequences_equal_the_record(runs):
    params, feat, ens = runs
    th = Thresholds(**feat.meta["thresholds"])
    p0, p1 = feat.meta["window_periods"]
    assert [p0, p1] == ens.meta["window_periods"]
    for i in range(N):
        rec = ens["record"][i, : ens["record_n"][i]]
        out, hist, cos, sin, mism = _from_record(params, rec, th, p0, p1, BLOCKS)
        b = feat["blocks"][i]
        for key, col in (("coll", core.BF_COLL), ("tiny", core.BF_TINY),
                         ("jumps", core.BF_JUMPS), ("locked", core.BF_LOCKED)):  # fmt: skip
            np.testing.assert_array_equal(b[:, col], out[key], err_msg=f"{key}, particle {i}")
        np.testing.assert_array_equal(feat["hist"][i], hist)
        assert feat["glob"][i, core.G_COS] == pytest.approx(cos, rel=1e-12, abs=1e-9)
        assert feat["glob"][i, core.G_SIN] == pytest.approx(sin, rel=1e-12, abs=1e-9)
        np.testing.assert_array_equal(feat["mismatch"][i], mism)


def test_block_integrals_sum_to_the_ensemble_integrals(runs):
    """Energies, stuck time, collisions and jumps over the whole window, two event loops."""
    params, feat, ens = runs
    window_s = ens.meta["window_s"]
    b = feat["blocks"].sum(axis=1)
    for name, col in (("E_x", core.BF_EX), ("E_y", core.BF_EY), ("E_pot", core.BF_POT)):
        np.testing.assert_allclose(b[:, col] / window_s, ens[name], rtol=OBS_INTEGRAL_REL_TOL)
    np.testing.assert_allclose(b[:, core.BF_STUCK] / window_s, ens["stuck_fraction"], atol=1e-12)
    np.testing.assert_array_equal(b[:, core.BF_JUMPS], ens["jumps"])
    # the ensemble counts every impact; the features leave out the chattering tails
    th = Thresholds(**feat.meta["thresholds"])
    p0, p1 = feat.meta["window_periods"]
    for i in range(N):
        rec = ens["record"][i, : ens["record_n"][i]]
        floored = _from_record(params, rec, th, p0, p1, BLOCKS)[0]["floored"]
        assert b[i, core.BF_COLL] + floored == ens["collisions"][i]


def test_displacement_samples_equal_the_ensemble_displacements(runs):
    """The features run samples x - x(0) at the ensemble's default times, bit for bit."""
    params, feat, _ = runs
    ens = ensemble(params, t=T, n=N, seed=3, observables=("displacement",))
    np.testing.assert_array_equal(feat["sample_times"], ens["sample_times"])
    np.testing.assert_array_equal(feat["displacement"], ens["displacement"])
    assert np.any(feat["displacement"][:, -1] != 0.0)


def test_features_do_not_depend_on_threads():
    params = Params(f=85.2)
    a = trajectory_features(params, t=1.0, n=8, seed=5, threads=1)
    b = trajectory_features(params, t=1.0, n=8, seed=5, threads=2)
    for key in ("blocks", "hist", "kcount", "glob", "mismatch"):
        np.testing.assert_array_equal(a[key], b[key])


def one_particle_buffers(th):
    """Kernel thresholds of ``th``, a features output row and a ring for one particle, to
    feed ``core.feature_collision`` by hand."""
    kernel_th = th.kernel()
    out = core.FeatureOut(
        displacement=np.zeros((1, 0)),
        blocks=np.zeros((1, 1, core.BF_WIDTH)),
        counts=np.zeros((1, 0), dtype=np.int64),
        hist=np.zeros((1, int(round(10.0 / th.hist_width)) + 1)),
        kcount=np.zeros((1, th.kmax + 1)),
        glob=np.zeros((1, core.G_WIDTH)),
        mismatch=np.zeros((1, th.pmax)),
        status=np.zeros(1, dtype=np.int64),
    )
    return kernel_th, out, np.zeros((th.pmax, 3))


@pytest.mark.parametrize(("other_phase", "periodic"), [(TWO_PI - 1e-9, True), (math.pi, False)])
def test_period_1_across_phase_zero(other_phase, periodic):
    """A 1/1 orbit whose impacts straddle phase 0 (at 1e-9 and 2 pi - 1e-9 rad) is periodic:
    the phase difference is taken modulo 2 pi.  Control: alternating with pi is not."""
    params = Params(f=60.0)
    th = Thresholds()
    kernel_th, out, ring = one_particle_buffers(th)
    kp = params.kernel()
    n_ring = run = 0
    for c in range(40):
        phase = 1e-9 if c % 2 == 0 else other_phase
        hit = core.Collision(
            block=0, phase=phase, vyrel=100.0, kind=IMPACT, flight=1.0, jumped=False
        )
        n_ring, run = core.feature_collision(out, 0, ring, n_ring, run, hit, kernel_th, kp)
    mism = out.mismatch[0]
    expected = 2e-9 / TWO_PI if periodic else 0.5 - 1e-9 / TWO_PI
    assert mism[0] == pytest.approx(expected, rel=1e-6)
    assert mism[1] == pytest.approx(0.0, abs=1e-15)  # lag 2 compares equal phases
    assert (mism[0] <= th.period_tol) == periodic


def _chatter_features(depth, hop_floor):
    """Features of a resonant flight followed by a chattering sequence whose first ``depth``
    bounces are resolved one by one (flights 0.05 * 0.5^k periods) and the rest summed into
    the STICK, as the kernel does wherever its closed-form sum takes over."""
    params = Params(f=60.0)
    th = Thresholds(hop_floor=hop_floor)
    kernel_th, out, ring = one_particle_buffers(th)
    kp = params.kernel()
    n_ring = run = 0
    flights = [1.0] + [0.05 * 0.5**k for k in range(depth)]
    kinds = [IMPACT] * len(flights) + [STICK]
    flights.append(0.05 * 0.5**depth / (1 - 0.5))  # the sum of the rest
    t = 0.0
    for flight, kind in zip(flights, kinds, strict=True):
        t += flight
        hit = core.Collision(0, TWO_PI * (t % 1.0), 1.0, kind, flight, False)
        n_ring, run = core.feature_collision(out, 0, ring, n_ring, run, hit, kernel_th, kp)
    core.feature_finish(out.glob[0], out.mismatch[0], n_ring, run)
    return out


def test_chattering_tail_below_the_floor_is_not_counted():
    """Where the closed-form sum takes over below the hop floor does not change the counts:
    resolving 12 or 40 bounces of the same sequence (the 12th flight is 2.4e-5 periods, below
    the default floor 1e-4) gives the same collisions, tiny hops, histogram and runs.  Control:
    with no floor the deeper resolution counts 28 more collisions."""
    default = Thresholds().hop_floor
    a, b = _chatter_features(12, default), _chatter_features(40, default)
    for key in ("blocks", "hist", "kcount"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key))
    for col in (core.G_RUNS, core.G_RUNMAX, core.G_COS, core.G_SIN):
        assert a.glob[0, col] == b.glob[0, col]
    # the flight times summed differ only by the floored flights' time (< 2 * 1e-4 periods)
    assert abs(a.glob[0, core.G_TF] - b.glob[0, core.G_TF]) < 2 * default
    assert a.blocks[0, 0, core.BF_COLL] == 1 + 9 + 1  # resonant, 9 hops above 1e-4, the STICK
    a0, b0 = _chatter_features(12, 0.0), _chatter_features(40, 0.0)
    assert b0.blocks[0, 0, core.BF_COLL] - a0.blocks[0, 0, core.BF_COLL] == 28
