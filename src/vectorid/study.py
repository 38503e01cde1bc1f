"""One obvious entry point: a study is a definition plus its store.

>>> from vectorid import Study, load_study
>>> study = Study.create(load_study("binh.toml"), "runs/binh.db")   # doctest: +SKIP
>>> study.run(trials=2048)                                           # doctest: +SKIP
>>> a = study.analysis(limits={"f1": 40.0})                          # doctest: +SKIP
>>> a.n, a.n_feasible, a.n_pareto                                    # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, TextIO

from .analysis.results import Analysis, Bound
from .run.loop import RunSummary, run_store
from .spec import StudySpec, load_study
from .store.sqlite import Store, Trials

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
    """A study definition bound to its store.

    Use :meth:`create` for a new study, :meth:`open` for an existing store, or
    :meth:`create_or_open` to resume when the store exists.
    """

    def __init__(self, store: Store) -> None:
        self.store = store

    @classmethod
    def create(cls, spec: StudySpec | str | Path, store: str | Path) -> Study:
        """Create the store for ``spec`` (a spec or a study file path).

        An identification study's noise-floor limits (``limit = "noise"``, see
        :mod:`vectorid.identify.noise`) are computed here, once, and kept with the study."""
        if not isinstance(spec, StudySpec):
            spec = load_study(spec)
        if "identification" in spec.extra:
            from .identify.noise import resolve_noise_limits

            spec = resolve_noise_limits(spec)
        return cls(Store.create(store, spec))

    @classmethod
    def open(cls, store: str | Path, *, write: bool = False) -> Study:
        """Open an existing store (``write=True`` to extend it)."""
        return cls(Store.open(store, write=write))

    @classmethod
    def create_or_open(cls, spec: StudySpec, store: str | Path) -> Study:
        """Open ``store`` for writing if it exists (checking it holds the same study),
        else create it."""
        from .errors import StoreError

        path = Path(store)
        if not path.exists():
            return cls.create(spec, path)
        st = Store.open(path, write=True)
        held = st.spec

        def shape(criteria):  # limits are analysis-time choices, not part of the identity
            return [(c.name, c.sense, c.role) for c in criteria]

        if (
            held.space != spec.space
            or shape(held.criteria) != shape(spec.criteria)
            or held.model != spec.model
        ):
            st.close()
            raise StoreError(
                f"store {path} holds study {held.name!r}, whose model, variables or criteria "
                "differ from this study file's; use another --store, or run the store itself "
                f"(`vectorid run {path}`) to extend the study it holds"
            )
        return cls(st)

    @property
    def spec(self) -> StudySpec:
        return self.store.spec

    def run(
        self,
        trials: int | None = None,
        *,
        executor: str | None = None,
        workers: int | None = None,
        batch_size: int | None = None,
        progress: bool | TextIO = False,
    ) -> RunSummary:
        """Compute the missing trials (see :func:`vectorid.run.run_store`)."""
        return run_store(
            self.store,
            trials=trials,
            executor=executor,
            workers=workers,
            batch_size=batch_size,
            progress=progress,
        )

    def trials(self) -> Trials:
        """All sample-stage trials as arrays."""
        return self.store.load()

    def analysis(
        self,
        limits: Iterable[Bound] | Mapping[str, Any] | None = None,
        roles: Mapping[str, str] | None = None,
    ) -> Analysis:
        """Feasible and Pareto sets under ``limits`` (see :class:`~vectorid.analysis.Analysis`)."""
        return Analysis(self.spec, self.store.load(), limits, roles)

    def close(self) -> None:
        self.store.close()

    def __enter__(self) -> Study:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
