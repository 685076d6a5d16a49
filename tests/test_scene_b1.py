"""Scene B1 (regime map): fractions add up, Gamma < 1 is trapped, redraw from saved numbers."""

import numpy as np

from bbdyn.scenes import redraw_scene, run_scene, scene_module

TINY = {"f_min": 49.0, "f_max": 85.2, "n_f": 2, "n": 12, "t": 4.0, "workers": 1, "scan_dir": None}


def test_regime_map_on_a_tiny_scan(tmp_path, monkeypatch):
    module = scene_module("B1")
    monkeypatch.setattr(module, "QUICK", TINY)
    result, png = run_scene("B1", quick=True, out_dir=tmp_path, seed=1)
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
