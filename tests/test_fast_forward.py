"""Fast-forward of stick-release cycles (core.fast_forward).

Bitwise mode: the skipped cycles repeat the last one bit for bit (translation in periods and
tiles), so a run with fast-forward must give the same events, counts, jumps, displacements
and final states as the event-by-event run, and the same integrals up to the rounding of a
running sum against a product (SUM_ROUND_PER_TERM per event).  Cycles with a jump in the
window are not skipped (none was seen), so jump times are exact too.

Converged mode: cycles that converge onto a fixed point without repeating bit for bit
(70.2 Hz) are skipped once the proven drift ahead is below FF_DRIFT_TOL: the same counts,
integrals to FF_ENERGY_REL_TOL, positions to FF_DRIFT_TOL times the cycle's own
amplification of a release displacement (computed here from the tangent dynamics).
"""

from pathlib import Path

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.billiard import billiard_event
from bbdyn.core.billiard_tangent import billiard_tangent_event
from bbdyn.core.fast_forward import release_map
from bbdyn.core.status import RELEASE
from bbdyn.core.tolerances import FF_DRIFT_TOL, FF_ENERGY_REL_TOL, SUM_ROUND_PER_TERM
from bbdyn.ensemble import ensemble

ROOT = Path(__file__).resolve().parents[1]

EXACT = (
    "events",
    "collisions",
    "sticks",
    "jumps",
    "final",
    "displacement",
    "jump_len",
    "jump_time",
)
EXACT += ("record",)


def _pair(f, mode="bitwise", **kwargs):
    kwargs = {"n": 12, "t": 40.0, "seed": 1, "transient": 8.0, **kwargs}
    obs = ("displacement", "energy", "jumps", "record")
    on = ensemble(Params(f=f), observables=obs, fast_forward=mode, **kwargs)
    off = ensemble(Params(f=f), observables=obs, fast_forward="off", **kwargs)
    return on, off


# 54 Hz contracts slowly onto its cycle, 58 and 62 Hz reach a bitwise repeat with lag 2, 70.2 Hz
# only with lag 12 (FF_LAGS): 24 periods, with a sample time every 28 periods here
@pytest.mark.parametrize(
    "f", [54.0, 58.0, 62.0, 70.2], ids=["contracting_54Hz", "lag2_58Hz", "62Hz", "lag12_70Hz"]
)
def test_fast_forward_equals_the_event_by_event_run(f):
    on, off = _pair(f, jump_capacity=4096, record_particles=2, record_capacity=20000)
    assert np.all(off["skipped_events"] == 0)
    assert on["skipped_events"].sum() > 0  # it did skip
    assert np.all(on["skipped_events"][:2] == 0)  # recorded particles are not skipped
    for name in EXACT:
        assert np.array_equal(on[name], off[name]), name
    # integrals: running sums of n terms against K times one cycle's change
    n = off["events"]
    bound = 2 * n * SUM_ROUND_PER_TERM
    p = Params(f=f)
    for name in ("E_x", "E_y", "stuck_fraction"):  # integrands >= 0
        assert np.all(np.abs(on[name] - off[name]) <= bound * off[name]), name
    # g y >= -g A, so the integral of |g y| is at most that of g y + 2 g A
    scale = off["E_pot"] + 2 * p.g * p.A
    assert np.all(np.abs(on["E_pot"] - off["E_pot"]) <= bound * scale)


def test_sample_times_inside_the_cycles_are_exact():
    # dense, irregular samples: each one stops a skip, the positions stay bitwise equal
    times = np.sort(np.random.default_rng(0).uniform(0.0, 40.0, 300))
    on, off = _pair(62.0, n=6, sample_times=times)
    assert on["skipped_events"].sum() > 0
    assert np.array_equal(on["displacement"], off["displacement"])


def test_a_sample_time_exactly_at_a_skipped_release_is_exact(monkeypatch):
    """A sample time equal to a release of a skipped cycle, bit for bit (periods and phase
    handed to the kernel as the release's own): the position is that of the cycle the
    release begins, as in the event-by-event run (the tie rule of cycle_samples)."""
    import bbdyn.ensemble as ens

    p, kw = Params(f=62.0), {"n": 12, "t": 40.0, "seed": 1}
    skipped = ensemble(p, fast_forward="bitwise", observables=(), **kw)["skipped_events"]
    i = int(np.argmax(skipped))  # a particle whose cycles are skipped after 20 s
    ev = _release_of(p, i, ens.ensemble(p, fast_forward="off", **{**kw, "t": 20.0}))
    times = np.array([0.0, 20.0, (ev[0] + ev[1] / (2 * np.pi)) / p.f, 39.0])
    plain = ens.periods_phase

    def exact_release(t, f):
        periods, phase = plain(t, f)
        if t is times:  # the sample at the release: its periods and phase exactly
            periods[2], phase[2] = ev[0], ev[1]
        return periods, phase

    monkeypatch.setattr(ens, "periods_phase", exact_release)
    kw.update(sample_times=times, observables=("displacement",))
    on, off = ensemble(p, fast_forward="bitwise", **kw), ensemble(p, fast_forward="off", **kw)
    assert on["skipped_events"][i] > 0
    np.testing.assert_array_equal(on["displacement"], off["displacement"])


def _release_of(p, i, run):
    """The first release of particle ``i`` after the end of ``run``, event by event."""
    kp = p.kernel()
    ev = tuple(float(v) for v in run["final"][i][:6]) + (int(run["final"][i][6]),)
    for _ in range(10_000):
        ev = billiard_event(*ev, kp)[:7]
        if ev[6] == RELEASE:
            return ev
    raise AssertionError(f"particle {i} made no release in 10000 events")


@pytest.mark.parametrize("mode", ["bitwise", "converged"])
def test_sample_times_do_not_stop_the_skips(mode):
    # a skip goes on through the sample times (their positions from the cycle run once more):
    # 400 sample times or 2, the same cycles are skipped and the run ends in the same state
    kwargs = {"n": 4, "t": 40.0, "seed": 1, "fast_forward": mode}
    dense = ensemble(Params(f=70.2), sample_times=np.linspace(0.0, 40.0, 400), **kwargs)
    sparse = ensemble(Params(f=70.2), sample_times=np.linspace(0.0, 40.0, 2), **kwargs)
    assert np.all(dense["skipped_events"] > 0)
    for name in ("skipped_events", "events", "final", "E", "E_x", "E_y", "stuck_fraction"):
        assert np.array_equal(dense[name], sparse[name]), name
    assert np.array_equal(dense["displacement"][:, [0, -1]], sparse["displacement"])


def _release(f, t=40.0):
    """A release of particle 0 (seed 1) after ``t`` s at ``f`` Hz, and the kernel parameters."""
    kp = Params(f=f).kernel()
    res = ensemble(Params(f=f), n=2, t=t, seed=1, fast_forward="off")
    ev = tuple(float(v) for v in res["final"][0][:6]) + (int(res["final"][0][6]),)
    while ev[6] != RELEASE:
        ev = billiard_event(*ev, kp)[:7]
    return ev, kp


def _release_after(ev, releases, kp, dxi=0.0):
    """The release ``releases`` cycles after ``ev`` moved by ``dxi`` (mm), event by event."""
    ev = ev[:3] + (ev[3] + dxi,) + ev[4:]
    n = 0
    while True:
        ev = billiard_event(*ev, kp)[:7]
        n += 1
        if ev[6] == RELEASE:
            releases -= 1
            if releases == 0:
                return ev, n


def test_cycle_multiplier_matches_finite_differences():
    # the tangent dynamics against central differences of the release map, event by event;
    # the 70.2 Hz cycle has lag 2 and a multiplier of about -0.9 (it contracts slowly)
    ev, kp = _release(70.2)
    lam, P, ph, tile, xi, events, ok = release_map(*ev[:4], 2, 10_000, kp)
    end, n = _release_after(ev, 2, kp)
    assert ok and events == n and (P, ph, tile, xi) == end[:4]  # the same events, bitwise
    h = 1e-7  # mm: the rounding of F (~1e-13 mm) / h and the third derivative's h^2 << 1e-5
    (up, _), (down, _) = _release_after(ev, 2, kp, h), _release_after(ev, 2, kp, -h)
    fd = ((up[2] - down[2]) * kp.d + up[3] - down[3]) / (2 * h)
    assert abs(lam - fd) < 1e-5
    assert 0.5 < abs(lam) < 1.0


def _amplification(ev, releases, kp):
    """Largest displacement (mm) at any time of the cycles from ``ev`` per mm moved at that
    release: ``|dx| + |dvx| tau + |vx dtheta| / w`` after each event (tangent dynamics),
    ``tau`` the time to the next event."""
    J, W, T = (np.zeros((4, 4)) for _ in range(3))
    v = np.array([0.0, 1.0, 0.0, 0.0])
    rows = []
    while releases:
        ev = billiard_tangent_event(*ev, kp, (J, W, T))[:7]
        v = J @ v
        t = ev[0] * kp.period + ev[1] / kp.w
        rows.append((t, abs(v[1]), abs(v[2]), abs(ev[4] * v[0]) / kp.w))
        releases -= ev[6] == RELEASE
    return max(
        dx + dvx * (t1[0] - t0) + dth
        for (t0, dx, dvx, dth), t1 in zip(rows[:-1], rows[1:], strict=True)
    )


def test_converged_cycles_agree_with_the_event_by_event_run():
    # 70.2 Hz converges onto a lag-2 cycle that repeats bit for bit only 12 releases back:
    # the converged mode skips the lag-2 cycles before the bitwise mode can skip 12 releases
    ev, kp = _release(70.2)
    kwargs = {"n": 6, "t": 60.0, "transient": 12.0}
    on, off = _pair(70.2, mode="converged", **kwargs)
    bitwise, _ = _pair(70.2, mode="bitwise", **kwargs)
    assert np.all(on["skipped_events"] > bitwise["skipped_events"])
    for name in ("events", "collisions", "sticks", "jumps", "jump_len"):
        assert np.array_equal(on[name], off[name]), name
    # the releases of both runs are within FF_DRIFT_TOL of the fixed point, so within twice
    # that of each other, and the cycle moves the positions in between by its amplification
    bound = 2 * FF_DRIFT_TOL * _amplification(ev, 4, kp)
    assert np.all(np.abs(on["displacement"] - off["displacement"]) <= bound)
    rel = FF_ENERGY_REL_TOL + 2 * off["events"] * SUM_ROUND_PER_TERM
    for name in ("E_x", "E_y", "stuck_fraction"):  # integrands >= 0
        assert np.all(np.abs(on[name] - off[name]) <= rel * off[name]), name


def test_converged_mode_refuses_a_drifting_trapped_cycle():
    # at 50 Hz the releases drift along the arc by ~1e-6 mm per period (a multiplier close
    # to 1): nothing has converged, so the converged mode skips exactly what bitwise skips
    kwargs = {"n": 4, "t": 30.0, "transient": 6.0}
    conv, _ = _pair(50.0, mode="converged", **kwargs)
    bitwise, _ = _pair(50.0, mode="bitwise", **kwargs)
    for name in ("skipped_events", "final", "displacement", "E_x", "E_y"):
        assert np.array_equal(conv[name], bitwise[name]), name


@pytest.mark.parametrize("mode", ["fast", 1, None])
def test_bad_fast_forward_mode_is_refused(mode):
    with pytest.raises(ValueError, match="fast_forward must be one of"):
        ensemble(Params(f=70.2), n=2, t=1.0, seed=1, fast_forward=mode)


def _release_points(f, count):
    """``count`` successive releases of particle 0 (seed 1) after 40 s: (x, events before,
    periods, xi)."""
    ev, kp = _release(f)
    rows = []
    for _ in range(count):
        ev, n = _release_after(ev, 1, kp)
        rows.append((ev[2] * kp.d + ev[3], n, ev[0], ev[3]))
    return np.array(rows)


def test_the_numbers_in_the_docs():
    from bbdyn.core.ensemble import FF_LAGS

    text = " ".join((ROOT / "docs" / "billiard.md").read_text().split())
    assert f"`FF_LAGS` = {FF_LAGS} releases" in text
    assert f"`FF_DRIFT_TOL` = {FF_DRIFT_TOL:g} mm" in text
    assert f"`FF_ENERGY_REL_TOL` = {FF_ENERGY_REL_TOL:g}" in text
    ev, kp = _release(70.2)
    lam = release_map(*ev[:4], 2, 10_000, kp)[0]
    assert f"has the multiplier {lam:.2f}" in text
    rows = _release_points(70.2, 36)
    assert f"with {min(rows[:, 1]):.0f} and {max(rows[:, 1]):.0f} events" in text
    assert set(rows[:, 1]) == {min(rows[:, 1]), max(rows[:, 1])}
    assert "less than 1e-13 mm from those two cycles back" in text
    step2 = np.abs(rows[2:, 0] - rows[:-2, 0])
    assert np.all(step2 < 1e-13) and np.all(step2 > 0.0)  # converged, not bitwise
    # bit for bit only twelve releases back, the ring's longest lag
    assert f"repeat bit for bit only {FF_LAGS} releases back" in text
    xi = rows[:, 3]
    assert np.array_equal(xi[FF_LAGS:], xi[:-FF_LAGS])
    assert not any(np.any(xi[lag:] == xi[:-lag]) for lag in range(1, FF_LAGS))
    assert "by 1e-7 to 1e-5 mm per period" in text
    rows = _release_points(50.0, 6)
    creep = np.abs(np.diff(rows[:, 0])) / np.diff(rows[:, 2])
    assert np.all((creep > 1e-7) & (creep < 1e-5))


def test_simulate_takes_the_mode(capsys):
    # bbdyn simulate --fast-forward: the mode reaches the run and its JSON; at 70.2 Hz the
    # converged mode and the event-by-event run give the same energies to FF_ENERGY_REL_TOL
    import json

    from bbdyn.commands import cli

    out = {}
    for mode in ("converged", "off"):
        argv = ["simulate", "--f", "70.2", "--n", "4", "--t", "30", "--threads", "1"]
        assert cli.main([*argv, "--fast-forward", mode, "--json"]) == 0
        out[mode] = json.loads(capsys.readouterr().out)
        assert out[mode]["fast_forward"] == mode
    # events of a particle: at most those of all, and the window (its collisions) is 4/5 of
    # the run; every event is a collision or the release after one
    events = 2 * out["off"]["collisions"] * 5 / 4
    rel = FF_ENERGY_REL_TOL + 2 * events * SUM_ROUND_PER_TERM
    for name in ("E", "E_x", "E_y"):
        assert abs(out["converged"][name] - out["off"][name]) <= rel * out["off"][name]
