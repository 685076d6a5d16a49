"""Result objects: named arrays plus metadata, saved without pickling.

A result is saved as two files side by side: ``NAME.npz`` (the arrays, loaded
with ``allow_pickle=False``) and ``NAME.json`` (the metadata: parameters, seed,
package version, run time, the result's ``kind`` and the SHA-256 of the .npz).
``load_result`` reads any saved result back into the class that wrote it, and
refuses (``DamagedResultError``) files that are truncated, unreadable or changed.

Files are written to a temporary file in the same folder and renamed over their
final name, so a file is complete or absent; they get the mode ``0666 & ~umask``
of any new file (0644 under the usual umask).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import hashlib
import importlib
import json
import os
import platform
import secrets
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any, ClassVar

import numpy as np

from bbdyn import __version__
from bbdyn.schema import units_of
from bbdyn.sources import package_digest

__all__ = [
    "KINDS",
    "DamagedResultError",
    "Result",
    "file_sha256",
    "load_result",
    "make_meta",
    "read_json",
    "result_paths",
    "write_json_atomic",
]

_REGISTRY: dict[str, type[Result]] = {}

#: Every kind of result bbdyn saves -> the module that defines its class.  ``load_result``
#: imports that module when the kind is not registered yet, so a result loads in a fresh
#: process without importing its module first (tests/test_results.py checks the table
#: against the classes).
KINDS = {
    "green_kubo": "bbdyn.approx.green_kubo",
    "billiard_trajectory": "bbdyn.billiard",
    "trajectory_features": "bbdyn.classify",
    "classification": "bbdyn.classify",
    "correlations": "bbdyn.correlations",
    "flat_orbit_branch": "bbdyn.flat.continuation",
    "flat_doubling_cascades": "bbdyn.flat.continuation",
    "ensemble": "bbdyn.ensemble",
    "flat_trajectory": "bbdyn.flat.flatball",
    "flat_ensemble": "bbdyn.flat.flatball",
    "flat_lyapunov": "bbdyn.lyapunov",
    "billiard_lyapunov": "bbdyn.lyapunov",
    "poincare": "bbdyn.poincare",
    "scan_point": "bbdyn.scans.runner",
    "scan": "bbdyn.scans.runner",
    "statcost": "bbdyn.scans.statcost",
    "scene_b1": "bbdyn.scenes.b1_regime_map",
    "bench_billiard": "bbdyn.scenes.b2_billiard",
    "bench_flat": "bbdyn.scenes.b2_flat",
    "bench_scan_cost": "bbdyn.scenes.b2_scan_cost",
    "scene_b4": "bbdyn.scenes.b4_higher_tongues",
    "scene_b5": "bbdyn.scenes.b5_lyapunov",
    "scene_b6": "bbdyn.scenes.b6_fine_structure",
    "scene_b7": "bbdyn.scenes.b7_tilt",
    "scene_b8": "bbdyn.scenes.b8_noise",
    "scene_b9": "bbdyn.scenes.b9_distributions",
    "frequency_scan_scene": "bbdyn.scenes.frequency_scene",
    "scene_s10": "bbdyn.scenes.s10_green_kubo",
    "scene_s1": "bbdyn.scenes.s1_tongues",
    "scene_s2": "bbdyn.scenes.s2_geometry",
    "scene_s9": "bbdyn.scenes.s9_random_walk",
    "flat_periodic_orbit": "bbdyn.flat.tongues",
    "flat_tongues": "bbdyn.flat.tongues",
}


def make_meta(params=None, seed=None, wall_s=None, cpu_s=None, **extra: Any) -> dict[str, Any]:
    """Metadata common to all results: parameters, seed, version and source digest
    (``bbdyn.sources.package_digest``), run time (``wall_s`` wall-clock, ``cpu_s`` CPU time
    of the process, seconds), machine, and ``units``: the unit of each key that has one
    (``bbdyn.schema``)."""
    meta: dict[str, Any] = {
        "bbdyn_version": __version__,
        "bbdyn_source": package_digest(),
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "python": platform.python_version(),
        "machine": platform.machine(),
    }
    if params is not None:
        meta["params"] = params.to_dict()
    if seed is not None:
        meta["seed"] = seed
    if wall_s is not None:
        meta["wall_s"] = float(wall_s)
    if cpu_s is not None:
        meta["cpu_s"] = float(cpu_s)
    meta.update(extra)
    meta["units"] = units_of({**meta, **meta.get("params", {})})
    return meta


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def result_paths(path: str | os.PathLike) -> tuple[Path, Path]:
    """The ``(NAME.npz, NAME.json)`` pair of a result saved as ``path``.

    ``path`` may end in ``.npz`` or ``.json`` or in neither; any other dot in the
    name is kept (``f_50.200000000`` -> ``f_50.200000000.npz``), never taken
    for a suffix.
    """
    path = Path(path)
    if path.suffix in (".npz", ".json"):
        path = path.with_suffix("")
    return path.with_name(path.name + ".npz"), path.with_name(path.name + ".json")


class DamagedResultError(ValueError):
    """A saved result whose files are unreadable, truncated or changed since they were written."""


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of the file's bytes, as hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _write_atomic(path: Path, write: Callable[[IO[bytes]], None]) -> None:
    """Write ``path`` through ``write(binary_file)``: a temporary file renamed over ``path``.

    The temporary file is created with mode 0666 (the OS applies the umask) and is
    removed if the write fails (disk full, interrupt), so ``path`` is complete or absent.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{secrets.token_hex(4)}.tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_json_atomic(path: str | os.PathLike, obj: Any) -> Path:
    """Write ``obj`` as JSON to ``path`` atomically (temporary file, then rename)."""
    path = Path(path)

    def write(fh: IO[bytes]) -> None:
        text = json.dumps(_jsonable(obj), indent=2, allow_nan=True)
        fh.write(text.encode())

    _write_atomic(path, write)
    return path


def read_json(path: str | os.PathLike) -> Any:
    """The JSON in ``path``; ``DamagedResultError`` naming the file if it is not valid JSON."""
    try:
        with open(path, "rb") as fh:
            return json.loads(fh.read().decode())
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise DamagedResultError(f"{path} is not valid JSON ({err}): the file is damaged") from None


class Result:
    """Named arrays plus metadata, with ``save``, ``load`` and ``plot``.

    Subclasses set ``kind`` (a unique string, listed with its module in ``KINDS``) and
    implement ``plot(ax=None)``; they are registered automatically so ``load_result`` can
    rebuild them.
    """

    kind: ClassVar[str] = "result"

    def __init__(self, arrays: dict[str, np.ndarray], meta: dict[str, Any]):
        self.arrays = {k: np.asarray(v) for k, v in arrays.items()}
        self.meta = dict(meta)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.kind in _REGISTRY and _REGISTRY[cls.kind] is not cls:
            raise TypeError(f"result kind {cls.kind!r} is defined twice")
        _REGISTRY[cls.kind] = cls

    def __getitem__(self, name: str) -> np.ndarray:
        return self.arrays[name]

    def __repr__(self) -> str:
        shapes = ", ".join(f"{k}{tuple(v.shape)}" for k, v in self.arrays.items())
        return f"{type(self).__name__}({shapes})"

    def save(self, path: str | os.PathLike) -> Path:
        """Save to ``path.npz`` and ``path.json`` (atomically); returns the .json path.

        The .json, written last, records the SHA-256 of the .npz (``npz_sha256``).
        """
        npz_path, json_path = result_paths(path)
        _write_atomic(npz_path, lambda fh: np.savez(fh, **self.arrays))
        header = {"kind": self.kind, "meta": self.meta, "npz_sha256": file_sha256(npz_path)}
        return write_json_atomic(json_path, header)

    @classmethod
    def load(cls, path: str | os.PathLike) -> Result:
        """Load a result saved by ``save`` (``path`` with or without suffix)."""
        result = load_result(path)
        if not isinstance(result, cls):
            raise TypeError(f"{path} holds a {type(result).__name__}, not a {cls.__name__}")
        return result

    def plot(self, ax=None):
        """Draw the result on ``ax`` (a new figure if None) and return the axes."""
        raise NotImplementedError(f"{type(self).__name__} has no plot")


def load_result(path: str | os.PathLike) -> Result:
    """Load any saved result; the class is chosen by the ``kind`` stored in its JSON.

    Raises ``DamagedResultError`` (a ValueError) naming the file if the .json is not
    valid JSON or the .npz is unreadable or differs from the checksum in the .json.
    """
    npz_path, json_path = result_paths(path)
    header = read_json(json_path)
    if not isinstance(header, dict) or not isinstance(header.get("meta"), dict):
        raise DamagedResultError(f"{json_path} is not a saved result (no 'kind' and 'meta')")
    kind = header.get("kind")
    if kind not in _REGISTRY and kind in KINDS:
        importlib.import_module(KINDS[kind])
    if kind not in _REGISTRY:
        raise ValueError(f"{json_path}: unknown result kind {kind!r}")
    checksum = header.get("npz_sha256")  # absent in results saved before bbdyn recorded it
    if checksum is not None and file_sha256(npz_path) != checksum:
        raise DamagedResultError(
            f"{npz_path} differs from the checksum recorded in {json_path.name}: "
            "the file is damaged (truncated or changed after it was written)"
        )
    try:
        with np.load(npz_path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except (zipfile.BadZipFile, EOFError) as err:
        raise DamagedResultError(f"{npz_path} is unreadable ({err}): the file is damaged") from None
    obj = _REGISTRY[kind].__new__(_REGISTRY[kind])
    Result.__init__(obj, arrays, header["meta"])
    return obj
