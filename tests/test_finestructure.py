"""Fine-structure statistics (bbdyn.scans.fine_structure) and scene B6 on synthetic data.

Independent facts: the increment chi-squared equals a weighted straight-line fit's;
on smooth function + noise the p-values are uniform (false-positive rate at the
nominal level); the noise-corrected S2 is unbiased and its error matches the scatter
over replicas; on a Takagi-Landsberg function of known Hoelder exponent the
structure is found and the exponent recovered within its error.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from bbdyn.scans import fine_structure as fs
from bbdyn.scans.cache import scene_folder

STEPS = (0.02, 0.005, 0.001, 0.0002)


def _noisy(rng, y, se):
    return y + se * rng.standard_normal(y.shape)


def test_chi2_equals_weighted_line_fit():
    rng = np.random.default_rng(0)
    x = fs.nested_grid(1.0, 0.1, 9)
    se = rng.uniform(0.5, 2.0, x.size)
    y = 3.0 + 2.0 * x + rng.standard_normal(x.size) * se + 0.5 * np.sin(7 * x)
    test = fs.level_test(y, se)
    coef = np.polyfit(x, y, 1, w=1 / se)
    assert test["chi2"] == pytest.approx(np.sum(((y - np.polyval(coef, x)) / se) ** 2), rel=1e-9)
    assert test["dof"] == x.size - 2
    flat = fs.level_test(y, se, detrend=False)
    mean = np.sum(y / se**2) / np.sum(1 / se**2)
    assert flat["chi2"] == pytest.approx(np.sum(((y - mean) / se) ** 2), rel=1e-9)
    assert flat["dof"] == x.size - 1


def test_increment_covariance_matches_sampling():
    rng = np.random.default_rng(1)
    se = np.array([0.5, 1.0, 2.0, 0.7, 1.3])
    draws = np.diff(se * rng.standard_normal((200_000, se.size)), axis=1)
    np.testing.assert_allclose(np.cov(draws.T), fs.increment_covariance(se), atol=0.03)


@pytest.mark.parametrize("m", [5, 11, 21])
def test_no_structure_in_smooth_function_false_positive_rate(m):
    """Smooth (locally linear at the noise level) function + noise with known, unequal
    errors: p uniform, P(p < 0.05) within 4 binomial sigma of 0.05."""
    rng = np.random.default_rng(m)
    reps = 2000
    ps = np.empty(reps)
    for i in range(reps):
        x = fs.nested_grid(rng.uniform(0, 3), 0.002, m)
        se = rng.uniform(0.5, 1.5, m) * 0.01
        ps[i] = fs.level_test(_noisy(rng, 2 + np.sin(1.3 * x), se), se)["p"]
    rate = np.mean(ps < 0.05)
    assert abs(rate - 0.05) < 4 * np.sqrt(0.05 * 0.95 / reps), rate
    assert stats.kstest(ps, "uniform").pvalue > 1e-3


def test_ignoring_the_shared_points_is_wrong():
    """The exact covariance matters: treating the increments as independent gives the
    right mean (K) but a variance of 3K - 1 instead of 2K, hence too many false alarms."""
    rng = np.random.default_rng(2)
    m, se, reps = 11, np.ones(11), 4000
    k = m - 1
    naive = np.array([np.sum(np.diff(rng.standard_normal(m)) ** 2 / 2.0) for _ in range(reps)])
    exact = np.array([fs.level_test(rng.standard_normal(m), se, detrend=False)["chi2"]
                      for _ in range(reps)])  # fmt: skip
    assert naive.var() == pytest.approx(3 * k - 1, rel=0.1)
    assert exact.var() == pytest.approx(2 * k, rel=0.1)
    assert np.mean(stats.chi2.sf(naive, k) < 0.05) > 0.065  # about 0.08
    assert abs(np.mean(stats.chi2.sf(exact, k) < 0.05) - 0.05) < 4 * np.sqrt(0.0475 / reps)


def test_noise_correction_unbiased_and_error_right():
    rng = np.random.default_rng(3)
    x = fs.nested_grid(0.37, 0.001, 21)
    truth = fs.takagi(x, 0.5)
    se = rng.uniform(0.5, 1.5, x.size) * 5e-3
    delta = np.diff(truth)
    pd = delta - delta.mean()
    true_s2 = pd @ pd / delta.size
    reps = np.array([[fs.level_test(_noisy(rng, truth, se), se)[k] for k in ("S2", "S2_err")]
                     for _ in range(4000)])  # fmt: skip
    s2, err = reps[:, 0], reps[:, 1]
    assert abs(s2.mean() - true_s2) < 4 * s2.std() / np.sqrt(s2.size)
    assert np.median(err) == pytest.approx(s2.std(), rel=0.1)
    # pure noise: mean 0 (no bias from subtracting the noise)
    zero = [fs.level_test(_noisy(rng, 1 + 0 * x, se), se)["S2"] for _ in range(4000)]
    assert abs(np.mean(zero)) < 4 * np.std(zero) / np.sqrt(len(zero))


def _takagi_levels(rng, H, se):
    centre = rng.uniform(0.2, 0.8)
    tests = []
    for h in STEPS:
        x = fs.nested_grid(centre, h, 21)
        tests.append(fs.level_test(_noisy(rng, fs.takagi(x, H), se), np.full(x.size, se)))
    return tests


def _fit(tests):
    columns = ([t[k] for t in tests] for k in ("S2", "S2_err", "S2_spread"))
    return fs.scaling_exponent(STEPS, *columns)


@pytest.mark.parametrize("H", [0.3, 0.5, 0.7])
def test_fractal_found_and_exponent_recovered(H):
    rng = np.random.default_rng(int(10 * H))
    fits = []
    for _ in range(100):
        tests = _takagi_levels(rng, H, 3e-4)
        assert all(t["p"] < fs.P_STRUCTURE for t in tests)
        fits.append(_fit(tests))
    h = np.array([f["H"] for f in fits])
    err = np.array([f["H_err"] for f in fits])
    assert np.mean(np.abs(h - H) < 2 * err) > 0.85
    assert abs(h.mean() - H) < 0.03


def test_pure_noise_gives_no_exponent():
    rng = np.random.default_rng(5)
    measurable = 0
    for _ in range(200):
        tests = [fs.level_test(rng.standard_normal(11), np.ones(11)) for _ in STEPS]
        fit = _fit(tests)
        measurable += np.isfinite(fit["H"])
    assert measurable < 200 * 0.05


def test_verdict_words_follow_the_p_value():
    structure = {"p": 1e-4, "S2": 4.0, "S2_err": 0.5}
    assert fs.verdict(structure, "mm^2/s").startswith("structure (p = 0.0001); rms increment 2 ")
    noise = {"p": 0.4, "S2": -1.0, "S2_err": 2.0}
    assert fs.verdict(noise).startswith("not resolved at this precision")
    assert "< 1.73" in fs.verdict(noise)


def test_grid_budget_and_takagi_facts():
    g = fs.nested_grid(85.2, 0.002, 11)
    assert g[5] == 85.2 and np.allclose(np.diff(g), 0.002)
    assert fs.n_for_error(1000, 2.0, 1.0) == 4000
    assert fs.takagi(np.array([0.0, 0.5]), 0.5).tolist() == [0.0, 0.5]


@pytest.mark.parametrize(
    "call, words",
    [
        (lambda: fs.level_test([1, 2, 3, 4], [1, 0, 1, 1]), "se finite and > 0"),
        (lambda: fs.level_test([1, 2, 3], [1, 1, 1]), "length >= 4"),
        (lambda: fs.nested_grid(1.0, 0.1, 2), "points must be an integer >= 3"),
        (lambda: fs.nested_grid(1.0, -0.1, 5), "step must be"),
        (lambda: fs.takagi(0.1, 1.5), "H must lie in (0, 1)"),
    ],
)
def test_bad_input_named(call, words):
    with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
        call()


# ---- scene B6 ------------------------------------------------------------------------------
TINY = {"centres": (85.2,), "steps": (0.05, 0.01), "points": 5, "n": 16, "t": 2.0, "workers": 1}


def test_scene_b6_tiny_run_shares_and_resumes(tmp_path):
    from bbdyn.scenes import b6_fine_structure as b6

    res = b6.compute(TINY, seed=1, out_dir=tmp_path)
    centre = res["f"] == 85.2
    assert centre.sum() == 2 and np.ptp(res["D"][centre]) == 0  # one scan point, two levels
    assert res["p"].shape == (1, 2)
    for lv in range(2):
        sel = res["level"] == lv
        assert res["chi2"][0, lv] == pytest.approx(
            fs.level_test(res["D"][sel], res["D_err"][sel])["chi2"]
        )
    again = b6.compute(TINY, seed=1, out_dir=tmp_path)  # loaded from the stored scan
    np.testing.assert_array_equal(again["D"], res["D"])
    assert len(list(tmp_path.glob("scans/finestructure_*"))) == 1
    assert "| 85.2 | 0.05 |" in b6.table(res)
    from bbdyn.results import load_result

    loaded = load_result(res.save(tmp_path / "b6"))  # draw works from saved numbers
    assert len(b6.draw(loaded).axes) == 2 + 1  # one panel per level and the scaling plot


def test_scene_b6_passes_the_scheduler(monkeypatch, tmp_path):
    from bbdyn.scenes import b6_fine_structure as b6

    seen = {}

    def fake_run_scan(values, compute, **kwargs):
        seen.update(kwargs)
        raise RuntimeError("stop")

    monkeypatch.setattr(b6, "run_scan", fake_run_scan)
    with pytest.raises(RuntimeError, match="stop"):
        b6.compute({**TINY, "scheduler": "tcp://cluster:8786"}, 0, out_dir=tmp_path)
    assert seen["scheduler"] == "tcp://cluster:8786"
    # the scheduler is not in the digest
    assert seen["out_dir"] == scene_folder("finestructure", TINY, 0, tmp_path)
    monkeypatch.setenv(b6.SCHEDULER_VARIABLE, "tcp://other:8786")
    with pytest.raises(RuntimeError, match="stop"):
        b6.compute(TINY, 0, out_dir=tmp_path)
    assert seen["scheduler"] == "tcp://other:8786"


# ---- docs/fine_structure.md states what the code and the committed figure give ------------
DOCS = Path(__file__).resolve().parents[1] / "docs"


def test_doc_budget_numbers_are_computed():
    text = (DOCS / "fine_structure.md").read_text(encoding="utf-8")
    stated = re.findall(r"([\d.]+) se for m = (\d+)", text)
    assert stated
    for value, m in stated:
        assert f"{fs.detectable_rms(int(m)):.2f}" == value


def test_doc_table_is_the_figure_table():
    import json

    text = (DOCS / "fine_structure.md").read_text(encoding="utf-8")
    meta = json.loads((DOCS / "figures" / "B6_full.json").read_text())["meta"]
    assert meta["table"] in text
    stated = dict(re.findall(r"^\* (.+?): (.+)$", text.split("## Measured")[1], flags=re.M))
    assert stated == {k: str(v) for k, v in meta["key_numbers"].items()}


def test_doc_settings_are_the_scene_settings():
    from bbdyn.scenes import b6_fine_structure as b6

    text = " ".join((DOCS / "fine_structure.md").read_text(encoding="utf-8").split())
    for name, s in (("QUICK", b6.QUICK), ("MEDIUM", b6.MEDIUM), ("FULL", b6.FULL)):
        line = text.split(f"* {name}")[1].split("* ")[0]
        assert f"{s['points']} points per level" in line and f"n = {s['n']}" in line, name
        centres = [f"{c:g}" for c in s["centres"]]
        assert all(c in line for c in centres), name
    assert f"({np.unique(b6.grid_points(b6.MEDIUM)[0]).size} scan points:" in text


def test_doc_prose_matches_the_measured_conclusion():
    """The prose under the table says: structure on every level, H well below 1."""
    import json

    from bbdyn.scenes import b6_fine_structure as b6
    from bbdyn.scenes.reproduce import DOCS_OVERRIDES

    text = " ".join((DOCS / "fine_structure.md").read_text(encoding="utf-8").split())
    meta = json.loads((DOCS / "figures" / "B6_full.json").read_text())["meta"]
    s, key = meta["settings"], meta["key_numbers"]
    assert f"({(s['points'] - 1) * s['steps'][0]:g} Hz down to " in text
    assert f" {(s['points'] - 1) * s['steps'][-1]:g} Hz wide)" in text
    assert s == json.loads(json.dumps(b6.FULL | DOCS_OVERRIDES["B6"]))
    assert "not linear on any of the four" in text
    assert "not resolved" not in key["85.2 Hz conclusion"]
    assert "well below the H = 1" in text
    h, err = map(
        float, re.match(r"([\d.]+) \+- ([\d.]+)", key["85.2 Hz exponent H (S2 ~ step^2H)"]).groups()
    )
    assert h + 2 * err < 1


def test_noise_term_is_exact_on_a_short_window():
    """Pure noise on m = 9 points, the end points noisier: S2 has expectation 0 (Monte Carlo
    over 20000 windows).  The noise of the increments about their mean is tr(P C) / K, which
    differs from tr(C) / K by (se_0^2 + se_8^2) / K^2 = 0.125 here: far outside the error."""
    rng = np.random.default_rng(11)
    se = np.array([2.0, 1, 1, 1, 1, 1, 1, 1, 2.0])
    s2 = np.array([fs.level_test(_noisy(rng, np.zeros(se.size), se), se)["S2"]
                   for _ in range(20000)])  # fmt: skip
    assert abs(s2.mean()) < 4 * s2.std() / np.sqrt(s2.size)
