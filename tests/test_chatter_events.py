"""benchmarks/chatter_events.py: the events a chattering sum accepted earlier would absorb."""

import json

import numpy as np
from derivation_loader import ROOT, load_benchmark

from bbdyn.core.status import IMPACT, RELEASE, STICK


def _module():
    return load_benchmark("chatter_events")


def test_absorbed_counts_the_slow_bounces_just_before_each_stick_on_its_tile():
    """A sequence at the arc's bottom (xi = 0: V.n = vyrel) with normal velocities halving
    towards a STICK, a bounce on another tile in between, and a RELEASE: only the run of
    slow IMPACTs on the STICK's own tile, right before it, counts."""
    m = _module()
    vn = np.array([8.0, 4.0, 2.0, 1.0, 0.5, 0.25, 0.0, 0.0, 3.0, 0.5, 0.2, 0.0])
    kind = np.array([IMPACT] * 6 + [STICK, RELEASE] + [IMPACT] * 3 + [STICK])
    tile = np.zeros(vn.size)
    tile[9] = 1.0  # the slow bounce before the second STICK is on another tile
    xi, vx = np.zeros(vn.size), np.zeros(vn.size)
    count = m.absorbed(tile, xi, vx, vn, kind, 25.0, 1.5, STICK, IMPACT)
    assert count == 3 + 1  # 1.0, 0.5, 0.25 before the first STICK; 0.2 before the second
    assert m.absorbed(tile, xi, vx, vn, kind, 25.0, 0.1, STICK, IMPACT) == 0
    # off the bottom the normal velocity mixes vx and vyrel: V.n = (vyrel S + vx xi) / R
    xi = np.full(vn.size, 0.6)
    S = np.sqrt(25.0**2 - 0.6**2)
    vyrel = (vn * 25.0 - 2.0 * 0.6) / S  # vx = 2 mm/s along the arc
    count = m.absorbed(tile, xi, np.full(vn.size, 2.0), vyrel, kind, 25.0, 1.5, STICK, IMPACT)
    assert count == 4


def test_committed_report_counts_more_events_below_a_larger_threshold():
    """docs/scan_compare/chatter_events.json (the table of docs/benchmarks.md): at every
    frequency the shares are fractions of all events and grow with the threshold (a bounce
    slower than a threshold is slower than every larger one)."""
    report = json.loads((ROOT / "docs" / "scan_compare" / "chatter_events.json").read_text())
    assert report["thresholds"] == sorted(report["thresholds"])
    for row in report["rows"]:
        assert row["events"] == report["n"] * report["events"]
        assert 0.0 <= row["share"][0] and row["share"] == sorted(row["share"])
        assert row["share"][-1] <= 1.0
