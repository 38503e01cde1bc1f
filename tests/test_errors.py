"""Messages: counts in the right number, notes printed as notes (issue 37)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from vectorid.errors import plural


def test_plural():
    assert plural(1, "criterion") == "1 criterion" and plural(2, "criterion") == "2 criteria"
    assert plural(1, "member") == "1 member" and plural(0, "member") == "0 members"
    assert plural(3, "batch") == "3 batches" and plural(1, "batch") == "1 batch"
    assert plural(2, "axis", "axes") == "2 axes"


def test_a_note_prints_as_a_note_in_python_and_other_warnings_as_python_does():
    """In a script (the README's tour), a VectoridNote is one ``note:`` line, not Python's
    warning format with a file and line; a VectoridWarning and other warnings keep theirs."""
    script = textwrap.dedent(
        """
        import warnings
        from vectorid.errors import VectoridNote, VectoridWarning
        warnings.warn(VectoridNote("taken from the study file: a description"))
        warnings.warn(VectoridWarning("damaged batches left out"))
        warnings.warn("a plain one")
        """
    )
    err = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True).stderr
    lines = err.strip().splitlines()
    assert lines[0] == "note: taken from the study file: a description"
    assert "VectoridWarning: damaged batches left out" in err and ":5:" in err
    assert "UserWarning: a plain one" in err
