"""Server-side state of the browser UI: the trials of one store, cached, and the parsing of
everything the browser sends.

The UI process only ever *reads* the store (read-only SQLite connections, one per request,
since a connection may not cross threads); background jobs write it from another process
(:mod:`vectorid.views.ui.jobs`). The loaded trials are cached and reloaded when the store's
trial or stage count changes, so a constraint change never touches the disk beyond three
``count`` queries and a read of the study definition (whose checksum shows constraints saved
with the study), and a running stage shows up as it grows.

Nothing the browser sends is a path or code: constraints and parameters are parsed here as
numbers (non-finite, over-long or non-numeric text is rejected with a message that says what
was expected), trial ids as integers, names are checked against the study.
"""

from __future__ import annotations

import logging
import math
import threading
import zlib
from collections import OrderedDict
from collections.abc import Iterator, Mapping, Sequence, Sized
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...analysis.results import Analysis, TestTable
from ...errors import StudyDefinitionError, suggest
from ...samplers import Weighting, sampler_for
from ...spec import StudySpec
from ...store import Stage, Store, Trials

__all__ = [
    "Constraints",
    "StoreCache",
    "parse_constraints",
    "parse_number",
    "parse_trial_id",
]

_MAX_TEXT = 64  # longest text accepted in a numeric field


def parse_number(
    text: Any,
    field: str,
    *,
    allow_empty: bool = True,
    example: str = "40.5",
    empty_means: str = "no limit",
) -> float | None:
    """A finite number from a browser field (``None`` for an empty field).

    Parameters
    ----------
    text : str, number or None
        What the browser sent.
    field : str
        Name of the field, for the message.
    allow_empty : bool
        Whether an empty field is accepted (returned as None).

    Raises
    ------
    StudyDefinitionError
        When the text is not a finite number (or is empty and ``allow_empty`` is False).
    """
    if text is None or (isinstance(text, str) and not text.strip()):
        if allow_empty:
            return None
        raise StudyDefinitionError(field, "the field is empty", f"type a number, e.g. {example}")
    if isinstance(text, bool):
        raise StudyDefinitionError(field, f"expected a number, got {text!r}", f"e.g. {example}")
    if isinstance(text, int | float):
        value = float(text)
    else:
        s = str(text).strip()
        if len(s) > _MAX_TEXT:
            raise StudyDefinitionError(
                field, f"expected a number, got {len(s)} characters of text", f"e.g. {example}"
            )
        try:
            value = float(s)
        except ValueError:
            hint = f"type a number such as {example}"
            if allow_empty:
                hint += f", or clear the field for {empty_means}"
            raise StudyDefinitionError(field, f"expected a number, got {s!r}", hint) from None
    if math.isnan(value):
        raise StudyDefinitionError(field, "NaN is not a bound", f"type a number, e.g. {example}")
    if math.isinf(value):
        if allow_empty:
            return None  # 'inf' removes the bound, as with --limit 'f1<=inf'
        raise StudyDefinitionError(field, f"expected a finite number, got {value}", example)
    return value


def parse_trial_id(text: Any, field: str = "trial id") -> int:
    """A trial id (positive whole number) from a browser field.

    Raises
    ------
    StudyDefinitionError
        When the text is not a whole number >= 1.
    """
    if text is None or (isinstance(text, str) and not text.strip()):
        raise StudyDefinitionError(
            field, "no trial chosen", "type a trial id, or click a point or a table row"
        )
    if isinstance(text, bool):
        raise StudyDefinitionError(field, f"expected a whole number, got {text!r}", "e.g. 110")
    s = str(text).strip()
    if len(s) > 20:
        raise StudyDefinitionError(
            field, f"expected a trial id, got {len(s)} characters", "e.g. 110"
        )
    try:
        value = float(s) if not s.isdigit() else int(s)
    except ValueError:
        raise StudyDefinitionError(
            field, f"expected a whole number, got {s!r}", "type an id such as 110"
        ) from None
    if isinstance(value, float):
        if not (math.isfinite(value) and value.is_integer()):
            raise StudyDefinitionError(field, f"expected a whole number, got {s!r}", "e.g. 110")
        value = int(value)
    if value < 1:
        raise StudyDefinitionError(field, f"trial ids start at 1, got {value}", "e.g. 110")
    return value


@dataclass(frozen=True)
class Constraints:
    """Criteria constraints, functional-constraint bounds and roles as chosen in the browser,
    validated.

    Attributes
    ----------
    limits : dict
        Criterion name -> bound on its worse side (upper for ``min``, lower for ``max``),
        or None for no bound; only criteria whose field parsed are present (the others keep
        the study's limit).
    roles : dict
        Criterion name -> ``"pure"`` or ``"pseudo"``.
    errors : dict
        Field -> message, for fields that did not parse: the criterion's name, or
        ``"<constraint>.low"`` / ``"<constraint>.high"`` for a functional bound.
    functional : dict
        Functional constraint name -> ``(low, high)`` (None for no bound on that side), for
        every constraint whose fields were sent; a side whose field did not parse keeps the
        study's bound.
    """

    limits: dict[str, float | None]
    roles: dict[str, str]
    errors: dict[str, str]
    functional: dict[str, tuple[float | None, float | None]] = field(default_factory=dict)

    def key(self) -> tuple:
        """Hashable form (memo key)."""
        return (
            tuple(sorted(self.limits.items())),
            tuple(sorted(self.roles.items())),
            self.functional_key(),
        )

    def functional_key(self) -> tuple:
        """Hashable form of the functional bounds alone (they fix the test tables' rows)."""
        return tuple(sorted(self.functional.items()))

    @property
    def overrides(self) -> dict[str, Any]:
        """The bounds as :class:`~vectorid.analysis.Analysis` takes them: criterion ->
        worse-side limit, functional constraint -> ``(low, high)``."""
        return {**self.limits, **self.functional}

    @property
    def messages(self) -> list[str]:
        out = [f"{msg} (ignored: the study's bound is used)" for msg in self.errors.values()]
        return list(dict.fromkeys(out))  # low > high marks both fields with one message


def parse_constraints(
    spec: StudySpec,
    limit_texts: Sequence[Any] | None,
    roles: Sequence[Any] | None,
    functional: Sequence[Sequence[Any]] | None = None,
) -> Constraints:
    """Validate the constraint fields and role toggles of the test tables.

    Parameters
    ----------
    spec : StudySpec
    limit_texts : sequence
        One field per criterion, in the study's order (text, number or None).
    roles : sequence
        One ``"pure"``/``"pseudo"`` per criterion, in the study's order.
    functional : sequence, optional
        One ``(low text, high text)`` pair per functional constraint, in the study's order
        (empty for no bound on that side); None keeps the study's bounds.
    """
    names = spec.criterion_names
    limits: dict[str, float | None] = {}
    errors: dict[str, str] = {}
    texts = list(limit_texts or [])
    if texts and len(texts) != len(names):
        raise StudyDefinitionError(
            "constraints", f"expected {len(names)} fields, got {len(texts)}", "reload the page"
        )
    for name, text in zip(names, texts):
        sense = spec.criteria[names.index(name)].sense
        exact = _exact(text, spec.criteria[names.index(name)].limit)
        try:
            limits[name] = (
                exact
                if exact is not None
                else parse_number(
                    text, f"constraint on {name} ({'<=' if sense == 'min' else '>='})"
                )
            )
        except StudyDefinitionError as exc:
            errors[name] = str(exc)
    out_roles: dict[str, str] = {}
    for name, role in zip(names, list(roles or [])):
        if role not in ("pure", "pseudo"):
            raise StudyDefinitionError(
                f"role of {name}", f"expected 'pure' or 'pseudo', got {role!r}", "reload the page"
            )
        out_roles[name] = str(role)
    bounds: dict[str, tuple[float | None, float | None]] = {}
    pairs = list(functional or [])
    if pairs and len(pairs) != len(spec.constraints):
        raise StudyDefinitionError(
            "functional constraints",
            f"expected {len(spec.constraints)} pairs of bounds, got {len(pairs)}",
            "reload the page",
        )
    for con, pair in zip(spec.constraints, pairs):
        if not isinstance(pair, list | tuple) or len(pair) != 2:
            raise StudyDefinitionError(
                f"bounds of {con.name}", f"expected a (low, high) pair, got {pair!r}", "reload"
            )
        side: list[float | None] = [con.low, con.high]
        for k, (label, op) in enumerate((("low", ">="), ("high", "<="))):
            exact = _exact(pair[k], (con.low, con.high)[k])
            if exact is not None:
                side[k] = exact
                continue
            try:
                side[k] = parse_number(
                    pair[k],
                    f"{label} bound of {con.name} ({con.name} {op})",
                    example="25",
                    empty_means=f"no {label} bound",
                )
            except StudyDefinitionError as exc:
                errors[f"{con.name}.{label}"] = str(exc)
        lo, hi = side
        if lo is not None and hi is not None and lo > hi:
            for label in ("low", "high"):
                errors[f"{con.name}.{label}"] = str(
                    StudyDefinitionError(
                        f"bounds of {con.name}",
                        f"expected low <= high, got {lo:g} .. {hi:g}",
                        "swap them, or clear one side",
                    )
                )
            lo, hi = con.low, con.high
        bounds[con.name] = (lo, hi)
    return Constraints(limits, out_roles, errors, bounds)


class StoreCache:
    """The trials of one study store, loaded once and reloaded when the store grows.

    Parameters
    ----------
    path : path
        The store (``.db``). It is only opened read-only here.
    memo : int
        How many :class:`~vectorid.analysis.Analysis` objects (one per constraint set) to keep.
    """

    def __init__(self, path: str | Path, memo: int = 8) -> None:
        self.path = Path(path).resolve()
        self._lock = threading.RLock()
        self._memo_size = int(memo)
        self._memo: OrderedDict[tuple, Analysis] = OrderedDict()
        self._key: tuple | None = None
        self._trials: Trials | None = None
        self._weighting: Weighting | None = None
        self._spec: StudySpec | None = None
        self._stages: list[Stage] = []
        self._tables: OrderedDict[tuple, list[TestTable]] = OrderedDict()
        self.loads = 0  # how many times the trials were read from disk
        self.narrowed = 0  # analyses computed from a memoised one (a constraint tightened)
        self.widened = 0  # analyses computed from a memoised one (a constraint loosened)
        with self.open() as st:
            self._spec = st.spec

    @contextmanager
    def open(self) -> Iterator[Store]:
        """A read-only connection to the store (closed on exit)."""
        st = Store.open(self.path)
        try:
            yield st
        finally:
            st.close()

    @staticmethod
    def _key_of(st: Store) -> tuple[int, int, int, int]:
        # the study definition changes when constraints are saved with it (Store.set_limits);
        # a CRC-32 of its JSON stays exact through the browser's JSON numbers
        study = st.meta().get("study", "")
        return (st.count_sample(), st.count(), len(st.stages()), zlib.crc32(study.encode()))

    def version(self) -> tuple[int, int, int, int]:
        """``(sample trials, all trials, stages, checksum of the study definition)`` now in
        the store (four cheap queries)."""
        with self.open() as st:
            return self._key_of(st)

    def count_sample(self) -> int:
        """Sample trials now in the store (one query; the progress of run jobs)."""
        with self.open() as st:
            return st.count_sample()

    def _refresh(self) -> None:
        with self.open() as st:
            key = self._key_of(st)
            if key == self._key and self._trials is not None:
                return
            self._spec = st.spec
            self._stages = st.stages()
            if self._key is None or key[:3] != self._key[:3] or self._trials is None:
                self._trials = None
                self._memo.clear()
                self._tables.clear()
                self._trials = st.load()  # only the definition changed: the trials stay
                # the parameters column by column (Fortran order): each view reads one
                # parameter over every trial (histograms, identifiability, plots), which is
                # then contiguous, and no view needs a transposed copy (96 MB at 1e6)
                self._trials.X = np.asfortranarray(self._trials.X)
                self._weighting = sampler_for(self._spec).weighting(st, self._trials)
                self.loads += 1
                release_freed_memory()
            self._key = key
            self._memo.clear()
            self._tables.clear()

    @property
    def spec(self) -> StudySpec:
        assert self._spec is not None
        return self._spec

    def state(self) -> tuple[tuple, Trials, list[Stage]]:
        """The current ``(version key, sample trials, stages)``, reloaded if the store changed."""
        with self._lock:
            self._refresh()
            assert self._trials is not None and self._key is not None
            return self._key, self._trials, list(self._stages)

    def trials(self) -> Trials:
        return self.state()[1]

    def analysis(self, c: Constraints | None = None) -> Analysis:
        """The :class:`~vectorid.analysis.Analysis` of the current trials under ``c``
        (memoised per constraint set and store version): computed from a memoised one where
        ``c`` only tightens (:meth:`~vectorid.analysis.Analysis.narrowed`) or only loosens
        (:meth:`~vectorid.analysis.Analysis.widened`) its bounds, else from the trials."""
        c = c or Constraints({}, {}, {})
        with self._lock:
            key, trials, _ = self.state()
            full = (key, c.key())
            hit = self._memo.get(full)
            if hit is not None:
                self._memo.move_to_end(full)
                return hit
            a = None
            # a tightened constraint set: computed from the smallest memoised D holding it
            for (k, _), prev in sorted(self._memo.items(), key=lambda kv: kv[1].n_feasible):
                if k == key:
                    a = prev.narrowed(c.overrides, c.roles)
                    if a is not None:
                        self.narrowed += 1
                        break
            # a loosened one: from the largest memoised D it holds (only the trials between
            # the old and the new bounds are checked, and the Pareto set grows from the old)
            if a is None:
                for (k, _), prev in sorted(self._memo.items(), key=lambda kv: -kv[1].n_feasible):
                    if k == key:
                        a = prev.widened(c.overrides, c.roles)
                        if a is not None:
                            self.widened += 1
                            break
            if a is None:
                a = Analysis(self.spec, trials, c.overrides, c.roles, self._weighting)
            self._memo[full] = a
            while len(self._memo) > self._memo_size:
                self._memo.popitem(last=False)
            return a

    def test_tables(self, c: Constraints | None = None, top: int | None = None) -> list[TestTable]:
        """The test tables (every criterion's trials meeting the functional constraints, best
        first) of the current trials under the functional bounds of ``c`` (the study's when
        None). Their order depends only on the trials and the functional bounds, so they are
        computed once per store version and functional bounds (4 kept); a criteria constraint
        change only re-reads ``Analysis.feasible`` for the rows shown (:meth:`rows_of`).
        With ``top``, only each table's first ``top`` rows are kept (all the page shows: at
        1e6 trials the whole tables take ~100 MB)."""
        functional = c.functional if c is not None else {}
        with self._lock:
            self.state()
            key = (tuple(sorted(functional.items())), top)
            hit = self._tables.get(key)
            if hit is not None:
                self._tables.move_to_end(key)
                return hit
            a = self.analysis(Constraints({}, {}, {}, dict(functional)))
            tables = a.test_tables(top=top)
            self._tables[key] = tables
            while len(self._tables) > 4:
                self._tables.popitem(last=False)
            return tables

    def rows_of(self, ids: np.ndarray, trials: Trials | None = None) -> np.ndarray:
        """Rows with these ids (all must exist) in ``trials`` — pass the trials of the
        Analysis the rows index (``a.trials``): a run appending meanwhile must not shift
        them — default: the cached sample trials."""
        t = trials if trials is not None else self.trials()
        ids = np.asarray(ids, dtype=np.int64)
        if trials is not None:  # ids from a newer version may be missing: -1
            if len(t) and np.all(t.id[1:] > t.id[:-1]):
                at = np.minimum(np.searchsorted(t.id, ids), len(t) - 1)
                return np.where(t.id[at] == ids, at, -1).astype(np.int64)
            where = {int(v): i for i, v in enumerate(t.id)}
            return np.array([where.get(int(v), -1) for v in ids], dtype=np.int64)
        if len(t) and np.all(t.id[1:] > t.id[:-1]):  # ids ascend: binary search
            return np.searchsorted(t.id, ids)
        where = {int(v): i for i, v in enumerate(t.id)}
        return np.array([where[int(v)] for v in ids], dtype=np.int64)

    def row_of(self, trial_id: int) -> int:
        """Row of a sample trial in the cached arrays.

        Raises
        ------
        StudyDefinitionError
            With the range of valid ids when no sample trial has that id.
        """
        t = self.trials()
        hit = np.flatnonzero(t.id == int(trial_id))
        if len(hit) == 0:
            hint = (
                f"sample trial ids run from {int(t.id.min())} to {int(t.id.max())}"
                if len(t)
                else "the store holds no trial yet"
            )
            raise StudyDefinitionError(
                "trial id", f"no sample trial has id {trial_id}", hint + "; click a point instead"
            )
        return int(hit[0])

    def check_name(self, name: Any, kind: str) -> str:
        """``name`` if it is a criterion/parameter/functional of the study (``kind``:
        ``"criterion"``, ``"parameter"`` or ``"any"``)."""
        spec = self.spec
        valid = {
            "criterion": spec.criterion_names,
            "parameter": spec.space.names,
            "any": spec.criterion_names + spec.constraint_names + spec.space.names,
        }[kind]
        if not isinstance(name, str) or name not in valid:
            raise StudyDefinitionError(kind, f"unknown {kind} {name!r}", suggest(str(name), valid))
        return name


def release_freed_memory() -> None:
    """Give the memory freed by the C allocator back to the system (glibc's
    ``malloc_trim``; nothing elsewhere). Reading a store leaves its batches' blobs freed but
    held by the process (they are smaller than the allocator's mmap threshold): at 1e6
    trials ~200 MB more than the columns themselves."""
    global _TRIM
    if _TRIM is None:
        try:
            import ctypes

            _TRIM = ctypes.CDLL("libc.so.6").malloc_trim
        except (OSError, AttributeError):
            _TRIM = False
    if _TRIM:
        _TRIM(0)


_TRIM: Any = None


def limit_allocator_arenas(arenas: int = 2) -> None:
    """Let the C allocator keep at most ``arenas`` heaps (glibc's ``mallopt(M_ARENA_MAX)``;
    nothing elsewhere). The web server answers each request in a thread of its own, and
    glibc gives busy threads heaps of their own, each keeping what its requests freed: at
    1e6 trials, hundreds of MB beyond the columns after a few minutes of use. Called once,
    before the server starts its threads.

    It also fixes the size from which a block gets pages of its own (``M_MMAP_THRESHOLD``,
    1 MiB) and is given back the moment it is freed: glibc otherwise raises that size to
    the largest block freed so far (up to 32 MiB), so a request's temporaries over the
    columns (8 MB each at 1e6 trials) were carved from the heaps and held there."""
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-8, int(arenas))  # M_ARENA_MAX
        libc.mallopt(-3, 1 << 20)  # M_MMAP_THRESHOLD (fixed: no dynamic raise)
    except (OSError, AttributeError):
        pass


#: The thread-count setters of the OpenBLAS builds numpy and scipy ship (and of a plain one).
_BLAS_SETTERS = (
    "scipy_openblas_set_num_threads64_",
    "scipy_openblas_set_num_threads",
    "openblas_set_num_threads64_",
    "openblas_set_num_threads",
)


def limit_blas_threads(threads: int = 1) -> list[str]:
    """Let every OpenBLAS library loaded in this process use at most ``threads`` threads
    (nothing where none is loaded, or off Linux). The web server answers each request in a
    thread of its own, several at once after a typed limit; a BLAS product inside each (the
    combinations' covariance and projections over D at 1e6 trials) then started a thread per
    core too, and on two busy cores they waited on each other: the explorer's summary took
    0.4 s instead of 0.12 s. Called once the server's modules are loaded.

    Returns
    -------
    list of str
        The libraries set (file names), for the log.
    """
    import ctypes

    done = []
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as f:
            libs = {line.split()[-1] for line in f if "openblas" in line.lower()}
    except OSError:
        return done
    for path in sorted(libs):
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for name in _BLAS_SETTERS:
            fn = getattr(lib, name, None)
            if fn is not None:
                fn(int(threads))
                done.append(Path(path).name)
                break
    return done


class FreedMemoryReleaser:
    """Gives the allocator's freed memory back (:func:`release_freed_memory`) once requests
    have stopped for ``quiet`` seconds: a burst of requests (a typed limit redraws several
    views) leaves its temporaries freed but held; one trim after the burst returns them."""

    def __init__(self, quiet: float = 1.0) -> None:
        import threading

        self._lock = threading.Lock()
        self._timer: Any = None
        self._quiet = quiet

    def poke(self) -> None:
        """A request ended: (re)start the countdown."""
        import threading

        with self._lock:
            if self._timer is not None:
                self._timer.cancel()
            self._timer = threading.Timer(self._quiet, release_freed_memory)
            self._timer.daemon = True
            self._timer.start()


def _text_of(v: float | None) -> str:
    """A bound as field text: about five significant digits (what a person reads); the
    parsing keeps the exact stored value while the text is unchanged (see
    :func:`parse_constraints`)."""
    if v is None:
        return ""
    return f"{float(v):.5g}"


def _exact(text: Any, stored: float | None) -> float | None:
    """The stored bound when ``text`` is still its rounded form, else None."""
    if stored is None or not isinstance(text, str):
        return None
    return float(stored) if text.strip() == _text_of(stored) else None


def limits_text(spec: StudySpec) -> list[str]:
    """The study's own limits as the initial text of the constraint fields."""
    return [_text_of(c.limit) for c in spec.criteria]


def bounds_text(spec: StudySpec) -> list[tuple[str, str]]:
    """The study's functional-constraint bounds as the initial ``(low, high)`` text of their
    fields (empty for no bound)."""
    return [(_text_of(c.low), _text_of(c.high)) for c in spec.constraints]


def finite(v: Any) -> float | None:
    """JSON-safe float (None for NaN/inf)."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def as_mapping(d: Mapping[str, Any] | None) -> dict[str, Any]:
    return dict(d or {})


log = logging.getLogger("vectorid.ui")


def refused(what: str, problem: str) -> StudyDefinitionError:
    """A malformed value from the page (only a hand-made request sends one): one log line,
    and the error the page shows."""
    log.warning("refused a malformed value from the page: %s: %s", what, problem)
    return StudyDefinitionError(what, problem, "reload the page")


def page_table(value: Any, what: str) -> dict[str, Any] | None:
    """A value the page sends as a table (a Plotly event, a selection, a job note): None
    when empty, else a dict.

    Raises
    ------
    StudyDefinitionError
        For anything else (only a hand-made request sends it): one line, no traceback.
    """
    if value is None or (isinstance(value, Sized) and not isinstance(value, str) and not value):
        return None
    if not isinstance(value, Mapping):
        raise refused(
            what, f"expected a table from the page, got {type(value).__name__} {_short(value)}"
        )
    return dict(value)


def page_numbers(value: Any, n: int, what: str) -> list[float]:
    """``n`` finite numbers the page sends as a list (a range, a bin's custom data).

    Raises
    ------
    StudyDefinitionError
        For anything else: one line, no traceback.
    """
    ok = isinstance(value, list | tuple) and len(value) == n
    out: list[float] = []
    for v in value if ok else ():
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            ok = False
            break
        out.append(float(v))
    if not ok:
        raise refused(what, f"expected {n} finite numbers, got {_short(value)}")
    return out


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
