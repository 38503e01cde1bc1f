"""The file hash the stores record."""

from __future__ import annotations

import hashlib

from vectorid._files import file_sha256


def test_file_sha256_of_bytes_and_of_what_cannot_be_read(tmp_path):
    f = tmp_path / "data.csv"
    body = b"t,h\n" + b"0,1\n" * 300_000  # larger than one read chunk
    f.write_bytes(body)
    assert file_sha256(f) == hashlib.sha256(body).hexdigest()
    assert file_sha256(tmp_path / "absent.csv") is None
    assert file_sha256(tmp_path) is None  # a folder
