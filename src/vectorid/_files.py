"""The content hash of a file, the one the stores record for model code and data files."""

from __future__ import annotations

import hashlib
from pathlib import Path

__all__ = ["file_sha256"]


def file_sha256(path: str | Path) -> str | None:
    """SHA-256 of a file's bytes, as hex; None when the file cannot be read (absent, a
    folder, no permission), so that a caller can say which."""
    try:
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
        return h.hexdigest()
    except OSError:
        return None
