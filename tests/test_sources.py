"""bbdyn.sources: kernels compiled from other source are never loaded (numba alone would).

numba checks only the stamp of the file that defines a cached kernel; these tests run a
copy of bbdyn in fresh processes, edit a function the kernel calls from another module,
and check what each run computes.
"""

import json
import os
import shutil
import subprocess
import sys

import pytest

import bbdyn.sources
from bbdyn.sources import MARKER, kernel_digest, kernel_modules

RUN = """
import json, sys
from bbdyn.sources import refresh_kernel_caches
cleared = refresh_kernel_caches() if sys.argv[1] == "refresh" else []
import bbdyn
from bbdyn import Params
from bbdyn.core.billiard import flight_gap
assert bbdyn.__file__.startswith(sys.argv[2]), bbdyn.__file__
gap = flight_gap(0.3, 0.1, 5.0, 20.0, 0.01, Params(f=58.0).kernel())
print(json.dumps({"cleared": len(cleared), "gap": gap,
                  "hits": sum(flight_gap.stats.cache_hits.values())}))
"""


@pytest.fixture()
def copy(tmp_path):
    """A copy of bbdyn without compiled files, and a run of it in a fresh process."""
    src = tmp_path / "src"
    shutil.copytree(
        bbdyn.sources.PACKAGE, src / "bbdyn", ignore=shutil.ignore_patterns("__pycache__")
    )
    env = dict(os.environ, PYTHONPATH=str(src), NUMBA_CACHE_DIR=str(tmp_path / "cache"))

    def run(mode="refresh"):
        out = subprocess.run(
            [sys.executable, "-c", RUN, mode, str(src)],
            env=env, cwd=tmp_path, capture_output=True, text=True, check=True,
        )  # fmt: skip
        return json.loads(out.stdout)

    return src / "bbdyn", run


def test_an_edited_callee_is_recompiled(copy):
    package, run = copy
    first = run()
    assert first["cleared"] >= 1 and first["hits"] == 0  # no marker yet: compiled here
    again = run()
    assert again == {"cleared": 0, "gap": first["gap"], "hits": 1}  # unchanged: loaded
    floor = package / "core" / "floor.py"  # arc_root, which flight_gap calls
    original = floor.read_text()
    floor.write_text(original.replace("return math.sqrt((kp.R", "return 1.0 + math.sqrt((kp.R"))
    edited = run()
    assert edited["cleared"] >= 1 and edited["hits"] == 0
    assert edited["gap"] != first["gap"]
    # without the refresh numba loads the kernel of the edit just undone: stale
    floor.write_text(original)
    stale = run("plain")
    assert stale["hits"] == 1 and stale["gap"] == edited["gap"]
    assert run() == {"cleared": len(kernel_cache_folders(package)), "gap": first["gap"], "hits": 0}


def kernel_cache_folders(package):
    """The cache folders of the copy that hold a marker."""
    return {p.parent for p in package.parent.parent.joinpath("cache").rglob(MARKER)}


def test_kernel_digest_covers_what_kernels_reach(tmp_path):
    package = tmp_path / "bbdyn"
    shutil.copytree(bbdyn.sources.PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    key = kernel_digest(package)
    assert key == kernel_digest()  # a copy digests like the original
    cli = package / "commands" / "cli.py"
    cli.write_text(cli.read_text() + "\n")  # no kernel
    assert kernel_digest(package) == key
    for touched in (
        "core/tolerances.py",
        "reference/bench_kernels.py",
    ):  # constants; kernels outside core
        path = package / touched
        path.write_text(path.read_text() + "\n")
        assert kernel_digest(package) != key
        key = kernel_digest(package)


def test_kernel_modules_are_the_ones_with_cached_kernels():
    modules = kernel_modules()
    assert {"bbdyn.core.billiard", "bbdyn.core.ensemble", "bbdyn.reference.bench_kernels"} <= set(
        modules
    )
    assert "bbdyn.sources" not in modules and "bbdyn.core.tolerances" not in modules
