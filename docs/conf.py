"""Sphinx configuration of auvdock's manual.

Build (no network needed; warnings are errors, as in CI)::

    python -m pip install -e ".[docs]"
    python -m sphinx -W --keep-going -b html docs docs/_build/html

Pages are Markdown (myst-parser); the API reference is generated from the package's
numpydoc docstrings by autosummary into ``docs/api/_autosummary`` (not committed).
"""

from __future__ import annotations

import shutil
import sys
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


project = "auvdock"
author = "the auvdock authors"
copyright = "auvdock authors, MIT licence"
try:
    release = metadata.version("auvdock")
except metadata.PackageNotFoundError:  # pragma: no cover - a checkout that is not installed
    release = "0.1.0"
version = ".".join(release.split(".")[:2])

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    # MathJax shipped with the manual (no CDN): the pages load nothing from outside
    "sphinx-mathjax-offline",
    "numpydoc",
]

# autosummary writes its generated pages as reStructuredText
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
# docs/compare and docs/sweeps are campaign outputs written by `auvdock compare` / `auvdock
# sweep` (their figures are shown in the pages; their Markdown is not part of the manual).
exclude_patterns = ["_build", "compare", "sweeps"]
templates_path = ["_templates"]

# --- Markdown -----------------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# --- API reference --------------------------------------------------------------------------
# The pages are generated afresh at every build: autosummary never removes the page of a module
# that has since been moved or deleted, and a stale page would be read (and fail to import).
shutil.rmtree(ROOT / "docs" / "api" / "_autosummary", ignore_errors=True)
autosummary_generate = True
autosummary_imported_members = False
# modules left out of the recursive walk, with why: auvdock.cli's attribute ``app`` (the Typer
# application) hides the module auvdock.cli.app, so that name documents the Typer object instead
autosummary_context = {"skip_modules": ["auvdock.cli.app"]}
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_member_order = "bysource"
autodoc_typehints = "none"  # the docstrings state the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()
numpydoc_xref_param_type = False

# --- output ---------------------------------------------------------------------------------
html_theme = "alabaster"
html_title = f"auvdock {release}"
html_static_path: list[str] = []
html_theme_options = {
    "description": "FSE-MPC docking of a BlueROV2 Heavy",
    "fixed_sidebar": True,
    "show_powered_by": False,
}
html_show_sphinx = False
# no intersphinx, no remote images: the build needs no network
