"""A particle the kernel fails on does not abort the ensemble (issue 10).

The particles are independent: the others must come out bitwise equal to their runs
alone, the failed one is marked in ``status`` and counted in the meta and the summary,
and the estimators use the particles that succeeded.
"""

import math

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.status import FAILURES, ROOT_NOT_CONVERGED, SimulationError
from bbdyn.diffusion import einstein_D
from bbdyn.ensemble import Box, ensemble

ALL = ("displacement", "energy", "jumps", "record")
GOOD = [[1.0, 3.0, 20.0], [2.0, -5.0, 30.0], [0.5, 10.0, 5.0]]
BAD = [1.0, 0.0, 1e300]  # launched to 5e595 mm: the first-contact search cannot converge
KW = {"t": 2.0, "observables": ALL, "record_particles": 4, "record_capacity": 2000}


def _mixed(**kwargs):
    return ensemble(Params(f=85.2), initial=[GOOD[0], BAD, GOOD[1], GOOD[2]], **KW, **kwargs)


def test_the_others_are_bitwise_what_they_are_alone():
    with pytest.warns(RuntimeWarning, match="1 of 4 particle"):
        mixed = _mixed()
    assert mixed["status"][1] == ROOT_NOT_CONVERGED
    assert not np.isin(mixed["status"][[0, 2, 3]], FAILURES).any()
    assert mixed.meta["n_failed"] == 1
    assert mixed.meta["failures"] == {"root_not_converged": 1}
    for row, ic in zip((0, 2, 3), GOOD, strict=True):
        alone = ensemble(Params(f=85.2), initial=[ic], **KW)
        for name in alone.arrays:
            if name in ("sample_times", "record_n"):
                continue
            assert np.array_equal(mixed[name][row], alone[name][0], equal_nan=True), name
        assert mixed["record_n"][row] == alone["record_n"][0]


def test_estimators_use_the_particles_that_succeeded():
    with pytest.warns(RuntimeWarning):
        mixed = _mixed()
    good = ensemble(Params(f=85.2), initial=GOOD, **KW)
    s, g = mixed.summary(), good.summary()
    assert s["n_ok"] == 3 and s["n_failed"] == 1 and s["failures"] == {"root_not_converged": 1}
    for name in ("D", "D_se", "E", "E_se", "stuck_fraction", "collisions_per_particle_per_s"):
        assert s[name] == g[name], name
    assert mixed.D() == einstein_D(good["sample_times"], good["displacement"])
    assert np.array_equal(mixed.msd()[1], good.msd()[1])
    assert np.isnan(mixed["displacement"][1, -1])  # no position after the failure


def test_on_failure_raise_names_the_particle():
    with pytest.raises(SimulationError, match=r"1 of 4 particle\(s\) failed .* particle 1 from"):
        _mixed(on_failure="raise")
    with pytest.raises(ValueError, match="on_failure must be one of"):
        _mixed(on_failure="ignore")


def test_an_ensemble_where_every_particle_fails_raises():
    # the reproducer: a box with vy up to 1e300 mm/s
    box = Box(s=(0.0, 1.0), vx=(-1.0, 1.0), vy=(1e299, 1e300))
    with pytest.raises(SimulationError, match="4 of 4 particle"):
        ensemble(Params(f=85.2), n=4, t=1.0, seed=0, box=box)


def test_one_particle_left_gives_no_standard_error():
    with pytest.warns(RuntimeWarning):
        res = ensemble(Params(f=85.2), initial=[GOOD[0], BAD], t=2.0)
    s = res.summary()
    assert s["n_ok"] == 1 and math.isnan(s["D_se"]) and math.isnan(s["E_se"])
    assert s["E"] == res["E"][0]


def test_simulate_command_reports_a_failed_particle_and_uses_the_others(monkeypatch, capsys):
    """``bbdyn simulate`` keeps going past a failed particle, says so, and its D by window
    is computed from the particles that succeeded (NaN positions of the failed one left out)."""
    import json

    import bbdyn.ensemble as ens
    from bbdyn.commands.cli import main

    monkeypatch.setattr(
        ens, "initial_conditions", lambda *a, **k: np.array([GOOD[0], BAD, GOOD[1], GOOD[2]])
    )
    with pytest.warns(RuntimeWarning, match="1 of 4 particle"):
        assert main(["simulate", "--f", "85.2", "--n", "4", "--t", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["n_failed"] == 1 and out["n_ok"] == 3
    assert all(math.isfinite(d) for d in out["D_windows"]["D"])


def test_classification_keeps_the_others_and_counts_the_failed_one():
    """A failed trajectory is left out of every attractor (label -2): the others get the labels
    and features they get alone, and basins + unsettled + failed fractions sum to one."""
    from bbdyn.classify import classify, trajectory_features

    kw = {"t": 4.0, "blocks": 4}
    mixed_ics = [GOOD[0], BAD, GOOD[1], GOOD[2]] * 2
    with pytest.warns(RuntimeWarning, match="2 of 8 particle"):
        mixed = classify(Params(f=85.2), initial=mixed_ics, **kw)
    good = classify(Params(f=85.2), initial=GOOD * 2, **kw)
    rows = [0, 2, 3, 4, 6, 7]
    assert np.array_equal(mixed["labels"][[1, 5]], [-2, -2])
    assert np.array_equal(mixed["labels"][rows], good["labels"])
    assert np.array_equal(mixed["D"][rows], good["D"])
    s = mixed.summary
    assert s["failed_fraction"] == 0.25 and s["failures"] == {"root_not_converged": 2}
    total = sum(a["fraction"] for a in s["attractors"]) + s["unsettled_fraction"]
    assert math.isclose(total + s["failed_fraction"], 1.0)
    with pytest.raises(SimulationError, match="2 of 8 particle"):
        trajectory_features(Params(f=85.2), initial=mixed_ics, on_failure="raise", **kw)
