"""Scene B1 (regime map): fractions add up, Gamma < 1 is trapped, redraw from saved numbers."""

import numpy as np

from bbdyn.scenes import redraw_scene, run_scene, scene_module

TINY = {"f_min": 49.0, "f_max": 85.2, "n_f": 2, "n": 12, "t": 4.0, "workers": 1, "scan_dir": None}


def test_regime_map_on_a_tiny_scan(tmp_path, monkeypatch):
    module = scene_module("B1")
    monkeypatch.setattr(module, "QUICK", TINY)
    result, png = run_scene("B1", setting="quick", out_dir=tmp_path, seed=1)
    f = result["f"]
    np.testing.assert_allclose(f, [49.0, 85.2])
    # basin fractions of the attractors plus the unsettled fraction cover the ensemble
    total = result["fractions"].sum(axis=1) + result["unsettled_fraction"]
    np.testing.assert_allclose(total, 1.0, atol=1e-12)
    # 49 Hz is below Gamma = 1 (49.82 Hz): trapped, regime (a)
    assert module.LABELS[int(result["regime"][0])] == "a"
    # the scan is kept under the output folder (resumable), and the figure redraws from data
    assert list((tmp_path / "scans").glob("regime_*/manifest.json"))
    monkeypatch.setattr(module, "compute", None)  # redrawing must not recompute
    assert redraw_scene(tmp_path / "B1.json") == png


def test_regime_bands_merge_equal_neighbours_and_cover_the_range():
    from bbdyn.results import Result
    from bbdyn.scenes.b1_regime_map import LABELS, regime_bands

    f = np.array([50.0, 51.0, 52.0, 53.0, 54.0])
    codes = np.array([0, 0, 3, 3, 4], dtype=float)  # a, a, c, c, d
    result = Result({"f": f[::-1], "regime": codes[::-1]}, {})  # order must not matter
    bands = regime_bands(result)
    assert [b[2] for b in bands] == [LABELS[0], LABELS[3], LABELS[4]]
    assert bands[0][0] == 50.0 and bands[-1][1] == 54.0
    assert all(a[1] == b[0] for a, b in zip(bands, bands[1:], strict=False))
    assert bands[0][1] == 51.5 and bands[1][1] == 53.5
