"""Every notebook in notebooks/ runs from top to bottom (at its quick settings) in a Jupyter
kernel with the inline backend, draws figures, and is stored without outputs.

The notebooks guard every sentence that states a computed result with an ``assert``
right after the computation (or generate the sentence from the result), so running
them also checks that their words still match their numbers.  They run once per test
run, in the documentation site's build (the session fixture ``site`` of conftest.py:
myst-nb executes each notebook with the inline backend and fails the build on any error,
docs/conf.py); the tests here read the executed copies.
"""

import re
from pathlib import Path

import nbformat
import pytest

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
PATHS = sorted(NOTEBOOKS.glob("*.ipynb"))
FORBIDDEN = re.compile(r"MODEL\.md|SCENES\.md|STYLE\.md|matplotlib\.use|MPLBACKEND")


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
def test_notebook_runs_and_draws_inline(path, executed_notebooks):
    """The site build ran every code cell of the notebook, without an error, and it drew at
    least one inline figure."""
    stored = nbformat.read(path, as_version=4)
    nb = nbformat.read(executed_notebooks / path.name, as_version=4)
    code = [cell for cell in nb.cells if cell.cell_type == "code"]
    assert [cell.source for cell in code] == [
        cell.source for cell in stored.cells if cell.cell_type == "code"
    ], f"{path.name}: the executed copy is not the stored notebook"
    not_run = [i for i, cell in enumerate(code) if cell.execution_count is None]
    assert not not_run, f"{path.name}: code cells {not_run} did not run"
    outputs = _outputs(nb)
    errors = [out for out in outputs if out.output_type == "error"]
    assert not errors, [f"{e.ename}: {e.evalue}" for e in errors]
    images = sum("image/png" in out.get("data", {}) for out in outputs)
    print(f"{path.stem}: {images} inline image(s)")
    assert images >= 1, f"{path.name} drew no inline figure"
