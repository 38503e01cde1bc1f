"""The study file and its store agree, or the user is told.

A store holds the study definition its trials were computed with. When a study file is run
against an existing store, :func:`compare` lists every difference, field by field, and sorts
each into

* **taken** — it does not change a trial already computed: criteria limits Φ**, functional
  constraint bounds, criterion sense and role, labels (names of the study, units,
  descriptions, nominal values), run settings (target trial count, executor, workers,
  timeout, batch size, scheduler, store path), the declared inputs (``[study] inputs``:
  their content is compared by :mod:`vectorid.store.inputs` before a trial is added), ``x-``
  tables, the seed of an unscrambled Sobol sequence (which does not use it), and the path of
  a data file whose content is the same as the one the trials were computed from;
* **refused** — it would change computed trials: the model, the variables (names, order,
  kinds, bounds, values), the criteria and constraints themselves (names, order), the
  sampler, scrambling, the seed of a scrambled or Latin hypercube sequence, ``batch``,
  ``command``, ``[study.fmu]``, anything in a registered table such as
  ``[identification]``, and a data file whose content changed.

A store records the SHA-256 of each data file its study reads (:func:`data_file_hashes`,
from the problem builder's list of files, see :mod:`vectorid.builders`), so an edited data
file is found even when its path did not change.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._files import file_sha256
from ..builders import analysis_only, data_files
from ..spec import StudySpec

__all__ = ["Agreement", "Difference", "compare", "data_file_hashes"]

#: Keys of [study] that do not change computed trials.
TAKEN_STUDY = {
    "name": "a label",
    "description": "a label",
    "trials": "the target; stored trials stay",
    "batch_size": "a run setting",
    "executor": "a run setting",
    "workers": "a run setting",
    "scheduler": "a run setting",
    "timeout": "a run setting for trials still to compute",
    "budget": "a run setting (sequential sampler): stored trials stay",
    "population": "the target of later generations (sequential sampler); stored trials stay",
    "store": "where the store is",
    "inputs": "what else is hashed: a declared input's content is checked before a trial is "
    "added (vectorid.store.inputs)",
}
TAKEN_VARIABLE = {"unit": "a label", "description": "a label", "nominal": "a reference value"}
TAKEN_CRITERION = {
    "sense": "how stored values are read",
    "role": "an analysis choice",
    "limit": "a criteria constraint (analysis only)",
    "limit_source": "where a criteria constraint came from (analysis only)",
    "limit_note": "where a criteria constraint came from (analysis only)",
    "unit": "a label",
    "description": "a label",
}
TAKEN_CONSTRAINT = {
    "low": "a functional bound (analysis only)",
    "high": "a functional bound (analysis only)",
    "unit": "a label",
    "description": "a label",
}

_MISSING = object()


def _show(value: Any) -> str:
    if value is _MISSING:
        return "(absent)"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


@dataclass(frozen=True)
class Difference:
    """One field where the study file and the stored definition differ."""

    field: str
    stored: Any
    given: Any
    taken: bool
    why: str
    #: A file's content changed (not the definition): ``--accept-changes`` may take it.
    content: bool = False

    def describe(self) -> str:
        old, new = _show(self.stored), _show(self.given)
        return f"{self.field}: {old} (store) -> {new} (file) — {self.why}"


@dataclass
class Agreement:
    """The differences between a study file and a store's definition."""

    differences: list[Difference] = field(default_factory=list)
    hashes: dict[str, Any] = field(default_factory=dict)

    @property
    def taken(self) -> list[Difference]:
        return [d for d in self.differences if d.taken]

    @property
    def refused(self) -> list[Difference]:
        return [d for d in self.differences if not d.taken]

    def __bool__(self) -> bool:
        return bool(self.differences)


def data_file_hashes(spec: StudySpec) -> dict[str, Any]:
    """``{field: {"path", "sha256", "size"}}`` of the data files ``spec`` reads (those that
    exist; a missing one is the problem builder's to report)."""

    out: dict[str, Any] = {}
    try:
        files = data_files(spec)
    except Exception:  # a malformed table: the builder reports it when it builds
        return out
    for name, path in files.items():
        digest = file_sha256(path)
        if digest is not None:
            out[name] = {"path": str(path), "sha256": digest, "size": path.stat().st_size}
    return out


def _flatten(prefix: str, value: Any, out: dict[str, Any]) -> None:
    if isinstance(value, Mapping):
        if not value:
            out[prefix] = {}
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, out)
    elif isinstance(value, list | tuple) and any(isinstance(v, Mapping) for v in value):
        for i, v in enumerate(value):
            _flatten(f"{prefix}[{i}]", v, out)
    else:
        out[prefix] = list(value) if isinstance(value, tuple) else value


def _by_name(items: list[Mapping[str, Any]]) -> list[str]:
    return [str(x.get("name")) for x in items]


def compare(
    held: StudySpec, given: StudySpec, recorded: Mapping[str, Any] | None = None
) -> Agreement:
    """Every difference between the stored definition ``held`` and the study file's
    ``given``, sorted into taken and refused (see the module docstring).

    Parameters
    ----------
    held : StudySpec
        The definition in the store.
    given : StudySpec
        The study file's.
    recorded : mapping, optional
        Data-file hashes recorded in the store (:meth:`Store.data_files`); None for a store
        that recorded none (the stored paths' current content is compared instead).
    """
    a, b = held.to_dict(), given.to_dict()
    out = Agreement(hashes=data_file_hashes(given))
    diffs = out.differences

    def add(path: str, x: Any, y: Any, taken: bool, why: str, content: bool = False) -> None:
        diffs.append(Difference(path, x, y, taken, why, content))

    # [study]
    sa, sb = a.get("study", {}), b.get("study", {})
    unscrambled_sobol = (
        sa.get("sampler") == sb.get("sampler") == "sobol"
        and not sa.get("scramble")
        and not sb.get("scramble")
    )
    for key in sorted(set(sa) | set(sb)):
        x, y = sa.get(key, _MISSING), sb.get(key, _MISSING)
        if x == y:
            continue
        if key in TAKEN_STUDY:
            add(f"study.{key}", x, y, True, TAKEN_STUDY[key])
        elif key == "seed" and unscrambled_sobol:
            add("study.seed", x, y, True, "an unscrambled Sobol sequence does not use it")
        elif key == "model" and _same_fmu(held, given, recorded):
            add("study.model", x, y, True, "the same FMU file content")
        else:
            add(f"study.{key}", x, y, False, "changes the trials")

    # [[variables]], [[criteria]], [[constraints]]
    for table, taken_keys in (
        ("variables", TAKEN_VARIABLE),
        ("criteria", TAKEN_CRITERION),
        ("constraints", TAKEN_CONSTRAINT),
    ):
        la, lb = list(a.get(table, [])), list(b.get(table, []))
        if _by_name(la) != _by_name(lb):
            add(
                table,
                ", ".join(_by_name(la)) or "none",
                ", ".join(_by_name(lb)) or "none",
                False,
                "other columns: every trial's values would change meaning",
            )
            continue
        for x, y in zip(la, lb):
            for key in sorted(set(x) | set(y)):
                vx, vy = x.get(key, _MISSING), y.get(key, _MISSING)
                if vx == vy:
                    continue
                where = f"{table}.{x.get('name')}.{key}"
                if key in taken_keys:
                    add(where, vx, vy, True, taken_keys[key])
                else:
                    add(where, vx, vy, False, "changes the trials")

    # other top-level tables: x- tables are labels; registered tables change the problem
    files_held = _data_files(held)
    files_given = _data_files(given)
    for key in sorted((set(a) | set(b)) - {"study", "variables", "criteria", "constraints"}):
        x, y = a.get(key, _MISSING), b.get(key, _MISSING)
        if key.startswith("x-"):
            if x != y:
                add(key, x, y, True, "an extension table, kept as is")
            continue
        fa: dict[str, Any] = {}
        fb: dict[str, Any] = {}
        if x is not _MISSING:
            _flatten(key, _long_mappings(x), fa)
        if y is not _MISSING:
            _flatten(key, _long_mappings(y), fb)
        for path in sorted(set(fa) | set(fb)):
            vx, vy = fa.get(path, _MISSING), fb.get(path, _MISSING)
            if path in files_held or path in files_given:
                continue  # data files: compared by content below
            if vx != vy:
                said = _stated_unit(path, vx, vy)
                if said:
                    add(path, vx, vy, True, said)
                elif analysis_only(given, path):
                    add(path, vx, vy, True, "what the criteria constraints derive from")
                else:
                    add(path, vx, vy, False, "changes the trials")

    # data files, by content
    recorded = dict(recorded or {})
    for name in sorted(set(files_held) | set(files_given)):
        if name == "study.model" and sa.get("model") != sb.get("model"):
            continue  # compared with the model above
        new_path = files_given.get(name)
        old_path = files_held.get(name)
        new_hash = out.hashes.get(name, {}).get("sha256") if new_path is not None else None
        old_hash = (recorded.get(name) or {}).get("sha256")
        checked_against = "the file the store's trials were computed from"
        if old_hash is None and old_path is not None:
            old_hash = file_sha256(old_path)
            checked_against = f"{old_path} as it is now (the store recorded no hash)"
        shown_old = str(old_path) if old_path is not None else _MISSING
        shown_new = str(new_path) if new_path is not None else _MISSING
        if new_path is None or old_path is None:
            add(name, shown_old, shown_new, False, "a data file added or removed")
        elif old_hash is None or new_hash is None:
            if old_path != new_path:
                add(name, shown_old, shown_new, False, "cannot compare the files' content")
        elif old_hash != new_hash:
            add(
                name,
                shown_old,
                shown_new,
                False,
                f"the file's content differs from {checked_against}",
                content=True,
            )
        elif old_path != new_path:
            add(name, shown_old, shown_new, True, "the same file content")
    return out


#: Channels of a flight-data mapping whose short forms (a column name, a list of columns,
#: ``column``) are the table ``{columns = [...]}``.
_MAPPED = ("position", "velocity", "euler", "rates", "altitude", "controls")

#: Units a flight-data mapping once defaulted to (before units had to be stated): a store made
#: then read its files in these units, so stating the same unit now changes no trial.
_FORMER_DEFAULT_UNITS = {
    "time_unit": "s",
    "position.unit": "m",
    "position.angle_unit": "deg",
    "position.alt_unit": "m",
    "velocity.unit": "m/s",
    "altitude.unit": "m",
}


def _long_mappings(value: Any) -> Any:
    """``value`` with every flight-data ``mapping``'s channels in their table form, so that
    ``altitude = "h"`` and ``altitude = { column = "h", unit = "m" }`` differ by the unit only."""
    if isinstance(value, list | tuple):
        return [_long_mappings(v) for v in value]
    if not isinstance(value, Mapping):
        return value
    out = {k: _long_mappings(v) for k, v in value.items()}
    m = out.get("mapping")
    if isinstance(m, Mapping):
        m = {k: (_table_form(v) if k in _MAPPED else v) for k, v in m.items()}
        if isinstance(m.get("channels"), Mapping):
            m["channels"] = {k: _table_form(v) for k, v in m["channels"].items()}
        out["mapping"] = m
    return out


def _table_form(spec: Any) -> Any:
    if isinstance(spec, str):
        return {"columns": [spec]}
    if isinstance(spec, list | tuple):
        return {"columns": list(spec)}
    if isinstance(spec, Mapping) and "column" in spec:
        return {**{k: v for k, v in spec.items() if k != "column"}, "columns": [spec["column"]]}
    return spec


def _stated_unit(path: str, held: Any, given: Any) -> str:
    """Why a unit newly stated in a flight-data mapping is taken ("" if it is not): the unit
    the store's trials were read in (the former default), or the unit of a channel that is
    not converted (controls, other channels: a label)."""
    if held is not _MISSING:
        return ""
    if re.fullmatch(r"identification\.data\[\d+\]\.time_unit", path) and given == "s":
        return "states the unit the store's trials read the record's time in (it was s)"
    if ".mapping." not in path:
        return ""
    key = path.rsplit(".mapping.", 1)[1]
    if _FORMER_DEFAULT_UNITS.get(key) == given:
        return "states the unit the store's trials read the file in (it was the default)"
    if key == "controls.unit" or (key.startswith("channels.") and key.endswith(".unit")):
        return "the unit of a channel that is not converted: a label"
    return ""


def _data_files(spec: StudySpec) -> dict[str, Path]:
    try:
        return data_files(spec)
    except Exception:
        return {}


def _same_fmu(held: StudySpec, given: StudySpec, recorded: Mapping[str, Any] | None) -> bool:
    """Both models are ``fmu:PATH`` with the same file content (only the path moved)."""
    if not (isinstance(held.model, str) and isinstance(given.model, str)):
        return False
    if not (held.model.startswith("fmu:") and given.model.startswith("fmu:")):
        return False
    old = _data_files(held).get("study.model")
    new = _data_files(given).get("study.model")
    if old is None or new is None:
        return False
    old_hash = ((recorded or {}).get("study.model") or {}).get("sha256") or file_sha256(old)
    return old_hash is not None and old_hash == file_sha256(new)


def new_store_name(path: Path) -> Path:
    """A store path beside ``path`` that does not exist yet (``NAME-2.db``, ``NAME-3.db``)."""
    for i in itertools.count(2):
        candidate = path.with_name(f"{path.stem}-{i}{path.suffix}")
        if not candidate.exists():
            return candidate
    raise AssertionError("unreachable")  # pragma: no cover
