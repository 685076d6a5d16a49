"""Run sizes and the shared validation of ensembles and classification (issue 10).

Absurd sizes are refused with an estimate before anything large is allocated; the
estimate's rate model must bound the measured event rates; one rule for n and one
validation of t / transient / window serve both ``ensemble`` and ``trajectory_features``.
"""

import tracemalloc

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.classify import trajectory_features
from bbdyn.ensemble import ensemble
from bbdyn.runs import EVENTS_PER_PERIOD


def test_rate_model_bounds_the_measured_event_rates():
    # every particle, event by event (no fast-forward), over the frequency range of the paper
    worst = 0.0
    for f in np.arange(30.0, 100.5, 1.0):
        res = ensemble(
            Params(f=float(f)), n=4, t=2.0, seed=1, fast_forward=False, observables=(), threads=1
        )
        worst = max(worst, res["events"].max() / (2.0 * f))
    assert 10.0 < worst <= EVENTS_PER_PERIOD  # 50-62 Hz make > 20 events per period


def test_estimate_bounds_the_run_it_allowed():
    obs = ("displacement", "energy", "jumps", "record")
    res = ensemble(
        Params(f=58.0), n=5, t=3.0, seed=2, fast_forward=False, observables=obs, record_particles=2
    )
    est = res.meta["estimate"]
    assert res["events"].sum() <= est["events"]
    assert sum(a.nbytes for a in res.arrays.values()) <= est["bytes"]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n": 20, "t": 1e300}, "t must be at most 2\\^52 driving periods"),
        ({"n": 100_000_000_000, "t": 200.0}, "run too long: n = 100000000000 .* GiB of arrays"),
        ({"n": 20, "t": 1e9}, "run too long: .* h of CPU time"),
        ({"n": 10_000_000, "t": 1.0}, "run too large: .*GiB of arrays .*max_bytes"),
    ],
    ids=["t_1e300", "n_1e11", "t_1e9", "n_1e7_memory"],
)
def test_absurd_sizes_are_refused_before_allocating(kwargs, message):
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=message):
            ensemble(Params(f=85.2), seed=0, **kwargs)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 2**20  # nothing of the run's size was allocated


@pytest.mark.parametrize("boxes", [1, 3])
def test_classification_size_is_checked_before_drawing(boxes):
    """classify refuses an oversized run (here 13 GiB of feature arrays per 2 million
    particles) before it draws the initial conditions (48 MB per box here, 22 GiB for
    10^9 particles)."""
    from bbdyn.classify import classify
    from bbdyn.ensemble import reference_box

    p = Params(f=85.2)
    trajectory_features(p, t=1.0, n=2, seed=0)  # imports and kernels, outside the count
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="run too large: n = .* GiB of arrays"):
            classify(p, t=10.0, n=2_000_000, seed=0, boxes=[reference_box(p)] * boxes)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 2**20


def test_limits_are_arguments():
    p, kw = Params(f=85.2), {"n": 4, "t": 1.0, "seed": 0}
    events = 4 * 1.0 * 85.2 * EVENTS_PER_PERIOD
    with pytest.raises(ValueError, match="max_events"):
        ensemble(p, max_events=0.99 * events, **kw)
    assert ensemble(p, max_events=1.01 * events, **kw).meta["estimate"]["events"] == events
    nbytes = ensemble(p, **kw).meta["estimate"]["bytes"]
    with pytest.raises(ValueError, match="max_bytes"):
        ensemble(p, max_bytes=nbytes - 1, **kw)
    ensemble(p, max_bytes=nbytes, **kw)


def _refusals(kwargs):
    """The messages of ensemble and trajectory_features for the same bad arguments."""
    out = []
    for run in (ensemble, trajectory_features):
        with pytest.raises(ValueError) as err:
            run(Params(f=85.2), seed=0, **{"t": 1.0, "n": 4, "transient": 0.5, **kwargs})
        out.append(str(err.value))
    return out


@pytest.mark.parametrize("n", [0, 1, 1.5, -3])
def test_one_rule_for_n(n):
    a, b = _refusals({"n": n})
    assert a == b and a.startswith("n must be an integer >= 2")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"t": -1.0}, "t must be a finite time"), ({"transient": 2.0}, "transient must be in"),
     ({"t": 0.01, "transient": 0.005}, "no room for")],
)  # fmt: skip
def test_one_validation_of_t_and_transient(kwargs, message):
    a, b = _refusals(kwargs)
    assert message in a and message in b


def test_two_particles_make_an_ensemble():
    s = ensemble(Params(f=85.2), n=2, t=1.0, seed=0).summary()
    assert np.isfinite(s["D_se"]) and np.isfinite(s["E_se"])


def test_a_single_trajectory_refuses_absurd_event_counts():
    from bbdyn.billiard import BYTES_PER_STATE, simulate

    p, ic = Params(f=58.0), {"s0": 1.0, "vx0": 1.0, "vy0": 10.0}
    with pytest.raises(ValueError, match="n_events = 100000000000 would take .* GiB"):
        simulate(p, n_events=100_000_000_000, **ic)
    traj = simulate(p, n_events=50, **ic)
    assert sum(a.nbytes for a in traj.arrays.values()) <= 51 * BYTES_PER_STATE
    with pytest.raises(ValueError, match="max_bytes"):
        simulate(p, n_events=50, max_bytes=50 * BYTES_PER_STATE, **ic)
