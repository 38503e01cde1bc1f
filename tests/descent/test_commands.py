"""Each shared flight's documented ``vectorid descent`` command (docs/descent.md, printed by
``examples/descent_gallery.py --commands``) builds the gallery's plan of that flight: only what
the flight's README states (mass, canopies, trigger, lag, pad, and a unit where the file states
none). Parsed, not run (the gallery's test runs the flights)."""

from __future__ import annotations

import importlib.util
import math
import shlex
from pathlib import Path

import pytest

from vectorid.cli.descent import plan_from_args
from vectorid.cli.main import _parser
from vectorid.descent import DescentPlan

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("descent_gallery", ROOT / "examples" /
                                               "descent_gallery.py")  # fmt: skip
GALLERY = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(GALLERY)

FIELDS = ("mass", "convention", "main_at", "main_lag", "pad_altitude", "altitude_reference",
          "time_unit", "altitude_unit", "format", "columns", "start", "end", "windows")  # fmt: skip


def _close(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float | int):
        return math.isclose(a, b, rel_tol=1e-9)
    return a == b


@pytest.mark.parametrize("name", list(GALLERY.FLIGHTS))
def test_the_documented_command_is_the_gallery_plan(name):
    line = GALLERY.command(name)
    argv = shlex.split(line)[1:]  # without the program
    cmd = plan_from_args(_parser().parse_args(argv))
    rel, kw, _ = GALLERY.FLIGHTS[name]
    plan = DescentPlan(file=Path("../shared/data") / rel, **kw)
    assert Path(cmd.file) == plan.file
    for f in FIELDS:
        assert _close(getattr(cmd, f), getattr(plan, f)), (f, getattr(cmd, f), getattr(plan, f))
    for c in ("drogue", "main"):
        a, b = getattr(cmd, c), getattr(plan, c)
        assert (a is None) == (b is None), c
        if a is not None:
            for f in ("cds", "diameter", "cd"):
                va, vb = getattr(a, f), getattr(b, f)
                assert (va is None) == (vb is None) and (va is None or _close(va, vb)), (c, f)


def test_docs_list_every_flight_command():
    text = (ROOT / "docs" / "descent.md").read_text(encoding="utf-8")
    for name in GALLERY.FLIGHTS:
        assert GALLERY.command(name) in text.replace("\\\n    ", ""), name
