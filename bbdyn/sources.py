"""Digests of bbdyn's own source, so that nothing computed by older code is reused.

Two caches outlive a process and must not survive a change of the code they came from:

* the scans behind the scenes (``bbdyn.scans.cache.scene_folder``), keyed by
  ``package_digest`` (every module: a change in an estimator changes the numbers too);
* numba's compiled kernels (``cache=True``).  Numba checks only the file that defines a
  function: a kernel whose callee in another module changed (a tolerance in
  ``core/tolerances.py``, a helper in ``core/floor.py``) is loaded stale.
  ``refresh_kernel_caches`` clears bbdyn's compiled kernels when ``kernel_digest`` (the
  modules a kernel can reach) has changed since they were written.

``refresh_kernel_caches`` runs at the start of every ``bbdyn`` command and of the test run;
a script that edits bbdyn and then calls kernels directly calls it itself.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import os
import re
from pathlib import Path

__all__ = ["package_digest", "kernel_digest", "kernel_modules", "refresh_kernel_caches"]

PACKAGE = Path(__file__).resolve().parent
#: The file beside numba's cache files that records the kernel digest they were built from.
MARKER = "bbdyn-kernels.sha256"
#: Subpackages whose modules kernels can reach (the core, the reference kernels).
KERNEL_PACKAGES = ("core", "reference")
CACHED_KERNEL = re.compile(r"@n?jit\([^)]*cache=True")


def digest_of(paths, root: Path = PACKAGE) -> str:
    """SHA-256 (hex) of the files' paths relative to ``root`` and their contents."""
    digest = hashlib.sha256()
    for path in sorted(paths):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()


def defines_kernels(path: Path) -> bool:
    """True if the module compiles cached kernels (a numba decorator with ``cache=True``)."""
    return CACHED_KERNEL.search(path.read_text(encoding="utf-8")) is not None


def package_digest(package: Path | None = None) -> str:
    """Digest of every module of the package; by default of ``PACKAGE``, bbdyn's own folder,
    read once per process (about 4 ms; the code a process runs is the code it imported)."""
    if package is None:
        return loaded_package_digest()
    return digest_of(package.rglob("*.py"), package)


@functools.cache
def loaded_package_digest() -> str:
    """``package_digest(PACKAGE)``, computed at the first call."""
    return package_digest(PACKAGE)


def kernel_files(package: Path | None = None) -> list[Path]:
    """The modules a cached kernel can reach: ``KERNEL_PACKAGES`` and every module with one."""
    package = package or PACKAGE
    files = {p for sub in KERNEL_PACKAGES for p in (package / sub).rglob("*.py")}
    return sorted(files | {p for p in package.rglob("*.py") if defines_kernels(p)})


def kernel_digest(package: Path | None = None) -> str:
    """Digest of the modules a cached kernel can reach (``kernel_files``)."""
    package = package or PACKAGE
    return digest_of(kernel_files(package), package)


def kernel_modules() -> list[str]:
    """Dotted names of bbdyn's modules that compile cached kernels."""
    return [
        ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        for path in kernel_files()
        if defines_kernels(path)
    ]


def kernel_cache_dirs() -> set[Path]:
    """The folders numba keeps bbdyn's compiled kernels in (``Dispatcher.stats.cache_path``)."""
    from numba.core.registry import CPUDispatcher

    dirs = set()
    for name in kernel_modules():
        module = importlib.import_module(name)
        for obj in vars(module).values():
            if isinstance(obj, CPUDispatcher) and obj.__module__ == name:
                path = obj.stats.cache_path
                if path:
                    dirs.add(Path(path))
    return dirs


def refresh_kernel_caches() -> list[Path]:
    """Delete bbdyn's compiled kernels that were built from other source; return their folders.

    In each cache folder a marker file (``MARKER``) records the ``kernel_digest`` of the
    source its kernels were built from; where it differs or is missing, the folder's
    ``*.nbi``/``*.nbc`` files (numba's index and data files; only bbdyn's kernels are kept
    in a folder of bbdyn's) are deleted and the marker rewritten.  Folders that cannot be
    written are left alone (numba then cannot cache there either).
    """
    digest = kernel_digest()
    cleared = []
    for folder in sorted(kernel_cache_dirs()):
        marker = folder / MARKER
        try:
            if marker.is_file() and marker.read_text().strip() == digest:
                continue
            folder.mkdir(parents=True, exist_ok=True)
            for stale in [*folder.glob("*.nbi"), *folder.glob("*.nbc")]:
                stale.unlink(missing_ok=True)
            partial = folder / f"{MARKER}.{os.getpid()}"
            partial.write_text(digest + "\n")
            os.replace(partial, marker)
        except OSError:
            continue
        cleared.append(folder)
    return cleared
