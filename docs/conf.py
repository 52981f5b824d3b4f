"""Sphinx configuration of the K37 manual (MyST Markdown pages).

Build it from the repository's root (warnings are errors, as in CI)::

    python -m sphinx -W -b html docs docs/_build/html
"""

import sys
from importlib import metadata
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path[:0] = [str(DOCS.parent), str(DOCS / "_ext")]

project = "K37"
author = "the K37 authors"
copyright = "the K37 authors, MIT licence"

try:
    release = metadata.version("k37")
except metadata.PackageNotFoundError:
    release = "0.1.0"

extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.napoleon", "k37_sphinx"]
source_suffix = {".md": "markdown"}
root_doc = "index"
# job-keys.md is included by guide/jobs.md; the rest of the folder is not pages.
exclude_patterns = ["_build", "_ext", "job-keys.md"]

myst_enable_extensions = ["colon_fence", "deflist", "dollarmath"]
myst_heading_anchors = 3

autodoc_member_order = "bysource"
autodoc_typehints = "description"
napoleon_numpy_docstring = True
napoleon_google_docstring = False

html_theme = "alabaster"
html_title = f"K37 {release}"
html_static_path: list[str] = []
