"""The chosen-trial page, the refine page and the study overview."""

from __future__ import annotations

import itertools
from typing import Any

from ..context import UIContext
from ..explore import HIST_COLUMNS, ROW_HEIGHTS, histogram_rows
from ..overview import overview_view
from ..refine import refine_view
from ..trial import drop_names, trial_view
from ..verdicts import identifiability_view
from .common import Wiring, err, rows_table, table, verdict_table

__all__ = ["overview_layout", "refine_layout", "register", "trial_layout"]


def _W(px: int) -> dict[str, str]:
    """The width of a field in a bar: Dash 4's input container (``container-type:
    inline-size``) has no width of its own, so a field in a label gets the label text's."""
    return {"width": f"{px}px", "display": "inline-flex"}


def _drop_options(ctx: UIContext) -> dict[str, Any]:
    names = drop_names(ctx.spec)
    return {
        "options": [{"label": n, "value": n} for n in names],
        "value": names[0] if names else None,
        "clearable": False,
        "style": {"width": "200px", "display": "inline-block", "verticalAlign": "middle"},
    }


def trial_layout(ctx: UIContext) -> Any:
    from dash import dcc, html

    spec = ctx.spec
    return html.Div(
        [
            html.Div(id="trial-msg", className="msg"),
            html.Div(id="trial-summary", className="section"),
            html.Div(
                className="section",
                children=[
                    html.H3("Criteria and functionals against the bounds in force"),
                    table(
                        "trial-criteria",
                        style_cell_conditional=[
                            {"if": {"column_id": "limit source"}, "textAlign": "left"}
                        ],
                    ),
                ],
            ),
            html.Div(
                className="section",
                children=[
                    html.H3("Parameters: what the data determine, and this trial's values"),
                    html.P(
                        "Verdict under the constraints in force (vectorid.analysis."
                        "identifiability): a value is shown only for an identified parameter; "
                        "any other is shown as its feasible range with its verdict (the trial's "
                        "own value is one value the data allow, not an estimate).",
                        className="muted",
                    ),
                    html.Div(id="trial-params"),
                ],
            ),
            dcc.Graph(id="trial-spread", config={"displaylogo": False}),
            html.Div(
                className="section",
                children=[
                    html.H3("Flight against the measured one"),
                    html.Div(
                        className="bar",
                        children=[
                            html.Label(
                                [
                                    "overlay up to two more trials (ids, comma-separated) ",
                                    dcc.Input(
                                        id="trial-overlay",
                                        type="text",
                                        debounce=True,
                                        style={"width": "140px"},
                                    ),
                                ]
                            ),
                            html.Label(
                                ["drop ", dcc.Dropdown(id="trial-drop", **_drop_options(ctx))],
                                id="trial-drop-label",
                                style={} if len(drop_names(spec)) > 1 else {"display": "none"},
                            ),
                        ],
                    ),
                    html.Div(id="trial-ident"),
                    table("trial-rms"),
                ],
            ),
            html.Div(
                className="section",
                children=[
                    html.H3("Run in the background"),
                    html.Div(
                        className="bar",
                        children=[
                            html.Label("section along "),
                            dcc.Dropdown(
                                id="sec-param",
                                options=[
                                    {"label": ctx.labels.short(n), "value": n}
                                    for n in spec.space.names
                                ],
                                value=spec.space.names[0],
                                clearable=False,
                                style={"width": "170px"},
                            ),
                            html.Label(
                                [
                                    "points ",
                                    dcc.Input(
                                        id="sec-points", type="text", value="21", style=_W(50)
                                    ),
                                ]
                            ),
                            html.Label(
                                [
                                    "range ",
                                    dcc.Input(
                                        id="sec-lo", type="text", placeholder="low", style=_W(70)
                                    ),
                                    " .. ",
                                    dcc.Input(
                                        id="sec-hi", type="text", placeholder="high", style=_W(70)
                                    ),
                                ]
                            ),
                            html.Button("Run section", id="sec-run"),
                        ],
                    ),
                    html.Div(
                        className="bar",
                        children=[
                            html.Label(
                                [
                                    "robustness radius (fraction of the box) ",
                                    dcc.Input(
                                        id="rob-radius", type="text", value="0.02", style=_W(60)
                                    ),
                                ]
                            ),
                            html.Label(
                                [
                                    "points ",
                                    dcc.Input(
                                        id="rob-points", type="text", value="32", style=_W(50)
                                    ),
                                ]
                            ),
                            html.Button("Check robustness", id="rob-run"),
                        ],
                    ),
                ],
            ),
            html.Div(id="trial-results"),
        ]
    )


def refine_layout(ctx: UIContext) -> Any:
    from dash import dcc, html

    return html.Div(
        [
            html.Div(
                className="bar",
                children=[
                    html.Label("proposal from the "),
                    dcc.RadioItems(
                        id="ref-basis",
                        options=[
                            {"label": " feasible set D ", "value": "feasible"},
                            {"label": " Pareto set", "value": "pareto"},
                        ],
                        value="feasible",
                        inline=True,
                    ),
                    html.Label(
                        [
                            "quantile ",
                            dcc.Input(
                                id="ref-q", type="text", value="0.05", debounce=True, style=_W(60)
                            ),
                        ]
                    ),
                    html.Label(
                        [
                            "margin (fraction of the width) ",
                            dcc.Input(
                                id="ref-margin",
                                type="text",
                                value="0.1",
                                debounce=True,
                                style=_W(60),
                            ),
                        ]
                    ),
                ],
            ),
            html.Div(id="ref-msg", className="msg"),
            html.Div(id="ref-summary", className="muted"),
            html.P(
                "Edit new_low / new_high to move or widen the box (an edited row overrides the "
                "rule). The identifiability column is each parameter's verdict (details below): "
                "narrowing the box of a parameter that is not identified cuts what the data "
                "still allow.",
                className="muted",
            ),
            table(
                "ref-table",
                editable=True,
                style_data_conditional=[
                    {"if": {"column_editable": True}, "backgroundColor": "#fffbe6"}
                ],
            ),
            html.Div(
                className="bar",
                children=[
                    html.Label(
                        ["trials ", dcc.Input(id="ref-n", type="text", value="1024", style=_W(100))]
                    ),
                    html.Button("Apply this box and run the trials", id="ref-apply"),
                    html.Button("Run the trials in the current box", id="ref-continue"),
                ],
            ),
            html.Div(
                className="section",
                children=[
                    html.H3("Identifiability under the constraints in force"),
                    html.P(
                        "Per parameter: the verdict from the spread of the feasible set D "
                        "relative to the box it is judged against (the study's, or an earlier "
                        "step's when this step inherited a narrowed box; identified: D spans at "
                        "most 25 % of it, off its edges; not identified: more than 60 %), D's "
                        "and the Pareto set's ranges, the constraints whose limits cut the "
                        "range, and what would identify it. It follows every limit typed, "
                        "dragged or brushed.",
                        className="muted",
                    ),
                    html.Div(id="ref-verdicts"),
                ],
            ),
            # the ranges' histograms, one figure per row of four panels, each drawn by the
            # page when it comes near the screen (``vid.lazyRows``): the rows below the fold
            # cost nothing until scrolled to; each row's box keeps its height meanwhile
            html.Div(
                id="ref-hist",
                className="vid-lazy",
                children=[
                    html.Div(
                        id=gid,
                        className="vid-lazy-row",
                        style={"height": f"{ROW_HEIGHTS[r > 0]}px"},
                    )
                    for r, gid in enumerate(ref_graph_ids(ctx))
                ],
            ),
            dcc.Store(id="ref-fig"),
            dcc.Store(id="ref-lazy"),
        ]
    )


def ref_graph_ids(ctx: UIContext) -> list[str]:
    """The ids of the refine view's histogram rows (:data:`~vectorid.views.ui.explore.
    HIST_COLUMNS` panels a row): ``ref-graph``, ``ref-graph-2``, ..."""
    rows = max(1, -(-len(ctx.spec.space) // HIST_COLUMNS))
    return ["ref-graph"] + [f"ref-graph-{r + 1}" for r in range(1, rows)]


def overview_layout(ctx: UIContext) -> Any:
    from dash import html

    return html.Div(id="overview")


def register(app: Any, ctx: UIContext, w: Wiring) -> None:
    from dash import Input, Output, State, dcc, html
    from dash.exceptions import PreventUpdate

    revs = itertools.count(1)

    def cols(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
        return [{"id": k, "name": k} for k in (rows[0] if rows else {})]

    @app.callback(
        Output("trial-msg", "children"),
        Output("trial-summary", "children"),
        Output("trial-criteria", "columns"),
        Output("trial-criteria", "data"),
        Output("trial-params", "children"),
        Output("trial-spread", "figure"),
        Output("trial-results", "children"),
        Output("trial-ident", "children"),
        Output("trial-rms", "columns"),
        Output("trial-rms", "data"),
        w.gate(app, "trial"),
        Input("trial-id", "value"),
        Input("trial-overlay", "value"),
        Input("trial-drop", "value"),
        State("tabs", "value"),
        Input("version", "data"),
        prevent_initial_call=True,
    )
    def trial(cons, tid, overlay, drop, tab, _v):
        if tab != "trial" or not cons:
            raise PreventUpdate
        texts, roles, pairs = w.split(list(cons[0]))
        empty = {"data": [], "layout": {}}
        try:
            v = trial_view(ctx, tid, texts, roles, pairs, overlay, drop)
        except Exception as exc:
            return (err(exc), "", [], [], [], empty, [], "", [], [])
        results: list[Any] = []
        if v["robustness_text"]:
            results.append(
                html.Div(
                    [html.H3("Robustness"), *[html.Div(t) for t in v["robustness_text"]]],
                    className="section",
                )
            )
        if v["robustness"] is not None:
            results.append(dcc.Graph(figure=v["robustness"]))
        for f in v["sections"]:
            results.append(dcc.Graph(figure=f))
        if not results:
            results = [
                html.P(
                    "No section or robustness check stored for this trial yet.", className="muted"
                )
            ]
        note = html.P(v["identification_note"], className="muted", id="trial-ident-note")
        ident = (
            [note, dcc.Graph(figure=v["identification"])]
            if v["identification"] is not None
            else note
        )
        return (
            "",
            html.Span(v["summary"], id="trial-summary-text"),
            cols(v["criteria"]),
            v["criteria"],
            verdict_table(v["params"], "vid-trial-param", trial=True),
            v["spread"],
            results,
            ident,
            cols(v["rms"]),
            v["rms"],
        )

    @app.callback(
        Output("ref-msg", "children"),
        Output("ref-summary", "children"),
        Output("ref-table", "columns"),
        Output("ref-table", "data"),
        Output("ref-fig", "data"),
        w.gate(app, "refine"),
        State("tabs", "value"),
        Input("ref-basis", "value"),
        Input("ref-q", "value"),
        Input("ref-margin", "value"),
        Input("version", "data"),
        prevent_initial_call=True,
    )
    def refine(cons, tab, basis, q, margin, _v):
        if tab != "refine" or not cons:
            raise PreventUpdate
        texts, roles, pairs = w.split(list(cons[0]))
        try:
            v = refine_view(ctx, texts, roles, basis, q, margin, pairs)
        except Exception as exc:
            return err(exc), "", [], [], {"rev": next(revs), "rows": []}
        columns = [
            {"id": k, "name": k, "editable": k in ("new_low", "new_high")}
            | (
                {"type": "text"}
                if k in ("name", "unit", "identifiability")
                else {"type": "numeric", "format": {"specifier": ".5~g"}}
            )
            for k in v["rows"][0]
        ]
        rev = next(revs)
        fig = v["figure"]
        fig["layout"]["meta"] = dict(fig["layout"].get("meta") or {}, rev=rev)
        return "", v["summary"], columns, v["rows"], {"rev": rev, "rows": histogram_rows(fig)}

    # the rows drawn by the page as they come near the screen, each in a task of its own
    app.clientside_callback(
        "function(f) { if (!f) { return dash_clientside.no_update; } "
        f"window.vid.lazyRows({ref_graph_ids(ctx)!r}, f.rows, f.rev); return f.rev; }}",
        Output("ref-lazy", "data"),
        Input("ref-fig", "data"),
        prevent_initial_call=True,
    )

    @app.callback(
        Output("ref-verdicts", "children"),
        w.gate(app, "refine"),
        State("tabs", "value"),
        Input("version", "data"),
        prevent_initial_call=True,
    )
    def ref_verdicts(cons, tab, _v):
        if tab != "refine" or not cons:
            raise PreventUpdate
        texts, roles, pairs = w.split(list(cons[0]))
        try:
            v = identifiability_view(ctx, texts, roles, pairs)
        except Exception as exc:
            return html.Div(err(exc), className="msg")
        return verdict_table(v["rows"], "vid-verdict")

    @app.callback(
        Output("overview", "children"),
        Input("tabs", "value"),
        Input("version", "data"),
        prevent_initial_call=True,
    )
    def overview(tab, _v):
        if tab != "overview":
            raise PreventUpdate
        try:
            v = overview_view(ctx)
        except Exception as exc:
            return html.Div(err(exc), className="msg")
        sec = lambda title, body: html.Div([html.H3(title), body], className="section")  # noqa: E731
        return [
            sec("Study", rows_table(v["study"], "ov-study")),
            sec("Variables (box Π)", rows_table(v["variables"])),
            sec("Criteria (limits saved with the study)", rows_table(v["criteria"], "ov-criteria")),
            sec("Functional constraints", rows_table(v["constraints"], "ov-constraints")),
            sec("Stages", rows_table(v["stages"], "ov-stages")),
            sec("Boxes of the sample stages", rows_table(v["boxes"])),
            sec(f"Failures ({v['n_failed']})", rows_table(v["failures"])),
            sec("Timing", html.Div([html.P(v["timing"]), rows_table(v["runs"])])),
        ]
