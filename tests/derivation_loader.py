"""Load a sympy derivation of derivations/ as a module (they are scripts, not a package)."""

import importlib.util
from pathlib import Path

DERIVATIONS = Path(__file__).resolve().parents[1] / "derivations"


def load_derivation(name: str):
    """Execute ``derivations/<name>.py`` and return it as a module."""
    spec = importlib.util.spec_from_file_location(f"derivation_{name}", DERIVATIONS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
