"""Fast-forward of exactly periodic stick-release cycles (core.ensemble.fast_forward).

The skipped cycles repeat the last one bit for bit (translation in periods and tiles), so a
run with fast-forward must give the same events, counts, jumps, displacements and final
states as the event-by-event run, and the same integrals up to the rounding of a running
sum against a product (SUM_ROUND_PER_TERM per event).  Cycles with a jump in the window are
not skipped (none was seen), so jump times are exact too.
"""

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.tolerances import SUM_ROUND_PER_TERM
from bbdyn.ensemble import ensemble

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


def _pair(f, **kwargs):
    kwargs = {"n": 12, "t": 40.0, "seed": 1, "transient": 8.0, **kwargs}
    obs = ("displacement", "energy", "jumps", "record")
    on = ensemble(Params(f=f), observables=obs, fast_forward=True, **kwargs)
    off = ensemble(Params(f=f), observables=obs, fast_forward=False, **kwargs)
    return on, off


# 54 Hz contracts slowly onto its cycle, 58 and 62 Hz reach a bitwise repeat with lag 2
@pytest.mark.parametrize("f", [54.0, 58.0, 62.0], ids=["contracting_54Hz", "lag2_58Hz", "62Hz"])
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
