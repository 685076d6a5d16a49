"""Sphinx configuration of bbdyn's documentation site.

Build (warnings are errors; the notebooks of ``notebooks/`` are executed):

    pip install -e '.[docs]' && sphinx-build -W --keep-going -b html docs docs/_build/html

Pages are Markdown (MyST, through myst-nb); ``docs/notebooks`` is a link to ``notebooks/``.
The gallery (``gallery.md``) is filled at build time from ``docs/figures/*.json`` by the local
extension ``_ext/gallery.py``; the API pages (``api/*.md``) list their modules and
autosummary writes one page per module into ``api/generated/`` (not committed).
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent

# Document and execute the bbdyn of this checkout, also in the notebook kernels (which
# inherit the environment), whatever bbdyn is installed.
sys.path.insert(0, str(ROOT))
os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
# The kernels draw with their inline backend (tests/test_notebooks.py checks the figures).
os.environ.pop("MPLBACKEND", None)
sys.path.insert(0, str(DOCS / "_ext"))

import bbdyn  # noqa: E402

project = "bbdyn"
author = "the bbdyn developers"
copyright = "2026, the bbdyn developers"
version = release = bbdyn.__version__

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "gallery",
    "datavalue",
    "devicereport",
    # MathJax 3 copied into the site's _static and loaded from there (``mathjax_path``):
    # equations, on the pages and in the notebooks, render with no network.
    "sphinx-mathjax-offline",
]

# Only pages are sources: not the build, the figure data, the scripts or the checkpoints.
exclude_patterns = ["_build", "figures", "**/.ipynb_checkpoints", "_ext", "_templates"]
templates_path = ["_templates"]
# .rst first: autosummary writes its generated pages (reST) with the first suffix.
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}

# --- MyST and notebooks ----------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "colon_fence", "attrs_inline"]
myst_heading_anchors = 3
nb_execution_mode = "force"  # every build runs every notebook: figures and asserts are current
nb_execution_raise_on_error = True
nb_execution_timeout = 300  # s per cell
nb_execution_show_tb = True

# --- API reference -----------------------------------------------------------------------------
autosummary_generate = True  # one page per module: its docstring, then every public member
# autosummary writes api/generated anew but never deletes a page: start from an empty folder,
# so a module that was renamed or removed leaves no stale page behind (a build error)
shutil.rmtree(DOCS / "api" / "generated", ignore_errors=True)
autodoc_default_options = {"members": True, "member-order": "bysource"}
autodoc_typehints = "none"  # the numpydoc docstrings state types and units
numpydoc_show_class_members = False
numpydoc_validation_checks: set[str] = set()

# --- HTML --------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"bbdyn {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "header_links_before_dropdown": 8,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
# Pages without sub-pages get no (empty) section navigation on the left.
html_sidebars = {
    page: [] for page in ("index", "getting_started", "model", "gallery", "results", "paper")
}


def skip_reexports(app, what, name, obj, skip, options):
    """Document each function and class once, in the module that defines it: skip a module's
    members imported from elsewhere (``bbdyn.approx`` re-exports ``green_kubo`` ...)."""
    if what != "module" or not (callable(obj) or isinstance(obj, type)):
        return None
    defined_in = getattr(obj, "__module__", None)
    documented = app.env.current_document.autodoc_module
    return True if isinstance(defined_in, str) and defined_in != documented else None


def setup(app):
    app.connect("autodoc-skip-member", skip_reexports)
