"""The documentation site: Sphinx builds docs/ (the guides and the API reference generated from
the package's numpydoc docstrings) with warnings as errors, as a user or CI would build it.

numpydoc's validation (docs/conf.py) turns a public name without a docstring, or a parameter
its docstring leaves out, into a warning, so this test fails on either.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

import vectorid

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
API = DOCS / "reference" / "api.rst"


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    cmd = [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-E", "-q", "-b", "html",
           str(DOCS), str(out)]  # fmt: skip
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, (
        f"the docs site does not build without warnings ({' '.join(cmd)}):\n"
        f"{r.stdout[-3000:]}\n{r.stderr[-6000:]}"
    )
    return out


def test_site_builds_without_warnings(site):
    assert (site / "index.html").is_file()
    pages = {p.stem for p in site.glob("*.html")}
    # every guide of docs/ is a page of the site (the toctree globs them)
    assert {p.stem for p in DOCS.glob("*.md")} <= pages


def test_api_reference_documents_the_public_names(site):
    html = (site / "reference" / "api.html").read_text(encoding="utf-8")
    names = ("Study.open", "Study.run", "Analysis.to_frame", "Analysis.verdicts_frame",
             "Analysis.constraints_in_force", "Trials", "ParameterVerdict.value_text",
             "models.Model.simulate", "models.get")  # fmt: skip
    for name in names:
        assert f'id="vectorid.{name}"' in html, f"vectorid.{name} is not in the API reference"
    # units are part of the reference, not only of the prose
    assert "in the criterion" in html and "wall time" in html


def test_every_public_name_is_in_the_api_reference():
    text = API.read_text(encoding="utf-8")
    listed = set(re.findall(r"^\.\. auto\w+:: vectorid\.(\w+)\s*$", text, re.M))
    public = {n for n in vectorid.__all__ if not n.startswith("__")}
    assert public == listed, (
        f"docs/reference/api.rst and vectorid.__all__ differ: missing {sorted(public - listed)}, "
        f"not public {sorted(listed - public)}"
    )
