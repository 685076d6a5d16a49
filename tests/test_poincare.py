"""Poincaré records, trajectory pieces and region numbering (bbdyn.poincare)."""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.floor import arc_coordinates, xi_from_arc_length
from bbdyn.core.status import IMPACT, STICK
from bbdyn.core.tolerances import EPS, IMPACT_GAP_REL
from bbdyn.poincare import (
    PoincareResult,
    number_regions,
    poincare,
    poincare_trajectory,
    trajectory_pieces,
    visit_sequence,
)
from bbdyn.results import load_result


@pytest.fixture(scope="module", params=[58.0, 85.2, 88.4], ids=lambda f: f"f{f:g}")
def record(request):
    """Collisions of three ensemble particles after a short transient."""
    return poincare(Params(f=request.param), n=30, transient=3.0, particles=3, n_events=600)


def test_collision_points_lie_on_the_floor(record):
    kp = Params(**record.meta["params"]).kernel()
    s, y, phase = record["s"], record["y"], record["phase"]
    assert np.all((s >= 0) & (s <= Params(**record.meta["params"]).s_max))
    # the floor height at the recorded arc length and phase, through the inverse map s -> xi
    xi = np.array([xi_from_arc_length(v, kp) for v in s])
    _, b = arc_coordinates(xi, kp)
    floor = -kp.A * np.sin(phase) + b
    np.testing.assert_allclose(y, floor, rtol=0, atol=IMPACT_GAP_REL * (kp.A + kp.d))
    # and at the recorded x: the tile and local coordinate agree with x
    np.testing.assert_allclose(
        record["x"], (record["tile"] + 0.5) * kp.d + record["xi"], rtol=0, atol=64 * EPS * kp.d
    )


def test_collisions_leave_the_floor(record):
    """Post-collision velocity relative to the floor points out of the arc (V_n >= 0)."""
    kp = Params(**record.meta["params"]).kernel()
    imp = record["kind"] == IMPACT
    xi, vx, vyrel = record["xi"][imp], record["vx"][imp], record["vyrel"][imp]
    vn = vx * xi + vyrel * np.sqrt(kp.R**2 - xi**2)
    speed = np.hypot(vx, vyrel) * kp.R
    assert np.all(vn >= -64 * EPS * speed)


def _pieces_for(record, particle, points=7):
    rows = np.flatnonzero(record["particle"] == particle)
    return rows, trajectory_pieces(record, rows[0], rows[-1], points=points)


def test_pieces_join_the_collision_points(record):
    kp = Params(**record.meta["params"]).kernel()
    points = 7
    rows, pieces = _pieces_for(record, 0, points)
    start = rows[:-1]
    x = pieces["x"].reshape(-1, points)
    y = pieces["y"].reshape(-1, points)
    np.testing.assert_array_equal(x[:, 0], record["x"][start])
    np.testing.assert_array_equal(y[:, 0], record["y"][start])
    # Interval ends: the next event.  An interval ending in STICK also contains its
    # chattering sequence (unrecorded, shorter than ~1e-8 s), so only IMPACT ends are exact.
    end_impact = record["kind"][start + 1] == IMPACT
    dt = np.diff(pieces["t"].reshape(-1, points)[:, [0, -1]], axis=1)[:, 0]
    vy = np.abs(record["vy"][start]) + kp.g * dt
    scale_y = vy * dt + 0.5 * kp.g * dt**2 + 2 * kp.A + np.abs(vy) / kp.w * 2 * math.pi
    scale_x = np.abs(record["x"][start]) + np.abs(record["vx"][start]) * dt
    err_y = np.abs(y[:, -1] - record["y"][start + 1])[end_impact]
    err_x = np.abs(x[:, -1] - record["x"][start + 1])[end_impact]
    assert end_impact.sum() > 100
    assert np.all(err_y <= IMPACT_GAP_REL * scale_y[end_impact])
    assert np.all(err_x <= IMPACT_GAP_REL * scale_x[end_impact])


def test_pieces_stay_above_the_floor(record):
    """Inside every flight the particle is on or above the floor under it.

    Flights ending in STICK are left out: they contain the unrecorded chattering
    sequence, during which the drawn parabola dips below the floor by ~1e-14 mm.
    """
    kp = Params(**record.meta["params"]).kernel()
    _, pieces = _pieces_for(record, 1, points=25)
    keep = record["kind"][pieces["event"] + 1] != STICK
    gap = (pieces["y"] - pieces["floor"])[keep]
    scale = 2 * kp.A + kp.d + np.abs(pieces["y"][keep])
    assert keep.sum() > 1000
    assert np.all(gap >= -IMPACT_GAP_REL * scale)


def test_collision_law_between_pieces(record):
    """Pre-impact velocity from the parabola and post-impact velocity obey docs/model.md §2."""
    kp = Params(**record.meta["params"]).kernel()
    rows = np.flatnonzero(record["particle"] == 2)
    i = rows[:-1]
    j = i + 1
    ok = (record["kind"][i] == IMPACT) & (record["kind"][j] == IMPACT)
    ok &= np.abs(record["xi"][j]) < 0.5 * kp.d * (1 - 1e-9)  # away from the wedge rule
    i, j = i[ok], j[ok]
    dt = (record["periods"][j] - record["periods"][i]) * kp.period + (
        record["phase"][j] - record["phase"][i]
    ) / kp.w
    u = -kp.A * kp.w * np.cos(record["phase"][j])
    vx_m, vy_m = record["vx"][i], record["vy"][i] - kp.g * dt
    xi = record["xi"][j]
    S = np.sqrt(kp.R**2 - xi**2)
    n = np.stack([xi, S]) / kp.R
    t = np.stack([S, -xi]) / kp.R
    rel_m = np.stack([vx_m, vy_m - u])
    rel_p = np.stack([record["vx"][j], record["vy"][j] - u])
    scale = np.hypot(*rel_m) + kp.g * dt + kp.A * kp.w
    np.testing.assert_array_less(
        np.abs((rel_p * n).sum(0) + kp.alpha * (rel_m * n).sum(0)), 1e3 * EPS * scale
    )
    np.testing.assert_array_less(
        np.abs((rel_p * t).sum(0) - kp.beta * (rel_m * t).sum(0)), 1e3 * EPS * scale
    )
    assert ok.sum() > 50


def test_record_saves_and_loads(tmp_path, record):
    loaded = load_result(record.save(tmp_path / "rec"))
    assert isinstance(loaded, PoincareResult)
    for name in ("s", "vx", "vy", "y", "t", "tile", "kind", "flight", "particle"):
        np.testing.assert_array_equal(loaded[name], record[name])


def test_stuck_intervals_ride_the_floor():
    """After a STICK the piece is the floor itself, at fixed x."""
    rec = poincare(Params(f=58.0), n=5, transient=2.0, particles=5, n_events=200)
    sticks = np.flatnonzero(rec["kind"][:-1] == STICK)
    sticks = sticks[rec["particle"][sticks] == rec["particle"][sticks + 1]]
    assert sticks.size > 0
    for i in sticks[:5]:
        p = trajectory_pieces(rec, i, i + 1, points=9)
        np.testing.assert_array_equal(p["x"], rec["x"][i])
        np.testing.assert_allclose(p["y"], p["floor"], rtol=0, atol=64 * EPS)


def test_trajectory_source_discards_the_transient():
    p = Params(f=85.2)
    full = poincare_trajectory(p, s0=1.0, vx0=10.0, vy0=30.0, n_events=300)
    late = poincare_trajectory(p, s0=1.0, vx0=10.0, vy0=30.0, n_events=200, transient_events=100)
    np.testing.assert_array_equal(late["t"], full["t"][100:])
    np.testing.assert_array_equal(late["vx"], full["vx"][100:])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"particles": 0}, "particles"),
        ({"particles": 31}, "particles"),
    ],
    ids=["no_particles", "more_than_n"],
)
def test_poincare_refuses_bad_input(kwargs, match):
    with pytest.raises(ValueError, match=match):
        poincare(Params(f=85.2), n=30, transient=1.0, **kwargs)


# ---- region numbering ----------------------------------------------------------------


def _cyclic_blobs(n_cycles=40, seed=3):
    rng = np.random.default_rng(seed)
    centres = np.array([[0.0, 0.0], [5.0, 1.0], [2.0, 8.0]])
    pts = np.concatenate([c + 0.1 * rng.standard_normal((n_cycles, 2)) for c in centres], axis=1)
    return pts.reshape(-1, 2)  # visits blob 0, 1, 2, 0, 1, 2, ...


def test_regions_of_a_cycle_are_numbered_in_visiting_order():
    pts = _cyclic_blobs()
    labels = number_regions(pts[:, 0], pts[:, 1], bins=8)
    np.testing.assert_array_equal(visit_sequence(labels), np.tile([1, 2, 3], 40))


def test_region_numbers_are_first_visits_in_order():
    rng = np.random.default_rng(0)
    u, v = rng.random(500), rng.random(500) ** 3
    labels = number_regions(u, v, bins=12)
    _, first = np.unique(labels, return_index=True)
    assert np.all(np.diff(first) > 0)  # region k + 1 is first entered after region k
    assert labels[0] == 1 and set(labels) == set(range(1, labels.max() + 1))


def test_region_numbering_is_a_function_of_the_sequence():
    pts = _cyclic_blobs(seed=5)
    a = number_regions(pts[:, 0], pts[:, 1], bins=10)
    np.testing.assert_array_equal(a, number_regions(pts[:, 0].copy(), pts[:, 1].copy(), bins=10))
    # exact rescaling by powers of two moves no point across a cell edge
    np.testing.assert_array_equal(a, number_regions(4.0 * pts[:, 0], 0.5 * pts[:, 1], bins=10))
    # relabelling follows the order: reversing the visits reverses the first visits
    b = number_regions(pts[::-1, 0], pts[::-1, 1], bins=10)
    assert visit_sequence(b)[:3].tolist() == [1, 2, 3]
    assert len(set(zip(a[::-1].tolist(), b.tolist(), strict=True))) == a.max()


@pytest.mark.parametrize(
    "u, v, bins",
    [([], [], 4), ([1.0, 2.0], [1.0], 4), ([1.0, math.nan], [1.0, 2.0], 4), ([1.0], [1.0], 0)],
    ids=["empty", "shape_mismatch", "nan", "zero_bins"],
)
def test_number_regions_refuses_bad_input(u, v, bins):
    with pytest.raises(ValueError):
        number_regions(u, v, bins=bins)


def test_single_point_is_region_one():
    assert number_regions([0.3], [0.7]).tolist() == [1]
