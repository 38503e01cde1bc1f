"""The Dash application: layout and the wiring of components to the plain callback
functions of :mod:`vectorid.views.ui.callbacks`.

Every Dash callback here does three things only: read the component values, call one plain
function, and put its result into components. Errors a user can cause
(:class:`~vectorid.errors.VectoridError`) are shown in the page next to the control; any
other exception is logged on the server and shown as one line, never as a traceback.
"""

from __future__ import annotations

import logging
import math
import warnings
from pathlib import Path
from typing import Any

from ...errors import VectoridError
from . import callbacks as cb
from .data import StoreCache, bounds_text, limits_text
from .jobs import JobManager

__all__ = ["create_app"]

log = logging.getLogger("vectorid.ui")

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0;color:#222;
background:#fafafa}
.page{max-width:1500px;margin:0 auto;padding:0 16px 40px}
.top{position:sticky;top:0;z-index:10;background:#fff;border-bottom:1px solid #ddd;
padding:6px 16px;display:flex;flex-wrap:wrap;gap:18px;align-items:center}
.top h1{font-size:19px;margin:0}.muted{color:#777;font-size:12px}
.counts{font-size:16px}.counts b{font-size:20px;margin-right:4px}
.counts .nd{color:#1f77b4}.counts .np{color:#2ca02c}
.msg{color:#b00020;white-space:pre-wrap;font-size:13px;margin:4px 0}
.ok{color:#2a7a2a;font-size:13px;margin:4px 0}
.cards{display:flex;flex-wrap:wrap;gap:10px;margin:10px 0}
.card{background:#fff;border:1px solid #ddd;border-radius:6px;padding:8px 10px;width:230px}
.card input[type=text]{width:120px}
.invalid,.invalid input{outline:2px solid #b00020;background:#fff0f0 !important}
.row{display:flex;gap:16px;align-items:flex-start;flex-wrap:wrap}
.col{flex:1 1 520px;min-width:420px}
.bar{display:flex;gap:8px;align-items:center;flex-wrap:wrap;margin:6px 0}
.bar label{font-size:13px}
button{padding:4px 10px;cursor:pointer}
progress{width:160px}
.section{background:#fff;border:1px solid #e4e4e4;border-radius:6px;padding:8px 12px;margin:10px 0}
h3{margin:6px 0;font-size:15px}
.show-hide{display:none}
"""

_INDEX = (
    "<!DOCTYPE html><html><head>{%metas%}<title>{%title%}</title>{%favicon%}{%css%}"
    "<style>" + _CSS + "</style></head><body>{%app_entry%}<footer>{%config%}{%scripts%}"
    "{%renderer%}</footer></body></html>"
)


def _table(id_: str, **kw: Any) -> Any:
    from dash import dash_table

    style = {
        "style_table": {"overflowX": "auto"},
        "style_cell": {"fontSize": 12, "padding": "2px 6px", "fontFamily": "monospace"},
        "style_header": {"fontWeight": 600, "backgroundColor": "#f3f3f3"},
    }
    style.update(kw)
    return dash_table.DataTable(id=id_, **style)


def _rows_table(rows: list[dict[str, Any]], id_: str | None = None) -> Any:
    from dash import dash_table, html

    if not rows:
        return html.P("none", className="muted")
    cols = [{"id": k, "name": k} for k in rows[0]]
    kw: dict[str, Any] = {"id": id_} if id_ else {}
    return dash_table.DataTable(
        columns=cols,
        data=rows,
        style_table={"overflowX": "auto"},
        style_cell={"fontSize": 12, "padding": "2px 6px", "textAlign": "left"},
        style_header={"fontWeight": 600, "backgroundColor": "#f3f3f3"},
        **kw,
    )


def _layout(ctx: cb.UIContext) -> Any:
    import numpy as np
    from dash import dcc, html

    ctx.cache.state()  # built at every page load: start from the limits saved in the store
    spec = ctx.spec
    a = ctx.cache.analysis()
    names = spec.criterion_names
    texts = limits_text(spec)
    cards = []
    for j, c in enumerate(spec.criteria):
        t = a.test_table(c.name) if a.n else None
        lo = t.min if t is not None and math.isfinite(t.min) else 0.0
        hi = t.max if t is not None and math.isfinite(t.max) else 1.0
        if hi <= lo:
            hi = lo + 1.0
        worse = hi if c.sense == "min" else lo
        value = c.limit if c.limit is not None else worse
        cards.append(
            html.Div(
                className="card",
                children=[
                    html.B(f"{c.name} ({c.sense})"),
                    html.Div(
                        f"range {lo:.4g} .. {hi:.4g}",
                        id={"type": "range", "name": c.name},
                        className="muted",
                    ),
                    html.Label(
                        [
                            f"{c.name} {'<=' if c.sense == 'min' else '>='} ",
                            dcc.Input(
                                id={"type": "limit", "name": c.name},
                                type="text",
                                value=texts[j],
                                debounce=True,
                                placeholder="no limit",
                            ),
                        ]
                    ),
                    dcc.Slider(
                        id={"type": "slider", "name": c.name},
                        min=lo,
                        max=hi,
                        step=(hi - lo) / 500,
                        value=min(max(value, lo), hi),
                        marks=None,
                        updatemode="mouseup",
                        tooltip={"placement": "bottom", "always_visible": False},
                    ),
                    dcc.RadioItems(
                        id={"type": "role", "name": c.name},
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
        span = f"range {col.min():.4g} .. {col.max():.4g}" if len(col) else "no value yet"
        cards.append(
            html.Div(
                className="card",
                children=[
                    html.B(f"{g.name} (functional)"),
                    html.Div(span, className="muted"),
                    html.Label(
                        [
                            dcc.Input(
                                id={"type": "con-low", "name": g.name},
                                type="text",
                                value=lo_text,
                                debounce=True,
                                placeholder="no low",
                                size="7",
                            ),
                            f" <= {g.name} <= ",
                            dcc.Input(
                                id={"type": "con-high", "name": g.name},
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
    axes = names + spec.constraint_names + spec.space.names
    x0 = names[0]
    y0 = names[1] if len(names) > 1 else spec.space.names[0]
    header = html.Div(
        className="top",
        children=[
            html.Div(
                [
                    html.H1(f"vectorid · {spec.name}"),
                    html.Span(str(ctx.cache.path), className="muted"),
                ]
            ),
            html.Div(id="counts", className="counts"),
            html.Label(
                [
                    "chosen trial ",
                    dcc.Input(
                        id="trial-id",
                        type="text",
                        debounce=True,
                        size="8",
                        value=str(cb.initial_choice(ctx) or ""),
                    ),
                ]
            ),
            html.Div(
                className="bar",
                children=[
                    html.Progress(id="job-progress", max="1", value="0"),
                    html.Span(id="job-text", className="muted"),
                    html.Button("Stop job", id="job-stop"),
                ],
            ),
            html.Div(id="job-msg", className="msg"),
        ],
    )
    tables_tab = html.Div(
        [
            html.Div(id="messages", className="msg"),
            html.Div(
                className="bar",
                children=[
                    html.Span(id="in-force", className="muted"),
                    html.Button("Save constraints with the study", id="save-limits"),
                ],
            ),
            html.Div(cards, className="cards"),
            html.Div(
                className="row",
                children=[
                    html.Div(
                        className="col",
                        children=[
                            html.H3(
                                "Test tables (best first; red: outside D) — click a row to choose"
                            ),
                            _table(
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
                                        style={"width": "150px"},
                                    ),
                                    html.Label("y "),
                                    dcc.Dropdown(
                                        id="y-axis",
                                        options=axes,
                                        value=y0,
                                        clearable=False,
                                        style={"width": "150px"},
                                    ),
                                    html.Button(
                                        "Set the two constraints from the box", id="box-limits"
                                    ),
                                    html.Button("Clear selection", id="clear-sel"),
                                ],
                            ),
                            html.Div(id="box-msg", className="msg"),
                            dcc.Graph(id="scatter", config={"displaylogo": False}),
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
                            html.P("Click a bar to select its trials.", className="muted"),
                            dcc.Graph(id="hist-graph", config={"displaylogo": False}),
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
                                        options=names,
                                        value=names[0],
                                        clearable=False,
                                        style={"width": "160px"},
                                    ),
                                ],
                            ),
                            dcc.Graph(id="cvp-graph", config={"displaylogo": False}),
                        ],
                    ),
                    dcc.Tab(
                        label="Feasible & Pareto trials",
                        value="sets",
                        children=[
                            html.Div(id="sets-note", className="muted"),
                            _table("sets-table", page_size=25, sort_action="native"),
                        ],
                    ),
                ],
            ),
            html.Div(id="panel-msg", className="msg"),
        ]
    )
    trial_tab = html.Div(
        [
            html.Div(id="trial-msg", className="msg"),
            html.Div(id="trial-summary", className="section"),
            html.Div(
                className="row",
                children=[
                    html.Div(
                        className="col",
                        children=[html.H3("Criteria and functionals"), _table("trial-criteria")],
                    ),
                    html.Div(
                        className="col",
                        children=[html.H3("Parameters against nominal"), _table("trial-params")],
                    ),
                ],
            ),
            dcc.Graph(id="trial-spread", config={"displaylogo": False}),
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
                                options=spec.space.names,
                                value=spec.space.names[0],
                                clearable=False,
                                style={"width": "150px"},
                            ),
                            html.Label(
                                [
                                    "points ",
                                    dcc.Input(id="sec-points", type="text", value="21", size="4"),
                                ]
                            ),
                            html.Label(
                                [
                                    "range ",
                                    dcc.Input(
                                        id="sec-lo", type="text", placeholder="low", size="6"
                                    ),
                                    " .. ",
                                    dcc.Input(
                                        id="sec-hi", type="text", placeholder="high", size="6"
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
                                    "robustness radius ",
                                    dcc.Input(id="rob-radius", type="text", value="0.02", size="5"),
                                ]
                            ),
                            html.Label(
                                [
                                    "points ",
                                    dcc.Input(id="rob-points", type="text", value="32", size="4"),
                                ]
                            ),
                            html.Button("Check robustness", id="rob-run"),
                        ],
                    ),
                ],
            ),
            html.Div(id="trial-results"),
            html.Div(
                className="section",
                children=[html.H3("Trajectories against the flight"), html.Div(id="trial-ident")],
            ),
        ]
    )
    refine_tab = html.Div(
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
                                id="ref-q", type="text", value="0.05", size="5", debounce=True
                            ),
                        ]
                    ),
                    html.Label(
                        [
                            "margin ",
                            dcc.Input(
                                id="ref-margin", type="text", value="0.1", size="5", debounce=True
                            ),
                        ]
                    ),
                ],
            ),
            html.Div(id="ref-msg", className="msg"),
            html.Div(id="ref-summary", className="muted"),
            html.P(
                "Edit new_low / new_high to move or widen the box "
                "(an edited row overrides the rule).",
                className="muted",
            ),
            _table(
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
                        ["trials ", dcc.Input(id="ref-n", type="text", value="1024", size="8")]
                    ),
                    html.Button("Apply this box and run the trials", id="ref-apply"),
                    html.Button("Run the trials in the current box", id="ref-continue"),
                ],
            ),
            dcc.Graph(id="ref-graph", config={"displaylogo": False}),
        ]
    )
    return html.Div(
        [
            header,
            html.Div(
                className="page",
                children=[
                    dcc.Interval(id="tick", interval=1000),
                    dcc.Store(id="version", data=list(ctx.cache.version())),
                    dcc.Store(id="selection", data=None),
                    dcc.Store(id="job-note", data=None),
                    dcc.Tabs(
                        id="tabs",
                        value="tables",
                        children=[
                            dcc.Tab(
                                label="Test tables & plots", value="tables", children=tables_tab
                            ),
                            dcc.Tab(label="Chosen trial", value="trial", children=trial_tab),
                            dcc.Tab(label="Refine & continue", value="refine", children=refine_tab),
                            dcc.Tab(
                                label="Study overview",
                                value="overview",
                                children=html.Div(id="overview"),
                            ),
                        ],
                    ),
                ],
            ),
        ]
    )


def _err(exc: BaseException) -> str:
    """The message shown for an exception raised by a callback."""
    if isinstance(exc, VectoridError):
        return str(exc)
    log.exception("unexpected error in a UI callback")
    return f"internal error ({type(exc).__name__}: {exc}); the server log has the details"


def create_app(
    store: str | Path,
    *,
    executor: str | None = None,
    workers: int | None = None,
    max_points: int = 20_000,
) -> tuple[Any, cb.UIContext]:
    """Build the Dash app serving one study store.

    Parameters
    ----------
    store : path
        The study store (``.db``); read-only in this process.
    executor, workers
        For background run jobs (see :func:`vectorid.run.run_store`).
    max_points : int
        Points drawn in the criterion-vs-criterion plot.

    Returns
    -------
    app : dash.Dash
    ctx : UIContext
        The state shared by the callbacks (its ``jobs`` must be shut down on exit).
    """
    try:
        import dash
        import flask
        from dash import ALL, Input, Output, State, html, no_update
        from dash import ctx as dctx
        from dash.exceptions import PreventUpdate
    except ModuleNotFoundError as exc:  # pragma: no cover - exercised without dash only
        raise ImportError(
            "vectorid ui needs dash: pip install 'vectorid[ui]' (or pip install dash)"
        ) from exc

    cache = StoreCache(store)
    jobs = JobManager(
        cache.path,
        executor=executor,
        workers=workers,
        progress_of=lambda: cache.version()[0],
    )
    ctx = cb.UIContext(cache=cache, jobs=jobs, max_points=max_points)
    cache.analysis()  # load and compile (numba) before the first request

    server = flask.Flask("vectorid.ui", static_folder=None)
    server.config["MAX_CONTENT_LENGTH"] = 8 * 1024 * 1024

    def _bad_request(exc: Exception) -> Any:
        """A request the app cannot serve (a malformed callback body, an unknown resource):
        a one-line answer and a one-line log entry, no traceback anywhere."""
        from werkzeug.exceptions import HTTPException

        if isinstance(exc, HTTPException):
            return exc
        log.warning(
            "rejected %s %s: %s: %s",
            flask.request.method,
            flask.request.path,
            type(exc).__name__,
            str(exc).splitlines()[0] if str(exc) else "",
        )
        return f"bad request: {type(exc).__name__}", 400

    server.register_error_handler(Exception, _bad_request)
    app = dash.Dash(
        "vectorid.ui",
        server=server,
        title=f"vectorid · {ctx.spec.name}",
        assets_folder=str(Path(__file__).parent / "_no_assets"),
        include_assets_files=False,
        serve_locally=True,
        update_title=None,
        enable_mcp=False,
        index_string=_INDEX,
    )
    # Dash 4 announces that DataTable leaves the builtin components in a future major version;
    # the extra pins dash < 5, and the tables move to dash-ag-grid then.
    warnings.filterwarnings(
        "ignore",
        message="(?s).*DataTable will be removed",
        category=DeprecationWarning,
        module="dash",
    )
    app.layout = lambda: _layout(ctx)  # a function: a reload reads the saved limits
    names = ctx.spec.criterion_names
    K = len(names)
    LIM = Input({"type": "limit", "name": ALL}, "value")
    ROL = Input({"type": "role", "name": ALL}, "value")
    LIM_S = State({"type": "limit", "name": ALL}, "value")
    ROL_S = State({"type": "role", "name": ALL}, "value")
    FLO = Input({"type": "con-low", "name": ALL}, "value")
    FHI = Input({"type": "con-high", "name": ALL}, "value")
    FLO_S = State({"type": "con-low", "name": ALL}, "value")
    FHI_S = State({"type": "con-high", "name": ALL}, "value")
    M = len(ctx.spec.constraints)

    def pairs(lows: Any, highs: Any) -> list[list[Any]] | None:
        """The functional-constraint fields as (low, high) text pairs, one per constraint."""
        if lows is None or highs is None:
            return None
        return [[lo, hi] for lo, hi in zip(lows, highs)]

    # -- constraints: typed, dragged, or from a box -------------------------------------------

    @app.callback(
        Output({"type": "limit", "name": ALL}, "value"),
        Output({"type": "slider", "name": ALL}, "value"),
        Output("box-msg", "children"),
        Input({"type": "limit", "name": ALL}, "value"),
        Input({"type": "slider", "name": ALL}, "value"),
        Input("box-limits", "n_clicks"),
        State("selection", "data"),
        prevent_initial_call=True,
    )
    def sync_limits(texts, sliders, _n, selected):
        keep = [no_update] * K
        trig = dctx.triggered_id
        try:
            if trig == "box-limits":
                new, msg = cb.box_to_limits(ctx, selected, texts)
                return new, [_slider(ctx, n, t) for n, t in zip(names, new)], msg
            if isinstance(trig, dict) and trig.get("type") == "slider":
                j = names.index(trig["name"])
                out = list(keep)
                out[j] = f"{float(sliders[j]):.6g}"
                return out, keep, ""
            if isinstance(trig, dict) and trig.get("type") == "limit":
                j = names.index(trig["name"])
                out = list(keep)
                out[j] = _slider(ctx, names[j], texts[j])
                return keep, out, ""
        except Exception as exc:
            return keep, keep, _err(exc)
        raise PreventUpdate

    # -- counts, test tables, simplified table -------------------------------------------------

    @app.callback(
        Output("counts", "children"),
        Output("messages", "children"),
        Output("in-force", "children"),
        Output("test-table", "columns"),
        Output("test-table", "data"),
        Output("test-table", "style_data_conditional"),
        Output("sets-table", "columns"),
        Output("sets-table", "data"),
        Output("sets-table", "style_data_conditional"),
        Output("sets-note", "children"),
        Output({"type": "limit", "name": ALL}, "className"),
        Output({"type": "con-low", "name": ALL}, "className"),
        Output({"type": "con-high", "name": ALL}, "className"),
        LIM,
        ROL,
        FLO,
        FHI,
        Input("version", "data"),
    )
    def summary(texts, roles, lows, highs, _v):
        try:
            s = cb.summary_view(ctx, texts, roles, pairs(lows, highs))
        except Exception as exc:
            keep = [no_update] * M
            return (no_update, _err(exc), *([no_update] * 8), [no_update] * K, keep, keep)
        c = s["counts"]
        counts = [
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
        t, st = s["table"], s["sets"]
        return (
            counts,
            "\n".join(s["messages"]),
            f"constraints in force: {s['in_force']}; "
            f"Pareto over: {', '.join(s['pure']) or '(none)'}",
            t["columns"],
            t["data"],
            t["styles"],
            st["columns"],
            st["data"],
            st["styles"],
            st["note"],
            ["invalid" if bad else "" for bad in s["invalid"]],
            ["invalid" if lo else "" for lo, _ in s["invalid_functional"]],
            ["invalid" if hi else "" for _, hi in s["invalid_functional"]],
        )

    # -- plots -------------------------------------------------------------------------------

    @app.callback(
        Output("scatter", "figure"),
        Output("sel-text", "children"),
        LIM,
        ROL,
        FLO,
        FHI,
        Input("x-axis", "value"),
        Input("y-axis", "value"),
        Input("selection", "data"),
        Input("trial-id", "value"),
        Input("version", "data"),
    )
    def scatter(texts, roles, lows, highs, x, y, sel, chosen, _v):
        try:
            return cb.scatter_view(
                ctx, texts, roles, x, y, sel, chosen, functional=pairs(lows, highs)
            )
        except Exception as exc:
            return no_update, _err(exc)

    @app.callback(
        Output("hist-graph", "figure"),
        Output("cvp-graph", "figure"),
        Output("panel-msg", "children"),
        LIM,
        ROL,
        FLO,
        FHI,
        Input("panel", "value"),
        Input("cvp-crit", "value"),
        Input("selection", "data"),
        Input("trial-id", "value"),
        Input("version", "data"),
    )
    def panel(texts, roles, lows, highs, which, crit, sel, chosen, _v):
        if which == "sets":
            raise PreventUpdate
        try:
            fig = cb.panel_view(
                ctx, texts, roles, which, crit, sel, chosen, functional=pairs(lows, highs)
            )
        except Exception as exc:
            return no_update, no_update, _err(exc)
        return (fig, no_update, "") if which == "histograms" else (no_update, fig, "")

    # -- selection and choice --------------------------------------------------------------------

    @app.callback(
        Output("selection", "data"),
        Input("scatter", "selectedData"),
        Input("cvp-graph", "selectedData"),
        Input("hist-graph", "clickData"),
        Input("clear-sel", "n_clicks"),
        State("x-axis", "value"),
        State("y-axis", "value"),
        State("cvp-crit", "value"),
        LIM_S,
        ROL_S,
        FLO_S,
        FHI_S,
        prevent_initial_call=True,
    )
    def selection(s_sel, c_sel, h_click, _clear, x, y, crit, texts, roles, lows, highs):
        trig = dctx.triggered_id
        if trig == "clear-sel":
            return None
        try:
            if trig == "scatter":
                spec = cb.selection_from_event(ctx, "scatter", s_sel, x=x, y=y)
            elif trig == "cvp-graph":
                spec = cb.selection_from_event(ctx, "cvp", c_sel, y=crit)
            else:
                spec = cb.selection_from_event(
                    ctx,
                    "hist",
                    h_click,
                    limit_texts=texts,
                    roles=roles,
                    functional=pairs(lows, highs),
                )
        except Exception as exc:
            _err(exc)
            raise PreventUpdate from None
        if spec is None:
            raise PreventUpdate
        return spec

    @app.callback(
        Output("trial-id", "value"),
        Input("scatter", "clickData"),
        Input("cvp-graph", "clickData"),
        Input("test-table", "active_cell"),
        Input("sets-table", "active_cell"),
        State("test-table", "data"),
        prevent_initial_call=True,
    )
    def choose(s_click, c_click, t_cell, s_cell, t_data):
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
        elif trig == "sets-table" and s_cell:
            tid = s_cell.get("row_id")
        if tid is None or isinstance(tid, bool) or not isinstance(tid, int | float):
            raise PreventUpdate
        return str(int(tid))

    # -- the chosen trial ----------------------------------------------------------------------

    @app.callback(
        Output("trial-msg", "children"),
        Output("trial-summary", "children"),
        Output("trial-criteria", "columns"),
        Output("trial-criteria", "data"),
        Output("trial-params", "columns"),
        Output("trial-params", "data"),
        Output("trial-spread", "figure"),
        Output("trial-results", "children"),
        Output("trial-ident", "children"),
        Input("trial-id", "value"),
        Input("tabs", "value"),
        LIM,
        ROL,
        FLO,
        FHI,
        Input("version", "data"),
    )
    def trial(tid, tab, texts, roles, lows, highs, _v):
        from dash import dcc

        if tab != "trial":
            raise PreventUpdate
        try:
            v = cb.trial_view(ctx, tid, texts, roles, pairs(lows, highs))
        except Exception as exc:
            return (_err(exc), "", [], [], [], [], {"data": [], "layout": {}}, [], "")
        cols = lambda rows: [{"id": k, "name": k} for k in (rows[0] if rows else {})]  # noqa: E731
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
        ident = (
            dcc.Graph(figure=v["identification"])
            if v["identification"] is not None
            else html.P(v["identification_note"], className="muted")
        )
        return (
            "",
            html.Span(v["summary"], id="trial-summary-text"),
            cols(v["criteria"]),
            v["criteria"],
            cols(v["params"]),
            v["params"],
            v["spread"],
            results,
            ident,
        )

    # -- refine ----------------------------------------------------------------------------------

    @app.callback(
        Output("ref-msg", "children"),
        Output("ref-summary", "children"),
        Output("ref-table", "columns"),
        Output("ref-table", "data"),
        Output("ref-graph", "figure"),
        Input("tabs", "value"),
        Input("ref-basis", "value"),
        Input("ref-q", "value"),
        Input("ref-margin", "value"),
        LIM,
        ROL,
        FLO,
        FHI,
        Input("version", "data"),
    )
    def refine(tab, basis, q, margin, texts, roles, lows, highs, _v):
        if tab != "refine":
            raise PreventUpdate
        try:
            v = cb.refine_view(ctx, texts, roles, basis, q, margin, pairs(lows, highs))
        except Exception as exc:
            return _err(exc), "", [], [], {"data": [], "layout": {}}
        cols = [
            {"id": k, "name": k, "editable": k in ("new_low", "new_high")}
            | (
                {"type": "text"}
                if k == "name"
                else {"type": "numeric", "format": {"specifier": ".6~g"}}
            )
            for k in v["rows"][0]
        ]
        return "", v["summary"], cols, v["rows"], v["figure"]

    # -- jobs --------------------------------------------------------------------------------------

    @app.callback(
        Output("job-note", "data"),
        Input("sec-run", "n_clicks"),
        Input("rob-run", "n_clicks"),
        Input("ref-apply", "n_clicks"),
        Input("ref-continue", "n_clicks"),
        Input("save-limits", "n_clicks"),
        Input("job-stop", "n_clicks"),
        State("trial-id", "value"),
        State("sec-param", "value"),
        State("sec-points", "value"),
        State("sec-lo", "value"),
        State("sec-hi", "value"),
        State("rob-radius", "value"),
        State("rob-points", "value"),
        State("ref-basis", "value"),
        State("ref-q", "value"),
        State("ref-margin", "value"),
        State("ref-table", "data"),
        State("ref-n", "value"),
        LIM_S,
        ROL_S,
        FLO_S,
        FHI_S,
        prevent_initial_call=True,
    )
    def job(*values):
        (*_clicks, tid, sp, spts, slo, shi, rr, rpts, basis, q, mg, rows, n) = values[:-4]
        texts, roles, lows, highs = values[-4:]
        bounds = {"limit_texts": texts, "roles": roles, "functional": pairs(lows, highs)}
        trig = dctx.triggered_id
        try:
            if trig == "job-stop":
                note = cb.job_action(ctx, "stop")
            elif trig == "sec-run":
                note = cb.job_action(
                    ctx, "section", trial=tid, param=sp, points=spts, lo=slo, hi=shi
                )
            elif trig == "rob-run":
                note = cb.job_action(ctx, "robustness", trial=tid, radius=rr, points=rpts, **bounds)
            elif trig == "ref-apply":
                note = cb.job_action(
                    ctx,
                    "refine",
                    trials=n,
                    basis=basis,
                    quantile=q,
                    margin=mg,
                    rows=rows,
                    **bounds,
                )
            elif trig == "ref-continue":
                note = cb.job_action(ctx, "continue", trials=n)
            elif trig == "save-limits":
                note = cb.job_action(ctx, "limits", **bounds)
            else:
                raise PreventUpdate
        except PreventUpdate:
            raise
        except Exception as exc:
            note = {"text": _err(exc), "busy": None}
        # a fresh dict every time, so that the same message twice still updates the page
        return dict(note, at=_clicks_total(_clicks))

    @app.callback(
        Output("job-progress", "value"),
        Output("job-text", "children"),
        Output("version", "data"),
        Output("job-msg", "children"),
        Input("tick", "n_intervals"),
        Input("job-note", "data"),
        State("version", "data"),
        State("job-msg", "children"),
    )
    def tick(_n, note, version, shown):
        try:
            st = cb.job_view(ctx)
            now = list(ctx.cache.version())
            msg = cb.job_message(ctx, note)
        except Exception as exc:
            return no_update, _err(exc), no_update, no_update
        prog = st["progress"]
        value = str(prog) if prog is not None else (None if st["state"] == "running" else "0")
        return (
            value,
            st["text"],
            (now if now != version else no_update),
            (msg if msg != (shown or "") else no_update),
        )

    # -- overview ----------------------------------------------------------------------------------

    @app.callback(Output("overview", "children"), Input("tabs", "value"), Input("version", "data"))
    def overview(tab, _v):
        if tab != "overview":
            raise PreventUpdate
        try:
            v = cb.overview_view(ctx)
        except Exception as exc:
            return html.Div(_err(exc), className="msg")
        sec = lambda title, body: html.Div([html.H3(title), body], className="section")  # noqa: E731
        return [
            sec("Study", _rows_table(v["study"], "ov-study")),
            sec("Variables (box Π)", _rows_table(v["variables"])),
            sec(
                "Criteria (limits saved with the study)", _rows_table(v["criteria"], "ov-criteria")
            ),
            sec("Functional constraints", _rows_table(v["constraints"], "ov-constraints")),
            sec("Stages", _rows_table(v["stages"], "ov-stages")),
            sec("Boxes of the sample stages", _rows_table(v["boxes"])),
            sec(f"Failures ({v['n_failed']})", _rows_table(v["failures"])),
            sec("Timing", html.Div([html.P(v["timing"]), _rows_table(v["runs"])])),
        ]

    return app, ctx


def _clicks_total(clicks: Any) -> int:
    """Sum of the buttons' click counts (None for a button never pressed)."""
    return sum(int(c) for c in clicks if isinstance(c, int))


def _slider(ctx: cb.UIContext, name: str, text: Any) -> Any:
    """Slider position for a constraint field (no update when the field does not parse)."""
    from dash import no_update

    from .data import parse_number

    try:
        v = parse_number(text, name)
    except VectoridError:
        return no_update
    if v is None:
        return no_update
    return v
