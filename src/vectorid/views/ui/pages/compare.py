"""The *Compare* tab (``vectorid ui A.db B.db``): two models side by side on the same data."""

from __future__ import annotations

from typing import Any

from ..compare import compare_view
from ..context import UIContext
from .common import err

__all__ = ["compare_layout", "register"]


def _table(id_: str, head: list[str], rows: list[list[str]]) -> Any:
    from dash import html

    return html.Div(
        html.Table(
            [
                html.Thead(html.Tr([html.Th(h) for h in head])),
                html.Tbody([html.Tr([html.Td(x) for x in r]) for r in rows]),
            ],
            id=id_,
        ),
        className="scroll",
    )


def compare_body(v: dict[str, Any]) -> list[Any]:
    """The tab's tables from :func:`~vectorid.views.ui.compare.compare_view`."""
    from dash import html

    out: list[Any] = [
        html.P(
            [html.B("Data: "), v["drop"]],
            id="cmp-drop",
            className="note" if v["same_drop"] else "msg",
        ),
        html.P(
            f"Compared: {', '.join(v['criteria'])}"
            + (f"; only in {v['a']}: {', '.join(v['only']['a'])}" if v["only"]["a"] else "")
            + (f"; only in {v['b']}: {', '.join(v['only']['b'])}" if v["only"]["b"] else "")
            + ". Common limits: each criterion's stated limit (this study's; where a stage "
            "relaxed it as the last resort, the stated one it started from), the same for both.",
            className="muted",
        ),
        _table("cmp-counts", v["heads"]["counts"], v["rows"]["counts"]),
        html.H3(
            "Per criterion: best value, whether it meets the common limit, and how many "
            "successful trials do"
        ),
        _table("cmp-criteria", v["heads"]["criteria"], v["rows"]["criteria"]),
    ]
    if v["rows"]["peaks"]:
        out += [
            html.H3("Spectral peaks (frequency / prominence)"),
            _table("cmp-peaks", v["heads"]["peaks"], v["rows"]["peaks"]),
            html.P(v["note"], id="cmp-note", className="muted"),
        ]
    return out


def compare_layout(ctx: UIContext) -> Any:
    from dash import dcc, html

    v = compare_view(ctx)
    return html.Div(
        [
            html.P(
                f"{v['a']} (this study) and {v['b']} side by side: the same criteria on the "
                "same data, N / ND / NP, which limits each model can meet, its best values "
                "and, for spectral criteria, the peaks its suggested vector flies.",
                className="muted",
            ),
            html.Div(compare_body(v), id="cmp-body"),
            dcc.Graph(id="cmp-graph", figure=v["figure"], config={"displaylogo": False}),
            dcc.Interval(id="cmp-tick", interval=1500, disabled=not v["pending"]),
        ]
    )


def register(app: Any, ctx: UIContext) -> None:
    from dash import Input, Output
    from dash.exceptions import PreventUpdate

    @app.callback(
        Output("cmp-body", "children"),
        Output("cmp-tick", "disabled"),
        Input("cmp-tick", "n_intervals"),
        prevent_initial_call=True,
    )
    def peaks(_n):
        """Polls while the spectral peaks are computed, then shows them and stops."""
        try:
            v = compare_view(ctx)
        except Exception as exc:
            return err(exc), True
        if v["pending"]:
            raise PreventUpdate
        return compare_body(v), True
