"""The Dash application: the page shell, the static files it serves, and the registration of
each view's page (:mod:`vectorid.views.ui.pages`).

Every Dash callback does three things only: read the component values, call one plain
function, and put its result into components. Errors a user can cause
(:class:`~vectorid.errors.VectoridError`) are shown in the page next to the control; any
other exception is logged on the server and shown as one line, never as a traceback.

The page loads a partial plotly.js bundle (scatter, scattergl, bar, box, heatmap, parcoords:
1.6 MB instead of 4.8 MB, built by ``scripts/build_plotly_bundle.sh`` from the plotly.js
version that plotly.py ships), served at ``/_vid/plotly.js``; Dash's graphs use it instead of
loading the full one.
"""

from __future__ import annotations

import logging
import warnings
from pathlib import Path
from typing import Any

from ...analysis import pareto
from . import callbacks as cb
from . import client
from .data import FreedMemoryReleaser, StoreCache
from .jobs import JobManager
from .pages import compare as compare_page
from .pages import detail, explore, sets
from .pages.common import Wiring, err

__all__ = ["create_app"]

log = logging.getLogger("vectorid.ui")

STATIC = Path(__file__).resolve().parents[1] / "static"
PLOTLY_BUNDLE = STATIC / "plotly-vectorid.min.js"
#: Tabs whose views get the constraint fields only while shown (see ``Wiring.gate``).
GATED = ("tables", "parallel", "table", "trial", "refine")

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0;color:#222;
background:#fafafa}
.page{max-width:1600px;margin:0 auto;padding:0 14px 40px}
.top{position:sticky;top:0;z-index:10;background:#fff;border-bottom:1px solid #ddd;
padding:4px 14px;display:flex;flex-wrap:wrap;gap:16px;align-items:center}
.top h1{font-size:18px;margin:0}.muted{color:#666;font-size:12px}.small{font-size:11px}
.counts{font-size:16px}.counts b{font-size:20px;margin-right:4px}
.counts .nd{color:#1f77b4}.counts .np{color:#2ca02c}
.msg{color:#333;background:#fff7e0;border-left:3px solid #d9a400;white-space:pre-wrap;
font-size:13px;margin:4px 0;padding:0 6px}.msg:empty{display:none}
.note{color:#333;font-size:13px;margin:2px 0}
.cards{display:flex;flex-wrap:wrap;gap:8px;margin:6px 0;align-content:flex-start}
.colcards{flex:0 1 520px;max-height:560px;overflow-y:auto}
.card{background:#fff;border:1px solid #ddd;border-radius:6px;padding:6px 8px;width:220px}
.card input[type=text]{width:110px}
.invalid,.invalid input{outline:2px solid #d9a400;background:#fff7e0 !important}
.row{display:flex;gap:14px;align-items:flex-start;flex-wrap:wrap}
.col{flex:1 1 560px;min-width:420px}
.bar{display:flex;gap:8px;align-items:center;flex-wrap:wrap;margin:4px 0}
.bar label{font-size:13px}
button,a.button{padding:3px 9px;cursor:pointer;font-size:13px}
a.button{border:1px solid #888;border-radius:3px;background:#f3f3f3;color:#222;
text-decoration:none}
progress{width:160px}
.section{background:#fff;border:1px solid #e4e4e4;border-radius:6px;padding:6px 10px;margin:8px 0}
.scroll{overflow-x:auto;max-width:100%}
.scroll table{border-collapse:collapse;font-size:12px}
.scroll td,.scroll th{border:1px solid #ddd;padding:2px 6px;text-align:left}
.scroll th{background:#f3f3f3}
h3{margin:6px 0;font-size:15px}
.source{font-size:11px;color:#555;line-height:1.25;margin:2px 0;display:-webkit-box;
-webkit-line-clamp:2;-webkit-box-orient:vertical;overflow:hidden}
.source.src-session,.chip.src-session{color:#222;font-weight:600}
.source.src-relaxed{display:block;color:#6b4a00}.chip.src-relaxed{border-color:#d9a400;
background:#fff7e0}.relaxed{color:#6b4a00;font-weight:600}
.chip{display:inline-block;border:1px solid #ccc;border-radius:10px;padding:0 7px;margin:1px 3px;
font-size:12px;background:#fff}
.chip.src-session{border-color:#777;background:#eee}
.scroll .vtable td{vertical-align:top}.vtable td.num{font-family:monospace;white-space:nowrap}
.verdict{border:1px solid #999;border-radius:3px;padding:0 5px;white-space:nowrap}
.v-identified{font-weight:700;background:#e9e9e9}.v-weak{font-style:italic}
.v-not-identified{border-style:dashed;color:#444}
#par-graph{overflow-x:auto;overflow-y:hidden;background:#fff}
.vid-par-title{font-size:13px;color:#333;margin:4px 0 2px;text-align:center}
.vid-par-svg text{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;fill:#333}
.vid-axis-title{font-size:12px;cursor:move;paint-order:stroke;stroke:#fff;stroke-width:3px}
.vid-title .vid-unit{fill:#666}
.vid-tick-label{font-size:11px;fill:#555;paint-order:stroke;stroke:#fff;stroke-width:3px}
.vid-axis-line{stroke:#444;stroke-width:1}
.vid-tick{stroke:#444}.vid-hit{fill:transparent;cursor:crosshair}
.vid-brush{fill:rgba(60,60,60,.22);stroke:#333;stroke-width:1;cursor:pointer}
.vid-limit{fill:#d9a400;stroke:#8a6a00;stroke-width:.5}
.axes-panel{font-size:13px}.axes-panel summary{cursor:pointer}
.axes-panel .vid-axes label{display:inline-block;min-width:150px;margin:1px 8px 1px 0;
font-size:12px}
.busy{visibility:hidden;color:#a15c00;font-size:13px}
body:has([data-dash-is-loading="true"]) .busy{visibility:visible}
#vid-counts[data-dash-is-loading="true"] b{opacity:.4}
@media print{.top{position:static}.busy,button,.modebar-container{display:none !important}}
.rangebar{position:relative;width:140px;height:12px;background:#e4e4e4;border-radius:2px;
margin-top:3px}
.vpanel{background:#fff;border:1px solid #e4e4e4;border-radius:6px;padding:4px 8px;margin:4px 0;
font-size:13px}.vgroup{display:flex;flex-wrap:wrap;gap:4px 6px;align-items:center;margin:3px 0}
.vgroup-name{font-weight:600;min-width:120px}.vchip{border:1px solid #bbb;border-radius:4px;
padding:0 5px;background:#fafafa;font-size:12px;white-space:nowrap}
.vchip .rangebar{display:inline-block;width:44px;height:8px;margin:0 0 0 4px;vertical-align:middle}
.vchip .rangebar>div{height:6px !important;top:1px !important}
.vchip.v-identified{border-color:#2ca02c;background:#f1faf1}.vchip.v-weak{border-style:dashed}.rangebar>div{position:absolute}.rb-trial{top:-3px;height:18px;width:2px}
"""

_INDEX = (
    "<!DOCTYPE html><html><head>{%metas%}<title>{%title%}</title>{%favicon%}{%css%}"
    "<style>" + _CSS + "</style>"
    "</head><body>{%app_entry%}<footer>{%config%}"
    '<script src="/_vid/plotly.js"></script><script src="/_vid/vid.js"></script>{%scripts%}'
    "{%renderer%}</footer></body></html>"
)


def _defaults(ctx: cb.UIContext) -> dict[str, Any]:
    """The values the page opens with (left out of the URL's fragment)."""
    from .data import bounds_text, limits_text
    from .overview import initial_choice

    spec = ctx.spec
    fields: dict[str, Any] = {}
    for c, text in zip(spec.criteria, limits_text(spec)):
        fields[f"lim.{c.name}"] = text
        fields[f"role.{c.name}"] = c.role
    for g, (lo, hi) in zip(spec.constraints, bounds_text(spec)):
        fields[f"low.{g.name}"] = lo
        fields[f"high.{g.name}"] = hi
    x0, y0 = explore.default_axes(ctx)
    view = sets.default_view(ctx)
    fields.update(
        tab="tables",
        x=x0,
        y=y0,
        panel="histograms",
        crit=spec.criterion_names[0],
        trial=str(initial_choice(ctx) or ""),
        axes=",".join(view["order"]),
        hide=",".join(sets.default_hidden(ctx)),
    )
    return {"fields": fields, "view": view}


def _layout(ctx: cb.UIContext) -> Any:
    from dash import dcc, html

    ctx.cache.state()  # built at every page load: start from the limits saved in the store
    defaults = _defaults(ctx)
    return html.Div(
        [
            dcc.Location(id="url", refresh=False),
            dcc.Store(id="vid-defaults", data=defaults),
            dcc.Store(id="vid-url", data=None),
            dcc.Store(id="par-view", data=defaults["view"]),
            explore.header(ctx),
            html.Div(
                className="page",
                children=[
                    # polls the job once a second while one runs, and never otherwise
                    dcc.Interval(id="tick", interval=1000, disabled=not ctx.jobs.status().running),
                    dcc.Store(id="version", data=list(ctx.cache.version())),
                    dcc.Store(id="selection", data=None),
                    dcc.Store(id="job-note", data=None),
                    *[dcc.Store(id=f"vid-con-{t}", data=None) for t in GATED],
                    dcc.Tabs(
                        id="tabs",
                        value="tables",
                        children=[
                            dcc.Tab(
                                label="Test tables & plots",
                                value="tables",
                                children=explore.layout(ctx),
                            ),
                            dcc.Tab(
                                label="Parallel coordinates & history",
                                value="parallel",
                                children=sets.parallel_layout(ctx),
                            ),
                            dcc.Tab(
                                label="Trial table", value="table", children=sets.table_layout(ctx)
                            ),
                            dcc.Tab(
                                label="Chosen trial",
                                value="trial",
                                children=detail.trial_layout(ctx),
                            ),
                            dcc.Tab(
                                label="Refine & continue",
                                value="refine",
                                children=detail.refine_layout(ctx),
                            ),
                            dcc.Tab(
                                label="Study overview",
                                value="overview",
                                children=detail.overview_layout(ctx),
                            ),
                            *(
                                [
                                    dcc.Tab(
                                        label="Compare two models",
                                        value="compare",
                                        children=compare_page.compare_layout(ctx),
                                    )
                                ]
                                if "compare" in ctx.extra
                                else []
                            ),
                        ],
                    ),
                ],
            ),
        ]
    )


def create_app(
    store: str | Path,
    *,
    executor: str | None = None,
    workers: int | None = None,
    max_points: int = 20_000,
    compare: str | Path | None = None,
) -> tuple[Any, cb.UIContext]:
    """Build the Dash app serving one study store.

    Parameters
    ----------
    store : path
        The study store (``.db``); read-only in this process.
    executor, workers
        For background run jobs (see :func:`vectorid.run.run_store`).
    max_points : int
        Points drawn per set in the criterion-vs-criterion plot.
    compare : path, optional
        A second store: a *Compare two models* tab shows both side by side
        (:mod:`vectorid.views.ui.compare`; the spectral peaks are computed in a thread).

    Returns
    -------
    app : dash.Dash
    ctx : UIContext
        The state shared by the callbacks (its ``jobs`` must be shut down on exit).
    """
    try:
        import dash
        import flask
    except ModuleNotFoundError as exc:  # pragma: no cover - exercised without dash only
        raise ImportError(
            "vectorid ui needs dash: pip install 'vectorid[ui]' (or pip install dash)"
        ) from exc

    # the Pareto scans on numpy: numba and its compiled kernels would add ~120 MB of code
    # to the server (the job worker, a process of its own, still runs the models compiled)
    pareto.prefer_numpy()
    cache = StoreCache(store)
    jobs = JobManager(
        cache.path,
        executor=executor,
        workers=workers,
        progress_of=lambda: cache.version()[0],
    )
    ctx = cb.UIContext(cache=cache, jobs=jobs, max_points=max_points)
    if compare is not None:
        from .compare import start_compare

        start_compare(ctx, compare)
    _warm(ctx)  # load, compile (numba) and keep what the first page needs
    jobs.warm()  # the job worker imports vectorid while the page loads

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
    releaser = FreedMemoryReleaser()

    @server.teardown_request
    def _release(_exc: Any = None) -> None:  # freed temporaries back after a burst
        releaser.poke()

    _compress(server)

    bundle = PLOTLY_BUNDLE.read_bytes()

    @server.route("/_vid/plotly.js")
    def plotly_bundle():  # the partial plotly.js bundle, cached by the browser (gzip: 0.5 MB)
        resp = flask.Response(bundle, mimetype="text/javascript")
        resp.headers["Cache-Control"] = "public, max-age=86400"
        return resp

    @server.route("/_vid/vid.js")
    def vid_js():  # the page's counting library (vectorid.views.ui.client)
        return flask.Response(client.VID_JS, mimetype="text/javascript")

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
        compress=False,
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
    w = Wiring(ctx.spec.criterion_names, ctx.spec.constraint_names)
    _register_url(app, ctx, w)
    tokens = sets.csv_route(server, ctx)
    explore.register(app, ctx, w, tokens)
    sets.register(app, ctx, w, tokens)
    detail.register(app, ctx, w)
    if "compare" in ctx.extra:
        compare_page.register(app, ctx)
    _register_jobs(app, ctx, w)
    return app, ctx


def _warm(ctx: cb.UIContext) -> None:
    """Before the first request: the store loaded and analysed (numba compiled), each
    trial's histogram bin and the default criterion plot's density cells kept (see
    :func:`~vectorid.views.ui.explore.fast_histograms`, :func:`~vectorid.views.clouds.
    cloud_traces`), so that the first page and the first typed limit count only D."""
    from .. import clouds
    from .explore import DENSITY_POINTS, histograms_of, trials_memo

    a = ctx.cache.analysis()
    if a.n:
        histograms_of(ctx, a)
        x, y = explore.default_axes(ctx)
        clouds.scatter_figure(
            a,
            x,
            y,
            max_points=ctx.max_points,
            raw=True,
            memo=trials_memo(ctx, a, "scatter"),
            density_above=DENSITY_POINTS,
        )


#: The fields of the view's state besides the constraints, in the order of the URL callbacks.
_VIEW_FIELDS = (
    ("tabs", "value"),
    ("x-axis", "value"),
    ("y-axis", "value"),
    ("panel", "value"),
    ("cvp-crit", "value"),
    ("trial-id", "value"),
    ("selection", "data"),
    ("par-view", "data"),
    ("par-colour", "value"),
    ("par-shown", "value"),
)


#: Content types sent gzip-compressed to a browser that accepts it.
_COMPRESSIBLE = (
    "application/json",
    "text/javascript",
    "application/javascript",
    "text/css",
    "text/html",
)


def _compress(server: Any) -> None:
    """gzip every text response over 1 kB (callback answers, the page, the scripts) for a
    browser that accepts it; the static scripts are compressed once and kept. A streamed
    response (the CSV download) is sent as it is."""
    import gzip

    import flask

    kept: dict[str, bytes] = {}
    static = ("/_dash-component-suites/", "/_vid/plotly.js", "/_vid/vid.js")

    @server.after_request
    def gzip_response(resp: Any) -> Any:
        if (
            resp.status_code != 200
            or resp.direct_passthrough
            or resp.is_streamed
            or "gzip" not in flask.request.headers.get("Accept-Encoding", "")
            or "Content-Encoding" in resp.headers
            or not (resp.mimetype or "").startswith(_COMPRESSIBLE)
        ):
            return resp
        path = flask.request.path
        body = kept.get(path) if path.startswith(static) else None
        if body is None:
            raw = resp.get_data()
            if len(raw) < 1024:
                return resp
            body = gzip.compress(raw, compresslevel=1 if path.startswith("/_dash-update") else 6)
            if path.startswith(static):
                kept[path] = body
        resp.set_data(body)
        resp.headers["Content-Encoding"] = "gzip"
        resp.headers["Content-Length"] = str(len(body))
        resp.vary.add("Accept-Encoding")
        return resp


def _register_url(app: Any, ctx: cb.UIContext, w: Wiring) -> None:
    """The whole view in the URL's fragment (:mod:`vectorid.views.ui.client`): read once at
    page load into the fields, written back on every change (``history.replaceState``)."""
    import json

    from dash import Input, Output, State

    spec = ctx.spec
    names = {
        "crit": json.dumps(w.crit),
        "cons": json.dumps(w.cons),
        "axes": json.dumps(spec.criterion_names + spec.constraint_names + spec.space.names),
    }
    outs = [Output(i, "value") for i in w.ids("limit") + w.ids("role") + w.ids("low")]
    outs += [Output(i, "value") for i in w.ids("high")]
    outs += [
        Output(i, p, allow_duplicate=(i in ("trial-id", "selection", "par-view")))
        for i, p in _VIEW_FIELDS
    ]
    app.clientside_callback(
        client.READ_URL_JS % names,
        outs,
        Input("url", "hash"),
        State("vid-defaults", "data"),
        prevent_initial_call="initial_duplicate",
    )
    app.clientside_callback(
        client.WRITE_URL_JS % names,
        Output("vid-url", "data"),
        *w.constraint_inputs(Input),
        *[Input(i, p) for i, p in _VIEW_FIELDS],
        State("vid-defaults", "data"),
        prevent_initial_call=True,
    )


def _register_jobs(app: Any, ctx: cb.UIContext, w: Wiring) -> None:
    from dash import Input, Output, State, no_update
    from dash import ctx as dctx
    from dash.exceptions import PreventUpdate

    CON_S = w.constraint_inputs(State)

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
        *CON_S,
        prevent_initial_call=True,
    )
    def job(*values):
        (*_clicks, tid, sp, spts, slo, shi, rr, rpts, basis, q, mg, rows, n) = values[:18]
        texts, roles, pairs = w.split(list(values[18:]))
        bounds = {"limit_texts": texts, "roles": roles, "functional": pairs}
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
            note = {"text": err(exc), "busy": None}
        # a fresh dict every time, so that the same message twice still updates the page
        return dict(note, at=sum(int(c) for c in _clicks if isinstance(c, int)))

    @app.callback(
        Output("job-progress", "value"),
        Output("job-text", "children"),
        Output("version", "data"),
        Output("job-msg", "children"),
        Output("tick", "disabled"),
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
            return no_update, err(exc), no_update, no_update, no_update
        prog = st["progress"]
        value = str(prog) if prog is not None else (None if st["state"] == "running" else "0")
        return (
            value,
            st["text"],
            (now if now != version else no_update),
            (msg if msg != (shown or "") else no_update),
            st["state"] != "running",
        )
