"""Scenes S9 (random walk) and S10 (Green-Kubo): compute, save, redraw from the data."""

import numpy as np
import pytest

from bbdyn.results import load_result
from bbdyn.scenes import SCENES, redraw_scene, scene_module
from bbdyn.scenes import s9_random_walk as s9
from bbdyn.scenes import s10_green_kubo as s10

#: Gamma = 2 (A w^2 = 2 g) at the defaults, Hz: sqrt(2 g / A) / 2 pi.
F_GAMMA2 = float(np.sqrt(2 * 9800.0 / 0.1) / (2 * np.pi))
TINY = {"n": 10, "t": 5.0}


def test_registered():
    assert scene_module("S9") is s9 and scene_module("s10") is s10
    assert {"S9", "S10"} <= set(SCENES)


def test_s9_d_a_only_where_gamma_at_least_2(tmp_path):
    """Frequencies straddling Gamma = 2: D_a is NaN exactly below it, and says so."""
    settings = {"f_start": 70.0, "f_stop": 71.0, "f_step": 0.5, **TINY}
    res = s9.compute(settings, seed=1, out_dir=tmp_path)
    np.testing.assert_allclose(res["f"], [70.0, 70.5, 71.0])
    np.testing.assert_array_equal(np.isnan(res["D_a"]), res["f"] < F_GAMMA2)
    assert res.meta["f_gamma2"] == pytest.approx(F_GAMMA2, rel=1e-12)
    assert "1 of 3 frequencies" in res.meta["key_numbers"]["D_a undefined (Gamma < 2)"]
    # the scan is on disk and resumes without recomputing (same numbers)
    again = s9.compute(settings, seed=1, out_dir=tmp_path)
    assert len(list(tmp_path.glob("scans/gk_*/points/*.json"))) == 3
    np.testing.assert_array_equal(again["D"], res["D"])


@pytest.mark.parametrize(
    "module, settings",
    [
        (s9, {"f_start": 85.0, "f_stop": 85.4, "f_step": 0.2, **TINY}),
        (
            s10,
            {
                "f_start": 85.0,
                "f_stop": 85.2,
                "f_step": 0.1,
                "nmax": 4,
                "orders": [0, 2, 4],
                **TINY,
            },
        ),  # fmt: skip
    ],
    ids=["S9", "S10"],
)
def test_save_and_redraw_from_data(module, settings, tmp_path):
    scene_id = module.__name__.rsplit(".", 1)[1].split("_")[0].upper()
    res = module.compute(settings, seed=2, out_dir=tmp_path)
    res.meta["scene"] = scene_id
    json_path = res.save(tmp_path / scene_id)
    loaded = load_result(json_path)
    assert type(loaded) is type(res) and loaded.meta["key_numbers"] == res.meta["key_numbers"]
    for name, array in res.arrays.items():
        np.testing.assert_array_equal(loaded[name], array)
    png = redraw_scene(json_path)
    assert png.exists() and png.stat().st_size > 10_000


def test_s10_refuses_orders_above_nmax(tmp_path):
    settings = {"f_start": 85.0, "f_stop": 85.0, "f_step": 0.1, "nmax": 3, "orders": [0, 7], **TINY}
    with pytest.raises(ValueError, match="orders must lie in"):
        s10.compute(settings, out_dir=tmp_path)
