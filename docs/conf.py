"""Sphinx configuration of vectorid's documentation site.

Build it (warnings are errors, as tests/test_docs_site.py builds it)::

    .venv/bin/python -m sphinx -W --keep-going -b html docs docs/_build/html

The pages are the Markdown files of this folder (MyST) and the API reference generated from
the package's numpydoc docstrings (``api.rst``).
"""

from __future__ import annotations

import vectorid

project = "vectorid"
author = "vectorid developers"
copyright = "vectorid developers"  # noqa: A001 - Sphinx's name
release = version = vectorid.__version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.intersphinx",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]

# Markdown: GitHub-style anchors (#the-identification-table) and colon fences for directives,
# so that ``` fences stay plain code blocks that tests/test_docs.py runs.
myst_enable_extensions = ["colon_fence"]
myst_heading_anchors = 4
# index.md lists the guides in reading order, then globs the rest ("*"), so that a new page
# joins the site by itself; contributing.md is left to the glob so that it always matches
# (Sphinx warns about a glob that matches nothing, and that warning cannot be suppressed).

# API reference: the docstrings are numpydoc; class members are listed by autodoc.
autodoc_member_order = "bysource"
# undocumented members are listed too, so that GL08 below catches them instead of autodoc
# leaving them out in silence
autodoc_default_options = {"undoc-members": True}
autodoc_typehints = "none"  # the numpydoc sections say the types, with units
numpydoc_show_class_members = False
numpydoc_xref_param_type = False
# Every public name documented: a missing docstring or an undocumented parameter is a warning,
# and warnings are errors in the build (tests/test_docs_site.py).
numpydoc_validation_checks = {"GL08", "PR01", "PR02"}
# Results a user reads but never builds: their fields are documented under "Attributes"
# (numpydoc's PR01 would ask for the dataclass constructor's parameters instead).
numpydoc_validation_exclude = {
    r"^vectorid\.(Trials|RunSummary|TestTable|EmptyDiagnosis|ParameterVerdict)$",
    r"^vectorid\.models\.(SimulationResult|SystemResult)$",
    r"^vectorid\.analysis\.combinations\.Combination$",
    r"^vectorid\.workflows\.design\.(Design|Candidate)$",
    # a class attribute documented by its ``#:`` comment, which autodoc shows
    r"^vectorid\.models\.Model\.compile_seconds$",
}

intersphinx_mapping = {}  # no network at build time

html_theme = "alabaster"
html_title = f"vectorid {release}"
html_static_path: list[str] = []
