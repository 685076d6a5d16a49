"""Load a sympy derivation of derivations/, or a script of benchmarks/, as a module (they are
scripts, not a package)."""

import importlib.util
from pathlib import Path

from extras import require

ROOT = Path(__file__).resolve().parents[1]
DERIVATIONS = ROOT / "derivations"
BENCHMARKS = ROOT / "benchmarks"


def _load(label: str, path: Path):
    spec = importlib.util.spec_from_file_location(label, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load_derivation(name: str):
    """Execute ``derivations/<name>.py`` and return it as a module (the test skips without
    sympy, which the derivations need)."""
    require("sympy", "derivations")
    return _load(f"derivation_{name}", DERIVATIONS / f"{name}.py")


def load_benchmark(name: str):
    """Execute ``benchmarks/<name>.py`` (its ``main`` does not run) and return it as a module."""
    return _load(f"benchmark_{name}", BENCHMARKS / f"{name}.py")
