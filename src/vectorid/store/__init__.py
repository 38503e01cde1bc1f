"""Study stores. SQLite is the embedded default (one file per study)."""

from .sqlite import SCHEMA_VERSION, DamagedBatch, Stage, Store, Trials, VerifyReport

__all__ = ["SCHEMA_VERSION", "DamagedBatch", "Stage", "Store", "Trials", "VerifyReport"]
