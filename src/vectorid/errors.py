"""Exceptions raised by vectorid.

Every error a user can cause says what was expected, what came, and how to fix it.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = [
    "StoreError",
    "StoreLockedError",
    "StudyDefinitionError",
    "VectoridError",
    "suggest",
]


class VectoridError(Exception):
    """Base class of every error vectorid raises on purpose."""


class StudyDefinitionError(VectoridError, ValueError):
    """A study definition (Python objects or TOML file) is invalid.

    Parameters
    ----------
    field : str
        Dotted path of the offending field, e.g. ``"variables[2].low"``.
    problem : str
        What is wrong, including what came.
    fix : str, optional
        How to fix it.
    """

    def __init__(self, field: str, problem: str, fix: str = "") -> None:
        self.field = field
        self.problem = problem
        self.fix = fix
        message = f"{field}: {problem}"
        if fix:
            message += f" — {fix}"
        super().__init__(message)


class StoreError(VectoridError):
    """A study store cannot be opened, read or written."""


class StoreLockedError(StoreError):
    """Another process is writing to the same study store."""


def suggest(word: str, candidates: Iterable[str]) -> str:
    """Return a ``"did you mean 'x'?"`` hint, or a list of valid names.

    Parameters
    ----------
    word : str
        The unknown name the user typed.
    candidates : iterable of str
        The valid names.

    Returns
    -------
    str
        A short sentence that can follow an error message.
    """
    candidates = sorted(candidates)
    close = difflib.get_close_matches(word, candidates, n=1, cutoff=0.6)
    if close:
        return f"did you mean {close[0]!r}? (valid: {', '.join(candidates)})"
    return f"valid names are: {', '.join(candidates) if candidates else '(none)'}"
