"""benchmarks/chatter_takeover.py: what depends on where the chattering sum takes over."""

import json

from derivation_loader import ROOT, load_benchmark


def _module():
    return load_benchmark("chatter_takeover")


def _report():
    return json.loads((ROOT / "docs" / "scan_compare" / "chatter_takeover.json").read_text())


def _flat(name: str) -> str:
    return " ".join((ROOT / "docs" / name).read_text().split())


def test_the_patch_scales_the_budget_once():
    m = _module()
    source = (ROOT / "bbdyn" / "core" / "tolerances.py").read_text()
    patched = m.scaled_source(source, 4.0)
    assert m.ANCHOR not in patched and patched.count("CHATTER_REL_TOL = 256.0 * EPS\n") == 1
    original, scaled = {}, {}
    exec(compile(source, "tolerances.py", "exec"), original)  # noqa: S102
    exec(compile(patched, "tolerances.py", "exec"), scaled)  # noqa: S102
    assert scaled["CHATTER_REL_TOL"] == 4.0 * original["CHATTER_REL_TOL"]
    assert {k: v for k, v in scaled.items() if k not in ("CHATTER_REL_TOL", "__builtins__")} == {
        k: v for k, v in original.items() if k not in ("CHATTER_REL_TOL", "__builtins__")
    }


def test_the_main_attractor_gives_the_share():
    m = _module()
    run = {"attractors": [{"fraction": 0.2, "tiny_fraction": 0.9},
                          {"fraction": 0.7, "tiny_fraction": 0.4}]}  # fmt: skip
    assert m.main_tiny_fraction(run) == 0.4


def test_the_docs_show_the_committed_report():
    m = _module()
    report = _report()
    scan = json.loads((ROOT / report["scan"]).read_text())
    wall = json.loads((ROOT / "docs" / "scan_compare" / "full_scan_323a012_wall.json").read_text())
    text = (ROOT / "docs" / "benchmarks.md").read_text()
    flat = " ".join(text.split())
    assert m.doc_table(report) in text
    assert m.scan_table(report, scan["points"]) in text
    assert m.predicted_scan(report, scan["points"]) == report["predicted_cpu_s"]
    (route3,) = report["timed"]
    predicted = report["predicted_cpu_s"][0][-1]
    walls = predicted * wall["wall_s"] / scan["cpu_s"]
    assert f"`route3-drive-shift` ({route3})" in flat
    assert f"{predicted:.0f} CPU s, about {walls:.0f} s wall" in flat
    assert f"{scan['cpu_s'] / predicted:.2f} times less" in flat


def test_the_classification_page_states_what_was_measured():
    report = _report()
    as_is, *others = [v for v in report["variants"] if "floor" not in v["label"]]
    assert as_is["label"] == "as is"
    share = {r["f"]: _module().main_tiny_fraction(r) for r in as_is["runs"]}
    flat = _flat("classification.md")
    assert f"{share[70.0]:.3f} at 70 Hz" in flat and f"{share[78.4]:.3f} at 78.4 Hz" in flat
    changed = {r["f"] for v in others for r, r0 in zip(v["runs"], as_is["runs"], strict=True)
               if r["regime"] != r0["regime"]}  # fmt: skip
    scaled = {r["f"] for v in others if v["label"].startswith("CHATTER_REL_TOL")
              for r, r0 in zip(v["runs"], as_is["runs"], strict=True)
              if r["regime"] != r0["regime"]}  # fmt: skip
    n = len(as_is["runs"])
    assert f"changes at {len(changed)} of the {n} frequencies" in flat
    assert f"at {len(scaled)} of them already with the budget alone scaled" in flat
    # the sums taking over much earlier (budget x 64, route 3) count fewer tiny hops everywhere
    m = _module()
    shares = {v["label"]: [m.main_tiny_fraction(r) for r in v["runs"]] for v in report["variants"]}
    for label in ("CHATTER_REL_TOL x 64", report["timed"][0]):
        assert all(a < b for a, b in zip(shares[label], shares["as is"], strict=True)), label
    assert "counts fewer tiny hops at every frequency" in flat


def test_with_a_floor_the_kernels_agree():
    """Impacts after flights below the floor left out: the count no longer depends on where
    the sum takes over, and the tree and the branch give the same regimes."""
    m = _module()
    report = _report()
    floor = report["floor"]
    base, route3 = (v for v in report["variants"] if "floor" in v["label"])
    assert base["label"] == f"as is, floor {floor:g} periods"
    assert route3["label"] == f"{report['timed'][0]}, floor {floor:g} periods"
    shares = [[m.main_tiny_fraction(r) for r in v["runs"]] for v in (base, route3)]
    regimes = [[r["regime"] for r in v["runs"]] for v in (base, route3)]
    assert regimes[0] == regimes[1]
    diff = max(abs(a - b) for a, b in zip(*shares, strict=True))
    flat = _flat("classification.md")
    f0 = base["runs"][0]["f"]
    assert (
        f"left out ({floor:g} periods), the tree and the branch give the same regime at every "
        f"frequency ({', '.join(sorted(set(regimes[0])))}), and tiny-hop fractions within "
        f"{diff:.3f} of each other ({shares[0][0]:.3f} and {shares[1][0]:.3f} at {f0:g} Hz)"
    ) in flat
