"""Study stores. SQLite is the embedded default (one file per study)."""

from .sqlite import SCHEMA_VERSION, Stage, Store, Trials

__all__ = ["SCHEMA_VERSION", "Stage", "Store", "Trials"]
