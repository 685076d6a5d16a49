"""Licence, citation and package metadata: one version, sympy only for the derivations.

``CITATION.cff`` is validated against the CFF 1.2.0 schema by ``cffconvert --validate``
where cffconvert is installed (it is not part of any extra); here it is read as YAML and
its fields checked against the package and the reference paper (docs/paper.md).
"""

import importlib.metadata
import re
import tomllib

import pytest
from derivation_loader import ROOT
from extras import require

import bbdyn

PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
PROJECT = PYPROJECT["project"]
DEVELOPERS = "the bbdyn developers"


def test_version_is_written_in_one_place():
    """pyproject.toml reads the version from bbdyn.__version__ (and writes none itself)."""
    assert "version" not in PROJECT and "version" in PROJECT["dynamic"]
    attr = PYPROJECT["tool"]["setuptools"]["dynamic"]["version"]["attr"]
    assert attr == "bbdyn.__version__"
    assert re.fullmatch(r"\d+\.\d+\.\d+", bbdyn.__version__)
    try:
        installed = importlib.metadata.version("bbdyn")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("bbdyn is not installed (pip install -e .)")
    assert installed == bbdyn.__version__


def test_license_and_authors():
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("BSD 3-Clause License")
    assert f"Copyright (c) 2026, {DEVELOPERS}" in text
    assert PROJECT["license"] == "BSD-3-Clause" and PROJECT["license-files"] == ["LICENSE"]
    assert PROJECT["authors"] == [{"name": DEVELOPERS}]
    assert "Topic :: Scientific/Engineering :: Physics" in PROJECT["classifiers"]


def test_citation_file_cites_the_software_and_the_paper():
    yaml = require("yaml", "docs")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert cff["authors"] == [{"name": DEVELOPERS}]
    assert cff["version"] == bbdyn.__version__
    assert cff["license"] == PROJECT["license"]
    assert cff["title"].startswith("bbdyn") and cff["message"]
    (paper,) = cff["references"]
    names = [(a["family-names"], a["given-names"]) for a in paper["authors"]]
    assert names == [("Mátyás", "L."), ("Klages", "R.")]
    assert paper["title"] == "Irregular diffusion in the bouncing ball billiard"
    assert "Physica D" in paper["journal"]
    assert (paper["volume"], paper["start"], paper["end"], paper["year"]) == (187, 165, 183, 2004)
    assert "Physica D 187" in (ROOT / "docs" / "paper.md").read_text(encoding="utf-8")


def test_sympy_is_an_extra_that_bbdyn_never_imports():
    assert not any(dep.startswith("sympy") for dep in PROJECT["dependencies"])
    extras = PROJECT["optional-dependencies"]
    assert any(dep.startswith("sympy") for dep in extras["derivations"])
    importing = re.compile(r"^\s*(import sympy|from sympy)", re.M)
    offenders = [
        str(p.relative_to(ROOT))
        for p in (ROOT / "bbdyn").rglob("*.py")
        if importing.search(p.read_text(encoding="utf-8"))
    ]
    assert not offenders, offenders


def test_the_test_extra_holds_what_the_default_run_needs_only():
    """The peers (heyoka), dask and linter packages are not in the test extra: their tests
    skip without them (tests/extras.py)."""
    test = PROJECT["optional-dependencies"]["test"]
    names = {re.match(r"[A-Za-z0-9_.\-]+(\[[^]]*\])?", dep).group() for dep in test}
    assert not names & {"heyoka", "ruff", "dask", "dask[distributed]", "bbdyn[peers]"}
    assert not names & {"bbdyn[dask]", "distributed"}
    assert {"pytest", "hypothesis", "bbdyn[docs]", "bbdyn[derivations]"} <= names
