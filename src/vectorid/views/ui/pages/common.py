"""What the pages share: stable element ids, the constraint inputs as Dash dependencies,
tables, and how an exception becomes a one-line message."""

from __future__ import annotations

import html as _html
import logging
import re
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ....errors import VectoridError

__all__ = [
    "Wiring",
    "err",
    "rows_table",
    "safe",
    "table",
    "verdict_panel",
    "verdict_panel_html",
    "verdict_table",
]

log = logging.getLogger("vectorid.ui")


def safe(name: str) -> str:
    """``name`` as a part of an element id (letters, digits, ``_`` and ``-`` kept)."""
    return re.sub(r"[^A-Za-z0-9_-]", "_", str(name))


def err(exc: BaseException) -> str:
    """The message shown for an exception raised by a callback: a
    :class:`~vectorid.errors.VectoridError`'s own (what came and the fix), else one line that
    is also logged as one line — the exception, its message and where it was raised — never
    a traceback (the traceback goes to the ``vectorid.ui`` logger at DEBUG level only)."""
    if isinstance(exc, VectoridError):
        return str(exc)
    text = " ".join(str(exc).split())[:300]
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" at {Path(tb[-1].filename).name}:{tb[-1].lineno} in {tb[-1].name}" if tb else ""
    log.error("UI callback failed: %s: %s%s", type(exc).__name__, text, where)
    log.debug("the traceback", exc_info=exc)
    return f"internal error ({type(exc).__name__}: {text}); the server log has one line on it"


def table(id_: str, **kw: Any) -> Any:
    """A DataTable with the UI's style (scrolls sideways in its container)."""
    from dash import dash_table

    style = {
        "style_table": {"overflowX": "auto"},
        "style_cell": {"fontSize": 12, "padding": "2px 6px", "fontFamily": "monospace"},
        "style_header": {"fontWeight": 600, "backgroundColor": "#f3f3f3"},
    }
    style.update(kw)
    return dash_table.DataTable(id=id_, **style)


def rows_table(rows: list[dict[str, Any]], id_: str | None = None) -> Any:
    """A static HTML table of rows (dicts with the same keys); "none" when empty."""
    from dash import html

    if not rows:
        return html.P("none", className="muted", id=id_ or "")
    head = list(rows[0])
    body = [
        html.Tr([html.Td("" if r.get(k) is None else str(r.get(k))) for k in head]) for r in rows
    ]
    kw: dict[str, Any] = {"id": id_} if id_ else {}
    return html.Div(
        html.Table([html.Thead(html.Tr([html.Th(k) for k in head])), html.Tbody(body)]),
        className="scroll",
        **kw,
    )


@dataclass
class Wiring:
    """The constraint fields as Dash dependencies (plain, stable ids:
    ``vid-limit-<criterion>``, ``vid-role-<criterion>``, ``vid-slider-<criterion>``,
    ``vid-low-<constraint>``, ``vid-high-<constraint>``)."""

    crit: list[str]
    cons: list[str]
    gated: set[str] = field(default_factory=set)

    def ids(self, kind: str) -> list[str]:
        names = self.crit if kind in ("limit", "role", "slider") else self.cons
        return [f"vid-{kind}-{safe(n)}" for n in names]

    def deps(self, cls: Any, kind: str, prop: str = "value") -> list[Any]:
        return [cls(i, prop) for i in self.ids(kind)]

    def constraint_inputs(self, cls: Any) -> list[Any]:
        """limit, role, low, high fields (in that order) as ``cls`` (Input or State)."""
        return (
            self.deps(cls, "limit")
            + self.deps(cls, "role")
            + self.deps(cls, "low")
            + self.deps(cls, "high")
        )

    @property
    def n_constraints(self) -> int:
        return 2 * len(self.crit) + 2 * len(self.cons)

    def gate(self, app: Any, tab: str) -> Any:
        """An Input carrying the constraint fields to a view on tab ``tab`` only while that tab
        is shown (a clientside callback fills ``vid-con-<tab>``), so that a constraint change
        sends no request for the views that are hidden, and coming back to a tab whose
        fields did not change sends none either. The value is ``[fields, version]``.
        Several views of one tab share its gate (registered once)."""
        from dash import Input, Output, State

        if tab in self.gated:
            return Input(f"vid-con-{tab}", "data")
        self.gated.add(tab)
        app.clientside_callback(
            "function(tab, ...v) { const cur = v.pop(), ver = v.pop(); return window.vidGate("
            + repr(tab)
            + ", tab, v, undefined, ver, cur); }",
            Output(f"vid-con-{tab}", "data"),
            Input("tabs", "value"),
            *self.constraint_inputs(Input),
            State("version", "data"),
            State(f"vid-con-{tab}", "data"),
        )
        return Input(f"vid-con-{tab}", "data")

    def split(self, values: list[Any]) -> tuple[list[Any], list[Any], list[list[Any]] | None]:
        """``(limit texts, roles, functional pairs)`` from the values of
        :meth:`constraint_inputs`."""
        k, q = len(self.crit), len(self.cons)
        texts = list(values[:k])
        roles = list(values[k : 2 * k])
        lows = values[2 * k : 2 * k + q]
        highs = values[2 * k + q : 2 * k + 2 * q]
        pairs = [[lo, hi] for lo, hi in zip(lows, highs)] if q else None
        return texts, roles, pairs


#: Colours of the ranges drawn in a verdict row: the sets' own (feasible blue, Pareto green)
#: over the box (grey), the chosen trial orange.
_RANGE_COLOURS = {"feasible": "rgba(31,119,180,0.45)", "pareto": "#2ca02c", "trial": "#ff7f0e"}


def _range_bar_parts(ranges: dict[str, Any], value: float | None) -> list[tuple[str, dict]]:
    """The pieces of a range bar: (CSS class, style) for D, the Pareto set and the trial."""
    lo, hi = ranges["box"]
    w = hi - lo if hi > lo else 1.0

    def at(x: float) -> float:
        return max(0.0, min(100.0, 100.0 * (x - lo) / w))

    parts = []
    for kind, top, height in (("feasible", 1, 10), ("pareto", 5, 2)):
        r = ranges.get(kind)
        if r is None:
            continue
        left, right = at(r[0]), at(r[1])
        style = {
            "left": f"{left:.2f}%",
            "width": f"max(2px, {right - left:.2f}%)",
            "top": f"{top}px",
            "height": f"{height}px",
            "background": _RANGE_COLOURS[kind],
        }
        parts.append((f"rb-{kind}", style))
    if value is not None:
        parts.append(
            ("rb-trial", {"left": f"{at(value):.2f}%", "background": _RANGE_COLOURS["trial"]})
        )
    return parts


_RANGE_BAR_TITLE = "box (grey), D (blue), Pareto (green)"


def _range_bar_html(ranges: dict[str, Any], value: float | None = None) -> str:
    """A small drawing of one variable's ranges over its box, as HTML text: D (blue band),
    the Pareto set (green line) and, when given, the chosen trial's value (orange tick)."""
    divs = "".join(
        f'<div class="{c}" style="{"; ".join(f"{k}: {v}" for k, v in st.items())};"></div>'
        for c, st in _range_bar_parts(ranges, value)
    )
    return f'<div class="rangebar" title="{_RANGE_BAR_TITLE}">{divs}</div>'


def verdict_table(rows: list[dict[str, Any]], prefix: str, *, trial: bool = False) -> Any:
    """The identifiability verdicts as an HTML table, one row per design variable with the
    stable id ``<prefix>-<variable>`` and ``data-verdict``: the variable (meaning, unit), its
    verdict, (``trial``: how the chosen trial shows it: a value only where identified, and
    the nominal), its ranges drawn and written (D, Pareto set, box), the constraints that
    cut it, and why / what would identify it.

    The table is one Dash component holding its markup (every text escaped), not one per
    cell: at 33 variables the ~600 components of a table built cell by cell took Dash's
    renderer 1.2-2.8 s of one main-thread task to mount (the Refine tab's first draw)."""
    from dash import html

    if not rows:
        return html.P("no design variable", className="muted")
    esc = _html.escape
    head = ["variable", "verdict"]
    if trial:
        head += ["this trial", "nominal"]
    head += [
        "ranges",
        "feasible (D)",
        "Pareto",
        "judged against",
        "cut by",
        "why / to identify it",
    ]
    body = []
    for r in rows:
        unit = f" [{r['unit']}]" if r.get("unit") else ""
        name = f'<b>{esc(str(r["name"]))}</b><span class="muted">{esc(unit)}</span>'
        if r.get("meaning"):
            name += f'<br><span class="muted small">{esc(str(r["meaning"]))}</span>'
        verdict = esc(str(r["verdict"]))
        cls = "verdict v-" + verdict.replace(" ", "-")
        cells = [name, f'<span class="{cls}">{verdict}</span>']
        extra = ["", ""]
        if trial:
            nominal = "" if r.get("nominal") is None else f"{r['nominal']:.5g}"
            cells += [esc(str(r["shown"])), nominal]
            extra += ["shown", ""]
        todo = r["reason"] + (f"; to identify it: {r['suggestion']}" if r["suggestion"] else "")
        cells += [
            _range_bar_html(r["ranges"], r.get("value") if trial else None),
            esc(str(r["feasible"])),
            esc(str(r["pareto"])),
            esc(str(r["box"])),
            esc(str(r["constrained_by"])),
            esc(str(todo)),
        ]
        extra += ["", "num", "num", "num", "", "small"]
        tds = "".join(
            f'<td class="{c}">{v}</td>' if c else f"<td>{v}</td>" for v, c in zip(cells, extra)
        )
        rid = esc(f"{prefix}-{safe(r['name'])}")
        body.append(f'<tr id="{rid}" data-verdict="{verdict}">{tds}</tr>')
    markup = (
        '<div class="scroll"><table class="vtable"><thead><tr>'
        + "".join(f"<th>{esc(h)}</th>" for h in head)
        + "</tr></thead><tbody>"
        + "".join(body)
        + "</tbody></table></div>"
    )
    # the page puts the markup in place (``vid.js``: every ``.vid-html`` element's
    # ``data-html``, whenever it changes)
    return html.Div(className="vid-html", **{"data-html": markup})


#: Combinations shown on the first screen before the rest are folded away (every identified
#: one is shown, however many).
COMBOS_SHOWN = 4


def verdict_panel(
    groups: list[dict[str, Any]],
    *,
    nd: int,
    thin: str = "",
    relaxed: str = "",
    combinations: list[dict[str, Any]] | None = None,
) -> Any:
    """What D pins down, at a glance: the identified, weak and not identified variables,
    each a chip (``vid-vchip-<variable>``, with ``data-verdict``) holding D's range and unit
    and a small drawing of it over the box (hover: meaning and why); then the combinations
    of gains D pins down (``vid-combo-<k>``: the terms on the box-normalised gains, the
    range in z, the width as a share of a box side; hover: the reading in the gains' own
    units and why), from :func:`~vectorid.views.ui.verdicts.combination_items`; the
    relaxation of the saved limits, where the study had to relax them, said first.

    The panel is one Dash component holding its markup (:func:`verdict_panel_html`, every
    text escaped), as :func:`verdict_table` is: built chip by chip, 33 gains and their
    combinations were ~250 Dash components mounted in the page load's longest task."""
    from dash import html

    markup = verdict_panel_html(
        groups, nd=nd, thin=thin, relaxed=relaxed, combinations=combinations
    )
    return html.Div(className="vid-html", **{"data-html": markup})


def verdict_panel_html(
    groups: list[dict[str, Any]],
    *,
    nd: int,
    thin: str = "",
    relaxed: str = "",
    combinations: list[dict[str, Any]] | None = None,
) -> str:
    """The markup of :func:`verdict_panel` (every text escaped)."""
    esc = _html.escape
    out: list[str] = []
    if relaxed:
        out.append(f'<div class="relaxed" id="vid-relaxed">{esc(relaxed)}</div>')
    if not groups:
        out.append('<span class="muted">no design variable</span>')
    for g in groups:
        verdict = str(g["verdict"])
        cls = "vchip v-" + verdict.replace(" ", "-")
        chips = []
        for it in g["items"]:
            unit = f" {it['unit']}" if it["unit"] else ""
            tip = "; ".join(x for x in (it["meaning"], it["why"]) if x)
            cid = esc("vid-vchip-" + safe(it["name"]))
            text = esc(f" {it['range']}{unit}")
            chips.append(
                f'<span id="{cid}" class="{esc(cls)}" title="{esc(tip)}" '
                f'data-verdict="{esc(verdict)}"><b>{esc(str(it["name"]))}</b>{text}'
                f"{_range_bar_html(it['ranges'])}</span>"
            )
        out.append(
            '<div class="vgroup"><span class="vgroup-name">'
            f"{esc(verdict)} ({len(g['items'])})"
            "</span>" + "".join(chips) + "</div>"
        )
    if combinations:
        chips = []
        for k, it in enumerate(combinations, 1):
            verdict = str(it["verdict"])
            text = f" {it['text']} in {it['range']}, width {100 * it['width']:.0f} %"
            tip = f"in the gains' units: {it['own_units']}; {it['why']}"
            chips.append(
                f'<span id="vid-combo-{k}" class="{esc("vchip v-" + verdict.replace(" ", "-"))}" '
                f'title="{esc(tip)}" data-verdict="{esc(verdict)}"><b>c{k}</b>{esc(text)}</span>'
            )
        n_id = sum(it["verdict"] == "identified" for it in combinations)
        keep = max(n_id, COMBOS_SHOWN)  # every identified one; the narrowest weak ones
        more = chips[keep:]
        folded = (
            f"<details><summary>{len(more)} more weak</summary>{''.join(more)}</details>"
            if more
            else ""
        )
        out.append(
            '<div class="vgroup" id="vid-combos"><span class="vgroup-name">'
            f"combinations ({n_id} identified, {len(combinations) - n_id} weak)</span>"
            + "".join(chips[:keep])
            + folded
            + '<span class="muted">z(g) = (g - low)/(high - low): each gain as a share of its '
            "box; range in z over D, widened to hold its boundary; width: a share of one box "
            "side</span></div>"
        )
    if thin:
        out.append(f'<div class="muted">{esc(thin)}</div>')
    return "".join(out)
