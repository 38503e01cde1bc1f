"""Design variables and the parameter box Π.

A :class:`Space` maps points of the unit cube ``[0, 1)^p`` (from a Sobol LP_tau or Latin
hypercube sequence) to parameter vectors by the scaling of seed 000, eq. (10)::

    alpha_j = alpha_j* + q_j (alpha_j** - alpha_j*)

for continuous variables. Integer and choice variables split the unit interval into equal
cells, one per admissible value, so every value is drawn with the same probability
(no bias towards the interior as rounding of eq. (10) would give).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from .errors import StudyDefinitionError, is_number, shown, suggest

__all__ = ["Choice", "Continuous", "Integer", "Space", "Variable"]


def _finite(name: str, field_name: str, value: Any) -> float:
    if not is_number(value):
        raise StudyDefinitionError(
            f"variables.{name}.{field_name}",
            f"expected a number, got {shown(value)} ({type(value).__name__})",
            "write a finite number such as 0.0, without quotes",
        )
    out = float(value)
    if not math.isfinite(out):
        raise StudyDefinitionError(
            f"variables.{name}.{field_name}",
            f"expected a finite number, got {value!r}",
            "use finite bounds; the PSI method samples a bounded box",
        )
    return out


class Variable(abc.ABC):
    """Base of the three variable kinds. Use :class:`Continuous`, :class:`Integer` or
    :class:`Choice`.

    Every variable has ``name``, ``low``, ``high`` (the box Π), ``nominal`` (or None) and
    ``unit``; it maps unit-interval values to its own values with :meth:`from_unit`.
    """

    kind = "abstract"
    name: str
    low: float
    high: float
    nominal: float | None
    unit: str

    @abc.abstractmethod
    def from_unit(self, q: np.ndarray) -> np.ndarray:
        """Map values in [0, 1) to this variable's values.

        Parameters
        ----------
        q : ndarray of float
            Points of the unit interval, any shape (dimensionless).

        Returns
        -------
        ndarray of float
            The variable's values, same shape, in its unit.
        """

    @abc.abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """The ``[[variables]]`` table of a study file."""

    @abc.abstractmethod
    def with_bounds(self, low: float, high: float) -> Variable:
        """The same variable on a narrower (or wider) interval (double tuning).

        Parameters
        ----------
        low, high : float
            The new bounds, in the variable's unit.

        Returns
        -------
        Variable
            A new variable of the same kind; a nominal outside the new bounds is dropped.
        """

    def __eq__(self, other: object) -> bool:
        return type(other) is type(self) and self.to_dict() == other.to_dict()

    def __hash__(self) -> int:
        return hash(repr(self.to_dict()))

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.to_dict().items() if k != "type")
        return f"{type(self).__name__}({args})"


class Continuous(Variable):
    """A continuous design variable ``low <= x <= high``.

    Parameters
    ----------
    name : str
        Variable name, unique within the study.
    low, high : float
        Parametric constraints α* and α** (eq. 5 of seed 000), ``low < high``.
    nominal : float, optional
        Reference value (e.g. 1 for a gain factor); must lie inside the box.
    unit : str, optional
        Physical unit, for display only.
    """

    kind = "continuous"

    def __init__(
        self,
        name: str,
        low: float,
        high: float,
        nominal: float | None = None,
        unit: str = "",
    ) -> None:
        _check_name(name)
        lo = _finite(name, "low", low)
        hi = _finite(name, "high", high)
        if not lo < hi:
            raise StudyDefinitionError(
                f"variables.{name}",
                f"low must be smaller than high, got low={lo!r}, high={hi!r}",
                "swap the bounds or widen the interval"
                if lo > hi
                else "a variable with equal bounds is a constant: remove it or widen the interval",
            )
        if nominal is not None:
            nominal = _finite(name, "nominal", nominal)
            if not lo <= nominal <= hi:
                raise StudyDefinitionError(
                    f"variables.{name}.nominal",
                    f"nominal {nominal!r} lies outside [{lo!r}, {hi!r}]",
                    "move the nominal value inside the bounds or widen them",
                )
        self.name = name
        self.low = lo
        self.high = hi
        self.nominal = nominal
        self.unit = str(unit)

    def from_unit(self, q: np.ndarray) -> np.ndarray:
        """Scale unit-interval values by eq. (10): ``low + q (high - low)``.

        Parameters
        ----------
        q : ndarray of float
            Points of the unit interval, any shape (dimensionless).

        Returns
        -------
        ndarray of float
            The variable's values, same shape, in its unit.
        """
        return self.low + q * (self.high - self.low)

    def with_bounds(self, low: float, high: float) -> Continuous:
        """The same variable on a narrower (or wider) interval (double tuning).

        Parameters
        ----------
        low, high : float
            The new bounds, in the variable's unit.

        Returns
        -------
        Variable
            A new variable of the same kind; a nominal outside the new bounds is dropped.
        """
        nominal = self.nominal
        if nominal is not None and not low <= nominal <= high:
            nominal = None
        return Continuous(self.name, low, high, nominal, self.unit)

    def to_dict(self) -> dict[str, Any]:
        """The ``[[variables]]`` table of a study file (dict of TOML values)."""
        out: dict[str, Any] = {"name": self.name, "low": self.low, "high": self.high}
        if self.nominal is not None:
            out["nominal"] = self.nominal
        if self.unit:
            out["unit"] = self.unit
        return out


class Integer(Variable):
    """An integer design variable taking every value ``low, low + 1, ..., high``.

    The unit interval is split into ``high - low + 1`` equal cells, one per value, so every
    value is equally likely.

    Parameters
    ----------
    name : str
        Variable name, unique within the study.
    low, high : int
        The smallest and largest value (a whole number each), ``low < high``.
    nominal : int, optional
        Reference value; must lie inside ``[low, high]``.
    unit : str, optional
        Physical unit, for display only.
    """

    kind = "integer"

    def __init__(
        self, name: str, low: int, high: int, nominal: int | None = None, unit: str = ""
    ) -> None:
        _check_name(name)
        for fname, value in (("low", low), ("high", high), ("nominal", nominal)):
            if value is None:
                continue
            if isinstance(value, bool) or not float(_finite(name, fname, value)).is_integer():
                raise StudyDefinitionError(
                    f"variables.{name}.{fname}",
                    f"an integer variable needs whole-number bounds, got {value!r}",
                    'write a whole number, or use type = "continuous"',
                )
        lo, hi = int(low), int(high)
        if not lo < hi:
            raise StudyDefinitionError(
                f"variables.{name}",
                f"low must be smaller than high, got low={lo}, high={hi}",
                "swap the bounds or widen the interval",
            )
        if nominal is not None and not lo <= int(nominal) <= hi:
            raise StudyDefinitionError(
                f"variables.{name}.nominal",
                f"nominal {nominal} lies outside [{lo}, {hi}]",
                "move the nominal value inside the bounds",
            )
        self.name = name
        self.low = lo
        self.high = hi
        self.nominal = None if nominal is None else int(nominal)
        self.unit = str(unit)

    def from_unit(self, q: np.ndarray) -> np.ndarray:
        """Map values in [0, 1) to this variable's values.

        Parameters
        ----------
        q : ndarray of float
            Points of the unit interval, any shape (dimensionless).

        Returns
        -------
        ndarray of float
            The variable's values, same shape, in its unit.
        """
        m = self.high - self.low + 1
        idx = np.minimum(np.floor(q * m), m - 1)
        return self.low + idx

    def with_bounds(self, low: float, high: float) -> Integer:
        """The same variable on a narrower (or wider) interval (double tuning).

        Parameters
        ----------
        low, high : float
            The new bounds, in the variable's unit.

        Returns
        -------
        Variable
            A new variable of the same kind; a nominal outside the new bounds is dropped.
        """
        lo, hi = math.floor(low), math.ceil(high)
        if lo == hi:
            hi = lo + 1 if hi < self.high else hi
            lo = hi - 1 if lo == hi else lo
        nominal = self.nominal if self.nominal is not None and lo <= self.nominal <= hi else None
        return Integer(self.name, lo, hi, nominal, self.unit)

    def to_dict(self) -> dict[str, Any]:
        """The ``[[variables]]`` table of a study file (dict of TOML values)."""
        out: dict[str, Any] = {
            "name": self.name,
            "type": "integer",
            "low": self.low,
            "high": self.high,
        }
        if self.nominal is not None:
            out["nominal"] = self.nominal
        if self.unit:
            out["unit"] = self.unit
        return out


class Choice(Variable):
    """A variable taking one of a finite set of numeric values (e.g. a catalogue of line
    lengths). The unit interval is split into ``len(values)`` equal cells.

    Parameters
    ----------
    name : str
        Variable name, unique within the study.
    values : sequence of float
        The admissible values, distinct, in the variable's unit.
    nominal : float, optional
        Reference value; must be one of ``values``.
    unit : str, optional
        Physical unit, for display only.
    """

    kind = "choice"

    def __init__(
        self, name: str, values: Sequence[float], nominal: float | None = None, unit: str = ""
    ) -> None:
        _check_name(name)
        if isinstance(values, str | bytes) or not isinstance(values, Iterable):
            raise StudyDefinitionError(
                f"variables.{name}.values",
                f"expected a list of numbers, got {values!r}",
                "write values = [1.0, 2.5, 4.0]",
            )
        vals = tuple(_finite(name, "values", v) for v in values)
        if len(vals) == 0:
            raise StudyDefinitionError(
                f"variables.{name}.values",
                "a choice variable needs at least one value, got an empty list",
                "list the admissible values, e.g. values = [1.0, 2.0]",
            )
        if len(set(vals)) != len(vals):
            raise StudyDefinitionError(
                f"variables.{name}.values",
                f"values must be distinct, got {list(vals)}",
                "remove the repeated values",
            )
        if nominal is not None:
            nominal = _finite(name, "nominal", nominal)
            if nominal not in vals:
                raise StudyDefinitionError(
                    f"variables.{name}.nominal",
                    f"nominal {nominal!r} is not one of the values {list(vals)}",
                    "pick the nominal among the values",
                )
        self.name = name
        self.values = vals
        self.nominal = nominal
        self.unit = str(unit)

    @property
    def low(self) -> float:
        """The smallest admissible value, in the variable's unit."""
        return min(self.values)

    @property
    def high(self) -> float:
        """The largest admissible value, in the variable's unit."""
        return max(self.values)

    def from_unit(self, q: np.ndarray) -> np.ndarray:
        """Map values in [0, 1) to this variable's values.

        Parameters
        ----------
        q : ndarray of float
            Points of the unit interval, any shape (dimensionless).

        Returns
        -------
        ndarray of float
            The variable's values, same shape, in its unit.
        """
        m = len(self.values)
        idx = np.minimum(np.floor(q * m), m - 1).astype(np.intp)
        return np.asarray(self.values, dtype=float)[idx]

    def with_bounds(self, low: float, high: float) -> Choice:
        """The same variable on a narrower (or wider) interval (double tuning).

        Parameters
        ----------
        low, high : float
            The new bounds, in the variable's unit.

        Returns
        -------
        Variable
            A new variable of the same kind; a nominal outside the new bounds is dropped.
        """
        kept = [v for v in self.values if low <= v <= high] or list(self.values)
        nominal = self.nominal if self.nominal in kept else None
        return Choice(self.name, kept, nominal, self.unit)

    def to_dict(self) -> dict[str, Any]:
        """The ``[[variables]]`` table of a study file (dict of TOML values)."""
        out: dict[str, Any] = {"name": self.name, "type": "choice", "values": list(self.values)}
        if self.nominal is not None:
            out["nominal"] = self.nominal
        if self.unit:
            out["unit"] = self.unit
        return out


def _check_name(name: Any) -> None:
    if not isinstance(name, str) or not name.strip():
        raise StudyDefinitionError(
            "variables.name",
            f"expected a non-empty string, got {name!r}",
            'give every variable a name, e.g. name = "x1"',
        )


class Space:
    """The ordered design variables and their box Π.

    Parameters
    ----------
    variables : sequence of Variable
        Columns of every parameter array, in this order.
    """

    def __init__(self, variables: Sequence[Variable]) -> None:
        variables = list(variables)
        if not variables:
            raise StudyDefinitionError(
                "variables",
                "a study needs at least one variable, got none",
                "add a [[variables]] table with name, low and high",
            )
        seen: set[str] = set()
        for v in variables:
            if not isinstance(v, Variable):
                raise StudyDefinitionError(
                    "variables", f"expected Variable objects, got {type(v).__name__}"
                )
            if v.name in seen:
                raise StudyDefinitionError(
                    f"variables.{v.name}",
                    f"duplicate variable name {v.name!r}",
                    "give each variable a unique name",
                )
            seen.add(v.name)
        self.variables: tuple[Variable, ...] = tuple(variables)

    def __len__(self) -> int:
        return len(self.variables)

    def __iter__(self):
        return iter(self.variables)

    def __repr__(self) -> str:
        return f"Space({list(self.variables)!r})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Space) and self.to_list() == other.to_list()

    @property
    def names(self) -> list[str]:
        """Variable names in column order."""
        return [v.name for v in self.variables]

    @property
    def lows(self) -> np.ndarray:
        """Lower bounds α* (p,)."""
        return np.array([v.low for v in self.variables], dtype=float)

    @property
    def highs(self) -> np.ndarray:
        """Upper bounds α** (p,)."""
        return np.array([v.high for v in self.variables], dtype=float)

    @property
    def nominal(self) -> np.ndarray:
        """Nominal values (p,), NaN where a variable has none."""
        return np.array(
            [np.nan if v.nominal is None else v.nominal for v in self.variables], dtype=float
        )

    def index(self, name: str) -> int:
        """Column of variable ``name``.

        Parameters
        ----------
        name : str
            A variable of this space.

        Returns
        -------
        int
            Its column in parameter arrays.

        Raises
        ------
        StudyDefinitionError
            Unknown name (the message suggests the nearest).
        """

        try:
            return self.names.index(name)
        except ValueError:
            raise StudyDefinitionError(
                "variable", f"unknown variable {name!r}", suggest(name, self.names)
            ) from None

    def scale(self, q: np.ndarray) -> np.ndarray:
        """Map unit-cube points to parameter vectors by eq. (10).

        Parameters
        ----------
        q : (n, p) array of float
            Points of the unit cube [0, 1)^p (dimensionless).

        Returns
        -------
        (n, p) ndarray of float
            Parameter vectors, each column in its variable's unit.
        """
        q = np.asarray(q, dtype=float)
        if q.ndim != 2 or q.shape[1] != len(self):
            raise ValueError(f"expected unit points of shape (n, {len(self)}), got {q.shape}")
        out = np.empty_like(q)
        for j, v in enumerate(self.variables):
            out[:, j] = v.from_unit(q[:, j])
        return out

    def contains(self, X: np.ndarray) -> np.ndarray:
        """Which parameter vectors lie inside the box Π.

        Parameters
        ----------
        X : (n, p) array of float
            Parameter vectors, columns in variable order and units.

        Returns
        -------
        (n,) ndarray of bool
        """
        X = np.asarray(X, dtype=float)
        return np.all((X >= self.lows) & (X <= self.highs), axis=1)

    def with_bounds(self, bounds: dict[str, tuple[float, float]]) -> Space:
        """A new space with some variables' bounds replaced (double tuning).

        Parameters
        ----------
        bounds : dict of str to (float, float)
            Variable name -> new (low, high), in the variable's unit.

        Returns
        -------
        Space
        """
        unknown = set(bounds) - set(self.names)
        if unknown:
            name = sorted(unknown)[0]
            raise StudyDefinitionError(
                "bounds", f"unknown variable {name!r}", suggest(name, self.names)
            )
        return Space(
            [v.with_bounds(*bounds[v.name]) if v.name in bounds else v for v in self.variables]
        )

    def to_list(self) -> list[dict[str, Any]]:
        """The ``[[variables]]`` tables of a study file."""
        return [v.to_dict() for v in self.variables]
