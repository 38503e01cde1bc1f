"""Data of the *Compare* tab (``vectorid ui A.db B.db``): two models side by side on the same
data (:func:`vectorid.views.compare.compare_stores`). The counts, limits and best values are
read when the UI starts (two analyses, milliseconds to a second); the spectral peaks need each
model's suggested vector simulated, so they are computed in a thread of their own and the tab
shows them when they are ready ("computing" until then), never making the page wait."""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

from ..compare import (
    Comparison,
    add_peaks,
    compare_stores,
    comparison_figure,
    comparison_heads,
    comparison_rows,
)
from .context import UIContext

__all__ = ["CompareState", "compare_view", "start_compare"]


class CompareState:
    """The comparison of the UI's store with a second one, its peaks filled by a thread."""

    def __init__(self, path_a: str | Path, path_b: str | Path) -> None:
        self.paths = (str(path_a), str(path_b))
        self.result: Comparison = compare_stores(path_a, path_b, peaks=False)
        self.pending = bool(self.result.spectral)
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        """Compute the spectral peaks in the background (daemon thread)."""
        if not self.pending:
            return

        def work() -> None:
            from ...store import Store

            with Store.open(self.paths[0]) as sa, Store.open(self.paths[1]) as sb:
                add_peaks(self.result, sa, sb)
            self.pending = False

        self._thread = threading.Thread(target=work, name="vectorid-compare-peaks", daemon=True)
        self._thread.start()

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the peaks (tests); True when they are done."""
        if self._thread is not None:
            self._thread.join(timeout)
        return not self.pending


def start_compare(ctx: UIContext, other: str | Path) -> CompareState:
    """Compare the UI's store with ``other`` and start computing the peaks."""
    state = CompareState(ctx.cache.path, other)
    ctx.extra["compare"] = state
    state.start()
    return state


def compare_view(ctx: UIContext) -> dict[str, Any]:
    """The Compare tab's content: ``heads`` and ``rows`` of the tables
    (:func:`~vectorid.views.compare.comparison_rows`), ``figure`` (best value over the
    common limit per criterion), ``drop`` (the same data or not, in words), ``criteria``
    (compared, and those only one study has), ``pending`` (peaks still computing) and
    ``note`` (how the peaks were found, or why not)."""
    state: CompareState | None = ctx.extra.get("compare")
    if state is None:
        return {}
    c = state.result
    note = (
        "computing: each model's suggested vector is simulated on the drop…"
        if state.pending
        else c.peaks_note
    )
    return {
        "a": c.a.label,
        "b": c.b.label,
        "heads": comparison_heads(c),
        "rows": comparison_rows(c),
        "figure": comparison_figure(c),
        "drop": c.drop,
        "same_drop": c.same_drop,
        "criteria": c.criteria,
        "only": c.only,
        "pending": state.pending,
        "note": note,
    }
