"""Sphinx configuration: ``sphinx-build -W --keep-going docs docs/_build/html`` (see README)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")  # offscreen pyvista in notebooks
os.environ.setdefault("JAX_PLATFORMS", "cpu")

from zonotope import __version__  # noqa: E402

project = "zonotope"
author = "the zonotope developers"
copyright = "2026, the zonotope developers"
release = __version__
version = __version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_nb",
    "zdocs",
]

root_doc = "index"
# Every cross-reference must resolve (zdocs links module paths and short names to the public API pages,
# and turns references to existing undocumented or external objects into plain text).
nitpicky = True
exclude_patterns = ["_build", "jupyter_execute", "**.ipynb_checkpoints", "guide/cli_help/*"]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}

# -- autodoc / numpydoc ---------------------------------------------------------------------------
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types and shapes
autodoc_default_options = {"exclude-members": "__init__, __new__"}
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# Public names without a docstring fail the build: docs/_ext/zdocs.py warns for every name in a package's
# __all__ without a docstring (constants: without a '#:' comment), and ruff's D rules do so for public
# methods. numpydoc's own GL08 check is not used: it flags attributes documented by '#:' comments.

# -- notebooks (myst-nb) --------------------------------------------------------------------------
# Execution of the gallery: every notebook that does not carry outputs runs once during the build; one
# already executed (by `pytest --nbmake --overwrite`, as CI does first) is rendered as it is, because
# zdocs adds it to nb_execution_excludepatterns. ("auto" is not used: it would re-run an executed
# notebook for any code cell that prints nothing.) `-D nb_execution_mode=off` builds without running
# any; the gallery page says which of these happened to each notebook.
nb_execution_mode = "force"
nb_execution_excludepatterns: list[str] = []
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True
myst_enable_extensions = ["dollarmath", "amsmath"]
# Links to headings of Markdown pages (docs/benchmarks.md, docs/notes/*.md) by their anchors.
myst_heading_anchors = 3
# The changelog's version headings skip a level under the included page title; module docstrings list
# References that their text does not cite (numpydoc renames them, Sphinx then calls them unreferenced).
suppress_warnings = ["myst.header", "ref.citation"]

# -- HTML -----------------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"zonotope {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    # the header holds the top-level pages; each one's pages are listed in the left sidebar
    "header_links_before_dropdown": 4,
    "show_nav_level": 2,
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_static_path = ["_static"]
html_css_files = ["zdocs.css"]
# The left sidebar lists a section's pages; pages that have none (the root page, which lists every section
# in its text, and the single-page sections) get no empty sidebar.
html_sidebars = {
    page: [] for page in ("index", "install", "guide/cli", "exact", "math", "data", "benchmarks", "changelog")
}
