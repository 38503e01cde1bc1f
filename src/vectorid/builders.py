"""Problem builders by kind: how a study definition becomes a :class:`~vectorid.problem.Problem`.

The core (:mod:`vectorid.spec`) never names a plug-in: it asks this registry. A builder is a
function ``build(spec) -> Problem``, registered under a *kind*:

* a **model scheme** — the part of ``model = "SCHEME:..."`` before the colon (``cmd``,
  ``fmu``), or the whole model for a bare ``"cmd"``;
* a **table** — a top-level table of the study file (``[identification]``) whose presence
  makes the study that kind, whatever its model;
* ``"python"`` — everything else: a built-in analytic problem or ``package.module:function``.

Built-in builders are registered here as ``"module:function"`` references, imported on first
use (so importing vectorid imports neither the identification stack nor FMPy). A package adds
its own with :func:`register_problem_builder`, the way Optuna registers samplers and
storages::

    from vectorid.builders import register_problem_builder
    register_problem_builder("mysim", build_mysim_problem)      # model = "mysim:..."
    register_problem_builder("campaign", build_campaign, table=True)   # a [campaign] table

A builder may also say which data files the study reads (``data_files(spec) -> {field:
path}``), so that a store can record their content and a later run can tell an edited data
file from a moved one (see :mod:`vectorid.store.agreement`); how a definition is completed
once when its store is created (``prepare(spec) -> spec``: an identification computes its
noise-floor criteria constraints there); and which keys of its table only shape the
analysis (``analysis_keys``: the noise statement behind those constraints), so that editing
them is taken into an existing store rather than refused; and what each design variable
means (``meanings(spec) -> {name: text}``: an identification reads its model's parameter
meanings), so that the analysis can say it without importing the builder; and which Python
modules of the user's its model runs besides the study's ``model`` (``code_modules(spec) ->
{module: role}``: an identification's own model class and its criterion functions ``use =
"module:function"``, an FMU's reductions), so that a store hashes that code too (see
:mod:`vectorid.store.inputs`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import StudyDefinitionError

__all__ = [
    "Builder",
    "analysis_only",
    "build_problem",
    "builder_for",
    "check_spec",
    "code_modules",
    "data_files",
    "kind_of",
    "prepare_spec",
    "register_problem_builder",
    "table_kinds",
    "variable_meanings",
]


@dataclass
class Builder:
    """A registered problem builder (see the module docstring)."""

    kind: str
    build: Callable[[Any], Any] | str
    table: bool = False
    data_files: Callable[[Any], Mapping[str, Path]] | str | None = None
    prepare: Callable[[Any], Any] | str | None = None
    analysis_keys: tuple[str, ...] = ()
    check: Callable[[Any], None] | str | None = None
    meanings: Callable[[Any], Mapping[str, str]] | str | None = None
    code_modules: Callable[[Any], Mapping[str, str]] | str | None = None

    def resolve(self, attr: str) -> Callable[..., Any] | None:
        ref = getattr(self, attr)
        if isinstance(ref, str):
            module, _, name = ref.partition(":")
            ref = getattr(importlib.import_module(module), name)
            setattr(self, attr, ref)
        return ref


_BUILDERS: dict[str, Builder] = {}


def register_problem_builder(
    kind: str,
    build: Callable[[Any], Any] | str,
    *,
    table: bool = False,
    data_files: Callable[[Any], Mapping[str, Path]] | str | None = None,
    prepare: Callable[[Any], Any] | str | None = None,
    analysis_keys: tuple[str, ...] = (),
    check: Callable[[Any], None] | str | None = None,
    meanings: Callable[[Any], Mapping[str, str]] | str | None = None,
    code_modules: Callable[[Any], Mapping[str, str]] | str | None = None,
) -> None:
    """Register how studies of ``kind`` become a Problem.

    Parameters
    ----------
    kind : str
        Model scheme (``model = "KIND:..."``) or, with ``table=True``, the name of a
        top-level table of the study file.
    build : callable or str
        ``build(spec) -> Problem``, or a ``"module:function"`` reference imported on first
        use.
    table : bool
        The kind is a top-level table (it is then accepted by the study-file parser).
    data_files : callable or str, optional
        ``data_files(spec) -> {field: path}``: the data files the study reads.
    prepare : callable or str, optional
        ``prepare(spec) -> spec``: the definition completed once when its store is created
        (derived criteria constraints, units filled); it must be deterministic.
    analysis_keys : tuple of str
        Keys of the kind's table (at any depth, e.g. ``noise`` also inside a drop) that
        only shape the analysis, never a computed trial.
    check : callable or str, optional
        ``check(spec)``: raises :class:`~vectorid.errors.StudyDefinitionError` for a
        definition the builder cannot run (run when a study file is loaded, before any store
        is touched).
    meanings : callable or str, optional
        ``meanings(spec) -> {variable name: meaning}``: what each design variable is, for
        people (the identifiability verdicts print it beside the name).
    code_modules : callable or str, optional
        ``code_modules(spec) -> {module name: role}``: Python modules (``"pkg.mod"``) of the
        user's that the study's model runs besides the study's ``model`` (a model class named
        in the kind's table, criterion or reduction functions), with their role in words
        (``"model module"``, ``"criterion module"``); they are hashed with the model's code.
    """
    if not isinstance(kind, str) or not kind or ":" in kind:
        raise ValueError(f"a builder kind is a non-empty name without ':', got {kind!r}")
    _BUILDERS[kind] = Builder(
        kind, build, table, data_files, prepare, tuple(analysis_keys), check, meanings,
        code_modules,
    )  # fmt: skip


def table_kinds() -> list[str]:
    """Top-level tables that make a study a registered kind (``["identification"]``)."""
    return sorted(k for k, b in _BUILDERS.items() if b.table)


def kind_of(spec: Any) -> str:
    """The kind of a study: a registered table it holds, else its model's scheme, else
    ``"python"``."""
    for kind in table_kinds():
        if kind in getattr(spec, "extra", {}):
            return kind
    model = spec.model
    if isinstance(model, str):
        scheme = model.partition(":")[0]
        b = _BUILDERS.get(scheme)
        if b is not None and not b.table and scheme != "python":
            return scheme
    return "python"


def builder_for(spec: Any) -> Builder:
    kind = kind_of(spec)
    try:
        return _BUILDERS[kind]
    except KeyError:  # pragma: no cover - "python" is always registered
        raise StudyDefinitionError("study.model", f"no problem builder for kind {kind!r}") from None


def _hook(spec: Any, attr: str) -> Callable[..., Any] | None:
    """The ``attr`` hook of ``spec``'s builder, imported on first use; None when it has none."""
    b = builder_for(spec)
    return None if getattr(b, attr) is None else b.resolve(attr)


def build_problem(spec: Any) -> Any:
    """The Problem of ``spec``, built by the builder of its kind."""
    build = builder_for(spec).resolve("build")
    assert build is not None
    return build(spec)


def data_files(spec: Any) -> dict[str, Path]:
    """``{field: path}`` of the data files the study reads (empty when its builder does not
    say). Paths are resolved against the study file's folder."""
    fn = _hook(spec, "data_files")
    return {} if fn is None else dict(fn(spec))


def code_modules(spec: Any) -> dict[str, str]:
    """``{module: role}`` of the user's Python modules ``spec``'s model runs besides the
    study's ``model`` (empty when its builder does not say; see ``code_modules`` of
    :func:`register_problem_builder`). A malformed table gives none: its builder reports it."""
    fn = _hook(spec, "code_modules")
    if fn is None:
        return {}
    try:
        return {str(k): str(v) for k, v in dict(fn(spec)).items()}
    except Exception:  # the builder says what is wrong when it builds
        return {}


def check_spec(spec: Any) -> None:
    """Run the ``check`` hook of ``spec``'s builder (nothing when it has none)."""
    fn = _hook(spec, "check")
    if fn is not None:
        fn(spec)


def prepare_spec(spec: Any) -> Any:
    """``spec`` completed by its builder's ``prepare`` hook (unchanged when it has none)."""
    fn = _hook(spec, "prepare")
    return spec if fn is None else fn(spec)


def variable_meanings(spec: Any) -> dict[str, str]:
    """What each design variable of ``spec`` means, from its builder's ``meanings`` hook
    (empty when the builder has none): variable name -> text, e.g. ``x6`` -> "C_D base value
    (eq. 11)" for an identification of the G-12 model."""
    fn = _hook(spec, "meanings")
    return {} if fn is None else dict(fn(spec))


def analysis_only(spec: Any, path: str) -> bool:
    """Whether the flattened field ``path`` (``"identification.drops[0].noise.velocity"``) of
    ``spec``'s own table only shapes the analysis (see ``analysis_keys``)."""
    b = builder_for(spec)
    if not b.table or not b.analysis_keys:
        return False
    head, _, rest = path.partition(".")
    if head != b.kind:
        return False
    parts = [p.split("[")[0] for p in rest.split(".")]
    return any(p in b.analysis_keys for p in parts)


def _identification_files(spec: Any) -> dict[str, Path]:
    """Data files of an ``[identification]`` table: each drop's ``file`` (or ``files``) and
    ``wind``, and each record's ``file`` (a model of your own)."""
    table = spec.extra.get("identification")
    base = Path(spec.base_dir) if spec.base_dir else Path.cwd()
    out: dict[str, Path] = {}
    if not isinstance(table, Mapping):
        return out
    for i, rec in enumerate(table.get("data") or []):  # records of a model of your own
        if isinstance(rec, Mapping) and isinstance(rec.get("file"), str):
            out[f"identification.data[{i}].file"] = base / rec["file"]
    drops = table.get("drops")
    if not isinstance(drops, list):
        return out
    for i, drop in enumerate(drops):
        if not isinstance(drop, Mapping):
            continue
        where = f"identification.drops[{i}]"
        for key in ("file", "wind"):
            if isinstance(drop.get(key), str):
                out[f"{where}.{key}"] = base / drop[key]
        files = drop.get("files")
        if isinstance(files, list):
            for j, src in enumerate(files):
                if isinstance(src, Mapping) and isinstance(src.get("file"), str):
                    out[f"{where}.files[{j}].file"] = base / src["file"]
    return out


def _fmu_code_modules(spec: Any) -> dict[str, str]:
    """Modules of the reductions of your own an FMU study names (``reduce =
    "mypkg.reductions:overshoot"`` under ``[study.fmu.outputs]``)."""
    outs = (spec.fmu or {}).get("outputs") if isinstance(spec.fmu, Mapping) else None
    out: dict[str, str] = {}
    if not isinstance(outs, Mapping):
        return out
    for entry in outs.values():
        red = entry.get("reduce") if isinstance(entry, Mapping) else None
        if isinstance(entry, str):
            red = entry.partition("(")[0].strip() if "(" in entry else None
        if isinstance(red, str) and ":" in red:
            out[red.partition(":")[0].strip()] = "reduction module"
    return out


def _fmu_files(spec: Any) -> dict[str, Path]:
    rest = str(spec.model).partition(":")[2].strip()
    if not rest:
        return {}
    base = Path(spec.base_dir) if spec.base_dir else Path.cwd()
    return {"study.model": base / rest}


register_problem_builder("python", "vectorid.problem:build_python_problem")
register_problem_builder("cmd", "vectorid.external:build_external_problem")
register_problem_builder(
    "fmu",
    "vectorid.external:build_external_problem",
    data_files=_fmu_files,
    code_modules=_fmu_code_modules,
)
register_problem_builder(
    "identification",
    "vectorid.identify.identification:problem_from_spec",
    table=True,
    data_files=_identification_files,
    prepare="vectorid.identify.noise.resolve:resolve_noise_limits",
    analysis_keys=(
        "noise",
        "discrepancy",
        "limits",
        "noise_quantile",
        "noise_coverage",
        "noise_draws",
        "noise_seed",
    ),
    check="vectorid.timesteps:check_identification_steps",
    meanings="vectorid.identify.identification:parameter_meanings",
    code_modules="vectorid.identify.system:code_modules",
)
