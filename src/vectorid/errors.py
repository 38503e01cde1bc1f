"""Exceptions raised by vectorid.

Every error a user can cause says what was expected, what came, and how to fix it.
"""

from __future__ import annotations

import difflib
import warnings
from collections.abc import Iterable

__all__ = [
    "RunFailedError",
    "StoreDamagedError",
    "StoreError",
    "StoreLockedError",
    "StudyDefinitionError",
    "VectoridError",
    "VectoridNote",
    "VectoridWarning",
    "is_number",
    "plural",
    "shown",
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


class StoreDamagedError(StoreError):
    """A study store's file is damaged where no analysis can go on (its definition, its
    tables or SQLite's own pages); damaged trial batches are left out with a warning instead
    (see :meth:`vectorid.store.Store.verify`)."""


class RunFailedError(VectoridError):
    """A run stopped because its first batch showed the study cannot work as defined (every
    trial failed for the same reason); nothing of that batch was stored."""


class VectoridWarning(UserWarning):
    """Something the user must know that does not stop the work: damaged batches left out of
    an analysis, a store upgraded to a newer schema, more workers than cores. The command
    line prints these as one ``warning:`` line each."""


class VectoridNote(VectoridWarning):
    """Something vectorid decided on the user's behalf and says so (a study-file change
    taken into the store, an empty store re-created): printed as one ``note:`` line, on the
    command line and in Python alike (not in Python's warning format with a file and line:
    it is no fault). Filter it like any warning: ``warnings.simplefilter("ignore",
    VectoridNote)``."""


def _format_warning(
    message: Warning | str, category: type[Warning], filename: str, lineno: int,
    line: str | None = None,
) -> str:  # fmt: skip
    """:func:`warnings.formatwarning` that prints a :class:`VectoridNote` as ``note: ...``
    (one line, no source location); every other warning as Python does."""
    if isinstance(category, type) and issubclass(category, VectoridNote):
        return f"note: {message}\n"
    return _PYTHON_FORMAT(message, category, filename, lineno, line)


# Installed once (a reload keeps Python's own as the fallback, never itself).
_PYTHON_FORMAT = getattr(warnings.formatwarning, "_vectorid_fallback", warnings.formatwarning)
_format_warning._vectorid_fallback = _PYTHON_FORMAT  # type: ignore[attr-defined]
warnings.formatwarning = _format_warning


#: Plurals that are not the singular plus "s".
_PLURALS = {"criterion": "criteria", "batch": "batches", "process": "processes",
            "matrix": "matrices", "this": "these"}  # fmt: skip


def plural(n: int, word: str, many: str | None = None) -> str:
    """A count with its noun in the right number: ``"1 criterion"``, ``"2 criteria"``,
    ``"0 members"``.

    Parameters
    ----------
    n : int
        The count.
    word : str
        The noun in the singular.
    many : str, optional
        Its plural (default: a known irregular one, else ``word + "s"``).

    Returns
    -------
    str

    Examples
    --------
    >>> plural(1, "criterion"), plural(8, "criterion"), plural(1, "member"), plural(0, "batch")
    ('1 criterion', '8 criteria', '1 member', '0 batches')
    """
    if n == 1:
        return f"{n} {word}"
    return f"{n} {many or _PLURALS.get(word, word + 's')}"


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


def is_number(value: object) -> bool:
    """True for a real number: an int or float (numpy's included), never a bool, a string or
    a complex number. Study files are typed: ``high = true`` or ``low = "0"`` is an error,
    not 1.0 or 0.0."""
    import numbers

    return (
        isinstance(value, numbers.Real)
        and not isinstance(value, bool)
        and not (type(value).__name__ == "bool_")
    )


def shown(value: object) -> str:
    """A value as the user wrote it in a study file: ``true``, ``"0"``, ``[1, 2]``, ``5``."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace('"', '\\"') + '"'
    return repr(value)
