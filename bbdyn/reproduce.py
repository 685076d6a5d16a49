"""Run every scene of ``bbdyn.scenes.SCENES`` and write an index page (``index.md``).

The index lists each scene with its title, setting, parameters, key numbers
(``result.meta["key_numbers"]`` when the scene provides them) and run time.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from pathlib import Path

from bbdyn.scenes import SCENES, run_scene, scene_module


def reproduce(
    out_dir: str | Path = "out",
    *,
    quick: bool = True,
    seed: int = 0,
    only: Iterable[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Path:
    """Run the scenes (all, or ``only``), save figures and data in ``out_dir``; return index.md."""
    out_dir = Path(out_dir)
    ids = [s.upper() for s in only] if only else list(SCENES)
    for scene_id in ids:
        scene_module(scene_id)  # fail early on an unknown id, before any long computation
    rows = []
    start = time.perf_counter()
    for scene_id in ids:
        result, png = run_scene(scene_id, quick=quick, out_dir=out_dir, seed=seed)
        rows.append((scene_id, scene_module(scene_id).TITLE, result, png))
        if progress:
            progress(f"{scene_id}: {png} ({result.meta['scene_wall_s']:.1f} s)")
    total = time.perf_counter() - start
    return _write_index(out_dir, rows, quick, seed, total)


def _write_index(out_dir: Path, rows, quick: bool, seed: int, total_s: float) -> Path:
    from bbdyn import __version__

    lines = [
        "# bbdyn reproduce",
        "",
        f"bbdyn {__version__}, {'quick' if quick else 'full'} settings, seed {seed}, "
        f"total {total_s:.1f} s.",
        "",
    ]
    for scene_id, title, result, png in rows:
        meta = result.meta
        lines += [f"## {scene_id}: {title}", "", f"![{scene_id}]({png.name})", ""]
        lines.append(f"* data: `{scene_id}.npz`, `{scene_id}.json`")
        lines.append(f"* run time: {meta['scene_wall_s']:.2f} s")
        lines.append(f"* settings: `{meta.get('settings')}`")
        if "params" in meta:
            lines.append(f"* parameters: `{meta['params']}`")
        for key, value in meta.get("key_numbers", {}).items():
            lines.append(f"* {key}: {value}")
        lines.append("")
    index = out_dir / "index.md"
    index.write_text("\n".join(lines))
    return index
