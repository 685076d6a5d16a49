"""Shared test set-up: a numba cache keyed on the kernel sources, hypothesis profiles, fixtures."""

import hashlib
import os
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def numba_source_key(repo: Path) -> str:
    """Hash of every source numba compiles with a cache: ``bbdyn/core/`` and any other module of
    ``bbdyn/`` or ``tests/`` that uses ``@njit`` (16 hex digits).

    numba's on-disk cache checks only the stamp of the file that defines a kernel, not of the
    functions it inlines or calls from other modules: after such a change it would load a stale
    kernel.  A cache directory per key cannot be stale.
    """
    files = sorted((repo / "bbdyn" / "core").glob("*.py"))
    for folder in (repo / "bbdyn", repo / "tests"):
        files += sorted(
            p for p in folder.rglob("*.py") if "core" not in p.parts and "@njit" in p.read_text()
        )
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.relative_to(repo).as_posix().encode() + b"\0")
        digest.update(path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


# Before numba is imported (it reads the variable once); child processes (notebook kernels,
# CLI runs) inherit it.
os.environ["NUMBA_CACHE_DIR"] = str(
    Path(tempfile.gettempdir()) / "bbdyn-numba-cache" / numba_source_key(REPO)
)

import matplotlib  # noqa: E402
import pytest  # noqa: E402
from hypothesis import settings  # noqa: E402

matplotlib.use("Agg")

# Property tests draw the same examples on every run (CI must not depend on luck);
# HYPOTHESIS_PROFILE=explore draws new random examples, to hunt for failures.  The named
# hard cases are explicit examples (``@example``), run first whatever the profile.
settings.register_profile("default", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

from bbdyn import Params  # noqa: E402


@pytest.fixture
def params58() -> Params:
    """Default parameters (docs/model.md) at 58 Hz (inside the 1/1 tongue)."""
    return Params(f=58.0)
