"""Views of a study: Plotly figures (:mod:`vectorid.views.figures`) and the self-contained
HTML report (:mod:`vectorid.views.report`). Both need the ``plot`` extra (plotly); they are
imported on first use so ``import vectorid.views`` stays cheap."""

from __future__ import annotations

from typing import Any

__all__ = ["figures", "report", "write_report"]


def __getattr__(name: str) -> Any:
    if name in ("figures", "report"):
        import importlib

        return importlib.import_module(f"{__name__}.{name}")
    if name == "write_report":
        from .report import write_report

        return write_report
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
