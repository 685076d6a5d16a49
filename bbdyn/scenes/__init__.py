"""Scenes: one module per figure or analysis, of the reference paper (S1-S10) and beyond
(B1-B9, the benchmarks B2 included); ``SCENES`` is the one registry that ``bbdyn scene``,
``bbdyn bench`` and ``bbdyn reproduce`` read.

Each scene module defines

* ``TITLE``: one line;
* ``QUICK`` and ``FULL`` (and optionally ``MEDIUM``): dicts of settings (quick: seconds
  to a minute on 2 cores); ``SETTINGS`` names them;
* ``compute(settings[, seed][, out_dir][, progress]) -> Result``: computes only what the
  figure needs; it names ``seed`` if it draws random numbers, ``out_dir`` if it keeps
  intermediate data (the scans of ``bbdyn.scans.cache``) there and ``progress`` if it
  can show the progress of a long scan (as ``bbdyn.scans.runner.run_scan``);
* ``draw(result) -> Figure`` (single-panel scenes also take ``ax``): draws a saved or
  fresh result;
* optionally ``table(result) -> str``: the numbers as a text table (benchmarks).

``run_scene`` computes, saves the numbers (``<name>.npz`` / ``<name>.json``) and the
figure (``<name>.png``) side by side, so a figure can be redrawn from its data with
``redraw_scene``.  Both record the provenance (``provenance``: bbdyn version, git commit
and dirty files of the source tree, scene, setting and its values, seed, run time) in
the JSON (``meta["provenance"]``) and in the PNG's text metadata (``read_png_provenance``);
a redrawn PNG adds the state of the code that drew it (``"drawn_by"``).
"""

from __future__ import annotations

import datetime as _dt
import importlib
import inspect
import json
import subprocess
import time
from pathlib import Path

from bbdyn import __version__
from bbdyn.results import load_result, result_paths

#: scene id -> module under bbdyn.scenes
SCENES = {
    "S1": "s1_tongues",
    "B1": "b1_regime_map",
    "S2": "s2_geometry",
    "S6": "s6_phase_space_58",
    "S7": "s7_phase_space_85",
    "S8": "s8_orbit_88",
    "S3": "s3_diffusion",
    "S4": "s4_energy",
    "S5": "s5_horizontal_energy",
    "S9": "s9_random_walk",
    "S10": "s10_green_kubo",
    "B2-FLAT": "b2_flat",
    "B2-BILLIARD": "b2_billiard",
    "B2-SCAN-COST": "b2_scan_cost",
    "B3": "b3_statcost",
    "B5": "b5_lyapunov",
    "B4": "b4_higher_tongues",
    "B6": "b6_fine_structure",
    "B7": "b7_tilt",
    "B8": "b8_noise",
    "B9": "b9_distributions",
}
#: setting name -> attribute of a scene module holding its values
SETTINGS = {"quick": "QUICK", "medium": "MEDIUM", "full": "FULL"}
#: key of the PNG text chunk holding the provenance as JSON
PNG_KEY = "bbdyn-provenance"
#: folder holding the ``bbdyn`` package: a git checkout's top level when installed editable
SOURCE_ROOT = Path(__file__).resolve().parents[2]


def figure_axes(ax=None, **subplots_kwargs):
    """``(figure, axes)`` to draw on: ``ax`` and its figure, or a new figure made with
    ``plt.subplots(**subplots_kwargs)`` when ``ax`` is None."""
    if ax is not None:
        return ax.figure, ax
    import matplotlib.pyplot as plt

    return plt.subplots(**subplots_kwargs)


def scene_module(scene_id: str):
    """The module of scene ``scene_id`` (case-insensitive), or ValueError listing the known ids."""
    key = scene_id.upper()
    if key not in SCENES:
        raise ValueError(f"unknown scene {scene_id!r}; known scene ids: {', '.join(SCENES)}")
    return importlib.import_module(f"bbdyn.scenes.{SCENES[key]}")


def setting_names(scene_id: str) -> list[str]:
    """The settings (``quick``, ``medium``, ``full``) that scene ``scene_id`` defines."""
    module = scene_module(scene_id)
    return [name for name, attr in SETTINGS.items() if hasattr(module, attr)]


def scene_settings(scene_id: str, setting: str) -> dict:
    """A copy of the values of ``setting`` (``quick``, ``medium`` or ``full``) of a scene;
    ValueError naming the settings the scene has."""
    have = setting_names(scene_id)
    if setting not in have:
        raise ValueError(
            f"scene {scene_id.upper()} has no setting {setting!r}; it has: {', '.join(have)}"
        )
    return dict(getattr(scene_module(scene_id), SETTINGS[setting]))


def scene_devices(scene_id: str) -> tuple[str, ...]:
    """Where scene ``scene_id`` can run: its module's ``DEVICES``, else the CPU only."""
    return tuple(getattr(scene_module(scene_id), "DEVICES", ("cpu",)))


def call_compute(module, settings: dict, seed: int, out_dir: str | Path, progress=False):
    """``module.compute(settings, ...)`` with ``seed``, ``out_dir`` and ``progress`` passed
    when it names them."""
    accepts = inspect.signature(module.compute).parameters
    given = {"seed": seed, "out_dir": Path(out_dir), "progress": progress}
    return module.compute(settings, **{k: v for k, v in given.items() if k in accepts})


def _git(root: Path, *args: str) -> str:
    out = subprocess.run(
        ["git", "-C", str(root), *args], capture_output=True, text=True, check=True, timeout=30
    )
    return out.stdout.rstrip("\n")


def source_state(root: str | Path = SOURCE_ROOT) -> dict:
    """Git state of the source tree at ``root`` (the folder holding ``bbdyn/``).

    Returns ``commit`` (the checked-out commit, or None when ``root`` is not the top
    of a git checkout or git is missing), ``dirty`` (tracked files under ``bbdyn/``
    differ from the commit; None without a commit) and ``dirty_files`` (their
    ``git status --porcelain`` lines).
    """
    root = Path(root).resolve()
    try:
        if Path(_git(root, "rev-parse", "--show-toplevel")).resolve() != root:
            raise ValueError("not the top of a checkout")
        commit = _git(root, "rev-parse", "HEAD")
        status = _git(root, "status", "--porcelain", "--untracked-files=no", "--", "bbdyn")
    except (OSError, ValueError, subprocess.SubprocessError):
        return {"commit": None, "dirty": None, "dirty_files": []}
    files = status.splitlines()
    return {"commit": commit, "dirty": bool(files), "dirty_files": files}


def provenance(
    scene_id: str, setting: str, settings: dict, seed: int, run_s: float, source: dict
) -> dict:
    """Where a scene output came from: bbdyn version, ``source`` (``source_state``),
    scene id, setting name and values, seed, run time ``run_s`` (s wall) and the UTC time."""
    return {
        "bbdyn_version": __version__,
        **source,
        "scene": scene_id.upper(),
        "setting": setting,
        "settings": settings,
        "seed": seed,
        "run_s": float(run_s),
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
    }


def save_figure(fig, png: str | Path, prov: dict) -> Path:
    """Save ``fig`` as ``png`` (150 dpi) with ``prov`` as JSON in its text metadata; close it."""
    import matplotlib.pyplot as plt

    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    meta = {"Software": f"bbdyn {__version__}", PNG_KEY: json.dumps(prov)}
    fig.savefig(png, dpi=150, bbox_inches="tight", metadata=meta)
    plt.close(fig)
    return png


def read_png_provenance(png: str | Path) -> dict:
    """The provenance saved in a PNG by ``save_figure``; ValueError if it has none."""
    from PIL import Image

    with Image.open(png) as image:
        text = image.text.get(PNG_KEY)
    if text is None:
        raise ValueError(f"{png} records no bbdyn provenance (no {PNG_KEY!r} text chunk)")
    return json.loads(text)


def run_scene(
    scene_id: str,
    *,
    setting: str = "quick",
    out_dir: str | Path = "out",
    seed: int = 0,
    name: str | None = None,
    scan_root: str | Path | None = None,
    overrides: dict | None = None,
    progress=False,
    device: str = "cpu",
):
    """Compute scene ``scene_id`` at ``setting``, save its numbers and figure in ``out_dir``.

    Files are ``<name>.npz/.json/.png`` (``name`` defaults to the scene id).  Scenes built
    on scans keep them under ``scan_root`` (default ``out_dir``), so an interrupted run
    resumes.  ``overrides`` replaces some values of the setting (they are recorded);
    ``progress`` (as in ``bbdyn.scans.runner.run_scan``) goes to scenes that can show it.
    ``device="cuda"``: the scan of a scene whose module lists it in ``DEVICES`` runs on the
    GPU (recorded as ``settings["device"]``); ValueError for the other scenes.
    Returns ``(result, png_path)``.
    """
    import matplotlib

    matplotlib.use("Agg")

    module = scene_module(scene_id)
    settings = scene_settings(scene_id, setting) | (overrides or {})
    if device != "cpu":
        if device not in scene_devices(scene_id):
            raise ValueError(
                f"scene {scene_id.upper()} runs on the CPU only (device={device!r}); the scans "
                f"of {', '.join(s for s in SCENES if 'cuda' in scene_devices(s))} run on a GPU: "
                "leave out --device"
            )
        settings["device"] = device
    out_dir = Path(out_dir)
    source = source_state()  # the code as it is when the run starts
    start = time.perf_counter()
    result = call_compute(
        module, settings, seed, out_dir if scan_root is None else scan_root, progress
    )
    run_s = time.perf_counter() - start
    prov = provenance(scene_id, setting, settings, seed, run_s, source)
    result.meta.update(
        scene=prov["scene"],
        setting=setting,
        settings=settings,
        seed=seed,
        scene_wall_s=run_s,
        provenance=prov,
    )
    stem = out_dir / (name or prov["scene"])
    result.save(stem)
    return result, save_figure(module.draw(result), stem.with_name(stem.name + ".png"), prov)


def redraw_scene(json_path: str | Path) -> Path:
    """Redraw a saved scene from its numbers, without recomputing; returns the PNG path.

    The PNG records the provenance saved with the numbers (data saved before provenance
    was recorded give ``{"provenance": None}``) and, under ``"drawn_by"``, the
    ``source_state`` of the code that drew it."""
    import matplotlib

    matplotlib.use("Agg")

    _, json_path = result_paths(json_path)
    with open(json_path) as fh:
        meta = json.load(fh)["meta"]
    module = scene_module(meta["scene"])  # registers the scene's result class before loading
    fig = module.draw(load_result(json_path))
    data = meta.get("provenance", {"provenance": None})
    return save_figure(fig, json_path.with_suffix(".png"), data | {"drawn_by": source_state()})
