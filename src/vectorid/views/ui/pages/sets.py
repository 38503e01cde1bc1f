"""The parallel-coordinates page (brushes are a selection, made constraints on request) with
the history of N/ND/NP, and
the trial table page (server-side sort, filter, page; CSV download)."""

from __future__ import annotations

import secrets
import threading
from collections import OrderedDict
from typing import Any

from .. import client
from ..context import UIContext
from ..parallel import (
    axis_groups,
    axis_presets,
    brushes_to_limits,
    default_hidden,
    default_view,
    history_view,
    parallel_view,
)
from ..table import SETS, TABLE_STYLES, csv_rows, table_columns, table_page
from ..verdicts import identifiability_view
from .common import Wiring, err, safe, table

__all__ = [
    "csv_route",
    "default_hidden",
    "default_view",
    "parallel_layout",
    "register",
    "table_layout",
]

#: The axis sets and orders offered beside the parallel coordinates, in words.
PRESETS = {
    "top": "criteria + the gains D depends on most (sensitivity)",
    "verdict": "criteria + identified and weak gains",
    "all": "every axis",
    "criteria": "criteria only",
}
ORDERS = {
    "sensitivity": "gains by sensitivity",
    "verdict": "gains grouped: identified, weak, not identified",
    "study": "the study's order",
}


def _axis_options(ctx: UIContext) -> list[dict[str, Any]]:
    """One checkbox per axis: criteria and functionals, then the gains by sensitivity, each
    with its unit, its verdict and its KS statistic (hover: the meaning)."""
    from dash import html

    g = axis_groups(ctx)
    lab = ctx.labels
    out = []
    for n in g["criteria"] + g["functionals"] + g["gains"]:
        extra = []
        if g["verdict"].get(n):
            extra.append(g["verdict"][n])
        ks = g["ks"].get(n)
        if ks is not None and ks == ks:
            extra.append(f"KS {ks:.2f}")
        text = lab.title(n) + (f" ({', '.join(extra)})" if extra else "")
        out.append({"label": html.Span(text, title=lab.hover(n)), "value": n})
    return out


def parallel_layout(ctx: UIContext) -> Any:
    from dash import dcc, html

    spec = ctx.spec
    names = spec.criterion_names + spec.constraint_names + spec.space.names
    opts = [{"label": ctx.labels.title(n), "value": n} for n in names]
    presets = axis_presets(ctx)
    hidden = set(default_hidden(ctx))
    shown = [n for n in names if n not in hidden]
    return html.Div(
        [
            html.P(
                "Brush an axis (drag along it) to select the trials within that range; drag "
                "again elsewhere on the axis for another range (a trial is selected when it "
                "lies in one range of every brushed axis). Click a brush to remove it; drag "
                "an axis's title to move it; hover a title for its unit and meaning. The "
                "selection is counted in the header and shown on every view; make it "
                "constraints with the button. Lines: a random subset per set (the title says "
                "how many); Pareto on top. Amber marks: the constraints in force.",
                className="muted",
            ),
            dcc.Store(id="par-presets", data=presets),
            dcc.Store(id="par-data"),
            dcc.Store(id="par-drawn"),
            html.Details(
                className="axes-panel",
                children=[
                    html.Summary(
                        id="par-axes-summary",
                        children=f"Axes: {len(shown)} of {len(names)} shown (choose, group, order)",
                    ),
                    html.Div(
                        className="bar",
                        children=[
                            html.Label("show "),
                            dcc.Dropdown(
                                id="par-preset",
                                options=[{"label": v, "value": k} for k, v in PRESETS.items()],
                                value=None,
                                placeholder=PRESETS["top"],
                                clearable=False,
                                style={"width": "360px"},
                            ),
                            html.Label("order "),
                            dcc.Dropdown(
                                id="par-order",
                                options=[{"label": v, "value": k} for k, v in ORDERS.items()],
                                value=None,
                                placeholder=ORDERS["sensitivity"],
                                clearable=False,
                                style={"width": "330px"},
                            ),
                        ],
                    ),
                    html.P(
                        "Gains listed by sensitivity (KS statistic between D and the other "
                        "trials, under the limits saved with the study); verdicts under the "
                        "same limits. Tick an axis to show it.",
                        className="muted",
                    ),
                    dcc.Checklist(
                        id="par-shown",
                        className="vid-axes",
                        options=_axis_options(ctx),
                        value=shown,
                        inline=True,
                    ),
                ],
            ),
            html.Div(
                className="bar",
                children=[
                    html.Button(
                        "Brushed criteria → constraints Φ**",
                        id="par-to-limits",
                        title="each brushed criterion's worse-side edge (upper for min, lower "
                        "for max) becomes its criteria constraint; a brushed functional's "
                        "edges become its bounds",
                    ),
                    html.Button("Clear brushes", id="par-clear"),
                    html.Label("colour by "),
                    dcc.Dropdown(
                        id="par-colour",
                        options=[{"label": "set (D, Pareto)", "value": "set"}, *opts],
                        value="set",
                        clearable=False,
                        style={"width": "180px"},
                    ),
                ],
            ),
            html.Div(id="par-msg", className="note"),
            html.Div(
                [
                    html.Span("constraints in force: ", className="muted"),
                    html.Span(id="par-in-force"),
                ],
                className="note",
            ),
            html.Div(
                [
                    html.Span("identifiability under these constraints: ", className="muted"),
                    html.Span(id="par-verdicts"),
                ],
                className="note",
            ),
            html.Div(id="par-graph"),
            html.H3("History: N, ND, NP against the number of trials"),
            html.P(
                "ND and NP among the first n trials (sequence order) under the constraints in "
                "force; dashed lines: where each sample stage starts. When NP no longer "
                "changes as N grows, more trials in this box add little.",
                className="muted",
            ),
            dcc.Graph(id="hist-history", config={"displaylogo": False}),
        ]
    )


def table_layout(ctx: UIContext) -> Any:
    from dash import dcc, html

    return html.Div(
        [
            html.Div(
                className="bar",
                children=[
                    html.Label("set "),
                    dcc.RadioItems(
                        id="tab-set",
                        options=[{"label": f" {s} ", "value": s} for s in SETS],
                        value="pareto",
                        inline=True,
                    ),
                    html.A(
                        "Download these rows as CSV",
                        id="tab-csv",
                        href="",
                        download="trials.csv",
                        className="button",
                    ),
                ],
            ),
            html.P(
                "Sorted, filtered and paged on the server over every trial of the set. Type a "
                "condition in a column's filter cell (e.g. < 0.5 or >= 2, Enter to apply); "
                "click a header to sort; click a row to choose the trial.",
                className="muted",
            ),
            html.Div(id="tab-note", className="muted"),
            html.Div(id="tab-msg", className="msg"),
            table(
                "vid-table",
                columns=table_columns(ctx),
                page_current=0,
                page_size=ctx.set_rows,
                page_action="custom",
                sort_action="custom",
                sort_mode="multi",
                sort_by=[],
                filter_action="custom",
                filter_query="",
                style_data_conditional=TABLE_STYLES,
                style_table={"overflowX": "auto"},
            ),
        ]
    )


def in_force_children(sources: list[dict[str, Any]]) -> list[Any]:
    """The criteria constraints in force, one chip each (``vid-force-<criterion>``): the
    bound and where it came from; a limit set in this session is marked and says which saved
    limit it replaces."""
    from dash import html

    out: list[Any] = []
    for s in sources:
        if s["kind"] == "none":
            continue
        text = f"{s['name']} {s['bound']}".strip() if s["bound"] else f"{s['name']}: no limit"
        out.append(
            html.Span(
                [text, html.Span(f" ({s['label']})", className="muted")],
                id=f"vid-force-{safe(s['name'])}",
                className=f"chip src-{s['kind']}",
                title=s["text"],
            )
        )
    return out or ["no criteria constraint"]


class CsvTokens:
    """Short-lived tokens naming a table state (constraints, set, filter, sort) for the CSV
    route: the browser only ever sends the token back, never a query of its own."""

    def __init__(self, size: int = 16) -> None:
        self._lock = threading.Lock()
        self._items: OrderedDict[str, dict[str, Any]] = OrderedDict()
        self._size = size

    def add(self, state: dict[str, Any]) -> str:
        token = secrets.token_urlsafe(12)
        with self._lock:
            self._items[token] = state
            while len(self._items) > self._size:
                self._items.popitem(last=False)
        return token

    def get(self, token: str) -> dict[str, Any] | None:
        with self._lock:
            return self._items.get(token)


def csv_route(server: Any, ctx: UIContext) -> CsvTokens:
    """Serve ``/_vid/trials.csv?t=TOKEN``: the rows of a table state, streamed."""
    import flask

    tokens = CsvTokens()

    @server.route("/_vid/trials.csv")
    def trials_csv():  # pragma: no cover - exercised through the browser test
        state = tokens.get(str(flask.request.args.get("t", "")))
        if state is None:
            return "this download link has expired; reload the table and try again", 404
        gen = csv_rows(ctx, **state)
        name = f"{ctx.spec.name}-{state['which']}.csv".replace(" ", "_")
        return flask.Response(
            gen,
            mimetype="text/csv",
            headers={"Content-Disposition": f'attachment; filename="{name}"'},
        )

    return tokens


def register(app: Any, ctx: UIContext, w: Wiring, tokens: CsvTokens) -> None:
    from dash import Input, Output, State, no_update
    from dash.exceptions import PreventUpdate

    CON_S = w.constraint_inputs(State)

    all_axes = ctx.spec.criterion_names + ctx.spec.constraint_names + ctx.spec.space.names

    @app.callback(
        Output("par-data", "data"),
        w.gate(app, "parallel"),
        Input("par-colour", "value"),
        State("par-shown", "value"),
        State("par-view", "data"),
        State("selection", "data"),
        State("tabs", "value"),
        Input("version", "data"),
        prevent_initial_call=True,
    )
    def parallel(cons, colour, shown, view, sel, tab, _v):
        """The axes and lines under the constraints in force: sent again when the
        constraints or the colour change, not on a brush, an axis moved or one shown or
        hidden (the page draws those itself from what it holds)."""
        if not cons or tab != "parallel":
            raise PreventUpdate
        texts, roles, pairs = w.split(list(cons[0]))
        hidden = [n for n in all_axes if n not in set(shown or [])] if shown is not None else []
        try:
            return parallel_view(ctx, texts, roles, pairs, sel, view, colour, hidden)
        except Exception as exc:
            err(exc)
            return no_update

    app.clientside_callback(
        client.PAR_JS,
        Output("par-drawn", "data"),
        Input("par-data", "data"),
        Input("selection", "data"),
        Input("par-shown", "value"),
        State("par-view", "data"),
    )

    app.clientside_callback(
        """function(preset, order, presets) {
          const nc = dash_clientside.no_update;
          const t = dash_clientside.callback_context.triggered_id;
          if (t === 'par-preset' && preset && presets.shown[preset]) {
            return presets.shown[preset];
          }
          if (t === 'par-order' && order && presets.order[order]) {
            window.vid.parOrder(presets.order[order]);
          }
          return nc;
        }""",
        Output("par-shown", "value", allow_duplicate=True),
        Input("par-preset", "value"),
        Input("par-order", "value"),
        State("par-presets", "data"),
        prevent_initial_call=True,
    )

    app.clientside_callback(
        "function(shown) { return 'Axes: ' + (shown || []).length + ' of "
        + str(len(all_axes))
        + " shown (choose, group, order)'; }",
        Output("par-axes-summary", "children"),
        Input("par-shown", "value"),
        prevent_initial_call=True,
    )

    @app.callback(
        Output("hist-history", "figure"),
        w.gate(app, "parallel"),
        State("tabs", "value"),
        Input("version", "data"),
        prevent_initial_call=True,
    )
    def history(cons, tab, _v):
        if not cons or tab != "parallel":
            raise PreventUpdate
        texts, roles, pairs = w.split(list(cons[0]))
        try:
            return history_view(ctx, texts, roles, pairs)
        except Exception as exc:
            err(exc)
            return no_update

    @app.callback(
        Output("selection", "data", allow_duplicate=True),
        Input("par-clear", "n_clicks"),
        prevent_initial_call=True,
    )
    def clear(_n):
        return None

    @app.callback(
        Output("par-in-force", "children"),
        Output("par-verdicts", "children"),
        w.gate(app, "parallel"),
        State("tabs", "value"),
        Input("version", "data"),
        prevent_initial_call=True,
    )
    def status(cons, tab, _v):
        """Where a brush sets the constraints, what is now in force (the limits changed in
        this session marked, with the saved ones they replace) and the verdicts."""
        if tab != "parallel" or not cons:
            raise PreventUpdate
        texts, roles, pairs = w.split(list(cons[0]))
        try:
            v = identifiability_view(ctx, texts, roles, pairs)
        except Exception as exc:
            return err(exc), no_update
        return in_force_children(v["sources"]), v["line"]

    lim, low, high = w.ids("limit"), w.ids("low"), w.ids("high")

    @app.callback(
        [Output(i, "value", allow_duplicate=True) for i in lim + low + high]
        + [Output("par-msg", "children")],
        Input("par-to-limits", "n_clicks"),
        State("selection", "data"),
        *CON_S,
        prevent_initial_call=True,
    )
    def to_limits(_n, sel, *cons):
        """The brushes made constraints Φ** (the one explicit action)."""
        texts, _roles, pairs = w.split(list(cons))
        lows = [p[0] for p in pairs or []]
        highs = [p[1] for p in pairs or []]
        try:
            t, lo, hi, msg = brushes_to_limits(ctx, sel, texts, lows, highs)
        except Exception as exc:
            keep = [no_update] * (len(lim) + len(low) + len(high))
            return [*keep, err(exc)]
        out = [v if v != old else no_update for v, old in zip(t, texts)]
        out += [v if v != old else no_update for v, old in zip(lo, lows)]
        out += [v if v != old else no_update for v, old in zip(hi, highs)]
        return [*out, msg]

    @app.callback(
        Output("vid-table", "data"),
        Output("vid-table", "page_count"),
        Output("tab-note", "children"),
        Output("tab-msg", "children"),
        Output("tab-csv", "href"),
        w.gate(app, "table"),
        Input("tab-set", "value"),
        Input("selection", "data"),
        Input("vid-table", "page_current"),
        Input("vid-table", "page_size"),
        Input("vid-table", "filter_query"),
        Input("vid-table", "sort_by"),
        State("tabs", "value"),
        Input("version", "data"),
        prevent_initial_call=True,
    )
    def trial_table(cons, which, sel, page, size, query, sort_by, tab, _v):
        if tab != "table" or not cons:
            raise PreventUpdate
        texts, roles, pairs = w.split(list(cons[0]))
        try:
            p = table_page(ctx, texts, roles, pairs, which, sel, page, size, query, sort_by)
        except Exception as exc:
            return no_update, no_update, no_update, err(exc), no_update
        token = tokens.add(
            {
                "limit_texts": texts,
                "roles": roles,
                "functional": pairs,
                "which": which,
                "selection": sel,
                "filter_query": query,
                "sort_by": sort_by,
            }
        )
        return p["data"], p["page_count"], p["note"], "", f"/_vid/trials.csv?t={token}"

    @app.callback(
        Output("trial-id", "value", allow_duplicate=True),
        Input("vid-table", "active_cell"),
        State("vid-table", "data"),
        prevent_initial_call=True,
    )
    def choose(cell, data):
        if not cell or not data:
            raise PreventUpdate
        row = cell.get("row")
        if not isinstance(row, int) or not 0 <= row < len(data):
            raise PreventUpdate
        return str(int(data[row]["id"]))
