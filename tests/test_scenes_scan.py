"""Scenes S3, S4, S5 on one shared scan, and the ``bbdyn scan`` command (tiny settings)."""

import json
import os
import shutil

import matplotlib.pyplot as plt
import numpy as np
import pytest

from bbdyn.commands.cli import main
from bbdyn.results import load_result
from bbdyn.scans.cache import scene_folder
from bbdyn.scenes import redraw_scene, scene_module
from bbdyn.scenes.frequency_scene import FrequencyScanScene

TINY = {"f_start": 49.0, "f_stop": 89.0, "f_step": 20.0, "n": 6, "t": 1.0, "workers": 2}


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    out = tmp_path_factory.mktemp("scenes")
    scenes = {
        sid: scene_module(sid).compute(dict(TINY), 3, out_dir=out) for sid in ("S3", "S4", "S5")
    }
    return out, scenes


def test_the_three_scenes_share_one_scan(shared):
    out, scenes = shared
    folders = list((out / "scans").iterdir())
    assert folders == [scene_folder("diffusion", TINY, 3, out)]
    # computed once: every scene reads the same points (same per-point timings)
    cpu = {sid: s.meta["scan_cpu_s"] for sid, s in scenes.items()}
    assert len(set(cpu.values())) == 1
    for s in scenes.values():
        np.testing.assert_array_equal(s["f"], [49.0, 69.0, 89.0])
        np.testing.assert_array_equal(s["D"], scenes["S3"]["D"])
        assert s.meta["key_numbers"]


def test_other_seed_or_setting_gets_its_own_scan(tmp_path):
    folder = scene_folder("diffusion", TINY, 3, tmp_path)
    assert folder != scene_folder("diffusion", TINY, 4, tmp_path)
    assert folder != scene_folder("diffusion", TINY | {"n": 7}, 3, tmp_path)


def test_edited_source_gets_its_own_scan(tmp_path):
    """Scans computed by other code are not reused: the folder follows bbdyn's source (a copy
    of the package, in fresh processes, before and after an edit of a module)."""
    import subprocess
    import sys

    import bbdyn.sources

    src = tmp_path / "src"
    shutil.copytree(
        bbdyn.sources.PACKAGE, src / "bbdyn", ignore=shutil.ignore_patterns("__pycache__")
    )
    code = (
        "import sys; from bbdyn.scans.cache import scene_folder; import bbdyn; "
        "assert bbdyn.__file__.startswith(sys.argv[1]); "
        f"print(scene_folder('diffusion', {TINY!r}, 3, sys.argv[1]))"
    )
    env = dict(os.environ, PYTHONPATH=str(src))

    def folder():
        run = [sys.executable, "-c", code, str(src)]
        out = subprocess.run(run, env=env, cwd=tmp_path, capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        return out.stdout.strip()

    first = folder()
    assert folder() == first  # the same source, the same scan
    estimator = src / "bbdyn" / "diffusion.py"  # not a kernel: the numbers change all the same
    estimator.write_text(estimator.read_text() + "\n")
    assert folder() != first


def test_scenes_draw_tongues_and_error_bars(shared):
    _, scenes = shared
    s3 = scenes["S3"]
    assert s3["tongues"][:, 0].tolist() == [1.0, 2.0, 3.0]
    assert s3["trapped"][0] == 1 and s3["D"][0] == 0.0  # 49 Hz: Gamma < 1
    for sid, scene in scenes.items():
        fig = scene_module(sid).draw(scene)
        ax = fig.axes[0]
        assert len(ax.patches) >= 3  # the three tongue intervals
        assert ax.containers  # error bars
        plt.close(fig)


def test_scene_saved_and_redrawn_without_recomputing(shared, tmp_path):
    _, scenes = shared
    scene = scenes["S4"]
    scene.meta["scene"] = "S4"
    path = scene.save(tmp_path / "S4")
    loaded = load_result(path)
    assert isinstance(loaded, FrequencyScanScene)
    np.testing.assert_array_equal(loaded["E"], scene["E"])
    assert redraw_scene(path).exists()


def test_scene_reads_a_given_scan_folder(shared):
    out, scenes = shared
    folder = scene_folder("diffusion", TINY, 3, out)
    again = scene_module("S5").compute({"scan_dir": str(folder)}, 0)
    np.testing.assert_array_equal(again["E_x"], scenes["S5"]["E_x"])


def test_bbdyn_scan_json(tmp_path, capsys):
    argv = ["scan", "--f-start", "85", "--f-stop", "86", "--f-step", "1", "--n", "4", "--t", "1"]
    assert main(argv + ["--out", str(tmp_path / "s"), "--json", "--workers", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [p["f"] for p in out["points"]] == [85.0, 86.0]
    assert all("D_se" in p for p in out["points"])
    # a second call refuses the existing folder unless --resume, which recomputes nothing
    with pytest.raises(SystemExit):
        main(argv + ["--out", str(tmp_path / "s")])
    assert main(argv + ["--out", str(tmp_path / "s"), "--resume"]) == 0
    assert "+-" in capsys.readouterr().out
