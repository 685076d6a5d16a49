"""Sphinx extension: numbers on a page are read from committed result files at build time.

A page never types a number that a computation produced. It writes a reference instead:

    {data}`figures/S3_full.json:meta/key_numbers/frequencies`
    {data}`data/paper.json:gk_85/D_rw|.2f`

``FILE`` is a JSON file relative to ``docs/``; ``KEY`` a path of keys (and list indices)
separated by ``/``; ``|FMT`` an optional Python format spec for numbers (``.3g`` when left
out for floats; in a Markdown table cell write ``\\|FMT``, since ``|`` ends the cell). A
value ``{"value": v, "se": s}`` is written ``v ± s`` with the same spec for both. A missing
file or key is a build error (the site is built with ``-W``), so a page cannot keep a number
whose data is gone. ``resolve`` is what the tests call to check every reference of the pages
without building the site.

A whole table computed by a script is drawn by the directive

    ```{data-table} data/lyapunov.json:flat
    ```

from ``{"columns": [...], "rows": [[cell, ...], ...]}`` at that key (``table_markdown``).
"""

from __future__ import annotations

import json
import re
from functools import cache
from pathlib import Path

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective

DOCS = Path(__file__).resolve().parents[1]
#: one reference: FILE:KEY[|FMT]
REFERENCE = re.compile(r"^(?P<file>[^:|]+\.json):(?P<key>[^|]+)(?:\|(?P<fmt>.*))?$")
#: a reference as written in a Markdown page or notebook cell
IN_TEXT = re.compile(r"\{data\}`([^`]+)`")


@cache
def _load(file: str) -> object:
    path = DOCS / file
    if not path.is_file():
        raise KeyError(f"no data file docs/{file}")
    return json.loads(path.read_text())


def lookup(file: str, key: str) -> object:
    """The value at KEY (``a/b/0/c``) of ``docs/FILE``; KeyError naming what is missing."""
    value = _load(file)
    for part in key.split("/"):
        if isinstance(value, list) and part.lstrip("-").isdigit():
            index = int(part)
            if not -len(value) <= index < len(value):
                raise KeyError(f"docs/{file}: index {part} out of range in '{key}'")
            value = value[index]
        elif isinstance(value, dict) and part in value:
            value = value[part]
        else:
            raise KeyError(f"docs/{file}: no key '{part}' in '{key}'")
    return value


def format_value(value: object, fmt: str | None) -> str:
    """Text of a value: numbers with FMT (``.3g`` for floats), ``v ± s`` for value-error pairs."""
    if isinstance(value, dict) and set(value) == {"value", "se"}:
        return f"{format_value(value['value'], fmt)} ± {format_value(value['se'], fmt)}"
    if isinstance(value, list):
        return ", ".join(format_value(v, fmt) for v in value)
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, float) and fmt is None:
        fmt = ".3g"
    if isinstance(value, int | float) and fmt:
        return format(value, fmt)
    return str(value)


def resolve(reference: str) -> str:
    """Text of one reference ``FILE:KEY[|FMT]``; KeyError or ValueError when it is broken."""
    # in a Markdown table a cell ends at "|", so a reference there writes "\\|FMT"
    match = REFERENCE.match(reference.strip().replace("\\|", "|"))
    if match is None:
        raise ValueError(f"a data reference is FILE.json:KEY[|FMT], got '{reference}'")
    return format_value(lookup(match["file"], match["key"]), match["fmt"])


def data_role(name, rawtext, text, lineno, inliner, options=None, content=None):
    """The ``{data}`` role: the referenced value as plain text, or a build error."""
    try:
        return [nodes.Text(resolve(text))], []
    except (KeyError, ValueError) as err:
        message = inliner.reporter.error(f"data reference: {err}", line=lineno)
        return [inliner.problematic(rawtext, rawtext, message)], [message]


def table_markdown(reference: str) -> list[str]:
    """Markdown lines of the table at ``FILE:KEY``: ``{"columns": [...], "rows": [[...]]}``,
    cells as they are written (``|`` escaped)."""
    match = REFERENCE.match(reference.strip())
    if match is None or match["fmt"] is not None:
        raise ValueError(f"a data table is FILE.json:KEY, got '{reference}'")
    table = lookup(match["file"], match["key"])
    if not (isinstance(table, dict) and {"columns", "rows"} <= set(table)):
        raise KeyError(f"docs/{match['file']}: '{match['key']}' is no table (columns, rows)")

    def line(cells) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"

    columns = table["columns"]
    if any(len(row) != len(columns) for row in table["rows"]):
        raise ValueError(f"docs/{match['file']}: a row of '{match['key']}' has the wrong length")
    return [line(columns), line(["---"] * len(columns)), *map(line, table["rows"])]


class DataTable(SphinxDirective):
    """The ``data-table`` directive: the table at ``FILE.json:KEY`` as a Markdown table."""

    required_arguments = 1

    def run(self):
        try:
            lines = table_markdown(self.arguments[0])
        except (KeyError, ValueError) as err:
            raise self.error(f"data table: {err}") from err
        return markdown_nodes(self, lines)


def markdown_nodes(directive: SphinxDirective, lines: list[str]) -> list:
    """The nodes of the Markdown ``lines`` parsed in place of ``directive``."""
    container = nodes.container()
    directive.state.nested_parse(StringList(lines, source=directive.env.docname),
                                 directive.content_offset, container)  # fmt: skip
    return container.children


def setup(app):
    app.add_role("data", data_role)
    app.add_directive("data-table", DataTable)
    # Sphinx looks a role up in the default domain first, and the Python domain has its own
    # "data" role (cross-references to module data): it would take every {data} reference and
    # render it as an unresolved literal, silently. The pages use no Python :data: role.
    app.add_role_to_domain("py", "data", data_role, override=True)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
