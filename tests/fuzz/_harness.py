"""Shared machinery of the fuzz tables: run a command or a call, classify what came out.

Every case ends in one of three outcomes, counted per input kind (``TALLY``) and printed at
the end of the session (``conftest.py``):

``clear``
    a one-line error (``error: ...``) with the expected exit status and wording, or the
    correct result (checked against a reference, never just "it ran");
``traceback``
    an exception escaped (a Python traceback on stderr, or out of ``main``);
``silent``
    anything else: exit 0 with a wrong or unchecked result, a wrong status, a vague message.

A case asserts ``clear``, so the suite fails on the other two. New bugs become new rows.
"""

from __future__ import annotations

import collections
import contextlib
import io
import re
from dataclasses import dataclass
from pathlib import Path

from vectorid.cli import main

#: kind -> Counter(outcome)
TALLY: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
#: Lines printed under the table (measurements of a case: time, memory).
NOTES: list[str] = []


@dataclass
class Result:
    code: int | None
    out: str
    err: str
    exc: BaseException | None = None


def cli(*argv: object) -> Result:
    """``vectorid ARGV`` in this process (stdout and stderr captured)."""
    out, err = io.StringIO(), io.StringIO()
    code: int | None = None
    exc: BaseException | None = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as e:  # argparse usage errors
            code = e.code if isinstance(e.code, int) else 2
        except BaseException as e:
            exc = e
    return Result(code, out.getvalue(), err.getvalue(), exc)


def classify_error(
    r: Result, match: str | None, code: int = 2, one_line: bool = True
) -> tuple[str, str]:
    """Outcome of a case that must fail with a clear error."""
    if r.exc is not None:
        return "traceback", f"{type(r.exc).__name__}: {r.exc}"
    if "Traceback (most recent call last)" in r.err:
        return "traceback", r.err[-2000:]
    errors = [ln for ln in r.err.splitlines() if ln.startswith("error:")]
    usage = code == 2 and "usage:" in r.err and any(": error:" in ln for ln in r.err.splitlines())
    if r.code != code:
        return "silent", f"exit {r.code}, expected {code}; stderr: {r.err[-800:]}"
    if not errors and not usage:
        return "silent", f"no 'error:' line; stderr: {r.err[-800:]}"
    if one_line and len(errors) > 1:
        return "silent", f"{len(errors)} error lines: {errors}"
    text = r.err
    if match is not None and not re.search(match, text, re.S):
        return "silent", f"message does not match {match!r}: {text[-800:]}"
    return "clear", ""


def expect_error(
    kind: str, r: Result, match: str | None, code: int = 2, one_line: bool = True
) -> None:
    outcome, why = classify_error(r, match, code, one_line)
    TALLY[kind][outcome] += 1
    assert outcome == "clear", f"[{outcome}] {why}"


def expect(kind: str, ok: bool, why: str = "", r: Result | None = None) -> None:
    """A case whose correct result was checked by the caller (``ok``)."""
    if r is not None and (r.exc is not None or "Traceback (most recent call last)" in r.err):
        TALLY[kind]["traceback"] += 1
        raise AssertionError(f"[traceback] {r.exc!r} {r.err[-2000:]}")
    TALLY[kind]["clear" if ok else "silent"] += 1
    assert ok, f"[silent] {why}"


def write(path: Path, text: str | bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path
