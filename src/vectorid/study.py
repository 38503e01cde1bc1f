"""One obvious entry point: a study is a definition plus its store.

>>> from vectorid import Study, load_study
>>> study = Study.create(load_study("binh.toml"), "runs/binh.db")   # doctest: +SKIP
>>> study.run(trials=2048)                                           # doctest: +SKIP
>>> a = study.analysis(limits={"f1": 40.0})                          # doctest: +SKIP
>>> a.n, a.n_feasible, a.n_pareto                                    # doctest: +SKIP
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, TextIO

from .analysis.results import Analysis, Bound
from .builders import analysis_only, prepare_spec
from .errors import StoreError, VectoridNote
from .run.loop import RunSummary, run_store
from .spec import StudySpec, load_study
from .store import Store, Trials
from .store.agreement import compare, data_file_hashes, new_store_name
from .store.inputs import record_history, record_inputs

__all__ = ["Study", "default_store_path"]


def default_store_path(spec: StudySpec, study_file: str | Path | None = None) -> Path:
    """Where a study's store goes when no ``--store`` is given: the study's ``store`` key
    (relative to the study file), else ``<study file stem>.db`` beside the study file."""
    base = Path(study_file).resolve().parent if study_file else Path.cwd()
    if spec.store:
        path = Path(spec.store)
        return path if path.is_absolute() else base / path
    stem = Path(study_file).stem if study_file else spec.name
    return base / f"{stem}.db"


class Study:
    """A study definition bound to its store: the entry point of the Python API.

    Use :meth:`create` for a new study, :meth:`open` for an existing store, or
    :meth:`create_or_open` to resume when the store exists; the command line uses the same
    calls. A study is a context manager that closes its store.

    Parameters
    ----------
    store : vectorid.store.Store
        The open store (use the class methods rather than this constructor).

    Attributes
    ----------
    store : vectorid.store.Store
        The SQLite store: the definition, the stages and every trial.

    Notes
    -----
    The README's tour (``example.py``) and ``docs/studies.md`` ("From Python") show it at
    work; the test suite runs both.

    Examples
    --------
    A model is a function of a batch of parameter vectors (n, p) that returns the criteria
    (n, k) and the functionals (n, q); here two criteria, in m², of two lengths in m, and a
    criteria constraint f1 <= 0.5 m² (a study file and :func:`vectorid.load_study` give the
    same definition):

    >>> import os, tempfile
    >>> import numpy as np
    >>> from vectorid import Continuous, Criterion, Space, Study, StudySpec
    >>> def wells(X):
    ...     f1 = X[:, 0] ** 2 + X[:, 1] ** 2
    ...     f2 = (X[:, 0] - 1.0) ** 2 + X[:, 1] ** 2
    ...     return np.column_stack([f1, f2]), np.empty((len(X), 0))
    >>> space = Space([Continuous("x1", 0.0, 1.0, unit="m"), Continuous("x2", 0.0, 1.0, unit="m")])
    >>> spec = StudySpec("wells", wells, space, (Criterion("f1", limit=0.5, unit="m2"),
    ...                  Criterion("f2", unit="m2")), trials=256, seed=1)
    >>> folder = tempfile.mkdtemp()
    >>> with Study.create(spec, os.path.join(folder, "wells.db")) as study:
    ...     summary = study.run(executor="inline")  # "processes" (the default): every core
    ...     a = study.analysis()
    >>> summary.stored, a.n, a.n_feasible, a.n_pareto  # N, ND, NP
    (256, 256, 99, 20)

    ``Study.open`` reads the store again later; nothing is recomputed:

    >>> with Study.open(os.path.join(folder, "wells.db")) as study:
    ...     study.analysis(limits={"f1": 0.25, "f2": 0.5}).n_feasible
    11
    """

    def __init__(self, store: Store) -> None:
        self.store = store

    @classmethod
    def create(cls, spec: StudySpec | str | Path, store: str | Path) -> Study:
        """Create the store for ``spec`` (a spec or a study file path).

        The definition is completed here, once, by its builder's ``prepare`` hook (an
        identification study's noise-floor limits, ``limit = "noise"``: see
        :mod:`vectorid.identify.noise`) and kept with the study.

        Parameters
        ----------
        spec : StudySpec or path
            The definition, or its TOML study file.
        store : path
            The store file to create (SQLite).

        Returns
        -------
        Study
            Open for writing; no trial is computed yet (see :meth:`run`).

        Raises
        ------
        StoreError
            If ``store`` exists already (use :meth:`create_or_open` to resume it).
        """
        if not isinstance(spec, StudySpec):
            spec = load_study(spec)

        spec = prepare_spec(spec)
        st = Store.create(store, spec, data_files=data_file_hashes(spec))
        try:
            record_inputs(st, spec)
        except BaseException:
            st.close()
            raise
        return cls(st)

    @classmethod
    def open(cls, store: str | Path, *, write: bool = False) -> Study:
        """Open an existing store.

        Parameters
        ----------
        store : path
            The store file.
        write : bool
            Open for writing (to run more trials); one process at a time may.

        Returns
        -------
        Study

        Raises
        ------
        StoreError
            No store there, or the file is not a vectorid store.
        StoreLockedError
            ``write=True`` while another process writes the store.
        """
        return cls(Store.open(store, write=write))

    @classmethod
    def create_or_open(
        cls,
        spec: StudySpec | str | Path,
        store: str | Path,
        *,
        study_file: str | Path | None = None,
        accept_changes: bool = False,
    ) -> Study:
        """Resume ``store`` if it exists, else create it: the same script or command run
        twice continues the same study.

        The study definition and the store must agree (:mod:`vectorid.store.agreement`):
        differences that do not change a computed trial (limits, functional bounds, labels,
        run settings, a moved data file with the same content) are taken into the store,
        each said in a :class:`~vectorid.errors.VectoridNote`; a store that holds no
        computed trial is re-created from ``spec``; any other difference is refused with a
        :class:`~vectorid.errors.StoreError` that lists it and gives the commands that start
        a new store or keep the stored definition.

        Parameters
        ----------
        spec : StudySpec or path
            The definition (or its study file).
        store : path
            The store.
        study_file : path, optional
            The study file ``spec`` came from (for the commands in messages).
        accept_changes : bool
            Take a data file whose content changed (or an FMU's) instead of refusing it, and
            record the change in the store's history (:mod:`vectorid.store.inputs`).

        Returns
        -------
        Study
            Open for writing.
        """
        if not isinstance(spec, StudySpec):
            study_file = study_file or spec
            spec = load_study(spec)
        path = Path(store)
        if not path.exists() and not path.is_symlink():
            return cls.create(spec, path)

        st = Store.open(path, write=True)
        try:
            agreement = compare(st.spec, spec, st.data_files())
            # a changed data file taken on purpose: what derives from the data is computed anew
            taking = (
                accept_changes
                and bool(agreement.refused)
                and all(d.content for d in agreement.refused)
            )
            if agreement and (not agreement.refused or taking) and _derived(st.spec, spec):
                # the file leaves derived parts (noise-floor limits) to be computed: take the
                # stored ones when nothing they derive from changed, else compute them anew

                spec = prepare_spec(spec) if taking else _with_derived(st.spec, spec, agreement)
                agreement = compare(st.spec, spec, st.data_files())
        except BaseException:
            st.close()
            raise
        if not agreement:
            return cls(st)
        if st.count_all_blocks() == 0:
            changed = ", ".join(d.field for d in agreement.refused[:6])
            st.delete()
            if changed:
                warnings.warn(
                    VectoridNote(
                        f"store {path} held no computed trial; re-created from the study "
                        f"definition (changed: {changed})"
                    ),
                    stacklevel=2,
                )
            return cls.create(spec, path)
        accepted = [d for d in agreement.refused if d.content] if accept_changes else []
        if len(accepted) < len(agreement.refused):
            n = st.count()
            st.close()
            raise StoreError(_refusal(path, study_file, agreement, n))
        old_hashes = st.data_files() or {}
        st.replace_study(spec, agreement.hashes)
        if accepted:
            _record_accepted(st, accepted, old_hashes, agreement.hashes)
        for d in agreement.taken:
            warnings.warn(VectoridNote(f"taken from the study file: {d.describe()}"), stacklevel=2)
        return cls(st)

    @property
    def spec(self) -> StudySpec:
        """The study definition held by the store."""
        return self.store.spec

    def run(
        self,
        trials: int | None = None,
        *,
        executor: str | None = None,
        workers: int | None = None,
        batch_size: int | None = None,
        progress: bool | TextIO | None = None,
        keep_going: bool = False,
        timeout: float | None = None,
        budget: int | None = None,
        population: int | None = None,
        accept_changes: bool = False,
    ) -> RunSummary:
        """Compute the missing trials and store them (see :func:`vectorid.run.run_store`).

        A run computes exactly the trials the store lacks, so an interrupted run resumes
        and a larger ``trials`` extends the study along the same sequence.

        Parameters
        ----------
        trials : int, optional
            The total number of trials the study should hold (default: the study's).
        executor : {"serial", "processes", "dask", "inline"}, optional
            Where trials run (default: the study's, else ``"processes"``).
        workers : int, optional
            Worker processes (default: all cores).
        batch_size : int, optional
            Trials per batch (default: chosen from the study size).
        progress : bool, text file or None
            Show progress (on stderr, or on the given file): a bar over the trials, or one
            line per generation of a sequential study. Default None: shown where someone
            watches (a terminal or a notebook), silent otherwise (a script whose stderr goes
            to a file or a pipe, a test).
        keep_going : bool
            Store the first batch even when every one of its trials failed (default: stop
            with the reason and store none).
        timeout : float, optional
            Most seconds one trial may take, in s (default: the study's, else no limit): a
            batch of n trials may run n x ``timeout``; one that runs longer is re-run trial
            by trial, and a trial that takes longer is stored as failed, "timed out after
            X s" (see docs/store.md).
        budget, population : int, optional
            A sequential study (``sampler = "sequential"``, docs/sequential.md): most model
            evaluations and members of D wanted (saved in the study; default: the study's,
            else 50,000 and 200). Its ``trials`` is the size of generation 0.
        accept_changes : bool
            When the model's code or a data file changed since the stored trials were
            computed, take the change and record it in the store's history instead of
            raising :class:`~vectorid.store.inputs.InputsChangedError`.

        Returns
        -------
        RunSummary
            Trials stored and failed, the failure reasons with an example each, elapsed s
            (a :class:`~vectorid.samplers.sequential.SequentialSummary` for a sequential study:
            generations, evaluations, members of D, ESS).

        Examples
        --------
        The sequential sampler's options, ``budget`` (most evaluations) and ``population``
        (members of D wanted), on a study whose D is small (f1 <= 0.05 m²):

        >>> import os, tempfile
        >>> import numpy as np
        >>> from vectorid import Continuous, Criterion, Space, Study, StudySpec
        >>> def wells(X):
        ...     f1 = X[:, 0] ** 2 + X[:, 1] ** 2
        ...     f2 = (X[:, 0] - 1.0) ** 2 + X[:, 1] ** 2
        ...     return np.column_stack([f1, f2]), np.empty((len(X), 0))
        >>> space = Space([Continuous("x1", 0.0, 1.0), Continuous("x2", 0.0, 1.0)])
        >>> spec = StudySpec("wells", wells, space, (Criterion("f1", limit=0.05),
        ...                  Criterion("f2", limit=0.9)), trials=128, seed=1,
        ...                  sampler="sequential")
        >>> path = os.path.join(tempfile.mkdtemp(), "wells.db")
        >>> with Study.create(spec, path) as study:
        ...     s = study.run(executor="inline", budget=3000, population=50)
        >>> s.converged, s.members, s.evaluations, s.generations
        (True, 62, 278, 4)
        """
        return run_store(
            self.store,
            accept_changes=accept_changes,
            trials=trials,
            executor=executor,
            workers=workers,
            batch_size=batch_size,
            progress=progress,
            keep_going=keep_going,
            timeout=timeout,
            budget=budget,
            population=population,
        )

    def trials(self) -> Trials:
        """All sample-stage trials as arrays.

        Returns
        -------
        Trials
            ``X`` (n, p) parameters, ``F`` (n, k) criteria, ``G`` (n, q) functionals, each in
            its study unit (NaN rows for failed trials), with ids, status and wall time (s).
        """
        return self.store.load()

    def analysis(
        self,
        limits: Iterable[Bound] | Mapping[str, Any] | None = None,
        roles: Mapping[str, str] | None = None,
    ) -> Analysis:
        """Feasible and Pareto sets of the stored trials under ``limits``.

        Nothing is re-run: limits chosen here only select among stored trials.

        Parameters
        ----------
        limits : mapping or iterable of Bound, optional
            Criteria constraints overriding the study's, in each criterion's unit:
            ``{"f1": 40.0}`` bounds f1 on its worse side (above for ``min``), ``None``
            removes a limit, ``{"g1": (low, high)}`` replaces a functional's bounds.
        roles : mapping of str to str, optional
            Criterion name -> ``"pure"`` or ``"pseudo"`` for this analysis.

        Returns
        -------
        Analysis
        """
        return Analysis.of_store(self.store, limits, roles)

    def close(self) -> None:
        """Close the store (and release its write lock)."""
        self.store.close()

    def __enter__(self) -> Study:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _derived(held: StudySpec, given: StudySpec) -> bool:
    """Whether ``given`` leaves to its builder a criteria constraint that the store holds as
    derived (a noise floor: ``limit = "noise"`` or ``[identification] limits = "noise"``)."""
    stored = {c.name: c for c in held.criteria}
    return any(
        c.limit is None and c.name in stored and stored[c.name].limit_source == "noise"
        for c in given.criteria
    ) or any(c.limit is None and c.limit_source == "noise" for c in given.criteria)


def _with_derived(held: StudySpec, given: StudySpec, agreement: Any) -> StudySpec:
    """``given`` with its derived criteria constraints: the stored ones where nothing they
    derive from changed (only limits, their notes and units differ), else computed anew by
    the builder's ``prepare`` hook (which also drops them when the file no longer asks)."""
    from dataclasses import replace as _replace

    if any(analysis_only(given, d.field) for d in agreement.differences):
        return prepare_spec(given)
    stored = {c.name: c for c in held.criteria}
    crit = []
    for c in given.criteria:
        h = stored.get(c.name)
        if c.limit is None and h is not None and h.limit_source == "noise":
            c = _replace(
                c,
                limit=h.limit,
                limit_source="noise",
                limit_note=h.limit_note,
                unit=c.unit or h.unit,
            )
        elif c.limit is None and c.limit_source == "noise":
            return prepare_spec(given)
        crit.append(c)
    return _replace(given, criteria=tuple(crit))


def _refusal(path: Path, study_file: str | Path | None, agreement: Any, n: int) -> str:
    src = str(study_file) if study_file else "STUDY.toml"
    refused = agreement.refused
    lines = [
        f"the study file {src} differs from the study held in {path} ({n} trials computed) in "
        f"{len(refused)} field{'s' if len(refused) > 1 else ''} that would change them:"
    ]
    lines += [f"  {d.describe()}" for d in refused]
    if agreement.taken:
        harmless = ", ".join(d.field for d in agreement.taken)
        lines.append(f"(also different, and harmless: {harmless})")
    lines.append(
        f"to start a new store from the file: vectorid run {src} --store {new_store_name(path)}"
    )
    if not all(d.content for d in refused):  # else the store path is refused just the same
        lines.append(f"to keep the stored definition and extend it: vectorid run {path}")
    else:
        lines.append(
            f"to take the changed file content and record it in the store's history: "
            f"vectorid run {src} --accept-changes"
        )
    return "\n".join(lines)


def _record_accepted(
    st: Store, accepted: list[Any], old: Mapping[str, Any], new: Mapping[str, Any]
) -> None:
    """Record data-file content changes taken with ``accept_changes`` in the history."""
    import time

    now = time.time()
    entries = [
        {
            "at": now,
            "what": f"data file {d.field}",
            "old": (old.get(d.field) or {}).get("sha256"),
            "new": (new.get(d.field) or {}).get("sha256"),
            "note": "accepted (--accept-changes)",
        }
        for d in accepted
    ]
    record_history(st, entries)
    for e in entries:
        warnings.warn(
            VectoridNote(f"accepted and recorded in the store's history: {e['what']}"), stacklevel=3
        )
