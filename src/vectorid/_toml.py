"""Writing TOML: the one writer of the study files the library composes (the demos' stages,
the two-step identification's control step).

:func:`toml_value` writes one value inline (numbers as Python writes them, so that a float
reads back to the same bits; strings JSON-quoted, which TOML accepts; lists and mappings as
inline arrays and tables); :func:`toml_key` quotes a key only where TOML needs it;
:func:`toml_tables` writes a document of ``[table]`` and ``[[array of tables]]`` sections in
the order given. Reading is :mod:`tomllib`'s.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

__all__ = ["toml_key", "toml_tables", "toml_value"]

_BARE = re.compile(r"[A-Za-z0-9_-]+")


def toml_key(key: str) -> str:
    """``key`` as a TOML key: bare where it is letters, digits, ``_`` and ``-``, else quoted."""
    return key if _BARE.fullmatch(key) else json.dumps(key)


def toml_value(value: Any) -> str:
    """One value as inline TOML.

    Parameters
    ----------
    value : bool, int, float, str, sequence or mapping
        Nested sequences and mappings are written as inline arrays and inline tables.

    Raises
    ------
    TypeError
        For a value TOML cannot hold (None, an object), naming it.
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return repr(int(value))
    if isinstance(value, float):
        return repr(float(value))
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, Mapping):
        items = ", ".join(f"{toml_key(str(k))} = {toml_value(v)}" for k, v in value.items())
        return "{ " + items + " }"
    if isinstance(value, Sequence):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {value!r} ({type(value).__name__}) as TOML")


def toml_tables(
    tables: Iterable[tuple[str, Mapping[str, Any] | Sequence[Mapping[str, Any]]]],
    header: str = "",
) -> str:
    """A TOML document: each ``(name, table)`` as ``[name]`` with one ``key = value`` line per
    entry, each ``(name, [table, ...])`` as one ``[[name]]`` section per table, in the order
    given and separated by blank lines; ``header`` lines first, as comments."""
    lines = [f"# {ln}" for ln in header.splitlines()]
    for name, body in tables:
        sections = [body] if isinstance(body, Mapping) else list(body)
        head = f"[{name}]" if isinstance(body, Mapping) else f"[[{name}]]"
        for section in sections:
            if len(lines) > len(header.splitlines()):
                lines.append("")
            lines.append(head)
            lines += [f"{toml_key(str(k))} = {toml_value(v)}" for k, v in section.items()]
    return "\n".join(lines) + "\n"
