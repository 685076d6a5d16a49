"""Result objects: named arrays plus metadata, saved without pickling.

A result is saved as two files side by side: ``NAME.npz`` (the arrays, loaded
with ``allow_pickle=False``) and ``NAME.json`` (the metadata: parameters, seed,
package version, run time, and the result's ``kind``).  ``load_result`` reads
any saved result back into the class that wrote it.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import tempfile
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

__all__ = ["Result", "make_meta", "load_result", "result_paths", "write_json_atomic"]

_REGISTRY: dict[str, type[Result]] = {}


def make_meta(params=None, seed=None, wall_s=None, **extra: Any) -> dict[str, Any]:
    """Metadata common to all results: parameters, seed, version, run time, machine."""
    from bbdyn import __version__

    meta: dict[str, Any] = {
        "bbdyn_version": __version__,
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
    meta.update(extra)
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


def write_json_atomic(path: str | os.PathLike, obj: Any) -> Path:
    """Write ``obj`` as JSON to ``path`` atomically (temporary file, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    with os.fdopen(fd, "w") as fh:
        json.dump(_jsonable(obj), fh, indent=2, allow_nan=True)
    os.replace(tmp, path)
    return path


class Result:
    """Named arrays plus metadata, with ``save``, ``load`` and ``plot``.

    Subclasses set ``kind`` (a unique string) and implement ``plot(ax=None)``;
    they are registered automatically so ``load_result`` can rebuild them.
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
        """Save to ``path.npz`` and ``path.json`` (atomically); returns the .json path."""
        npz_path, json_path = result_paths(path)
        npz_path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=npz_path.parent, prefix=npz_path.name, suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **self.arrays)
        os.replace(tmp, npz_path)
        return write_json_atomic(json_path, {"kind": self.kind, "meta": self.meta})

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
    """Load any saved result; the class is chosen by the ``kind`` stored in its JSON."""
    npz_path, json_path = result_paths(path)
    with open(json_path) as fh:
        header = json.load(fh)
    kind = header.get("kind")
    if kind not in _REGISTRY:
        raise ValueError(f"{json_path}: unknown result kind {kind!r}")
    with np.load(npz_path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    obj = _REGISTRY[kind].__new__(_REGISTRY[kind])
    Result.__init__(obj, arrays, header["meta"])
    return obj
