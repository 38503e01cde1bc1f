"""The header (counts, chosen trial, job bar) and the explorer page: constraint cards, the
criterion plot, the lower panels (histograms, criterion vs parameter) and the test tables."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from ..context import UIContext, fmt
from ..data import bounds_text, limits_text, parse_constraints
from ..explore import (
    HIST_COLUMNS,
    ROW_HEIGHTS,
    box_to_limits,
    counts_view,
    histogram_rows,
    panel_view,
    scatter_view,
    selection_counts_view,
    selection_from_event,
    summary_view,
)
from ..overview import initial_choice
from ..verdicts import limit_sources
from .common import Wiring, err, safe, table, verdict_panel

__all__ = ["counts_children", "default_axes", "header", "layout", "register"]


def counts_children(c: dict[str, int]) -> list[Any]:
    """The counts line: N, ND (blue), NP (green), failed and functional."""
    from dash import html

    return [
        "N ",
        html.B(f"{c['n']}", id="count-n"),
        " ND ",
        html.B(f"{c['nd']}", id="count-nd", className="nd"),
        " NP ",
        html.B(f"{c['np']}", id="count-np", className="np"),
        html.Span(
            f" (failed {c['failed']}, meeting functional constraints {c['functional']})",
            className="muted",
        ),
    ]


def header(ctx: UIContext) -> Any:
    from dash import dcc, html

    spec = ctx.spec
    return html.Div(
        className="top",
        children=[
            html.Div(
                [
                    html.H1(f"vectorid · {spec.name}"),
                    html.Span(str(ctx.cache.path), className="muted"),
                ]
            ),
            html.Div(
                counts_children(counts_view(ctx, None, None)), id="vid-counts", className="counts"
            ),
            html.Span("updating…", id="vid-busy", className="busy", title="waiting for the server"),
            html.Div(
                [
                    html.Span(id="vid-sel", className="muted"),
                    " ",
                    html.A(
                        "Export the selection as CSV",
                        id="sel-csv",
                        href="",
                        download="selection.csv",
                        className="button",
                        style={"display": "none"},
                    ),
                ],
                className="bar",
            ),
            html.Label(
                [
                    "chosen trial ",
                    dcc.Input(
                        id="trial-id",
                        type="text",
                        debounce=True,
                        size="8",
                        value=str(initial_choice(ctx) or ""),
                    ),
                ],
                title="type a trial id, or click a point or a table row",
            ),
            html.Div(
                className="bar",
                children=[
                    html.Progress(id="job-progress", max="1", value="0"),
                    html.Span(id="job-text", className="muted"),
                    html.Button("Stop job", id="job-stop"),
                ],
            ),
            html.Div(id="job-msg", className="note"),
        ],
    )


def _cards(ctx: UIContext) -> list[Any]:
    from dash import dcc, html

    spec = ctx.spec
    lab = ctx.labels
    a = ctx.cache.analysis()
    texts = limits_text(spec)
    sources = limit_sources(ctx, a, parse_constraints(spec, texts, None))
    cards = []
    for j, (c, src) in enumerate(zip(spec.criteria, sources)):
        # the range over the trials meeting the functional constraints (the test table's)
        col = a.trials.F[a.functional_ok, j]
        col = col[np.isfinite(col)]
        lo = float(col.min()) if len(col) else 0.0
        hi = float(col.max()) if len(col) else 1.0
        if hi <= lo:
            hi = lo + 1.0
        worse = hi if c.sense == "min" else lo
        value = c.limit if c.limit is not None else worse
        unit = lab.unit.get(c.name, "")
        cards.append(
            html.Div(
                className="card",
                title=lab.tip(c.name),
                children=[
                    html.B(f"{lab.short(c.name)} ({c.sense})"),
                    html.Div(lab.meaning.get(c.name, ""), className="muted small"),
                    html.Div(
                        f"range {fmt(lo)} .. {fmt(hi)}" + (f" {unit}" if unit else ""),
                        className="muted",
                    ),
                    html.Label(
                        [
                            f"Φ** {'<=' if c.sense == 'min' else '>='} ",
                            dcc.Input(
                                id=f"vid-limit-{safe(c.name)}",
                                type="text",
                                value=texts[j],
                                debounce=True,
                                placeholder="no limit",
                                size="9",
                            ),
                        ]
                    ),
                    html.Div(
                        src["text"],
                        id=f"vid-source-{safe(c.name)}",
                        className=f"source src-{src['kind']}",
                        title=src["text"],
                    ),
                    dcc.Slider(
                        id=f"vid-slider-{safe(c.name)}",
                        min=lo,
                        max=hi,
                        step=(hi - lo) / 500,
                        value=min(max(value, lo), hi),
                        marks=None,
                        updatemode="mouseup",
                    ),
                    dcc.RadioItems(
                        id=f"vid-role-{safe(c.name)}",
                        options=[
                            {"label": " pure ", "value": "pure"},
                            {"label": " pseudo", "value": "pseudo"},
                        ],
                        value=c.role,
                        inline=True,
                    ),
                ],
            )
        )
    for j, (g, (lo_text, hi_text)) in enumerate(zip(spec.constraints, bounds_text(spec))):
        col = a.trials.G[a.ok, j]
        col = col[np.isfinite(col)]
        unit = lab.unit.get(g.name, "")
        span = (
            f"range {fmt(col.min())} .. {fmt(col.max())}" + (f" {unit}" if unit else "")
            if len(col)
            else "no value yet"
        )
        cards.append(
            html.Div(
                className="card",
                title=lab.tip(g.name),
                children=[
                    html.B(f"{lab.short(g.name)} (functional)"),
                    html.Div(span, className="muted"),
                    html.Label(
                        [
                            dcc.Input(
                                id=f"vid-low-{safe(g.name)}",
                                type="text",
                                value=lo_text,
                                debounce=True,
                                placeholder="no low",
                                size="7",
                            ),
                            f" <= {g.name} <= ",
                            dcc.Input(
                                id=f"vid-high-{safe(g.name)}",
                                type="text",
                                value=hi_text,
                                debounce=True,
                                placeholder="no high",
                                size="7",
                            ),
                        ]
                    ),
                ],
            )
        )
    return cards


def default_axes(ctx: UIContext) -> tuple[str, str]:
    """The criterion plot's axes at page load: the first two criteria (or the first
    criterion against the first parameter)."""
    names = ctx.spec.criterion_names
    return names[0], (names[1] if len(names) > 1 else ctx.spec.space.names[0])


def hist_graph_ids(ctx: UIContext) -> list[str]:
    """The ids of the histogram grid's graphs, one per row: ``hist-graph`` (with the
    legend), ``hist-graph-2``, ..."""
    rows = max(1, -(-len(ctx.spec.space) // HIST_COLUMNS))
    return ["hist-graph"] + [f"hist-graph-{r + 1}" for r in range(1, rows)]


#: A set shown or hidden in the first row's legend: the same in the other rows.
_HIST_LEGEND_JS = """
function(ev) {
  const gd = document.querySelector('#hist-graph .js-plotly-plot');
  if (!ev || !gd || !gd._fullData) { return dash_clientside.no_update; }
  const vis = {};
  for (const t of gd._fullData) { vis[t.legendgroup] = t.visible; }
  for (const g of document.querySelectorAll('.vid-hist .js-plotly-plot')) {
    if (g === gd || !g.data) { continue; }
    const idx = [], v = [];
    g.data.forEach(function(t, i) {
      if (t.legendgroup in vis) { idx.push(i); v.push(vis[t.legendgroup]); }
    });
    if (idx.length) { Plotly.restyle(g, {visible: v}, idx); }
  }
  return dash_clientside.no_update;
}
"""


def layout(ctx: UIContext) -> Any:
    from dash import dcc, html

    spec = ctx.spec
    names = spec.criterion_names
    axes = [
        {"label": ctx.labels.short(n), "value": n}
        for n in names + spec.constraint_names + spec.space.names
    ]
    x0, y0 = default_axes(ctx)
    return html.Div(
        [
            html.Div(id="messages", className="msg"),
            html.Div(
                className="bar",
                children=[
                    html.Span(id="in-force", className="muted"),
                    html.Button("Save constraints with the study", id="save-limits"),
                ],
            ),
            html.Div(
                [
                    html.Div(
                        [
                            html.B("What D pins down"),
                            html.Span(
                                " under the constraints in force: each design variable's "
                                "verdict and the range of D (the box drawn grey, D blue, the "
                                "Pareto set green; no value where the data do not determine "
                                "one; details on Refine & continue and Chosen trial)",
                                className="muted",
                            ),
                        ]
                    ),
                    html.Div(id="vid-verdicts"),
                ],
                className="vpanel",
            ),
            html.Div(
                className="row",
                children=[
                    html.Div(_cards(ctx), className="cards colcards"),
                    html.Div(
                        className="col",
                        children=[
                            html.Div(
                                className="bar",
                                children=[
                                    html.Label("x "),
                                    dcc.Dropdown(
                                        id="x-axis",
                                        options=axes,
                                        value=x0,
                                        clearable=False,
                                        style={"width": "170px"},
                                    ),
                                    html.Label("y "),
                                    dcc.Dropdown(
                                        id="y-axis",
                                        options=axes,
                                        value=y0,
                                        clearable=False,
                                        style={"width": "170px"},
                                    ),
                                    html.Button(
                                        "Set the two constraints from the box", id="box-limits"
                                    ),
                                    html.Button("Clear selection", id="clear-sel"),
                                ],
                            ),
                            html.Div(id="box-msg", className="note"),
                            dcc.Graph(
                                id="scatter",
                                config={"displaylogo": False},
                                style={"height": "520px"},
                            ),
                            html.Div(id="sel-text", className="muted"),
                        ],
                    ),
                ],
            ),
            dcc.Tabs(
                id="panel",
                value="histograms",
                children=[
                    dcc.Tab(
                        label="Histograms per parameter",
                        value="histograms",
                        children=[
                            html.P(
                                "Each set on its own scale (share of the set). Click a step to "
                                "select that bin's trials of the set; click a legend entry to "
                                "hide or show a set.",
                                className="muted",
                            ),
                            # one graph per row of the grid (see histogram_rows), each
                            # drawn in a task of its own once it comes near the screen
                            # (vid.lazyRows): the rows below the fold wait until scrolled
                            # to; the first holds the legend
                            html.Div(
                                className="vid-hist",
                                children=[
                                    dcc.Graph(
                                        id=gid,
                                        config={"displaylogo": False},
                                        style={"height": f"{ROW_HEIGHTS[r > 0]}px"},
                                    )
                                    for r, gid in enumerate(hist_graph_ids(ctx))
                                ],
                            ),
                            # the histograms' row figures pass through here so that the
                            # page draws them after the criterion plot's, one by one
                            dcc.Store(id="hist-fig"),
                            dcc.Store(id="hist-lazy"),
                            dcc.Store(id="hist-legend"),
                        ],
                    ),
                    dcc.Tab(
                        label="Criterion vs parameter",
                        value="cvp",
                        children=[
                            html.Div(
                                className="bar",
                                children=[
                                    html.Label("criterion "),
                                    dcc.Dropdown(
                                        id="cvp-crit",
                                        options=[
                                            {"label": ctx.labels.short(n), "value": n}
                                            for n in names
                                        ],
                                        value=names[0],
                                        clearable=False,
                                        style={"width": "170px"},
                                    ),
                                ],
                            ),
                            dcc.Graph(id="cvp-graph", config={"displaylogo": False}),
                        ],
                    ),
                    dcc.Tab(
                        label="Test tables",
                        value="tables",
                        children=[
                            html.P(
                                "Each criterion's trials meeting the functional constraints, "
                                "best first (seed 000 Fig. 6); blue: in D, red: outside D. "
                                "Click a row to choose the trial.",
                                className="muted",
                            ),
                            table(
                                "test-table",
                                merge_duplicate_headers=True,
                                page_size=ctx.table_rows,
                                style_table={
                                    "overflowX": "auto",
                                    "maxHeight": "560px",
                                    "overflowY": "auto",
                                },
                            ),
                        ],
                    ),
                ],
            ),
            html.Div(id="panel-msg", className="msg"),
        ]
    )


def register(app: Any, ctx: UIContext, w: Wiring, tokens: Any) -> None:
    from dash import Input, Output, State, no_update
    from dash import ctx as dctx
    from dash.exceptions import PreventUpdate

    K, Q = len(w.crit), len(w.cons)
    CON = w.constraint_inputs(Input)
    CON_S = w.constraint_inputs(State)
    lim_ids, sld_ids = w.ids("limit"), w.ids("slider")
    src_ids = [f"vid-source-{safe(n)}" for n in w.crit]

    # -- constraints typed or dragged (in the page), or from a box (server) --------------------
    app.clientside_callback(
        """function(...v) {
          const k = v.length / 2, texts = v.slice(0, k), sliders = v.slice(k);
          const nc = dash_clientside.no_update;
          const t = dash_clientside.callback_context.triggered_id;
          const outT = texts.map(() => nc), outS = sliders.map(() => nc);
          const ids = """
        + repr(lim_ids)
        + """, sids = """
        + repr(sld_ids)
        + """;
          let j = ids.indexOf(t);
          if (j >= 0) {
            const x = Number(String(texts[j] || '').trim());
            if (String(texts[j] || '').trim() !== '' && isFinite(x)) outS[j] = x;
            return outT.concat(outS);
          }
          j = sids.indexOf(t);
          if (j >= 0 && sliders[j] !== null && sliders[j] !== undefined) {
            outT[j] = String(Number(Number(sliders[j]).toPrecision(5)));
          }
          return outT.concat(outS);
        }""",
        [Output(i, "value", allow_duplicate=True) for i in lim_ids]
        + [Output(i, "value") for i in sld_ids],
        w.deps(Input, "limit") + w.deps(Input, "slider"),
        prevent_initial_call=True,
    )

    @app.callback(
        [Output(i, "value", allow_duplicate=True) for i in lim_ids]
        + [Output("box-msg", "children")],
        Input("box-limits", "n_clicks"),
        State("selection", "data"),
        *w.deps(State, "limit"),
        prevent_initial_call=True,
    )
    def box_limits(_n, selected, *texts):
        try:
            new, msg = box_to_limits(ctx, selected, list(texts))
        except Exception as exc:
            return [*([no_update] * K), err(exc)]
        return [*new, msg]

    # -- counts: on the server, over the cached columns; the page only waits -----------------
    @app.callback(Output("vid-counts", "children"), *CON, Input("version", "data"))
    def counts(*values):
        texts, roles, pairs = w.split(list(values[:-1]))
        try:
            return counts_children(counts_view(ctx, texts, roles, pairs))
        except Exception as exc:
            err(exc)
            return no_update

    @app.callback(
        Output("vid-sel", "children"),
        Output("sel-csv", "href"),
        Output("sel-csv", "style"),
        Input("selection", "data"),
        *CON,
        Input("version", "data"),
    )
    def selection_counts(sel, *values):
        """The selection's size, how much of it is in D and in the Pareto set, and a link
        to its rows as CSV."""
        texts, roles, pairs = w.split(list(values[:-1]))
        try:
            c = selection_counts_view(ctx, texts, roles, pairs, sel)
        except Exception as exc:
            return err(exc), "", {"display": "none"}
        if c is None:
            return "", "", {"display": "none"}
        token = tokens.add(
            {
                "limit_texts": texts,
                "roles": roles,
                "functional": pairs,
                "which": "selection",
                "selection": sel,
                "filter_query": "",
                "sort_by": [],
            }
        )
        return c["text"], f"/_vid/trials.csv?t={token}", {}

    # -- messages, constraints in force, test tables ----------------------------------------
    @app.callback(
        Output("messages", "children"),
        Output("in-force", "children"),
        Output("test-table", "columns"),
        Output("test-table", "data"),
        Output("test-table", "style_data_conditional"),
        Output("vid-verdicts", "children"),
        [Output(i, "className") for i in lim_ids]
        + [Output(i, "className") for i in w.ids("low")]
        + [Output(i, "className") for i in w.ids("high")]
        + [Output(i, "children") for i in src_ids]
        + [Output(i, "title") for i in src_ids]
        + [Output(i, "className") for i in src_ids],
        *CON,
        Input("panel", "value"),
        Input("version", "data"),
    )
    def summary(*values):
        texts, roles, pairs = w.split(list(values[:-2]))
        which = values[-2]
        try:
            s = summary_view(ctx, texts, roles, pairs)
        except Exception as exc:
            keep = [no_update] * (4 * K + 2 * Q)
            return (err(exc), no_update, no_update, no_update, no_update, no_update, *keep)
        t = s["table"]
        cls = ["invalid" if bad else "" for bad in s["invalid"]]
        cls += ["invalid" if lo else "" for lo, _ in s["invalid_functional"]]
        cls += ["invalid" if hi else "" for _, hi in s["invalid_functional"]]
        src = s["sources"]
        cls += [x["text"] for x in src] + [x["text"] for x in src]
        cls += [f"source src-{x['kind']}" for x in src]
        shown = which == "tables"
        return (
            "\n".join(s["messages"]),
            f"constraints in force: {s['in_force']}; Pareto over: "
            f"{', '.join(s['pure']) or '(none)'}",
            t["columns"] if shown else no_update,
            t["data"] if shown else no_update,
            t["styles"] if shown else no_update,
            verdict_panel(
                s["verdict_groups"],
                nd=s["nd"],
                thin=s["thin"],
                relaxed=s["relaxed"],
                combinations=s["combinations"],
            ),
            *cls,
        )

    # -- plots: only while their tab is shown -------------------------------------------------
    # ``vid-con-tables`` carries [constraint fields, version, selection] while the explorer is
    # shown, so that a brush or a limit typed on another tab sends no request for its plots.
    app.clientside_callback(
        "function(tab, sel, ...v) { const cur = v.pop(), ver = v.pop(); "
        "return window.vidGate('tables', tab, v, sel === undefined ? null : sel, ver, cur); }",
        Output("vid-con-tables", "data"),
        Input("tabs", "value"),
        Input("selection", "data"),
        *CON,
        State("version", "data"),
        State("vid-con-tables", "data"),
    )
    GATE = Input("vid-con-tables", "data")

    @app.callback(
        Output("scatter", "figure"),
        Output("sel-text", "children"),
        GATE,
        Input("x-axis", "value"),
        Input("y-axis", "value"),
        Input("trial-id", "value"),
        Input("version", "data"),
    )
    def scatter(gate, x, y, chosen, _v):
        if not gate:
            raise PreventUpdate
        texts, roles, pairs = w.split(list(gate[0]))
        sel = gate[2]
        try:
            return scatter_view(ctx, texts, roles, x, y, sel, chosen, functional=pairs)
        except Exception as exc:
            return no_update, err(exc)

    # The histogram grid (12 panels) is plotly.js's longest drawing: handed to the graph
    # after a zero-delay timer, it is drawn in a task of its own instead of in the same
    # task as the criterion plot when both answers arrive together (the main thread's
    # longest task after a limit).
    # Each row of the grid is a graph of its own, drawn after the one above it, and only
    # once it comes near the screen (the rows below the fold when scrolled to).
    hist_ids = hist_graph_ids(ctx)
    app.clientside_callback(
        "function(figs) { if (!figs || !figs.length) { return dash_clientside.no_update; } "
        "const m = figs[0].layout.meta || {}; "
        f"window.vid.lazyRows({hist_ids!r}, figs, m.rev, true); return m.rev; }}",
        Output("hist-lazy", "data"),
        Input("hist-fig", "data"),
        prevent_initial_call=True,
    )
    app.clientside_callback(
        _HIST_LEGEND_JS,
        Output("hist-legend", "data"),
        Input("hist-graph", "restyleData"),
        prevent_initial_call=True,
    )
    revs = itertools.count(1)

    @app.callback(
        Output("hist-fig", "data"),
        Output("cvp-graph", "figure"),
        Output("panel-msg", "children"),
        GATE,
        Input("panel", "value"),
        Input("cvp-crit", "value"),
        Input("trial-id", "value"),
        Input("version", "data"),
    )
    def panel(gate, which, crit, chosen, _v):
        if not gate or which not in ("histograms", "cvp"):
            raise PreventUpdate
        texts, roles, pairs = w.split(list(gate[0]))
        sel = gate[2]
        try:
            fig = panel_view(ctx, texts, roles, which, crit, sel, chosen, functional=pairs)
        except Exception as exc:
            return no_update, no_update, err(exc)
        if which != "histograms":
            return no_update, fig, ""
        fig["layout"]["meta"] = dict(fig["layout"].get("meta") or {}, rev=next(revs))
        return histogram_rows(fig), no_update, ""

    # -- selection and choice --------------------------------------------------------------------
    @app.callback(
        Output("selection", "data", allow_duplicate=True),
        Input("scatter", "selectedData"),
        Input("cvp-graph", "selectedData"),
        Input("clear-sel", "n_clicks"),
        *(Input(gid, "clickData") for gid in hist_ids),
        State("x-axis", "value"),
        State("y-axis", "value"),
        State("cvp-crit", "value"),
        *CON_S,
        prevent_initial_call=True,
    )
    def selection(s_sel, c_sel, _clear, *rest):
        clicks = rest[: len(hist_ids)]
        x, y, crit = rest[len(hist_ids) : len(hist_ids) + 3]
        cons = rest[len(hist_ids) + 3 :]
        trig = dctx.triggered_id
        h_click = clicks[hist_ids.index(trig)] if trig in hist_ids else None
        if trig == "clear-sel":
            return None
        texts, roles, pairs = w.split(list(cons))
        try:
            if trig == "scatter":
                spec = selection_from_event(ctx, "scatter", s_sel, x=x, y=y)
            elif trig == "cvp-graph":
                spec = selection_from_event(ctx, "cvp", c_sel, y=crit)
            else:
                spec = selection_from_event(
                    ctx, "hist", h_click, limit_texts=texts, roles=roles, functional=pairs
                )
        except Exception as exc:
            err(exc)
            raise PreventUpdate from None
        if spec is None:
            raise PreventUpdate
        return spec

    @app.callback(
        Output("trial-id", "value", allow_duplicate=True),
        Input("scatter", "clickData"),
        Input("cvp-graph", "clickData"),
        Input("test-table", "active_cell"),
        State("test-table", "data"),
        prevent_initial_call=True,
    )
    def choose(s_click, c_click, t_cell, t_data):
        trig = dctx.triggered_id
        tid = None
        if trig in ("scatter", "cvp-graph"):
            ev = s_click if trig == "scatter" else c_click
            pts = (ev or {}).get("points") or []
            tid = pts[0].get("customdata") if pts else None
            if isinstance(tid, list):
                tid = tid[0] if tid else None
        elif trig == "test-table" and t_cell:
            col = str(t_cell.get("column_id", ""))
            row = t_cell.get("row")
            if col.startswith("c") and isinstance(row, int) and t_data and 0 <= row < len(t_data):
                tid = t_data[row].get(col.split("_")[0] + "_id")
        if tid is None or isinstance(tid, bool) or not isinstance(tid, int | float):
            raise PreventUpdate
        return str(int(tid))
