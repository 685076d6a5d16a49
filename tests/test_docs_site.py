"""The documentation site (docs/conf.py) builds with warnings as errors, the notebooks executed,
and shows what it claims: every notebook with its figures, the quickstart's output, every
committed figure in the gallery with what its JSON records, every public module in the API
reference.

One build (the session fixture ``site`` of conftest.py: about 2 minutes on 2 cores, most of it
running the notebooks) serves all tests, those of tests/test_notebooks.py included.
"""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest
from extras import require_docs_toolchain

require_docs_toolchain()

from bbdyn.scenes import scene_module  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
FIGURES = DOCS / "figures"
#: modules that are not part of the Python API: the command line, the one module per scene
#: (``bbdyn.scenes.s1_tongues`` ...; the gallery shows them)
NOT_API = re.compile(r"bbdyn\.(__main__|cli|commands)(\.|$)|bbdyn\.scenes\.[sb]\d+_")


def text_of(fragment: str) -> str:
    """The visible text of an HTML fragment, whitespace collapsed."""
    return " ".join(html.unescape(re.sub(r"<[^>]+>", " ", fragment)).split())


def section(page: str, anchor: str) -> str:
    """The HTML of ``<section id="anchor">`` up to the next section of the page."""
    start = page.index(f'<section id="{anchor}">')
    end = page.find("<section id=", start + 1)
    return page[start : end if end >= 0 else None]


def test_every_page_is_built(site):
    pages = [p.relative_to(DOCS).with_suffix(".html") for p in DOCS.glob("*.md")]
    pages += [Path("notebooks", p.stem + ".html") for p in NOTEBOOKS]
    pages += [p.relative_to(DOCS).with_suffix(".html") for p in (DOCS / "api").glob("*.md")]
    missing = [str(p) for p in pages if not (site / p).is_file()]
    assert not missing, missing
    assert len(pages) >= 20 + len(NOTEBOOKS)


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_page_shows_its_executed_figures(site, notebook):
    """The notebooks are stored without outputs, so an image on the page was drawn at build time."""
    page = (site / "notebooks" / f"{notebook.stem}.html").read_text(encoding="utf-8")
    images = re.findall(r'<img [^>]*src="\.\./_images/([^"]+)"', page)
    assert images, f"{notebook.name}: no figure on its page"
    assert all((site / "_images" / name).stat().st_size > 1000 for name in images)


def test_quickstart_output_is_on_the_page(site):
    """getting_started.md runs the README's example at build time (and checks it against the
    CLI); its printed line is on the page."""
    page = text_of((site / "getting_started.html").read_text(encoding="utf-8"))
    number = r"-?[0-9][0-9.]*(?:e[+-]?[0-9]+)?"
    line = rf"D = {number} \+- {number} mm\^2/s, E = {number} kg mm\^2/s\^2"
    assert re.search(line, page), page[:2000]


@pytest.mark.parametrize("record", sorted(FIGURES.glob("*.json")), ids=lambda p: p.stem)
def test_gallery_shows_the_figure_with_what_its_json_records(site, record):
    data = json.loads(record.read_text())
    if "provenance" in data.get("meta", {}):
        prov = data["meta"]["provenance"]
        scene, commit, run = prov["scene"], prov["commit"], f"{prov['run_s']:.1f} s"
    else:  # a note written for a figure made before provenance was recorded
        rec = data["record"]
        scene, commit, run = rec["scene"], rec["commit"], rec["run"]
    page = (site / "gallery.html").read_text(encoding="utf-8")
    entry = section(page, "gallery-" + record.stem.lower().replace("_", "-"))
    words = text_of(entry)
    assert scene_module(scene).TITLE in words
    assert f"bbdyn reproduce --docs --only {scene}" in words
    assert f"run time: {run}; commit: {commit[:7]}" in words
    image = re.search(r'<img [^>]*src="_images/([^"]+)"', entry).group(1)
    assert (site / "_images" / image).read_bytes() == record.with_suffix(".png").read_bytes()


def test_api_reference_lists_every_public_module_once():
    """Each module of bbdyn's Python API is on exactly one layer page of docs/api."""
    listed = []
    for page in sorted((DOCS / "api").glob("*.md")):
        listed += re.findall(r"^   (bbdyn[\w.]*)$", page.read_text(encoding="utf-8"), flags=re.M)
    files = (p.relative_to(ROOT).with_suffix("") for p in (ROOT / "bbdyn").rglob("*.py"))
    names = {".".join(f.parts[:-1] if f.name == "__init__" else f.parts) for f in files}
    modules = {name for name in names if name != "bbdyn" and not NOT_API.match(name)}
    assert len(listed) == len(set(listed)), "a module is listed twice"
    assert set(listed) == modules, set(listed) ^ modules


def test_api_page_documents_the_members(site):
    """An API page carries the docstrings of the module's public functions and classes."""
    from bbdyn import ensemble

    page = text_of((site / "api" / "generated" / "bbdyn.ensemble.html").read_text("utf-8"))
    for name in ensemble.__all__:
        first_line = getattr(ensemble, name).__doc__.strip().splitlines()[0]
        assert first_line.split("``")[0].strip() in page, name


def _mathjax_sources(page: Path) -> list[str]:
    """The ``src`` of every script of an HTML page that loads MathJax."""
    scripts = re.findall(r'<script [^>]*src="([^"]+)"', page.read_text(encoding="utf-8"))
    return [src for src in scripts if "mathjax" in src.lower()]


def test_equations_render_offline(site):
    """Pages with equations (the model page, the notebooks with LaTeX) typeset them with a
    MathJax served by the site itself: every page that shows math or loads MathJax loads a
    file of the build, with no host."""
    model = (site / "model.html").read_text(encoding="utf-8")
    assert model.count('class="math') >= 20, "docs/model.md shows too few equations"
    with_math = []
    for page in sorted(site.rglob("*.html")):
        sources = _mathjax_sources(page)
        if 'class="math' in page.read_text(encoding="utf-8"):
            with_math.append(page.relative_to(site).as_posix())
            assert sources, f"{page.name} shows math but loads no MathJax"
        for src in sources:
            assert "://" not in src and not src.startswith("//"), f"{page.name}: {src}"
            assert (page.parent / src.split("?")[0]).is_file(), f"{page.name}: {src} missing"
    assert "model.html" in with_math
    assert any(name.startswith("notebooks/") for name in with_math), with_math


def test_mathjax_is_a_file_of_the_site_by_configuration(tmp_path):
    """Without building: the configuration (docs/conf.py and its extensions) points MathJax
    to a path inside the site, and the file there is one that the configuration ships."""
    from sphinx.application import Sphinx

    app = Sphinx(str(DOCS), str(DOCS), str(tmp_path), str(tmp_path / "doctrees"), "html",
                 status=None, warning=None, freshenv=True)  # fmt: skip
    path = app.config.mathjax_path
    assert "://" not in path and not path.startswith("//"), path
    shipped = [DOCS / d for d in app.config.html_static_path]
    shipped += [Path(ext.module.__file__).parent / "static" for ext in app.extensions.values()]
    assert any((d / path).is_file() for d in shipped), (path, shipped)
