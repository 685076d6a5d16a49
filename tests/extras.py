"""Optional extras of pyproject.toml that some tests need: without one, its tests skip and
say which extra to install."""

import pytest


def require(module: str, extra: str):
    """``module`` imported, or skip the calling test (module) naming the extra that brings it."""
    return pytest.importorskip(
        module, reason=f"{module} not installed (optional extra: pip install -e '.[{extra}]')"
    )


#: The modules of the docs extra that the documentation site's build needs (docs/conf.py).
DOCS_TOOLCHAIN = ("sphinx", "myst_nb", "numpydoc", "pydata_sphinx_theme", "sphinx-mathjax-offline")


def require_docs_toolchain() -> None:
    """Skip the calling test (module) unless the docs extra is installed."""
    for module in DOCS_TOOLCHAIN:
        require(module, "docs")
