"""The ``{data}`` references of the pages and notebooks resolve to committed data.

Pages type no computed number: they write ``{data}`FILE.json:KEY|FMT``` and the site's
extension ``docs/_ext/datavalue.py`` inserts the value at build time. This test reads every
reference without building the site, so a page whose data file or key is gone fails here.
"""

from __future__ import annotations

import json
from pathlib import Path

import datavalue  # docs/_ext, on the path by conftest.py
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _texts():
    for page in sorted((ROOT / "docs").glob("*.md")):
        yield page.relative_to(ROOT).as_posix(), page.read_text()
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        cells = json.loads(notebook.read_text())["cells"]
        text = "\n".join("".join(c["source"]) for c in cells if c["cell_type"] == "markdown")
        yield notebook.relative_to(ROOT).as_posix(), text


# In a Markdown table the "|" before FMT is written as a backslash and "|" (else it ends the cell);
# the parser unescapes it before the role sees it, so the test does the same.
REFERENCES = [
    (name, ref.replace("\\|", "|"))
    for name, text in _texts()
    for ref in datavalue.IN_TEXT.findall(text)
]


@pytest.mark.parametrize(("page", "reference"), REFERENCES or [("none", None)])
def test_reference_resolves(page, reference):
    if reference is None:
        pytest.skip("no page uses a data reference")
    assert datavalue.resolve(reference)


def test_a_broken_reference_is_an_error(tmp_path):
    with pytest.raises(KeyError, match="no key 'nothing'"):
        datavalue.resolve("figures/S3_full.json:meta/nothing")
    with pytest.raises(KeyError, match="no data file"):
        datavalue.resolve("figures/none.json:x")
    with pytest.raises(ValueError, match="FILE.json:KEY"):
        datavalue.resolve("no colon here")


def test_values_are_formatted_as_asked():
    assert datavalue.format_value({"value": 1.23456, "se": 0.0456}, ".2f") == "1.23 ± 0.05"
    assert datavalue.format_value(0.000123456, None) == "0.000123"
    assert datavalue.format_value(227, None) == "227"
    assert datavalue.format_value([1.0, 2.5], ".1f") == "1.0, 2.5"
    frequencies = datavalue.resolve("figures/S3_full.json:meta/settings/f_step")
    assert frequencies == "0.2"


def test_the_role_inserts_the_value_in_a_built_page(tmp_path):
    """A page built by Sphinx (Python as its default domain, as on the site) shows the value,
    not the reference: the Python domain's own "data" role must not take it."""
    from sphinx.application import Sphinx

    src = tmp_path / "src"
    src.mkdir()
    (src / "conf.py").write_text(
        f"import sys\nsys.path.insert(0, {str(ROOT / 'docs' / '_ext')!r})\n"
        'extensions = ["myst_parser", "datavalue"]\n'
    )
    (src / "index.md").write_text(
        "# t\n\nstep {data}`figures/S3_full.json:meta/settings/f_step|.2f` Hz\n\n"
        "| a |\n|---|\n| {data}`figures/S3_full.json:meta/settings/f_step\\|.3f` |\n\n"
        "```{data-table} data/lyapunov.json:billiard_orbits\n```\n"
    )
    app = Sphinx(src, src, tmp_path / "out", tmp_path / "doctrees", "html", status=None,
                 warningiserror=True)  # fmt: skip
    app.build()
    html = (tmp_path / "out" / "index.html").read_text()
    assert "step 0.20 Hz" in html and "<td><p>0.200</p></td>" in html
    assert "S3_full.json" not in html
    # the data table: its header and every cell, in a table of the page
    table = datavalue.lookup("data/lyapunov.json", "billiard_orbits")
    assert "<th" in html and all(f"<p>{c}</p>" in html for c in table["columns"][:2])
    assert all(f"<td><p>{cell}</p></td>" in html for row in table["rows"] for cell in row)


def test_a_data_table_needs_columns_and_rows_of_their_length():
    lines = datavalue.table_markdown("data/lyapunov.json:flat")
    table = datavalue.lookup("data/lyapunov.json", "flat")
    assert len(lines) == 2 + len(table["rows"]) and lines[1].count("---") == len(table["columns"])
    with pytest.raises(KeyError, match="no table"):
        datavalue.table_markdown("data/lyapunov.json:command")
    with pytest.raises(ValueError, match="FILE.json:KEY"):
        datavalue.table_markdown("data/lyapunov.json:flat|.2f")
