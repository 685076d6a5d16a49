"""benchmarks/chatter_oracle.py: what an earlier chattering sum could save at most."""

from derivation_loader import ROOT, load_benchmark


def _module():
    return load_benchmark("chatter_oracle")


def test_the_patch_applies_to_the_kernel_once_and_compiles():
    # the anchor is chatter_sum's error budget: lifted below V, in chatter_sum, once
    m = _module()
    source = (ROOT / "bbdyn" / "core" / "billiard.py").read_text()
    patched = m.patched_source(source, 1e-3)
    assert patched.count("math.inf if vn < 0.001 else") == 1 and m.ANCHOR not in patched
    lifted = patched.index("math.inf if vn < 0.001 else")
    assert patched.index("def chatter_sum(") < lifted < patched.index("def wedge_reflect(")
    compile(patched, "billiard.py", "exec")


def test_prediction_divides_each_point_by_its_interpolated_ratio():
    m = _module()
    report = {"v": [1.0], "rows": [{"f": f, "ratio": [r]} for f, r in
                                   ((50.0, 2.0), (53.0, 4.0), (55.0, 1.0), (60.0, 1.0),
                                    (70.0, 1.0), (90.0, 1.0))]}  # fmt: skip
    points = [{"f": 50.0, "cpu_s": 8.0}, {"f": 51.5, "cpu_s": 9.0}, {"f": 49.8, "cpu_s": 2.0},
              {"f": 85.0, "cpu_s": 5.0}]  # fmt: skip
    pred = m.predict(report, points)[0]
    # 50 Hz: /2; 51.5 Hz: halfway between 2 and 4, /3; 49.8 Hz below the first sample: /2
    assert pred[0] == 8.0 / 2 + 9.0 / 3 + 2.0 / 2
    assert pred[4] == 5.0 and pred[-1] == sum(pred[:-1])
