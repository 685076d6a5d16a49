"""docs/model.md against the code: named functions exist, stated defaults and numbers hold.

Also: no tracked file refers to documents outside the repository.
"""

from __future__ import annotations

import importlib
import re
import subprocess
from pathlib import Path

import datavalue  # docs/_ext, on the path by conftest.py
import pytest

from bbdyn.flat.tongues import frequency_at_gamma, tongue_gamma_hi, tongue_gamma_lo
from bbdyn.params import Params

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "docs" / "model.md"


def section(text: str, heading: str) -> str:
    """The text of the ``## heading`` section of a markdown page (up to the next ``## ``)."""
    start = text.index(f"## {heading}")
    end = text.find("\n## ", start + 1)
    return text[start : end if end >= 0 else None]


def table_rows(text: str) -> list[list[str]]:
    """Cells of the markdown table rows in ``text`` (header and separator rows dropped)."""
    rows = [
        [c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]
        for line in text.splitlines()
        if line.strip().startswith("|")
    ]
    return [r for r in rows[2:] if not set("".join(r)) <= set("-: ")]


def resolve(name: str):
    """Import the longest module prefix of a dotted ``bbdyn`` name and getattr the rest."""
    parts = name.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for attr in parts[cut:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(name)


MODEL_TEXT = MODEL.read_text(encoding="utf-8")
IMPLEMENTED = sorted(
    set(re.findall(r"`(bbdyn(?:\.\w+)+)`", section(MODEL_TEXT, "7. Where each equation")))
)


def test_equation_table_is_not_empty():
    assert len(IMPLEMENTED) >= 25, IMPLEMENTED


@pytest.mark.parametrize("name", IMPLEMENTED)
def test_named_function_exists(name):
    obj = resolve(name)
    assert callable(obj), f"{name} is not a function or class"


def test_parameter_defaults_equal_params():
    rows = table_rows(section(MODEL_TEXT, "Parameters").split("Derived quantities")[0])
    p = Params(f=60.0)
    checked = 0
    for symbol, _meaning, default, _unit, field in rows:
        field = field.strip("`")
        if default == "none":
            assert field == "f", f"only f has no default, not {symbol}"
            continue
        assert float(default) == getattr(p, field), f"default of {symbol} ({field})"
        checked += 1
    fields = {f for f in p.to_dict() if f != "f"}
    assert checked == len(fields) == 8


def test_derived_values_equal_params():
    rows = table_rows(section(MODEL_TEXT, "Parameters").split("Derived quantities")[1])
    p = Params(f=60.0)
    checked = 0
    for _symbol, _definition, value, prop in rows:
        getattr(p, prop.strip("`"))  # every named property exists
        reference = datavalue.IN_TEXT.search(value)
        if reference is None:
            continue
        # the page's value is the data's, and the data is the property's
        match = datavalue.REFERENCE.match(reference.group(1).replace("\\|", "|"))
        stated = datavalue.lookup(match["file"], match["key"])
        assert stated == pytest.approx(getattr(p, prop.strip("`")), rel=1e-12), prop
        checked += 1
    assert checked == 3


def test_tongue_frequencies_equal_closed_form():
    text = section(MODEL_TEXT, "1. Flat bouncing ball")
    stated = re.findall(r"([0-9.]+)-([0-9.]+) Hz \(k = (\d)\)", text)
    assert len(stated) == 3
    for lo, hi, k in stated:
        f_lo = frequency_at_gamma(tongue_gamma_lo(int(k), 0.5))
        f_hi = frequency_at_gamma(tongue_gamma_hi(int(k), 0.5))
        assert (round(f_lo, 2), round(f_hi, 2)) == (float(lo), float(hi)), k


def test_gamma_two_frequency():
    stated = re.search(r"\\Gamma > 2\$ \(\$f\$ > ([0-9.]+) Hz", MODEL_TEXT)
    assert round(frequency_at_gamma(2.0), 2) == float(stated.group(1))


def test_no_references_outside_repository():
    """No tracked file names a document that is not in the repository (e.g. an outside spec)."""
    forbidden = [name + ".md" for name in ("MODEL", "SCENES", "STYLE")] + ["../" + "shared"]
    files = subprocess.run(
        ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True
    ).stdout.split(b"\0")
    tracked_names = {Path(rel.decode()).name for rel in filter(None, files)}
    offenders = []
    for rel in filter(None, files):
        path = ROOT / rel.decode()
        if not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" in data[:8192]:
            continue  # binary
        text = data.decode("utf-8", errors="replace")
        offenders += [f"{rel.decode()}: {word}" for word in forbidden if word in text]
        offenders += [
            f"{rel.decode()}: {name}"
            for name in set(re.findall(r"\b[A-Z][A-Z_]+\.md\b", text))
            if name not in tracked_names
        ]
    assert not offenders, "\n".join(offenders)


def test_wedge_and_high_bounce_numbers():
    from bbdyn.core.tolerances import EPS, WEDGE_MAX_REFLECTIONS, WEDGE_TOL
    from bbdyn.flat.highbounce import tongue_errors

    text = section(MODEL_TEXT, "2. Bouncing ball billiard")
    tol = re.search(r"within \$(\d+) \\varepsilon d\$", text).group(1)
    assert WEDGE_TOL == int(tol) * EPS
    assert int(re.search(r"After (\d+) reflections", text).group(1)) == WEDGE_MAX_REFLECTIONS
    error = re.search(r"too low \(by ([0-9.]+) % in \$\\Gamma\$ for \$k = 1\$", MODEL_TEXT).group(1)
    assert round(-100 * tongue_errors(1, 0.5)["gamma_hi"], 1) == float(error)


PAGES = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]


def _named_in_pages(pattern: str) -> list[tuple[str, str]]:
    found = set()
    for page in PAGES:
        for name in re.findall(pattern, page.read_text(encoding="utf-8")):
            found.add((page.name, name))
    return sorted(found)


@pytest.mark.parametrize(("page", "path"), _named_in_pages(r"`(bbdyn/[\w/]+\.py)`"))
def test_file_named_in_docs_exists(page, path):
    assert (ROOT / path).is_file(), f"{page} names {path}, which does not exist"


@pytest.mark.parametrize(("page", "name"), _named_in_pages(r"`(bbdyn(?:\.\w+)+)`"))
def test_object_named_in_docs_exists(page, name):
    try:
        resolve(name)
    except (ModuleNotFoundError, AttributeError) as err:
        pytest.fail(f"{page} names {name}, which does not exist ({err})")
