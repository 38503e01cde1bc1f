"""The UI's callbacks as plain functions, one module per view; this module gathers them
under one name (tests and ``benchmarks/ui.py`` call them directly, without a browser).

* :mod:`.explore` — counts, test tables, criterion plot, histograms, criterion vs parameter,
  selections, box to constraints;
* :mod:`.parallel` — parallel coordinates and their brushes, the history of N/ND/NP;
* :mod:`.table` — the server-side trial table and its CSV;
* :mod:`.trial` — the chosen trial;
* :mod:`.refine` — double tuning;
* :mod:`.verdicts` — identifiability verdicts and where each limit came from;
* :mod:`.actions` — background jobs and saving the constraints;
* :mod:`.overview` — the study overview.

Every function takes a :class:`UIContext` and the raw values the browser sent, validates
them, and returns plain data (dicts, lists, Plotly figures). Numbers come from
:mod:`vectorid.analysis`, figures from :mod:`vectorid.views`. Errors a user can cause raise
:class:`~vectorid.errors.VectoridError` subclasses with a message naming the fix.
"""

from __future__ import annotations

from .actions import job_action, job_message, job_view, limits_to_save, start_job
from .context import UIContext
from .explore import (
    box_to_limits,
    counts_view,
    histogram_rows,
    panel_view,
    scatter_view,
    selection_counts_view,
    selection_from_event,
    selection_mask,
    summary_view,
)
from .overview import initial_choice, overview_view
from .parallel import brushes_to_limits, history_view, parallel_view
from .refine import refine_view
from .table import csv_rows, table_page
from .trial import identification_view, trial_view
from .verdicts import identifiability_view

__all__ = [
    "UIContext",
    "box_to_limits",
    "brushes_to_limits",
    "counts_view",
    "csv_rows",
    "histogram_rows",
    "history_view",
    "identifiability_view",
    "identification_view",
    "initial_choice",
    "job_action",
    "job_message",
    "job_view",
    "limits_to_save",
    "overview_view",
    "panel_view",
    "parallel_view",
    "refine_view",
    "scatter_view",
    "selection_counts_view",
    "selection_from_event",
    "selection_mask",
    "start_job",
    "summary_view",
    "table_page",
    "trial_view",
]
