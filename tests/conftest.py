"""Shared test set-up: a numba cache keyed on the kernel sources, hypothesis profiles, fixtures
(the documentation site, built once per run)."""

import os
import subprocess
import sys
import tempfile
from pathlib import Path

from bbdyn.sources import defines_kernels, digest_of, kernel_digest

REPO = Path(__file__).resolve().parent.parent
# the site's extensions (docs/_ext: the {data} references of the pages) for the tests that
# check the pages' data
sys.path.insert(0, str(REPO / "docs" / "_ext"))


def numba_source_key(repo: Path) -> str:
    """Key (16 hex digits) of every source numba compiles with a cache: the modules bbdyn's
    kernels can reach (``bbdyn.sources.kernel_digest``) and the test modules with kernels.

    numba's on-disk cache checks only the stamp of the file that defines a kernel, not of the
    functions it inlines or calls from other modules: after such a change it would load a stale
    kernel.  A cache directory per key cannot be stale.
    """
    tests = [p for p in (repo / "tests").rglob("*.py") if defines_kernels(p)]
    return digest_of(tests, repo)[:8] + kernel_digest(repo / "bbdyn")[:8]


# Before numba is imported (it reads the variable once); child processes (notebook kernels,
# CLI runs) inherit it.
os.environ["NUMBA_CACHE_DIR"] = str(
    Path(tempfile.gettempdir()) / "bbdyn-numba-cache" / numba_source_key(REPO)
)

import matplotlib  # noqa: E402
import pytest  # noqa: E402
from extras import require_docs_toolchain  # noqa: E402
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


@pytest.fixture(scope="session")
def site(tmp_path_factory) -> Path:
    """The HTML site, built once per run as the README says (sphinx-build -W --keep-going -b
    html).  The build executes every notebook (myst-nb); tests/test_notebooks.py checks the
    executed copies (``executed_notebooks``), so each notebook runs once per test run."""
    require_docs_toolchain()
    out = tmp_path_factory.mktemp("site") / "html"
    command = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html"]
    proc = subprocess.run([*command, str(REPO / "docs"), str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-6000:]
    return out


@pytest.fixture(scope="session")
def executed_notebooks(site) -> Path:
    """The folder of the notebooks as the build of ``site`` executed them (myst-nb writes them
    to ``jupyter_execute/`` beside the HTML folder, under the page's path)."""
    return site.parent / "jupyter_execute" / "notebooks"
