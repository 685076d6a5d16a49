"""Scenes S2, S6, S7, S8 at quick settings: compute, save, redraw from the saved numbers."""

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.core.status import IMPACT
from bbdyn.core.tolerances import EPS
from bbdyn.poincare import number_regions
from bbdyn.results import load_result
from bbdyn.scenes import redraw_scene, run_scene

SCENE_IDS = ["S2", "S6", "S7", "S8"]


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    out = tmp_path_factory.mktemp("scenes")
    return out, {sid: run_scene(sid, setting="quick", out_dir=out, seed=0) for sid in SCENE_IDS}


@pytest.mark.parametrize("sid", SCENE_IDS)
def test_scene_saves_and_redraws_without_recomputing(scenes, sid, monkeypatch):
    out, results = scenes
    result, png = results[sid]
    assert png.stat().st_size > 10_000
    assert "key_numbers" in result.meta
    module = __import__(f"bbdyn.scenes.{_module(sid)}", fromlist=["compute"])

    def refuse(*args, **kwargs):
        raise AssertionError("redraw must not recompute")

    monkeypatch.setattr(module, "compute", refuse)
    png.unlink()
    assert redraw_scene(out / f"{sid}.json") == png and png.exists()
    loaded = load_result(out / f"{sid}.json")
    for name, arr in result.arrays.items():
        np.testing.assert_array_equal(loaded[name], arr)


def _module(sid):
    from bbdyn.scenes import SCENES

    return SCENES[sid]


def test_s2_marked_point_is_on_the_arc(scenes):
    result, _ = scenes[1]["S2"]
    p = Params(**result.meta["params"])
    x, y, s = result["point"]
    # the marked arc length, measured from the left wedge of tile 1 along the circle
    xi = x - 1.5 * p.d
    assert s == pytest.approx(p.R * (np.arcsin(xi / p.R) + np.arcsin(p.d / (2 * p.R))), rel=1e-14)
    # the difference of two square roots near R cancels: a few ulp of R
    y_arc = np.sqrt(p.R**2 - xi**2) - np.sqrt(p.R**2 - p.d**2 / 4)
    assert y == pytest.approx(y_arc, abs=8 * EPS * p.R)
    assert result["b"].max() == pytest.approx(p.h, rel=1e-6)


def test_s8_regions_are_numbered_from_the_saved_sequence(scenes):
    result, _ = scenes[1]["S8"]
    imp = result.impacts()
    labels = number_regions(result["y"][imp], result["vy"][imp], result.meta["settings"]["bins"])
    np.testing.assert_array_equal(result["region"][imp], labels)


def test_s8_path_joins_its_collisions(scenes):
    result, _ = scenes[1]["S8"]
    ev = result["piece_event"]
    first = np.flatnonzero(np.append(True, ev[1:] != ev[:-1]))
    np.testing.assert_array_equal(result["piece_x"][first], result["x"][ev[first]])
    np.testing.assert_array_equal(result["piece_y"][first], result["y"][ev[first]])


def test_s6_s7_key_numbers_count_the_drawn_collisions(scenes):
    for sid in ("S6", "S7"):
        result, _ = scenes[1][sid]
        k = result.meta["key_numbers"]
        assert k["collisions_drawn"] == result.impacts().sum()
        assert k["collisions_drawn"] <= np.count_nonzero(result["kind"] == IMPACT)
        assert 0.0 <= k["tiny_hop_fraction"] <= 1.0
