"""Provenance of scene outputs, the index and docs pages generated from it, reproduce --only."""

import json
import re
import subprocess
import time
from pathlib import Path

import pytest

from bbdyn import __version__
from bbdyn.commands.cli import main
from bbdyn.results import load_result
from bbdyn.scenes import (
    SCENES,
    SOURCE_ROOT,
    read_png_provenance,
    redraw_scene,
    run_scene,
    scene_module,
    scene_settings,
    source_state,
)
from bbdyn.scenes.reproduce import (
    DOCS_FIGURES,
    DOCS_OVERRIDES,
    PRE_PROVENANCE,
    TABLE_BEGIN,
    TABLE_END,
    docs_command,
    docs_table,
    figure_records,
    reproduce,
    reproduce_docs,
)

DOCS = Path(__file__).resolve().parents[1] / "docs"


def git(root, *args):
    return subprocess.run(["git", "-C", str(root), *args], check=True, capture_output=True,
                          text=True).stdout.strip()  # fmt: skip


@pytest.fixture
def repo(tmp_path):
    """A git checkout with bbdyn/a.py and notes.txt committed."""
    git(tmp_path, "init", "-q")
    git(tmp_path, "config", "user.email", "t@example.org")
    git(tmp_path, "config", "user.name", "t")
    (tmp_path / "bbdyn").mkdir()
    (tmp_path / "bbdyn" / "a.py").write_text("x = 1\n")
    (tmp_path / "notes.txt").write_text("n\n")
    git(tmp_path, "add", "bbdyn/a.py", "notes.txt")
    git(tmp_path, "commit", "-q", "-m", "one")
    return tmp_path


def test_source_state_names_the_commit_and_only_tracked_changes_under_bbdyn(repo):
    first = source_state(repo)
    assert first == {"commit": git(repo, "rev-parse", "HEAD"), "dirty": False, "dirty_files": []}
    assert re.fullmatch(r"[0-9a-f]{40}", first["commit"])
    (repo / "notes.txt").write_text("changed\n")  # outside bbdyn/: not the code
    (repo / "bbdyn" / "new.py").write_text("y = 2\n")  # untracked: not in the commit's code
    assert source_state(repo)["dirty"] is False
    (repo / "bbdyn" / "a.py").write_text("x = 2\n")
    state = source_state(repo)
    assert state["commit"] == first["commit"] and state["dirty"] is True
    assert state["dirty_files"] == [" M bbdyn/a.py"]
    git(repo, "commit", "-q", "-am", "two")
    second = source_state(repo)
    assert second["commit"] != first["commit"] and second["dirty"] is False


def test_source_state_outside_a_checkout_or_below_its_top(repo, tmp_path_factory):
    none = {"commit": None, "dirty": None, "dirty_files": []}
    assert source_state(tmp_path_factory.mktemp("plain")) == none
    assert source_state(repo / "bbdyn") == none  # bbdyn/ must sit at the top of the checkout


def test_saved_scene_records_provenance_in_json_and_png(tmp_path):
    state_before, before = source_state(SOURCE_ROOT), time.perf_counter()
    result, png = run_scene("S2", setting="quick", out_dir=tmp_path, seed=3, name="fig")
    elapsed = time.perf_counter() - before
    saved = json.loads((tmp_path / "fig.json").read_text())["meta"]["provenance"]
    assert read_png_provenance(png) == saved == result.meta["provenance"]
    assert saved["bbdyn_version"] == __version__
    assert saved["scene"] == "S2" and saved["setting"] == "quick" and saved["seed"] == 3
    assert saved["settings"] == scene_settings("S2", "quick")
    assert 0 < saved["run_s"] <= elapsed
    # the shared checkout may change during the run: the state at its start or end
    assert {k: saved[k] for k in state_before} in (state_before, source_state(SOURCE_ROOT))
    # a redraw from the data carries the data's provenance, not a new one, and who drew it
    png.unlink()
    redrawn = read_png_provenance(redraw_scene(tmp_path / "fig.json"))
    drawn_by = redrawn.pop("drawn_by")
    assert redrawn == saved
    assert drawn_by in (state_before, source_state(SOURCE_ROOT))


def test_redraw_records_the_code_that_drew_it(repo, tmp_path, monkeypatch):
    """A redraw names the commit and dirty state of the source tree at drawing time."""
    import bbdyn.scenes as scenes

    run_scene("S2", setting="quick", out_dir=tmp_path, seed=3, name="fig")
    monkeypatch.setattr(scenes.source_state, "__defaults__", (repo,))
    clean = read_png_provenance(redraw_scene(tmp_path / "fig.json"))["drawn_by"]
    assert clean == {"commit": git(repo, "rev-parse", "HEAD"), "dirty": False, "dirty_files": []}
    (repo / "bbdyn" / "a.py").write_text("x = 2\n")
    dirty = read_png_provenance(redraw_scene(tmp_path / "fig.json"))["drawn_by"]
    assert dirty["commit"] == clean["commit"] and dirty["dirty"] is True
    assert dirty["dirty_files"] == [" M bbdyn/a.py"]


def test_png_without_provenance_is_refused(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, _ = plt.subplots()
    fig.savefig(tmp_path / "plain.png")
    plt.close(fig)
    with pytest.raises(ValueError, match="records no bbdyn provenance"):
        read_png_provenance(tmp_path / "plain.png")


def test_scene_without_the_setting_names_those_it_has():
    with pytest.raises(ValueError, match=r"S6 has no setting 'medium'; it has: quick, full"):
        scene_settings("S6", "medium")


@pytest.fixture
def no_runs(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("no scene may run")

    monkeypatch.setattr("bbdyn.scenes.reproduce.run_scene", refuse)


def test_reproduce_only_without_ids_is_refused(no_runs, tmp_path, capsys):
    with pytest.raises(ValueError, match="--only needs at least one scene id"):
        reproduce(tmp_path, only=[])
    with pytest.raises(SystemExit) as exc:
        main(["reproduce", "--only", "--out", str(tmp_path)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "at least one scene id" in err and ", ".join(SCENES) in err


def test_reproduce_medium_runs_exactly_the_scenes_that_have_a_medium_setting(monkeypatch, tmp_path):
    ran = []

    def record(scene_id, **kwargs):
        ran.append((scene_id, kwargs["setting"]))
        return None, None

    monkeypatch.setattr("bbdyn.scenes.reproduce.run_scene", record)
    reproduce(tmp_path, setting="medium")
    have = [s for s in SCENES if hasattr(scene_module(s), "MEDIUM")]
    assert "B1" in have and "S6" not in have
    assert ran == [(s, "medium") for s in have]


def test_unknown_ids_are_refused_with_the_known_ones(no_runs, tmp_path, capsys):
    with pytest.raises(ValueError, match="unknown scene id"):
        reproduce(tmp_path, only=["S2", "S99"])
    for argv in (["scene", "S99", "--out", str(tmp_path)], ["reproduce", "--docs", "--only", "X"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        err = capsys.readouterr().err
        known = SCENES if argv[0] == "scene" else DOCS_FIGURES
        assert all(sid in err for sid in known), err


def test_reproduce_only_keeps_the_index_entries_of_other_scenes(tmp_path):
    reproduce(tmp_path, only=["S2"])
    index = reproduce(tmp_path, only=["S1"]).read_text()
    assert "## S1:" in index and "## S2:" in index
    assert [r["name"] for r in figure_records(tmp_path)] == ["S1", "S2"]  # SCENES order


def write_pre_provenance(folder, name, commit):
    record = {"scene": "S3", "setting": "full", "settings": "227 f x 1000 x 200 s", "seed": 0,
              "commit": commit, "dirty": None, "run": "44 min", "key_numbers": {}}  # fmt: skip
    sidecar = {"kind": PRE_PROVENANCE, "provenance": "pre-provenance, note", "record": record}
    (folder / f"{name}.json").write_text(json.dumps(sidecar))


def test_reproduce_docs_writes_figures_and_the_table_from_their_json(tmp_path):
    figures = tmp_path / "docs" / "figures"
    figures.mkdir(parents=True)
    write_pre_provenance(figures, "S3_full", "0123456789abcdef0123456789abcdef01234567")
    page = tmp_path / "docs" / "results.md"
    page.write_text(f"# head\n\n{TABLE_BEGIN}\nold table\n{TABLE_END}\n\ntail text\n")
    assert reproduce_docs(only=["s2"], root=tmp_path) == page
    setting, name = DOCS_FIGURES["S2"]
    saved = read_png_provenance(figures / f"{name}.png")
    assert saved["setting"] == setting
    text = page.read_text()
    assert text == f"# head\n\n{TABLE_BEGIN}\n{docs_table(figures)}\n{TABLE_END}\n\ntail text\n"
    s2_row, s3_row = docs_table(figures).splitlines()[2:]
    assert f"`{docs_command('S2')}`" in s2_row and "an earlier commit" not in s2_row
    commit = saved["commit"][:7] if saved["commit"] else "not a git checkout"
    assert f"| {commit}" in s2_row and f"{saved['run_s']:.1f} s" in s2_row
    assert f"an earlier commit, 0123456 (pre-provenance, note); to be regenerated by " \
           f"`{docs_command('S3')}`" in s3_row  # fmt: skip


def test_reproduce_docs_needs_the_table_markers(tmp_path):
    (tmp_path / "docs" / "figures").mkdir(parents=True)
    (tmp_path / "docs" / "results.md").write_text("no markers\n")
    with pytest.raises(ValueError, match="lacks the lines"):
        reproduce_docs(only=["S2"], root=tmp_path)


def test_docs_figures_record_where_they_came_from():
    """Every figure of docs/figures has its JSON; a regenerated one carries the same
    provenance in its PNG, from a clean tree at a commit of this history; a pre-provenance
    one names the commit that added it; the table in results.md is the generated one."""
    figures = DOCS / "figures"
    if git(SOURCE_ROOT, "rev-parse", "--show-toplevel") != str(SOURCE_ROOT):
        pytest.skip("not a git checkout")
    records = {r["name"]: r for r in figure_records(figures)}
    assert sorted(records) == sorted(p.stem for p in figures.glob("*.png"))
    assert sorted(records) == sorted(name for _, name in DOCS_FIGURES.values())
    for name, r in records.items():
        assert DOCS_FIGURES[r["scene"]] == (r["setting"], name)
        settings = scene_settings(r["scene"], r["setting"]) | DOCS_OVERRIDES.get(r["scene"], {})
        assert r["settings"] == json.loads(json.dumps(settings)), name
    for name, r in records.items():
        if r["pre"] is None:
            saved = json.loads((figures / f"{name}.json").read_text())["meta"]["provenance"]
            load_result(figures / f"{name}.json")  # its numbers are there (checksum), to redraw
            in_png = read_png_provenance(figures / f"{name}.png")
            # a figure redrawn from its data names the code that drew it: clean, in history
            drawn_by = in_png.pop("drawn_by", {"commit": r["commit"], "dirty": False})
            assert in_png == saved
            for state in (r, drawn_by):
                assert state["dirty"] is False, name
                git(SOURCE_ROOT, "merge-base", "--is-ancestor", state["commit"], "HEAD")
        else:
            added = git(SOURCE_ROOT, "log", "--diff-filter=A", "--format=%H", "--",
                        f"docs/figures/{name}.png")  # fmt: skip
            assert added.splitlines()[-1] == r["commit"], name
    text = (DOCS / "results.md").read_text()
    assert f"{TABLE_BEGIN}\n{docs_table(figures)}\n{TABLE_END}" in text


@pytest.mark.slow
@pytest.mark.parametrize("f", [70.0, 70.2])
def test_energy_claims_in_results_md(f):
    """The two points of docs/results.md's energy section (from the committed full scan),
    recomputed from the scan's own seeds with this code, agree with the committed ones within
    three combined standard errors, and are in the states the page gives them: at 70.0 Hz the
    particles jump, D is above three standard errors and E over twice A^2 w^2/2; at 70.2 Hz no
    particle jumps, so D is bounded by d^2/t (each particle stays within its trap, of width d)
    and E is below A^2 w^2/2."""
    import math

    import numpy as np

    from bbdyn.scans.frequency import average_rounding, diffusion_point, energy_scale
    from bbdyn.scans.runner import point_seed

    name = DOCS / "figures" / "S3_full"
    meta = json.loads(name.with_suffix(".json").read_text())["meta"]
    committed = np.load(name.with_suffix(".npz"))
    (i,) = np.flatnonzero(np.isclose(committed["f"], f))
    kwargs = meta["scan_compute"]["kwargs"]
    point = diffusion_point(f, point_seed(meta["scan_seed"], f), n=kwargs["n"], t=kwargs["t"])
    # energies where every particle is trapped scatter by less than their rounding: add it
    params = meta["params"]
    events = 0.5 * (point["events"] + committed["events"][i]) / kwargs["n"]
    E_scale = energy_scale(point["E"], params["g"], params["A"])
    scales = {"D": 0.0, "E": E_scale, "E_x": point["E_x"]}
    for key, scale in scales.items():
        bound = 3 * math.hypot(point[f"{key}_se"], committed[f"{key}_err"][i])
        bound += 2 * average_rounding(events, scale)
        assert abs(point[key] - committed[key][i]) <= bound, key
    ratio = point["E"] / point["E_reference"]
    if f == 70.0:
        assert point["jump_rate"] > 0 and point["D"] > 3 * point["D_se"] and ratio > 2
    else:
        d = meta["params"]["d"]
        assert point["jump_rate"] == 0 and abs(point["D"]) < d**2 / kwargs["t"] and ratio < 1


@pytest.mark.parametrize("scene_id", DOCS_FIGURES)
def test_every_docs_figure_has_its_setting(scene_id):
    assert scene_settings(scene_id, DOCS_FIGURES[scene_id][0])


def test_reproduce_docs_refuses_an_output_folder(no_runs, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["reproduce", "--docs", "--out", "elsewhere"])
    assert exc.value.code == 2 and "cannot be used with --docs" in capsys.readouterr().err


@pytest.mark.parametrize("scene_id", list(SCENES))
def test_settings_are_shown_in_words_not_python_reprs(scene_id):
    from bbdyn.scenes import SETTINGS
    from bbdyn.scenes.reproduce import settings_text

    for name, attr in SETTINGS.items():
        settings = getattr(scene_module(scene_id), attr, None)
        if settings is None:
            continue
        text = settings_text(settings)
        assert not set("{}[]'\"_") & set(text), (scene_id, name, text)
        if {"f_start", "f_stop", "f_step"} <= settings.keys():
            lo, hi, step = settings["f_start"], settings["f_stop"], settings["f_step"]
            assert f"f = {lo:g} to {hi:g} Hz in steps of {step:g} Hz" in text
        if "t" in settings and isinstance(settings["t"], float):
            assert f"t = {settings['t']:g} s" in text


def test_cost_estimate_names_the_documented_run():
    """The cost line of S3 at its full setting names the documented run of those settings
    (the forecast itself: tests/test_cost_forecast.py)."""
    from bbdyn.scenes.reproduce import cost_lines

    meta = json.loads((DOCS / "figures" / "S3_full.json").read_text())["meta"]
    if meta["provenance"]["settings"] != scene_settings("S3", "full"):
        pytest.skip("docs/figures/S3_full was made at other settings")
    (line,) = [s for s in cost_lines(["S3"], "full") if s.startswith("S3:")]
    assert "docs/figures/S3_full" in line and meta["provenance"]["commit"][:7] in line
