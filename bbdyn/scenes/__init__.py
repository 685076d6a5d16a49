"""Scenes (SCENES.md): one module per figure or analysis.

Each scene module defines

* ``TITLE``: one line;
* ``QUICK`` and ``FULL``: dicts of settings (quick: seconds to a minute on 2 cores);
* ``compute(settings, seed[, out_dir]) -> Result``: computes only what the figure needs
  (scenes built on frequency scans take ``out_dir`` and keep their scan there);
* ``draw(result, ax=None)``: draws a saved or fresh result, returns the figure.

``run_scene`` computes, saves the numbers (``<id>.npz`` / ``<id>.json``, with
parameters, seed, version and run time) and the figure (``<id>.png``) side by
side, so a figure can be redrawn from its data with ``redraw_scene``.
"""

from __future__ import annotations

import importlib
import inspect
import json
import time
from pathlib import Path

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
}


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
        raise ValueError(f"unknown scene {scene_id!r}; known: {', '.join(SCENES)}")
    return importlib.import_module(f"bbdyn.scenes.{SCENES[key]}")


def run_scene(scene_id: str, *, quick: bool = True, out_dir: str | Path = "out", seed: int = 0):
    """Compute scene ``scene_id``, save its numbers and figure in ``out_dir``.

    Returns ``(result, png_path)``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    module = scene_module(scene_id)
    settings = dict(module.QUICK if quick else module.FULL)
    out_dir = Path(out_dir)
    start = time.perf_counter()
    if "out_dir" in inspect.signature(module.compute).parameters:
        # scenes built on scans keep them under out_dir, so an interrupted run resumes
        result = module.compute(settings, seed, out_dir=out_dir)
    else:
        result = module.compute(settings, seed)
    result.meta.update(
        scene=scene_id.upper(),
        setting="quick" if quick else "full",
        settings=settings,
        seed=seed,
        scene_wall_s=time.perf_counter() - start,
    )
    result.save(out_dir / scene_id.upper())
    fig = module.draw(result)
    png = out_dir / f"{scene_id.upper()}.png"
    fig.savefig(png, dpi=150, bbox_inches="tight")
    plt.close(fig)
    return result, png


def redraw_scene(json_path: str | Path) -> Path:
    """Redraw a saved scene from its numbers, without recomputing; returns the PNG path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bbdyn.results import load_result, result_paths

    _, json_path = result_paths(json_path)
    with open(json_path) as fh:
        scene_id = json.load(fh)["meta"]["scene"]
    module = scene_module(scene_id)  # registers the scene's result class before loading
    fig = module.draw(load_result(json_path))
    png = json_path.with_suffix(".png")
    fig.savefig(png, dpi=150, bbox_inches="tight")
    plt.close(fig)
    return png
