"""Criteria, functional constraints, and the batch-first model protocol.

A model evaluates a whole batch of parameter vectors at once::

    evaluate(X: (n, p) float array) -> criteria (n, k)            or
    evaluate(X) -> (criteria (n, k), functionals (n, q))

with columns in the order of the study's criteria and constraints. A per-trial function
``f(x: (p,)) -> row (k,) | (row (k,), row (q,))`` is wrapped once into this form by
:func:`as_batch`. :meth:`Problem.evaluate` never raises because of a bad trial: a trial
whose model raises, returns NaN/inf or the wrong shape comes back with ``status = FAILED``
and a message saying why.
"""

from __future__ import annotations

import importlib
import math
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import analytic
from .errors import StudyDefinitionError, VectoridError, is_number, shown, suggest

__all__ = [
    "FAILED",
    "LIMIT_SOURCES",
    "OK",
    "Criterion",
    "EvalResult",
    "FunctionalConstraint",
    "ModelOutputError",
    "Problem",
    "as_batch",
    "build_python_problem",
    "checked_output",
    "describe_exception",
    "load_model",
]

OK = 0
FAILED = 1

#: Where a criteria constraint came from (:attr:`Criterion.limit_source`).
LIMIT_SOURCES = ("", "expert", "noise", "quantile")

BatchModel = Callable[[np.ndarray], Any]


class ModelOutputError(VectoridError, ValueError):
    """A function of the user's model returned another shape or type than its contract
    says: one line naming the function, the expected and the returned shape. Raised inside a
    batch, it fails the trials of that batch (bisected down to the trials that misbehave);
    raised before any trial (the noise floor of an identification), it stops the study."""


def _what_came(value: Any, arr: np.ndarray | None) -> str:
    if isinstance(value, list | tuple):
        inner = {np.shape(v) for v in value[:50]}
        first = f" of shape {next(iter(inner))}" if len(inner) == 1 else ""
        read = f" (read as shape {arr.shape})" if arr is not None else ""
        return f"a {type(value).__name__} of {len(value)} items{first}{read}"
    if arr is not None and arr.ndim == 0:
        return f"a scalar {value!r} (shape ())"
    if arr is None:
        return f"a {type(value).__name__}"
    return f"shape {arr.shape}"


def checked_output(
    where: str, value: Any, shape: tuple[int, ...], meaning: str, fix: str = ""
) -> np.ndarray:
    """``value`` as a float array of exactly ``shape``, checked before it is used.

    Parameters
    ----------
    where : str
        The function that returned it, as the user wrote it (``"msd.dynamics.MSD.rhs"``).
    value : array_like
        What it returned.
    shape : tuple of int
        The shape its contract says.
    meaning : str
        What the axes are (``"trials, states x, v"``).
    fix : str, optional
        How to return it right (said after the shapes).

    Returns
    -------
    ndarray
        ``value`` as float, shape ``shape`` (no copy when it is one already).

    Raises
    ------
    ModelOutputError
        Another shape (numpy broadcasting never fills it in), or values that are not real
        numbers (text, objects, complex).
    """
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError):  # a ragged list
        arr = None
    if arr is not None and arr.dtype.kind in "fiu" and arr.shape == shape:
        return arr.astype(float, copy=False)
    if arr is not None and arr.shape == shape:
        kind = {"c": "complex numbers", "b": "booleans", "U": "text", "S": "bytes"}.get(
            arr.dtype.kind, f"values of dtype {arr.dtype}"
        )
        raise ModelOutputError(
            f"{where} returned {kind}, expected real numbers of shape {shape} ({meaning})"
            + (f" — {fix}" if fix else "")
        )
    hint = fix
    if isinstance(value, list | tuple) and len(shape) == 2 and len(value) == shape[1]:
        hint = "a list of columns: stack them with np.column_stack([...])"
    elif arr is not None and arr.ndim == 2 and len(shape) == 2 and arr.shape == shape[::-1]:
        hint = "it is transposed: stack the columns with np.column_stack([...])"
    return_msg = (
        f"{where} returned {_what_came(value, arr)}, expected shape {shape} ({meaning})"
        + (f" — {hint}" if hint else "")
    )
    raise ModelOutputError(return_msg)


def _opt_finite(field_name: str, value: Any) -> float | None:
    if value is None:
        return None
    if not is_number(value):
        raise StudyDefinitionError(
            field_name,
            f"expected a number, got {shown(value)} ({type(value).__name__})",
            "write a finite number, without quotes",
        )
    out = float(value)
    if not math.isfinite(out):
        raise StudyDefinitionError(
            field_name,
            f"expected a finite number, got {value!r}",
            "leave the bound out to mean 'no bound'",
        )
    return out


def _check_name(kind: str, name: Any) -> str:
    if not isinstance(name, str) or not name.strip():
        raise StudyDefinitionError(
            f"{kind}.name",
            f"expected a non-empty string, got {name!r}",
            'give it a name, e.g. name = "f1"',
        )
    return name


def _check_text(where: str, value: Any) -> str:
    if not isinstance(value, str):
        raise StudyDefinitionError(
            where, f"expected text, got {value!r} ({type(value).__name__})", 'write e.g. unit = "m"'
        )
    return value


@dataclass(frozen=True)
class Criterion:
    """A quality (adequacy) criterion Φ_l.

    Parameters
    ----------
    name : str
        Column name, unique among criteria and constraints.
    sense : {"min", "max"}
        Whether smaller or larger values are better.
    role : {"pure", "pseudo"}
        Pure criteria define the Edgeworth–Pareto set; pseudo-criteria are only constrained.
    limit : float, optional
        Criteria constraint Φ**: the worst value accepted (an upper bound for ``min``,
        a lower bound for ``max``).
    unit : str, optional
        Physical unit, for display.
    limit_source : {"", "expert", "noise", "quantile"}
        Where the limit came from: the expert (a number in the study file, or ``--limit ...
        --save``), the noise floor of an identification (``limit = "noise"``, see
        :mod:`vectorid.identify.noise`) or the quantile stand-in
        (:func:`vectorid.workflows.twostep.auto_limits`). A limit given without a source is
        the expert's (:attr:`source`). ``limit = "noise"`` not yet computed is
        ``limit=None, limit_source="noise"``.
    limit_note : str
        A short note on how the limit was obtained, for people (e.g. "noise floor q=0.99 +
        2 m discrepancy").
    """

    name: str
    sense: str = "min"
    role: str = "pure"
    limit: float | None = None
    unit: str = ""
    limit_source: str = ""
    limit_note: str = ""

    def __post_init__(self) -> None:
        _check_name("criteria", self.name)
        _check_text(f"criteria.{self.name}.unit", self.unit)
        if not isinstance(self.sense, str) or self.sense not in ("min", "max"):
            raise StudyDefinitionError(
                f"criteria.{self.name}.sense",
                f"expected 'min' or 'max', got {self.sense!r}",
                'write sense = "min" or sense = "max"',
            )
        if not isinstance(self.role, str) or self.role not in ("pure", "pseudo"):
            raise StudyDefinitionError(
                f"criteria.{self.name}.role",
                f"expected 'pure' or 'pseudo', got {self.role!r}",
                'write role = "pure" (enters the Pareto set) or role = "pseudo"',
            )
        object.__setattr__(self, "limit", _opt_finite(f"criteria.{self.name}.limit", self.limit))
        if self.limit_source not in LIMIT_SOURCES:
            raise StudyDefinitionError(
                f"criteria.{self.name}.limit_source",
                f"expected one of {list(LIMIT_SOURCES)}, got {self.limit_source!r}",
                'leave it out (a number in limit is the expert\'s), or write limit = "noise"',
            )
        if not isinstance(self.limit_note, str):
            raise StudyDefinitionError(
                f"criteria.{self.name}.limit_note",
                f"expected text, got {self.limit_note!r}",
                'write limit_note = "..."',
            )

    @property
    def source(self) -> str:
        """Where the limit came from: ``"expert"``, ``"noise"``, ``"quantile"``, or ``""``
        when there is no limit (a limit without a stated source is the expert's)."""
        if self.limit is None:
            return self.limit_source if self.limit_source == "noise" else ""
        return self.limit_source or "expert"

    def describe_limit(self) -> str:
        """The limit and its source in words, e.g. ``"<= 812.3 m·s (noise: noise floor ...)"``;
        empty when there is none."""
        if self.limit is None:
            return "noise floor (not computed yet)" if self.limit_source == "noise" else ""
        side = "<=" if self.sense == "min" else ">="
        unit = f" {self.unit}" if self.unit else ""
        note = f": {self.limit_note}" if self.limit_note else ""
        return f"{side} {self.limit:.6g}{unit} ({self.source}{note})"

    def to_dict(self) -> dict[str, Any]:
        """The ``[[criteria]]`` table of a study file (dict of TOML values)."""
        out: dict[str, Any] = {"name": self.name, "sense": self.sense, "role": self.role}
        if self.limit is not None:
            out["limit"] = self.limit
        if self.unit:
            out["unit"] = self.unit
        if self.limit_source and (self.limit_source != "expert" or self.limit_note):
            out["limit_source"] = self.limit_source
        if self.limit_note:
            out["limit_note"] = self.limit_note
        return out


@dataclass(frozen=True)
class FunctionalConstraint:
    """A functional constraint ``low <= f_j(α) <= high`` (eq. 6 of seed 000).

    Either bound may be omitted. A trial violating it is outside the feasible set D.

    Parameters
    ----------
    name : str
        Column name, unique among criteria and constraints.
    low, high : float, optional
        The bounds, in the functional's unit (at least one of them).
    unit : str, optional
        Physical unit, for display.
    """

    name: str
    low: float | None = None
    high: float | None = None
    unit: str = ""

    def __post_init__(self) -> None:
        _check_name("constraints", self.name)
        _check_text(f"constraints.{self.name}.unit", self.unit)
        lo = _opt_finite(f"constraints.{self.name}.low", self.low)
        hi = _opt_finite(f"constraints.{self.name}.high", self.high)
        if lo is not None and hi is not None and lo > hi:
            raise StudyDefinitionError(
                f"constraints.{self.name}",
                f"low must not exceed high, got low={lo!r}, high={hi!r}",
                "swap the bounds",
            )
        object.__setattr__(self, "low", lo)
        object.__setattr__(self, "high", hi)

    def to_dict(self) -> dict[str, Any]:
        """The ``[[constraints]]`` table of a study file (dict of TOML values)."""
        out: dict[str, Any] = {"name": self.name}
        if self.low is not None:
            out["low"] = self.low
        if self.high is not None:
            out["high"] = self.high
        if self.unit:
            out["unit"] = self.unit
        return out


@dataclass
class EvalResult:
    """Outcome of a batch: criteria (n, k), functionals (n, q), status (n,), messages,
    and wall time per trial in seconds (n,). Failed rows hold NaN."""

    criteria: np.ndarray
    functionals: np.ndarray
    status: np.ndarray
    messages: dict[int, str] = field(default_factory=dict)
    wall: np.ndarray | None = None
    #: Model errors the batch recovered from by re-running its trials in parts (one line
    #: each, e.g. "raised ValueError: ... (at m.py:3)"), so that a run can report them even
    #: when every value came back.
    retried: list[str] = field(default_factory=list)
    #: Trials that still failed when re-run on their own after such an error.
    retry_lost: int = 0

    @property
    def n(self) -> int:
        return self.criteria.shape[0]

    @classmethod
    def concatenate(cls, parts: Sequence[EvalResult]) -> EvalResult:
        """The results of consecutive batches as one (rows in the given order).

        Parameters
        ----------
        parts : sequence of EvalResult

        Returns
        -------
        EvalResult
        """
        messages: dict[int, str] = {}
        offset = 0
        for r in parts:
            messages.update({offset + i: m for i, m in r.messages.items()})
            offset += r.n
        walls = [r.wall if r.wall is not None else np.zeros(r.n) for r in parts]
        return cls(
            np.concatenate([r.criteria for r in parts]),
            np.concatenate([r.functionals for r in parts]),
            np.concatenate([r.status for r in parts]),
            messages,
            np.concatenate(walls),
            [t for r in parts for t in r.retried],
            sum(r.retry_lost for r in parts),
        )


def load_model(spec: str | BatchModel, base_dir: str | Path | None = None) -> BatchModel:
    """Resolve a model reference to a callable.

    Parameters
    ----------
    spec : str or callable
        ``"package.module:function"`` (the study file's folder ``base_dir`` is put on the
        import path) or a built-in analytic problem name such as ``"binh-korn"``.
    base_dir : path, optional
        Folder of the study file.
    """
    if callable(spec):
        return spec
    if not isinstance(spec, str) or not spec:
        raise StudyDefinitionError(
            "study.model",
            f"expected a built-in name or 'module:function', got {spec!r}",
            'write model = "binh-korn" or model = "mypkg.mymodel:evaluate"',
        )
    if ":" not in spec:
        try:
            return analytic.get(spec).evaluate
        except ValueError as exc:
            raise StudyDefinitionError(
                "study.model",
                str(exc),
                "or name your own function as 'package.module:function'",
            ) from None
    module_name, _, func_name = spec.partition(":")
    if not all(part.isidentifier() for part in module_name.split(".")) or not all(
        part.isidentifier() for part in func_name.split(".")
    ):
        raise StudyDefinitionError(
            "study.model",
            f"expected 'package.module:function' (Python names), got {spec!r}",
            'write e.g. model = "mymodel:evaluate" (mymodel.py beside the study file), or a '
            'built-in name such as "binh-korn"',
        )
    if base_dir is not None:
        base = str(Path(base_dir).resolve())
        if base not in sys.path:
            sys.path.insert(0, base)
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        where = f" (looked beside the study file, in {base_dir})" if base_dir else ""
        missing = exc.name or module_name
        fix = (
            f"put {module_name.replace('.', '/')}.py next to the study file or install it"
            if missing == module_name or module_name.startswith(missing + ".")
            else f"install {missing!r} in this environment (the model module imports it)"
        )
        raise StudyDefinitionError(
            "study.model", f"cannot import module {module_name!r}: {exc}{where}", fix
        ) from None
    except SyntaxError as exc:
        raise StudyDefinitionError(
            "study.model",
            f"the model module {module_name!r} has a syntax error: {exc.msg} "
            f"({Path(exc.filename or '?').name}, line {exc.lineno})",
            "fix the module's syntax (python -m py_compile FILE shows it)",
        ) from None
    except Exception as exc:
        raise StudyDefinitionError(
            "study.model",
            f"importing the model module {module_name!r} raised {_describe(exc)}",
            "fix the module (it fails when imported, before any trial)",
        ) from None
    func: Any = module
    try:
        for part in func_name.split("."):
            func = getattr(func, part)
    except AttributeError:
        names = [n for n in dir(module) if not n.startswith("_")]
        raise StudyDefinitionError(
            "study.model",
            f"module {module_name!r} has no attribute {func_name!r}",
            suggest(func_name, names),
        ) from None
    if not callable(func):
        raise StudyDefinitionError(
            "study.model", f"{spec!r} is not callable", "point to a function"
        )
    return func


def _plural(n: int, word: str) -> str:
    plurals = {"criterion": "criteria"}
    return f"{n} {word if n == 1 else plurals.get(word, word + 's')}"


def build_python_problem(spec: Any) -> Problem:
    """The Problem of a study whose model is a built-in analytic problem or a Python function
    (the ``"python"`` kind of :mod:`vectorid.builders`).

    A built-in problem knows its dimensions: a study whose variables, criteria or functional
    constraints do not fit them is refused here, before any trial, naming both.
    """
    func = load_model(spec.model, spec.base_dir)
    if isinstance(spec.model, str) and ":" not in spec.model:
        ap = analytic.get(spec.model)
        have = (len(spec.space), len(spec.criteria), len(spec.constraints))
        want = (ap.n_var, ap.n_obj, ap.n_con)
        if have != want:
            names = lambda items: ", ".join(x[0] for x in items) or "none"  # noqa: E731
            raise StudyDefinitionError(
                "study.model",
                f"the built-in model {spec.model!r} takes {_plural(want[0], 'variable')} "
                f"({names(ap.variables)}) and returns {_plural(want[1], 'criterion')} "
                f"({names(ap.criteria)}) and {_plural(want[2], 'functional')} "
                f"({names(ap.constraints)}); this study has {_plural(have[0], 'variable')}, "
                f"{_plural(have[1], 'criterion')} and {_plural(have[2], 'constraint')}",
                f"make [[variables]], [[criteria]] and [[constraints]] match "
                f"(`vectorid init {spec.model}` writes a study file that does)",
            )
    if not spec.batch:
        func = as_batch(func)
    return Problem(func, spec.criteria, spec.constraints)


class _PerTrial:
    """A per-trial function lifted to the batch protocol (picklable when ``func`` is)."""

    def __init__(self, func: Callable[[np.ndarray], Any]) -> None:
        self.func = func
        self.per_trial = True

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise RuntimeError("per-trial models are evaluated row by row by Problem.evaluate")


def as_batch(func: Callable[[np.ndarray], Any]) -> BatchModel:
    """Mark a per-trial function ``f(x (p,)) -> row`` so it is evaluated row by row.

    :meth:`Problem.evaluate` calls it once per trial, catching each trial's failure
    separately and timing each trial.

    Parameters
    ----------
    func : callable
        ``func(x)`` with ``x`` one parameter vector (p,) in the variables' units, returning
        the criteria (k,) or a pair ``(criteria (k,), functionals (q,))``.

    Returns
    -------
    callable
        The batch model :class:`Problem` evaluates.
    """
    return _PerTrial(func)


def _split_output(out: Any) -> tuple[Any, Any]:
    if isinstance(out, tuple):
        if len(out) != 2:
            raise ValueError(
                f"expected criteria or a pair (criteria, functionals), got a tuple of {len(out)}"
            )
        return out
    return out, None


class Problem:
    """A model with its criteria and functional constraints.

    Parameters
    ----------
    model : callable
        Batch model (see the module docstring) or a per-trial function wrapped by
        :func:`as_batch`.
    criteria : sequence of Criterion
    constraints : sequence of FunctionalConstraint
    """

    def __init__(
        self,
        model: BatchModel,
        criteria: Sequence[Criterion],
        constraints: Sequence[FunctionalConstraint] = (),
    ) -> None:
        self.model = model
        self.criteria = tuple(criteria)
        self.constraints = tuple(constraints)
        if not self.criteria:
            raise StudyDefinitionError(
                "criteria",
                "a study needs at least one criterion, got none",
                "add a [[criteria]] table with a name and a sense",
            )
        names = [c.name for c in self.criteria] + [c.name for c in self.constraints]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise StudyDefinitionError(
                f"criteria.{dup[0]}",
                f"name {dup[0]!r} is used more than once among criteria and constraints",
                "give each criterion and constraint a unique name",
            )

    @property
    def k(self) -> int:
        """Number of criteria."""
        return len(self.criteria)

    @property
    def q(self) -> int:
        """Number of functional constraints."""
        return len(self.constraints)

    def evaluate(self, X: np.ndarray) -> EvalResult:
        """Evaluate a batch, never raising for a bad trial.

        A batch model that raises is bisected until the failing trials are isolated, so one
        bad trial does not fail its neighbours.

        Parameters
        ----------
        X : (n, p) array of float
            Parameter vectors, columns in variable order and units.

        Returns
        -------
        EvalResult
            Criteria (n, k) and functionals (n, q) in their units (NaN for a failed trial),
            status (n,), failure messages and wall time per trial (s).
        """
        X = np.ascontiguousarray(X, dtype=float)
        if getattr(self.model, "per_trial", False):
            return self._per_trial(X)
        return self._batch(X)

    # -- internals -----------------------------------------------------------------------

    def _empty(self, n: int) -> EvalResult:
        return EvalResult(
            criteria=np.full((n, self.k), np.nan),
            functionals=np.full((n, self.q), np.nan),
            status=np.zeros(n, dtype=np.int8),
            wall=np.zeros(n),
        )

    def _coerce(self, out: Any, n: int) -> tuple[np.ndarray, np.ndarray]:
        crit, func = _split_output(out)
        crit = _numeric(crit, "criteria")
        if crit.ndim == 1 and self.k == 1 and crit.shape[0] == n:
            crit = crit[:, None]
        if crit.shape != (n, self.k):
            raise ValueError(
                f"model returned criteria of shape {crit.shape}, expected ({n}, {self.k}) "
                f"(one column per criterion: {', '.join(c.name for c in self.criteria)})"
            )
        if func is None:
            if self.q:
                raise ValueError(
                    f"model returned no functionals, expected ({n}, {self.q}) for constraints "
                    f"{', '.join(c.name for c in self.constraints)}: return (criteria, functionals)"
                )
            func = np.empty((n, 0))
        func = _numeric(func, "functionals")
        if func.ndim == 1 and self.q == 1 and func.shape[0] == n:
            func = func[:, None]
        if func.shape != (n, self.q):
            raise ValueError(
                f"model returned functionals of shape {func.shape}, expected ({n}, {self.q})"
            )
        return crit, func

    def _mark_nonfinite(self, res: EvalResult, rows: np.ndarray) -> None:
        names = [c.name for c in self.criteria] + [c.name for c in self.constraints]
        values = np.concatenate([res.criteria[rows], res.functionals[rows]], axis=1)
        bad = ~np.isfinite(values)
        for i, r in enumerate(rows):
            if bad[i].any() and res.status[r] == OK:
                cols = [f"{names[j]}={values[i, j]}" for j in np.flatnonzero(bad[i])]
                res.status[r] = FAILED
                res.messages[int(r)] = "non-finite result: " + ", ".join(cols)
                res.criteria[r] = np.nan
                res.functionals[r] = np.nan

    def _put(self, res: EvalResult, rows: np.ndarray, crit: np.ndarray, func: np.ndarray) -> None:
        """Store a batch's output, failing the rows with a complex value (a real criterion
        has no imaginary part; dropping it would store a wrong number)."""
        if np.iscomplexobj(crit) or np.iscomplexobj(func):
            names = [c.name for c in self.criteria] + [c.name for c in self.constraints]
            both = np.concatenate([crit.reshape(len(rows), -1), func.reshape(len(rows), -1)], 1)
            imag = np.imag(both) != 0
            for i, r in enumerate(rows):
                if imag[i].any():
                    cols = [f"{names[j]}={complex(both[i, j])}" for j in np.flatnonzero(imag[i])]
                    res.status[r] = FAILED
                    res.messages[int(r)] = "complex result (a criterion must be real): " + (
                        ", ".join(cols[:4])
                    )
            crit, func = np.real(crit), np.real(func)
        ok = res.status[rows] != FAILED
        res.criteria[rows[ok]] = crit[ok]
        res.functionals[rows[ok]] = func[ok]

    def _batch(self, X: np.ndarray) -> EvalResult:
        n = X.shape[0]
        res = self._empty(n)
        self._batch_into(X, np.arange(n), res)
        self._mark_nonfinite(res, np.arange(n))
        return res

    def _batch_into(
        self, X: np.ndarray, rows: np.ndarray, res: EvalResult, split: bool = False
    ) -> None:
        t0 = time.perf_counter()
        try:
            out = self.model(X[rows])
            rows_back = _row_count(out)
            if rows_back is not None and rows_back != len(rows) and len(rows) > 1:
                raise _WrongRows(f"returned {rows_back} rows for {len(rows)} trials")
            crit, func = self._coerce(out, len(rows))
        except (Exception, SystemExit) as exc:
            if len(rows) == 1:
                res.status[rows[0]] = FAILED
                res.messages[int(rows[0])] = _describe(exc)
                res.wall[rows] = time.perf_counter() - t0
                res.retry_lost += split
                return
            if (
                isinstance(exc, ValueError)
                and "model returned" in str(exc)
                and not isinstance(exc, _WrongRows)
            ):
                # A shape error is a property of the model, not of a trial: fail the batch.
                res.status[rows] = FAILED
                for r in rows:
                    res.messages[int(r)] = str(exc)
                res.wall[rows] = (time.perf_counter() - t0) / len(rows)
                return
            # re-run in halves down to single trials: only the guilty trials fail
            res.retried.append(
                str(exc) if isinstance(exc, _WrongRows) else "raised " + _describe(exc)
            )
            half = len(rows) // 2
            self._batch_into(X, rows[:half], res, True)
            self._batch_into(X, rows[half:], res, True)
            return
        self._put(res, rows, crit, func)
        res.wall[rows] = (time.perf_counter() - t0) / len(rows)

    def _per_trial(self, X: np.ndarray) -> EvalResult:
        n = X.shape[0]
        res = self._empty(n)
        func = self.model.func
        for i in range(n):
            t0 = time.perf_counter()
            try:
                crit, fun = _split_output(func(X[i].copy()))
                crit = np.atleast_1d(_numeric(crit, "criteria"))
                if crit.shape != (self.k,):
                    raise ValueError(
                        f"model returned a criteria row of shape {crit.shape}, expected ({self.k},)"
                    )
                if fun is None:
                    if self.q:
                        raise ValueError(
                            f"model returned no functionals, expected {self.q} values: "
                            "return (criteria, functionals)"
                        )
                    fun = np.empty(0)
                fun = np.atleast_1d(_numeric(fun, "functionals"))
                if fun.shape != (self.q,):
                    raise ValueError(
                        f"model returned a functionals row of shape {fun.shape}, "
                        f"expected ({self.q},)"
                    )
                self._put(res, np.array([i]), crit[None, :], fun[None, :])
            except (Exception, SystemExit) as exc:
                res.status[i] = FAILED
                res.messages[i] = _describe(exc)
            res.wall[i] = time.perf_counter() - t0
        self._mark_nonfinite(res, np.arange(n))
        return res


class _WrongRows(ValueError):
    """A batch model returned another number of rows than it was given trials."""


def _row_count(out: Any) -> int | None:
    """Rows of the criteria a batch model returned (None when it cannot be told)."""
    try:
        crit, _ = _split_output(out)
        shape = np.shape(crit)
    except Exception:
        return None
    return int(shape[0]) if len(shape) >= 1 else None


def _numeric(value: Any, what: str) -> np.ndarray:
    """The model's output as a float (or complex) array; anything else is refused with what
    came (booleans, strings and objects are not numbers, even when float() would take them)."""
    arr = np.asarray(value)
    kind = arr.dtype.kind
    if kind in "fiu":
        return arr.astype(float, copy=False)
    if kind == "c":
        return arr.astype(complex, copy=False)
    if kind == "O":
        flat = arr.ravel()
        if all(is_number(v) for v in flat):
            return arr.astype(float)
        if all(is_number(v) or isinstance(v, complex) for v in flat):
            return arr.astype(complex)
        bad = next(v for v in flat if not (is_number(v) or isinstance(v, complex)))
        example = f"{bad!r} ({type(bad).__name__})"
    else:
        example = f"{arr.ravel()[0]!r} (dtype {arr.dtype})" if arr.size else f"dtype {arr.dtype}"
    raise ValueError(f"model returned {what} that are not numbers: {example}; return floats")


def describe_exception(exc: BaseException) -> str:
    """One line naming an exception a model raised and where (``ValueError: ... (at
    dynamics.py:40 in acceleration)``): how a failed trial's reason reads."""
    return _describe(exc)


def _describe(exc: BaseException) -> str:
    """One line naming the exception and where it came from (a :class:`ModelOutputError`
    names the user's function itself)."""
    tb = traceback.extract_tb(exc.__traceback__)
    where = ""
    if tb and not isinstance(exc, ModelOutputError):
        frame = tb[-1]
        where = f" (at {Path(frame.filename).name}:{frame.lineno} in {frame.name})"
    if isinstance(exc, SystemExit):
        return f"SystemExit: the model called sys.exit({exc.code!r}){where}"
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"{type(exc).__name__}: {text}{where}"
