"""Study stores. SQLite is the embedded default (one file per study).

The store stores: trials, stages, the run log and a sampler's records, which it keeps without
interpreting them. It imports nothing above the study definition (no sampler, no analysis).

* :mod:`.records` — the values a store holds (:class:`Trials`, :class:`Stage`,
  :class:`SamplerRecord`, :class:`DamagedBatch`, :class:`VerifyReport`);
* :mod:`.schema` — the file's layout, connections, migrations and the batch codec;
* :mod:`.lock` — one writer per store file;
* :mod:`.store` — :class:`Store`;
* :mod:`.agreement`, :mod:`.inputs` — what a store checks before a trial is added (the study
  definition, data files, the model's code).
"""

from .records import DamagedBatch, SamplerRecord, Stage, Trials, VerifyReport
from .schema import SCHEMA_VERSION
from .store import Store

__all__ = [
    "SCHEMA_VERSION",
    "DamagedBatch",
    "SamplerRecord",
    "Stage",
    "Store",
    "Trials",
    "VerifyReport",
]
