"""The study definition: Python objects and the equivalent TOML study file.

A study file::

    [study]
    name = "example"
    model = "mypkg.mymodel:evaluate"   # or a built-in name such as "binh-korn"
    trials = 2048
    seed = 1

    [[variables]]
    name = "x1"
    low = 0.0
    high = 5.0

    [[criteria]]
    name = "f1"
    sense = "min"                      # "min" | "max"
    role = "pure"                      # "pure" | "pseudo"; pure by default
    limit = 40.0                       # optional criteria constraint Φ** (the expert's);
                                       # "noise" in an identification study: its noise floor

    [[constraints]]
    name = "g1"
    low = 0.0                          # either bound optional
    high = 25.0

Validation rejects, naming the field, what came and how to fix it: inverted or equal bounds,
duplicate names, unknown keys (with the nearest valid key), no criteria, a choice variable
without values, a limit on an unknown criterion, non-finite numbers.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .builders import build_problem, check_spec, table_kinds
from .errors import StudyDefinitionError, shown, suggest
from .problem import Criterion, FunctionalConstraint, Problem
from .sampler_kinds import SAMPLER_OPTIONS, sampler_kind, sampler_names
from .sampling import PointSequence
from .space import Choice, Continuous, Integer, Space, Variable

#: Default ``population`` of a sequential study (members of D wanted).
DEFAULT_POPULATION = 200
#: Default ``budget`` of a sequential study (model evaluations; at least ``trials``).
DEFAULT_BUDGET = 50_000
#: Default ``trials`` of a plain table (Sobol, LHS).
DEFAULT_TRIALS = 1024


def first_generation_size(population: int) -> int:
    """Default size of a sequential study's generation 0 (when ``trials`` is not stated): the
    population rounded up to a power of two (a Sobol table's balanced size), at least 64.

    Like generation 0 of ABC-SMC (pyABC's ``population_size``) or nested sampling's live
    points, it only has to show where the criteria are small; the generations after it move
    toward D. A larger table spends evaluations the moves do better: on the parachute twin
    of ``benchmarks/sequential.py`` (3 gains, population 200) generation 0 of 256 reaches 200
    faithful members of D in 706 evaluations, of 1024 in 1,274 (docs/sequential.md).
    """
    return max(64, 1 << max(0, int(population) - 1).bit_length())


__all__ = ["StudySpec", "load_study"]

_STUDY_KEYS = {
    "name": "study name (text)",
    "model": "built-in name or 'package.module:function'",
    "trials": "total number of trials (integer >= 1)",
    "seed": "seed for scrambling and Latin hypercubes (integer)",
    "batch": "true if the model takes a batch (n, p); false for one vector at a time",
    "batch_size": "trials per batch sent to a worker (integer >= 1)",
    "sampler": "'sobol' (LP_tau, default), 'lhs' or 'sequential' (generations toward D)",
    "budget": "sampler 'sequential': " + SAMPLER_OPTIONS["budget"],
    "population": "sampler 'sequential': " + SAMPLER_OPTIONS["population"] + ", default 200",
    "scramble": "Owen-scramble the Sobol sequence (default false)",
    "store": "path of the SQLite store, relative to the study file",
    "description": "free text",
    "executor": "'serial', 'processes', 'dask' or 'inline' (no model process)",
    "workers": "number of worker processes",
    "scheduler": "Dask scheduler 'tcp://HOST:PORT' (executor 'dask'; default: local cluster)",
    "timeout": "most seconds one trial may take (default: no limit)",
    "command": "command-line model as a list, e.g. ['python', 'sim.py', '{input}', '{output}']",
    "fmu": "table of FMU options: interface, start_time, stop_time, parameters, outputs, ...",
    "inputs": "files and folders the model reads itself, hashed like data files "
    '(e.g. ["lib/", "coefficients.csv"], relative to the study file)',
}
_TOP_KEYS = {"study", "variables", "criteria", "constraints", "limits"}
_VARIABLE_KEYS = {"name", "type", "low", "high", "nominal", "unit", "values", "description"}
_CRITERION_KEYS = {
    "name", "sense", "role", "limit", "unit", "description", "limit_source", "limit_note"
}  # fmt: skip
_CONSTRAINT_KEYS = {"name", "low", "high", "unit", "description"}
_VARIABLE_TYPES = ("continuous", "integer", "choice")
EXECUTORS = ("serial", "processes", "dask", "inline")


_ADDRESS = re.compile(
    r"^(?:(tcp|tls|ws|wss|ucx|inproc)://)?(\[[0-9A-Fa-f:.]+\]|[^:/\s\[\]]+):(\d+)$"
)


def check_scheduler_address(address: Any, where: str = "--scheduler") -> str:
    """``address`` if it reads as ``[PROTOCOL://]HOST:PORT``, else a clear error."""
    m = _ADDRESS.match(address) if isinstance(address, str) else None
    if m is None or not 0 < int(m.group(3)) < 65536:
        raise StudyDefinitionError(
            where,
            f"expected a Dask scheduler address tcp://HOST:PORT (port 1-65535), got {address!r}",
            "write e.g. tcp://10.0.0.5:8786 (the address `dask scheduler` prints)",
        )
    return address


def _check_keys(where: str, got: Mapping[str, Any], valid: set[str] | Mapping[str, Any]) -> None:
    for key in got:
        if key not in valid:
            raise StudyDefinitionError(
                f"{where}.{key}", f"unknown key {key!r}", suggest(key, list(valid))
            )


def _int(where: str, value: Any, minimum: int | None = None) -> int:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or (isinstance(value, float) and (not math.isfinite(value) or not value.is_integer()))
    ):
        raise StudyDefinitionError(
            where, f"expected an integer, got {shown(value)}", "write e.g. 2048"
        )
    value = int(value)
    if minimum is not None and value < minimum:
        raise StudyDefinitionError(
            where, f"expected an integer >= {minimum}, got {value}", f"use a value >= {minimum}"
        )
    return value


@dataclass(frozen=True)
class StudySpec:
    """Everything that defines a study.

    Parameters
    ----------
    name : str
        Study name.
    model : str or callable
        Built-in model name, ``"package.module:function"``, or (Python API only) a callable.
    space : Space
        Design variables and the box Π.
    criteria : tuple of Criterion
    constraints : tuple of FunctionalConstraint
    trials : int, optional
        Total number of trials the study should hold (default 1024); for the sequential
        sampler, the size of generation 0 (default :func:`first_generation_size` of the
        population: 256 for 200).
    seed : int
        Seed of every random draw (scrambling, Latin hypercubes).
    batch : bool
        Whether the model takes a batch ``(n, p)`` (True) or one vector ``(p,)`` (False).
    batch_size : int, optional
        Trials per batch; chosen automatically when None.
    sampler : {"sobol", "lhs", "sequential"}
    scramble : bool
    budget : int, optional
        Sampler ``"sequential"``: most model evaluations (default 50,000, or ``trials``
        if larger).
    population : int, optional
        Sampler ``"sequential"``: distinct members of D wanted (default 200).
    store : str, optional
        Store path (relative to ``base_dir``).
    base_dir : str, optional
        Folder of the study file, put on the import path for ``module:function`` models.
    description : str, optional
        What the study is, for people.
    executor, workers : optional
        Default executor (``"serial"``, ``"processes"``, ``"dask"``, ``"inline"``) and worker count.
    scheduler : str, optional
        Dask scheduler address ``"tcp://HOST:PORT"`` (executor ``"dask"``).
    timeout : float, optional
        Most seconds one trial may take, in s (see :mod:`vectorid.run.executors`).
    command : tuple of str, optional
        Command-line model template, with ``model = "cmd"`` (see :mod:`vectorid.external`).
    fmu : dict, optional
        FMU options, with ``model = "fmu:PATH"`` (see :mod:`vectorid.external`).
    extra : dict, optional
        The study file's other tables: a builder's table (``[identification]``) or ``x-``
        tables kept for tools.
    inputs : tuple of str, optional
        Files and folders the model reads itself (``[study] inputs``), relative to
        ``base_dir``: hashed like data files before a trial is added
        (:mod:`vectorid.store.inputs`).
    """

    name: str
    model: Any
    space: Space
    criteria: tuple[Criterion, ...]
    constraints: tuple[FunctionalConstraint, ...] = ()
    trials: int | None = None  # type: ignore[assignment]  # resolved in __post_init__
    seed: int = 0
    batch: bool = True
    batch_size: int | None = None
    sampler: str = "sobol"
    scramble: bool = False
    store: str | None = None
    base_dir: str | None = None
    description: str = ""
    executor: str | None = None
    workers: int | None = None
    extra: dict[str, Any] = field(default_factory=dict, compare=False)
    scheduler: str | None = None
    timeout: float | None = None
    command: tuple[str, ...] | None = None
    fmu: dict[str, Any] | None = field(default=None, hash=False)
    budget: int | None = None
    population: int | None = None
    inputs: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise StudyDefinitionError(
                "study.name", f"expected a non-empty name, got {self.name!r}", 'name = "my-study"'
            )
        if not (isinstance(self.model, str) and self.model.strip()) and not callable(self.model):
            raise StudyDefinitionError(
                "study.model",
                f"expected a built-in name or 'module:function', got {self.model!r}",
                'write model = "binh-korn" or model = "mypkg.mymodel:evaluate"',
            )
        for key in ("sampler", "executor", "store", "description", "base_dir"):
            value = getattr(self, key)
            if value is not None and not isinstance(value, str):
                raise StudyDefinitionError(
                    f"study.{key}",
                    f"expected text, got {shown(value)} ({type(value).__name__})",
                    f'write {key} = "..." (quoted), or leave it out',
                )
        if not isinstance(self.space, Space):
            object.__setattr__(self, "space", Space(self.space))
        object.__setattr__(self, "criteria", tuple(self.criteria))
        object.__setattr__(self, "constraints", tuple(self.constraints))
        if not self.criteria:
            raise StudyDefinitionError(
                "criteria",
                "a study needs at least one criterion, got none",
                "add a [[criteria]] table with a name and a sense",
            )
        names = (
            self.space.names + [c.name for c in self.criteria] + [c.name for c in self.constraints]
        )
        for n in names:
            if names.count(n) > 1:
                raise StudyDefinitionError(
                    n,
                    f"name {n!r} is used more than once among variables, criteria and constraints",
                    "give each a unique name (they become column names)",
                )
        scheme = self.model.partition(":")[0].strip() if isinstance(self.model, str) else ""
        for key, kind, example in (
            ("command", "cmd", 'model = "cmd"'),
            ("fmu", "fmu", 'model = "fmu:model.fmu"'),
        ):
            if getattr(self, key) is not None and scheme != kind:
                raise StudyDefinitionError(  # never ignored silently
                    f"study.{key}",
                    f"{key} applies to a {kind!r} model only, but the model is {self.model!r}",
                    f"write {example} to use it, or remove {key}",
                )
        for i, c in enumerate(self.criteria):  # a noise floor needs noise: never "no limit"
            if c.limit is None and c.limit_source == "noise" and "identification" not in self.extra:
                raise StudyDefinitionError(
                    f"criteria[{i}].limit",
                    f'criterion {c.name!r} has limit = "noise", but this study states no noise '
                    "(a noise floor is computed from an [identification] table: model, measured "
                    "data and noise = { channel = σ })",
                    "write a number (limit = 40.0), remove the limit, or add an [identification] "
                    "table with a noise statement (docs/own-model.md)",
                )
        if self.trials is not None:
            object.__setattr__(self, "trials", _int("study.trials", self.trials, 1))
        object.__setattr__(self, "seed", _int("study.seed", self.seed, 0))
        if self.batch_size is not None:
            object.__setattr__(self, "batch_size", _int("study.batch_size", self.batch_size, 1))
        self._check_sampler()
        if self.trials is None:  # the default depends on the sampler (and its population)
            default = (
                first_generation_size(self.sequential_population)
                if self.sampler == "sequential"
                else DEFAULT_TRIALS
            )
            object.__setattr__(self, "trials", default)
        if self.executor is not None and self.executor not in EXECUTORS:
            raise StudyDefinitionError(
                "study.executor",
                f"unknown executor {self.executor!r}",
                suggest(str(self.executor), EXECUTORS),
            )
        if self.workers is not None:
            object.__setattr__(self, "workers", _int("study.workers", self.workers, 1))
        if self.scheduler is not None and not isinstance(self.scheduler, str):
            raise StudyDefinitionError(
                "study.scheduler",
                f"expected an address such as 'tcp://10.0.0.5:8786', got {self.scheduler!r}",
                'write scheduler = "tcp://HOST:PORT", or leave it out for a local cluster',
            )
        if self.scheduler is not None:
            check_scheduler_address(self.scheduler, "study.scheduler")
            if self.executor is None:  # a scheduler address means the dask executor
                object.__setattr__(self, "executor", "dask")
            elif self.executor != "dask":
                raise StudyDefinitionError(
                    "study.scheduler",
                    f"a scheduler address applies to executor 'dask', got {self.executor!r}",
                    'set executor = "dask", or remove scheduler',
                )
        if self.timeout is not None:
            t = self.timeout
            if isinstance(t, bool) or not isinstance(t, int | float) or not (0 < t < math.inf):
                raise StudyDefinitionError(
                    "study.timeout",
                    f"expected a positive number of seconds per trial, got {t!r}",
                    "write e.g. timeout = 60, or leave it out for no limit",
                )
            object.__setattr__(self, "timeout", float(t))
        if self.command is not None:
            cmd = self.command
            if isinstance(cmd, str) or not all(isinstance(c, str) for c in cmd) or not cmd:
                raise StudyDefinitionError(
                    "study.command",
                    f"expected a non-empty list of strings, got {cmd!r}",
                    'write command = ["python", "sim.py", "{input}", "{output}"]',
                )
            object.__setattr__(self, "command", tuple(cmd))
        if self.fmu is not None and not isinstance(self.fmu, Mapping):
            raise StudyDefinitionError(
                "study.fmu",
                f"expected a table, got {self.fmu!r}",
                "write [study.fmu] with stop_time = ..., [study.fmu.outputs] ...",
            )
        object.__setattr__(self, "inputs", _check_inputs(self.inputs))
        for flag in ("batch", "scramble"):
            if not isinstance(getattr(self, flag), bool):
                raise StudyDefinitionError(
                    f"study.{flag}",
                    f"expected true or false, got {getattr(self, flag)!r}",
                    f"write {flag} = true or {flag} = false",
                )

    def _check_sampler(self) -> None:
        """The sampler is registered (:mod:`vectorid.sampler_kinds`), and takes the options
        given (``budget`` and ``population`` are the sequential sampler's), the sequence's
        scrambling and the variables' types."""
        kind = sampler_kind(self.sampler)
        least = {"budget": 1, "population": 2}
        for key in SAMPLER_OPTIONS:
            value = getattr(self, key)
            if value is None:
                continue
            if key not in kind.options:
                takes = [n for n in sampler_names() if key in sampler_kind(n).options]
                raise StudyDefinitionError(
                    f"study.{key}",
                    f"{key} applies to sampler {' or '.join(repr(n) for n in takes)}, this "
                    f"study's sampler is {self.sampler!r}",
                    f'set sampler = "{takes[0]}", or remove {key}' if takes else f"remove {key}",
                )
            object.__setattr__(self, key, _int(f"study.{key}", value, least.get(key, 1)))
        if self.scramble and not kind.scramble:
            raise StudyDefinitionError(
                "study.scramble",
                f"sampler {self.sampler!r} starts from the unscrambled {kind.sequence.title()} "
                "sequence",
                "remove scramble = true",
            )
        if kind.continuous_only:
            odd = [v.name for v in self.space if v.kind != "continuous"]
            if odd:
                raise StudyDefinitionError(
                    "study.sampler",
                    f"sampler {self.sampler!r} needs continuous variables, got "
                    f"{', '.join(odd)} (integer or choice)",
                    'use sampler = "sobol" for this study, or make those variables continuous',
                )

    @property
    def sequential_budget(self) -> int:
        """Most model evaluations of a sequential study (``budget``, else 50,000 or
        ``trials`` if larger)."""
        return int(self.budget if self.budget is not None else max(DEFAULT_BUDGET, self.trials))

    @property
    def sequential_population(self) -> int:
        """Distinct members of D a sequential study wants (``population``, default 200)."""
        return int(self.population if self.population is not None else DEFAULT_POPULATION)

    # -- derived objects -----------------------------------------------------------------

    @property
    def criterion_names(self) -> list[str]:
        """Criterion names, in study order."""
        return [c.name for c in self.criteria]

    @property
    def constraint_names(self) -> list[str]:
        """Functional-constraint names, in study order."""
        return [c.name for c in self.constraints]

    def point_sequence(self) -> PointSequence:
        """The point sequence this study's sampler starts from (its registered ``sequence``)."""
        kind = sampler_kind(self.sampler).sequence
        return PointSequence(len(self.space), kind, scramble=self.scramble, seed=self.seed)

    def problem(self) -> Problem:
        """Resolve the model and build the :class:`~vectorid.problem.Problem`.

        The builder registered for the study's kind builds it (:mod:`vectorid.builders`): a
        Python function or built-in problem, a ``cmd:`` or ``fmu:`` model, or a registered
        table such as ``[identification]`` (model + flight data + adequacy criteria).
        """

        return build_problem(self)

    def with_study_keys(self, **keys: Any) -> StudySpec:
        """A copy with keys of the ``[study]`` table replaced (run settings such as
        ``trials``, ``budget``, ``population``), validated as a study file is.

        Parameters
        ----------
        **keys
            ``[study]`` keys and their new values (None leaves a key as it is).

        Returns
        -------
        StudySpec
        """
        unknown = [k for k in keys if k not in ("trials", "budget", "population", "seed")]
        if unknown:
            raise ValueError(f"with_study_keys takes run settings only, got {unknown}")
        return replace(self, **{k: v for k, v in keys.items() if v is not None})

    def with_limits(self, limits: Mapping[str, float | None]) -> StudySpec:
        """A copy with criteria constraints Φ** replaced.

        Parameters
        ----------
        limits : mapping of str to float or None
            Criterion name -> its new limit, in the criterion's unit (None removes it).

        Returns
        -------
        StudySpec
        """
        names = self.criterion_names
        for key in limits:
            if key not in names:
                raise StudyDefinitionError(
                    f"limits.{key}", f"limit on unknown criterion {key!r}", suggest(key, names)
                )
        crit = tuple(
            replace(c, limit=limits[c.name], limit_source="", limit_note="")
            if c.name in limits
            else c
            for c in self.criteria
        )
        return replace(self, criteria=crit)

    # -- serialisation -------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The study file as a dict (TOML structure); a callable model becomes its
        ``module:qualname``."""
        model = self.model
        if callable(model):
            model = f"{model.__module__}:{model.__qualname__}"
        study: dict[str, Any] = {
            "name": self.name,
            "model": model,
            "trials": self.trials,
            "seed": self.seed,
            "batch": self.batch,
            "sampler": self.sampler,
            "scramble": self.scramble,
        }
        for key in (
            "batch_size", "store", "executor", "workers", "scheduler", "timeout", "budget",
            "population",
        ):  # fmt: skip
            if getattr(self, key) is not None:
                study[key] = getattr(self, key)
        if self.command is not None:
            study["command"] = list(self.command)
        if self.fmu is not None:
            study["fmu"] = dict(self.fmu)
        if self.inputs:
            study["inputs"] = list(self.inputs)
        if self.description:
            study["description"] = self.description
        out: dict[str, Any] = {
            "study": study,
            "variables": self.space.to_list(),
            "criteria": [c.to_dict() for c in self.criteria],
        }
        if self.constraints:
            out["constraints"] = [c.to_dict() for c in self.constraints]
        out.update(self.extra)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], base_dir: str | Path | None = None) -> StudySpec:
        """Build and validate a spec from the TOML structure.

        Parameters
        ----------
        data : mapping
            The study file's tables, as ``tomllib.load`` returns them.
        base_dir : path, optional
            The study file's folder (model imports and data paths are relative to it).

        Returns
        -------
        StudySpec

        Raises
        ------
        StudyDefinitionError
            Naming the field, what came and the fix.
        """
        if not isinstance(data, Mapping):
            raise StudyDefinitionError("(top)", f"expected a table, got {type(data).__name__}")
        extra = {k: v for k, v in data.items() if k not in _TOP_KEYS}

        for key in extra:
            if not key.startswith("x-") and key not in table_kinds():
                raise StudyDefinitionError(
                    key,
                    f"unknown top-level table {key!r}",
                    suggest(key, sorted(_TOP_KEYS | set(table_kinds())))
                    + " (keys starting with 'x-' are kept as is)",
                )
        study = data.get("study")
        if not isinstance(study, Mapping):
            raise StudyDefinitionError(
                "study",
                "missing [study] table" if study is None else f"expected a table, got {study!r}",
                'start the file with [study] and name = "...", model = "...", trials = 1024',
            )
        _check_keys("study", study, _STUDY_KEYS)
        for required in ("name", "model"):
            if required not in study:
                raise StudyDefinitionError(
                    f"study.{required}",
                    f"missing required key {required!r}",
                    f"add {required} = ... under [study] ({_STUDY_KEYS[required]})",
                )
        variables = _parse_list(data, "variables", parse_variable)
        criteria = _parse_list(data, "criteria", _parse_criterion)
        constraints = _parse_list(data, "constraints", _parse_constraint, required=False)
        limits = data.get("limits", {})
        if not isinstance(limits, Mapping):
            raise StudyDefinitionError(
                "limits", f"expected a table of name = value, got {limits!r}", "[limits]\nf1 = 40.0"
            )
        spec = cls(
            name=study["name"],
            model=study["model"],
            space=Space(variables),
            criteria=tuple(criteria),
            constraints=tuple(constraints),
            trials=study.get("trials"),
            seed=study.get("seed", 0),
            batch=study.get("batch", True),
            batch_size=study.get("batch_size"),
            sampler=study.get("sampler", "sobol"),
            scramble=study.get("scramble", False),
            store=study.get("store"),
            base_dir=None if base_dir is None else str(base_dir),
            description=study.get("description", ""),
            executor=study.get("executor"),
            workers=study.get("workers"),
            extra=dict(extra),
            scheduler=study.get("scheduler"),
            timeout=study.get("timeout"),
            command=study.get("command"),
            fmu=study.get("fmu"),
            budget=study.get("budget"),
            population=study.get("population"),
            inputs=study.get("inputs", ()),
        )
        if limits:
            spec = spec.with_limits(dict(limits))
        return spec


def _check_inputs(value: Any) -> tuple[str, ...]:
    """``[study] inputs``: a list of distinct, non-empty paths (files or folders)."""
    fix = 'write inputs = ["lib/", "coefficients.csv"] (paths relative to the study file)'
    if isinstance(value, str) or not isinstance(value, list | tuple):
        raise StudyDefinitionError(
            "study.inputs", f"expected a list of paths, got {shown(value)}", fix
        )
    seen: dict[str, int] = {}
    for i, item in enumerate(value):
        if not isinstance(item, str) or not item.strip() or "\x00" in item:
            raise StudyDefinitionError(
                f"study.inputs[{i}]", f"expected a file or folder path, got {shown(item)}", fix
            )
        key = str(Path(item.strip()))
        if key in seen:
            raise StudyDefinitionError(
                f"study.inputs[{i}]",
                f"{item!r} is declared twice (also inputs[{seen[key]}])",
                "declare each file or folder once",
            )
        seen[key] = i
    return tuple(v.strip() for v in value)


def check_inputs_exist(spec: StudySpec) -> None:
    """Every declared input (``[study] inputs``) exists, relative to the study file's folder
    (run when a study file is loaded; a store read elsewhere is not refused for it).

    Raises
    ------
    StudyDefinitionError
        Naming the first that does not exist.
    """
    base = Path(spec.base_dir) if spec.base_dir else Path.cwd()
    for i, item in enumerate(spec.inputs):
        path = Path(item) if Path(item).is_absolute() else base / item
        if not path.exists():
            raise StudyDefinitionError(
                f"study.inputs[{i}]",
                f"{item!r} does not exist (looked for {path})",
                "paths are relative to the study file's folder; declare files or folders "
                "the model reads, or remove the entry",
            )


def _parse_list(data: Mapping[str, Any], key: str, parse, required: bool = True) -> list[Any]:
    items = data.get(key)
    if items is None:
        if required:
            raise StudyDefinitionError(
                key,
                f"a study needs at least one entry in [[{key}]], got none",
                f"add a [[{key}]] table",
            )
        return []
    if not isinstance(items, Sequence) or isinstance(items, str | bytes):
        raise StudyDefinitionError(
            key, f"expected an array of tables [[{key}]], got {items!r}", f"write [[{key}]] tables"
        )
    if required and not items:
        raise StudyDefinitionError(key, "empty list", f"add at least one [[{key}]] table")
    out = []
    for i, item in enumerate(items):
        if not isinstance(item, Mapping):
            raise StudyDefinitionError(f"{key}[{i}]", f"expected a table, got {item!r}")
        out.append(parse(f"{key}[{i}]", item))
    return out


def _check_texts(where: str, item: Mapping[str, Any], keys: Sequence[str]) -> None:
    """Fields that hold text must hold text (TOML strings), not numbers or booleans."""
    for key in keys:
        if key in item and not isinstance(item[key], str):
            value = item[key]
            raise StudyDefinitionError(
                f"{where}.{key}",
                f"expected text, got {shown(value)} ({type(value).__name__})",
                f'write {key} = "..." (quoted)',
            )


def parse_variable(where: str, item: Mapping[str, Any]) -> Variable:
    _check_keys(where, item, _VARIABLE_KEYS)
    if "name" not in item:
        raise StudyDefinitionError(f"{where}.name", "missing name", 'add name = "x1"')
    _check_texts(where, item, ("name", "type", "unit", "description"))
    kind = item.get("type", "choice" if "values" in item else "continuous")
    if kind not in _VARIABLE_TYPES:
        raise StudyDefinitionError(
            f"{where}.type", f"unknown variable type {kind!r}", suggest(kind, _VARIABLE_TYPES)
        )
    name = item["name"]
    if kind == "choice":
        if "values" not in item:
            raise StudyDefinitionError(
                f"variables.{name}.values",
                "a choice variable needs values, got none",
                "add values = [1.0, 2.0, 3.0]",
            )
        for key in ("low", "high"):
            if key in item:
                raise StudyDefinitionError(
                    f"variables.{name}.{key}",
                    "a choice variable takes values, not bounds",
                    'remove low/high, or use type = "continuous"',
                )
        values = item["values"]
        if not isinstance(values, Sequence) or isinstance(values, str | bytes):
            raise StudyDefinitionError(
                f"variables.{name}.values",
                f"expected an array of numbers, got {values!r}",
                "write values = [1.0, 2.0, 3.0]",
            )
        return Choice(name, values, item.get("nominal"), item.get("unit", ""))
    if "values" in item:
        raise StudyDefinitionError(
            f"variables.{name}.values",
            f"a {kind} variable takes low and high, not values",
            'remove values, or set type = "choice"',
        )
    for key in ("low", "high"):
        if key not in item:
            raise StudyDefinitionError(
                f"variables.{name}.{key}", f"missing {key}", f"add {key} = <number>"
            )
    cls = Integer if kind == "integer" else Continuous
    return cls(name, item["low"], item["high"], item.get("nominal"), item.get("unit", ""))


def _parse_criterion(where: str, item: Mapping[str, Any]) -> Criterion:
    _check_keys(where, item, _CRITERION_KEYS)
    if "name" not in item:
        raise StudyDefinitionError(f"{where}.name", "missing name", 'add name = "f1"')
    _check_texts(where, item, ("name", "sense", "role", "unit", "description"))
    limit, source = item.get("limit"), item.get("limit_source", "")
    if isinstance(limit, str):  # limit = "noise": the identification's noise floor
        if limit != "noise":
            raise StudyDefinitionError(
                f"criteria.{item['name']}.limit",
                f'expected a number or "noise", got {shown(limit)} (str)',
                'write limit = 40.0, or limit = "noise" in an identification study',
            )
        limit, source = None, "noise"
    return Criterion(
        item["name"],
        item.get("sense", "min"),
        item.get("role", "pure"),
        limit,
        item.get("unit", ""),
        source,
        item.get("limit_note", ""),
    )


def _parse_constraint(where: str, item: Mapping[str, Any]) -> FunctionalConstraint:
    _check_keys(where, item, _CONSTRAINT_KEYS)
    if "name" not in item:
        raise StudyDefinitionError(f"{where}.name", "missing name", 'add name = "g1"')
    _check_texts(where, item, ("name", "unit", "description"))
    if item.get("low") is None and item.get("high") is None:
        raise StudyDefinitionError(
            f"constraints.{item['name']}",
            "a functional constraint needs low, high or both, got neither",
            "add low = ... and/or high = ...",
        )
    return FunctionalConstraint(
        item["name"], item.get("low"), item.get("high"), item.get("unit", "")
    )


def load_study(path: str | Path) -> StudySpec:
    """Read and validate a TOML study file.

    Parameters
    ----------
    path : path
        The ``.toml`` file; its folder goes on the import path for ``module:function`` models.
    """
    path = Path(path)
    if path.is_dir():
        raise StudyDefinitionError(
            str(path),
            "is a folder, not a study file",
            "give the .toml study file (or a .db store to resume)",
        )
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise StudyDefinitionError(
            str(path), "study file not found", "check the path (run from the right folder?)"
        ) from None
    except OSError as exc:
        raise StudyDefinitionError(
            str(path), f"cannot read the study file: {exc.strerror}", "check its permissions"
        ) from None
    if b"\x00" in raw[:4096]:
        raise StudyDefinitionError(
            str(path),
            "is a binary file, not a TOML study file",
            "give the .toml study file (a .db store is run as `vectorid run STORE.db`)",
        )
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark is allowed and dropped
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise StudyDefinitionError(
            str(path),
            f"not UTF-8 text: byte {raw[exc.start]:#04x} on line {line} cannot be decoded",
            "save the file as UTF-8 (TOML files are UTF-8)",
        ) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StudyDefinitionError(
            str(path), f"not valid TOML: {exc}", "fix the syntax at the position given"
        ) from None
    spec = StudySpec.from_dict(data, base_dir=path.resolve().parent)
    check_inputs_exist(spec)
    check_spec(spec)  # what the study's builder cannot run (dt/output_dt, ...)
    return spec
