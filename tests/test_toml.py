"""The one TOML writer: what it writes reads back to the same values (tomllib)."""

from __future__ import annotations

import math
import tomllib

import pytest

from vectorid._toml import toml_key, toml_tables, toml_value


def test_values_read_back_exactly():
    value = {
        "flag": True,
        "n": 3,
        "x": 0.1 + 0.2,  # a float that needs all its digits
        "tiny": 5e-324,
        "text": 'quote " and \\ backslash, ünïcode',
        "list": [1, 2.5, "a", [False]],
        "table": {"inner key": 1.0, "plain": (1, 2)},
    }
    back = tomllib.loads(f"v = {toml_value(value)}")["v"]
    want = {**value, "table": {"inner key": 1.0, "plain": [1, 2]}}  # tuples read as arrays
    assert back == want
    assert back["x"] == 0.1 + 0.2 and back["tiny"] == 5e-324
    assert math.isnan(tomllib.loads(f"v = {toml_value(float('nan'))}")["v"])
    assert toml_key("position_h") == "position_h" and toml_key("a b") == '"a b"'


def test_a_value_toml_cannot_hold_is_refused_by_name():
    with pytest.raises(TypeError, match="None"):
        toml_value({"a": None})


def test_tables_in_order_with_arrays_of_tables_and_a_header():
    text = toml_tables(
        [
            ("study", {"name": "s", "trials": 8}),
            ("variables", [{"name": "x", "low": 0.0}, {"name": "y", "low": 1.0}]),
            ("identification", {"noise": {"position_h": 1.5}}),
            ("identification.drops", [{"name": "d", "window": [0.0, 1.0]}]),
        ],
        header="first line\nsecond line",
    )
    assert text.splitlines()[:3] == ["# first line", "# second line", "[study]"]
    data = tomllib.loads(text)
    assert data["study"] == {"name": "s", "trials": 8}
    assert [v["name"] for v in data["variables"]] == ["x", "y"]
    assert data["identification"] == {
        "noise": {"position_h": 1.5},
        "drops": [{"name": "d", "window": [0.0, 1.0]}],
    }
