"""Every notebook in notebooks/ runs from top to bottom (at its quick settings) in a Jupyter
kernel with the inline backend, draws figures, and is stored without outputs.

The notebooks guard every sentence that states a computed result with an ``assert``
right after the computation (or generate the sentence from the result), so running
them here also checks that their words still match their numbers.
"""

import os
import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
PATHS = sorted(NOTEBOOKS.glob("*.ipynb"))
FORBIDDEN = re.compile(r"MODEL\.md|SCENES\.md|STYLE\.md|matplotlib\.use|MPLBACKEND")


def _kernel_env() -> dict:
    """The test process's environment without MPLBACKEND: the kernel uses its inline backend."""
    return {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}


def _outputs(nb):
    return [out for cell in nb.cells if cell.cell_type == "code" for out in cell.outputs]


@pytest.mark.parametrize("path", PATHS, ids=lambda p: p.stem)
def test_notebook_is_stored_clean(path):
    """No outputs or execution counts in the repository; no backend override; docs/model.md."""
    nb = nbformat.read(path, as_version=4)
    for i, cell in enumerate(nb.cells):
        assert not FORBIDDEN.search(cell.source), (i, FORBIDDEN.search(cell.source).group())
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"cell {i} has outputs"


@pytest.mark.parametrize("path", PATHS, ids=lambda p: p.stem)
def test_notebook_runs_and_draws_inline(path):
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(NOTEBOOKS)}}
    )
    client.execute(env=_kernel_env())
    outputs = _outputs(nb)
    errors = [out for out in outputs if out.output_type == "error"]
    assert not errors, [f"{e.ename}: {e.evalue}" for e in errors]
    images = sum("image/png" in out.get("data", {}) for out in outputs)
    print(f"{path.stem}: {images} inline image(s)")
    assert images >= 1, f"{path.name} drew no inline figure"
