"""The Examples of the public API's docstrings run, as doctests (issue 37).

``Study``, ``Study.run`` (the sequential sampler's options), ``Analysis``, ``models.get``,
``sampler_kinds.sampler_kind`` (the sampler options) and the message helpers carry numpydoc
``Examples``; this runs them, so an example that stops working fails the suite.
"""

from __future__ import annotations

import doctest
import importlib

import pytest

#: Modules whose docstrings' examples run, and the names that must have an Examples section.
MODULES = {
    "vectorid.study": ("Study", "Study.run"),
    "vectorid.analysis.results": ("Analysis",),
    "vectorid.models": ("get",),
    "vectorid.sampler_kinds": ("sampler_kind",),
    "vectorid.errors": ("plural",),
}


@pytest.mark.parametrize("module", sorted(MODULES))
def test_docstring_examples_run(module):
    mod = importlib.import_module(module)
    for name in MODULES[module]:
        obj = mod
        for part in name.split("."):
            obj = getattr(obj, part)
        assert "Examples\n" in (obj.__doc__ or ""), f"{module}.{name} has no Examples section"
    flags = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
    result = doctest.testmod(mod, optionflags=flags, verbose=False, report=True)
    assert result.attempted > 0, f"no example ran in {module}"
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {module}"
