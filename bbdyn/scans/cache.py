"""Where the scans behind scene settings are kept, and how a scene gets its scan.

A scene built on a scan (S3-S5, S9/S10, B1, B6) keeps the scan in a folder named
after the settings that define it, ``<out_dir>/scans/<family>_<digest>``
(``scene_folder``), so scenes with the same setting share one scan, an interrupted
scene resumes, and changed code (a new version, or an edited source tree) never reuses
old numbers.  ``FAMILIES`` lists which settings define each family's scan;
``diffusion_scan`` and ``gk_scene_scan`` load or compute (resume) the two scans that
several scenes share.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from bbdyn import __version__
from bbdyn.scans.frequency import frequency_grid, frequency_scan, scan_cpu_forecast
from bbdyn.scans.green_kubo import gk_scan
from bbdyn.scans.runner import load_scan
from bbdyn.sources import package_digest

__all__ = ["FAMILIES", "scene_folder", "setting_grid", "grid_cpu_forecast", "diffusion_scan",
           "gk_scene_scan"]  # fmt: skip

#: scan family -> the setting keys that define its scan (with the seed and the version)
FAMILIES = {
    "diffusion": ("f_start", "f_stop", "f_step", "n", "t", "transient", "eta"),  # S3-S5, B8
    "gk": ("f_start", "f_stop", "f_step", "n", "t", "nmax"),  # S9, S10
    "regime": ("f_min", "f_max", "n_f", "n", "t"),  # B1
    "finestructure": ("centres", "steps", "points", "n", "t", "eta"),  # B6, B8
}


def scene_folder(family: str, settings: dict, seed: int, out_dir=None) -> Path:
    """Folder of the scan of a scene setting: ``<out_dir>/scans/<family>_<digest>``.

    The digest covers ``settings[k]`` for the keys ``FAMILIES[family]``, the seed, the
    package version and the digest of bbdyn's source (``bbdyn.sources.package_digest``).
    A scan on a GPU (``settings["device"]``) has its own folder.
    ``out_dir`` defaults to ``$BBDYN_CACHE`` or ``~/.cache/bbdyn``; ``settings["scan_dir"]``
    names a folder explicitly.
    """
    if settings.get("scan_dir"):
        return Path(settings["scan_dir"])
    if out_dir is None:
        out_dir = os.environ.get("BBDYN_CACHE", Path.home() / ".cache" / "bbdyn")
    defining = {k: settings.get(k) for k in FAMILIES[family]}
    defining |= {"seed": seed, "version": __version__, "source": package_digest()}
    if settings.get("device", "cpu") != "cpu":  # a GPU's scan is kept apart from the CPU's
        defining["device"] = settings["device"]
    digest = hashlib.sha256(json.dumps(defining, sort_keys=True).encode()).hexdigest()[:12]
    return Path(out_dir) / "scans" / f"{family}_{digest}"


def setting_grid(settings: dict):
    """The frequencies (Hz) of a grid setting: ``frequency_grid(f_start, f_stop, f_step)``."""
    return frequency_grid(settings["f_start"], settings["f_stop"], settings["f_step"])


def grid_cpu_forecast(settings: dict) -> dict[str, float]:
    """Forecast of the CPU time (s) of the scan of a grid setting (``n`` particles for ``t`` s
    at every frequency of ``setting_grid``): ``bbdyn.scans.frequency.scan_cpu_forecast``."""
    grid = setting_grid(settings)
    return scan_cpu_forecast(grid.sum(), grid.size, settings["n"], settings["t"],
                             workers=settings.get("workers"))  # fmt: skip


def diffusion_scan(settings: dict, seed: int, out_dir=None, progress=False):
    """The frequency scan of an S3-S5 setting (``bbdyn.scans.frequency.frequency_scan`` on
    ``frequency_grid(f_start, f_stop, f_step)``): loaded if finished, else computed or
    resumed (``progress`` as in ``run_scan``), at the noise amplitude ``settings["eta"]`` if
    given (scene B8).  With an explicit ``settings["scan_dir"]`` the scan is only loaded, and
    with ``settings["partial"]`` true its finished points are enough."""
    folder = scene_folder("diffusion", settings, seed, out_dir)
    if settings.get("scan_dir"):
        return load_scan(folder, partial=bool(settings.get("partial", False)))
    return frequency_scan(
        setting_grid(settings),
        out_dir=folder,
        seed=seed,
        n=settings["n"],
        t=settings["t"],
        transient=settings.get("transient"),
        workers=settings.get("workers"),
        progress=progress,
        device=settings.get("device", "cpu"),
        model={"eta": settings.get("eta") or 0.0},
    )


def gk_scene_scan(settings: dict, seed: int, out_dir=None, progress=False):
    """The Green-Kubo scan of an S9/S10 setting (``bbdyn.scans.green_kubo.gk_scan`` on
    ``frequency_grid(f_start, f_stop, f_step)``), computed or resumed;
    ``settings["workers"]`` optional; ``progress`` as in ``run_scan``."""
    return gk_scan(
        setting_grid(settings),
        out_dir=scene_folder("gk", settings, seed, out_dir),
        seed=seed,
        n=settings["n"],
        t=settings["t"],
        nmax=settings.get("nmax", 1),
        workers=settings.get("workers"),
        progress=progress,
    )
