"""The worked examples' numbers (docs/data/page_examples.py): what the pages' code computes,
and in agreement with what the pages say about them."""

import importlib.util
import json

import pytest
from derivation_loader import ROOT

DATA = ROOT / "docs" / "data"


def _examples():
    spec = importlib.util.spec_from_file_location("page_examples", DATA / "page_examples.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _stored(name: str) -> dict:
    return json.loads((DATA / f"{name}.json").read_text())


def test_green_kubo_example_is_the_pages_code_and_agrees_with_the_walk():
    """docs/green_kubo.md's worked example: the stored numbers are what the page's code
    computes now, and they agree with the persistent walk's closed forms: D_0 exact, each D_n
    within 3 bootstrap errors of D_0 (1 + 2 (q + ... + q^n)), the Einstein D within 3 errors
    of D_inf, the symbol probabilities within 4 errors of the Markov values, and the symbol
    combinations near q and q²."""
    stored = _stored("green_kubo_example")
    assert stored == json.loads(json.dumps(_examples().green_kubo_example())), (
        "run python docs/data/page_examples.py"
    )
    q, d0 = stored["q"], stored["D_0"]
    assert d0 == stored["d"] ** 2 / (2 * stored["tau"])
    for row in stored["rows"]:
        n, value = row["n"], row["D_n"]
        assert row["exact"] == pytest.approx(d0 * (1 + 2 * sum(q**k for k in range(1, n + 1))))
        assert abs(value["value"] - row["exact"]) <= 3 * value["se"] + 1e-12 * d0
    einstein = stored["D_einstein"]
    assert abs(einstein["value"] - stored["D_inf"]) <= 3 * einstein["se"]
    for word in stored["words"]:
        assert abs(word["p"]["value"] - word["markov"]) <= 4 * word["p"]["se"]
    assert stored["q_from_symbols"] == pytest.approx(q, abs=0.01)
    assert stored["q2_from_symbols"] == pytest.approx(q * q, abs=0.01)


def test_threshold_counts_are_lower_most_where_particles_stick_every_period():
    """docs/billiard.md: a run that sticks at the first impact below the threshold counts
    fewer collisions at every frequency; the difference is largest in the 1/1 tongue just above
    Gamma = 1 (51 and 58 Hz: chatter and a stick every period) and smallest at 66 Hz, where
    sticks are rare."""
    rows = {r["f"]: r for r in _stored("threshold_counts")["rows"]}
    for r in rows.values():
        assert 0 < r["threshold"] < r["bbdyn"]
        assert r["lower_by"] == pytest.approx(1 - r["threshold"] / r["bbdyn"], rel=1e-12)
    by_drop = sorted(rows, key=lambda f: rows[f]["lower_by"])
    assert set(by_drop[-2:]) == {51.0, 58.0} and by_drop[0] == 66.0


def test_threshold_counts_are_the_pages_code():
    """The stored counts are what docs/billiard.md's code computes now."""
    assert _stored("threshold_counts") == json.loads(json.dumps(_examples().threshold_counts()))
