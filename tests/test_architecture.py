"""The import direction of the layers (README, Layout), enforced by reading imports."""

import ast
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "bbdyn"
CORE_ALLOWED = {"math", "typing", "numpy", "numba", "bbdyn"}  # typing: NamedTuple


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
    return names


def test_core_imports_only_numpy_math_typing_numba_and_core():
    for path in (PACKAGE / "core").glob("*.py"):
        for name in _imports(path):
            top = name.split(".")[0]
            assert top in CORE_ALLOWED, f"{path.name} imports {name}"
            if top == "bbdyn":
                assert name.startswith("bbdyn.core"), f"{path.name} imports {name}"


def test_import_bbdyn_loads_neither_sympy_nor_matplotlib():
    code = "import sys, bbdyn; print('sympy' in sys.modules, 'matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]
