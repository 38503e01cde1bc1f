"""The self-contained HTML report of a study (``vectorid report STORE --out report.html``).

One file that opens offline: Plotly's JavaScript is embedded once, every figure is a JSON
document in the page, and every figure is drawn when the page loads (so printing or saving
as PDF shows them all; printing waits for any still being drawn). Point clouds are drawn in
SVG, not WebGL: each set thinned to ``max_points`` (a uniform subset per set, named in the
legend) and the infeasible bulk as a density, so only the scatter matrix, the parallel
coordinates and the 3-D trajectories use WebGL contexts, well under the browser's limit.
Histograms, heatmaps and tables are aggregated, so their size does not grow with N; wide
tables scroll sideways in their container.

Contents: study definition, stages and refine history, N/ND/NP and the constraints in
force, test tables (top rows), the Pareto set, the chosen vector(s) with the best trial per
criterion (seed 001 Table 4 layout), criterion vs criterion pairs and matrix, criterion vs
parameter, parallel coordinates, the history of N/ND/NP against the number of trials,
histograms per set (and by stage after double tuning), the double-tuning proposal with the
ranges per parameter, correlation and spread, sensitivity, and every stored section and
robustness check. A study
with an ``[identification]`` table also gets an "Identification" section: trajectories of the
flight and of the best trial per criterion (seed 000 Fig. 11), the 3-D projection with the
worst and best trial (seed 001 Fig. 7), channel time histories with envelopes and power
spectra of the Euler angles (numbers from :mod:`vectorid.views.trial_runs`); when the
flight data cannot be loaded from the store's location the section says so instead.
"""

from __future__ import annotations

import html
import math
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..analysis.choice import best_per_criterion, suggest_choice
from ..analysis.correlation import correlation_of, parameter_spread
from ..analysis.histograms import histograms, stage_histograms
from ..analysis.refine import propose_refine, refine_history
from ..analysis.results import Analysis, Bound
from ..analysis.robustness import chosen_table, load_robustness
from ..analysis.sections import load_sections
from ..analysis.sensitivity import sensitivity
from ..errors import VectoridError
from ..samplers.sequential import assess, generations, sample_note
from ..samplers.sequential.schedule import ESS_SHARE
from ..store import Store
from . import figures as fg
from .clouds import PROPOSED_COLOUR
from .history import history
from .labels import labels_of

__all__ = ["ReportResult", "build_report", "write_report"]

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0 auto;max-width:1240px;
padding:0 18px 60px;color:#222}
h1{margin-top:24px}h2{border-bottom:2px solid #ddd;padding-bottom:4px;margin-top:36px}
table{border-collapse:collapse;font-size:13px;margin:8px 0}
td,th{border:1px solid #ddd;padding:3px 7px;text-align:right}th{background:#f4f4f4}
td.l,th.l{text-align:left}.muted{color:#777}.x{color:#d62728}.p{color:#2ca02c;font-weight:600}
.fig{min-height:320px;margin:14px 0;border:1px solid #eee;break-inside:avoid}
.scroll{overflow-x:auto;max-width:100%}
img.raster{display:none}
@page{size:A4;margin:12mm}
@media print{nav{display:none}.fig{border:none}h2{break-after:avoid}
body{max-width:none;padding:0}.modebar-container{display:none!important}
.fig.rastered{display:none!important}
img.raster{display:block;width:100%;max-width:186mm;break-inside:avoid;margin:6px 0}
.scroll{overflow:visible}table{font-size:10px}}
.counts{font-size:18px}.counts b{font-size:22px}.note{color:#555;font-size:13px;
border-left:3px solid #d9a400;padding-left:6px}
nav a{margin-right:10px}
"""

_LOADER = """
(function(){
  var gl = (function(){try{var c=document.createElement('canvas');
    return !!(c.getContext('webgl')||c.getContext('experimental-webgl'));}
    catch(e){return false;}})();
  var divs = Array.prototype.slice.call(document.querySelectorAll('div.fig'));
  function plot(div){
    if(div.dataset.state==='plotted') return;
    var fig = JSON.parse(document.getElementById(div.id+'-json').textContent);
    if(!gl && fig.data.some(function(t){
        return t.type==='splom'||t.type==='scatter3d'||t.type==='parcoords';})){
      div.innerHTML='<p class="note">This figure needs WebGL, which this browser lacks.</p>';
      div.dataset.state='plotted'; return;}
    Plotly.newPlot(div, fig.data, fig.layout, {responsive:true, displaylogo:false});
    div.dataset.state='plotted';
    raster(div);
  }
  // for print: each figure as a picture the width of an A4 page (720 CSS px, drawn at
  // twice that), so that point clouds print as pixels, not as tens of thousands of vector
  // marks, and no figure runs over the page's edge; the screen keeps the live figure
  var pending = 0;
  function ready(){ if(!pending && next >= divs.length) window.vectoridPrintReady = true; }
  function raster(div){
    if(!window.Plotly || !Plotly.toImage || !div.clientWidth) return;
    var w = 720, h = Math.min(980, Math.round(div.clientHeight * w / div.clientWidth));
    pending++;
    Plotly.toImage(div, {format:'png', width:w, height:h, scale:2}).then(function(url){
      var img = document.createElement('img');
      img.className = 'raster'; img.src = url; img.alt = div.id;
      div.parentNode.insertBefore(img, div.nextSibling);
      div.classList.add('rastered');
    }).catch(function(){}).then(function(){ pending--; ready(); });
  }
  // every figure, one per task, from the top: the page stays responsive while they draw
  var next = 0;
  function step(){
    if(next < divs.length){ plot(divs[next++]); setTimeout(step, 0); } else { ready(); }
  }
  window.vectoridPlotAll = function(){ divs.forEach(plot); };
  window.addEventListener('beforeprint', window.vectoridPlotAll);
  if(document.readyState === 'loading'){ document.addEventListener('DOMContentLoaded', step); }
  else { step(); }
})();
"""


@dataclass
class ReportResult:
    """What :func:`write_report` wrote.

    Attributes
    ----------
    path : Path
    size : int
        Bytes.
    figures : list of str
        Titles of the embedded figures.
    notes : list of str
        Decimation and omission notes (also printed in the report).
    seconds : float
        Time to build and write.
    """

    path: Path
    size: int
    figures: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0


def _e(x: Any) -> str:
    return html.escape(str(x))


def _f(v: Any) -> str:
    try:
        v = float(v)
    except (TypeError, ValueError):
        return _e(v)
    if math.isnan(v):
        return "nan"
    return f"{v:.5g}"


def _table(head: Sequence[str], rows: Iterable[Sequence[Any]], left: int = 1) -> str:
    out = ['<div class="scroll"><table><tr>']
    out += [f'<th class="{"l" if i < left else ""}">{_e(h)}</th>' for i, h in enumerate(head)]
    out.append("</tr>")
    for r in rows:
        out.append("<tr>")
        for i, c in enumerate(r):
            cls = ' class="l"' if i < left else ""
            out.append(f"<td{cls}>{c}</td>")
        out.append("</tr>")
    out.append("</table></div>")
    return "".join(out)


class _Page:
    def __init__(self) -> None:
        self.parts: list[str] = []
        self.figures: list[str] = []
        self.notes: list[str] = []
        self.toc: list[tuple[str, str]] = []

    def h2(self, title: str) -> None:
        anchor = f"s{len(self.toc)}"
        self.toc.append((anchor, title))
        self.parts.append(f'<h2 id="{anchor}">{_e(title)}</h2>')

    def add(self, text: str) -> None:
        self.parts.append(text)

    def fig(self, figure: Any, caption: str = "") -> None:
        i = len(self.figures)
        title = figure.layout.title.text or f"figure {i + 1}"
        self.figures.append(title)
        thinned = [
            tr.name
            for tr in figure.data
            if tr.name and (" drawn, " in tr.name or "as a density" in tr.name)
        ]
        if thinned:
            self.notes.append(f"{title}: thinned for display: " + "; ".join(dict.fromkeys(thinned)))
        payload = figure.to_json().replace("</", "<\\/")
        height = int(figure.layout.height or 450)
        self.parts.append(
            f'<div class="fig" id="fig{i}" style="min-height:{height}px"></div>'
            f'<script type="application/json" id="fig{i}-json">{payload}</script>'
        )
        if caption:
            self.parts.append(f'<p class="muted">{_e(caption)}</p>')


def _definition(page: _Page, a: Analysis, store: Store) -> None:
    spec = a.spec
    page.h2("Study definition")
    d = spec.to_dict()["study"]
    page.add(
        _table(
            ["key", "value"],
            [[_e(k), _e(v)] for k, v in d.items()] + [["store", _e(store.path)]],
            left=2,
        )
    )
    page.add("<h3>Variables (box Π)</h3>")
    page.add(
        _table(
            ["name", "kind", "low", "high", "nominal", "unit"],
            [
                [
                    _e(v.name),
                    v.kind,
                    _f(v.low),
                    _f(v.high),
                    "" if v.nominal is None else _f(v.nominal),
                    _e(v.unit),
                ]
                for v in spec.space
            ],
            left=2,
        )
    )
    page.add("<h3>Criteria</h3>")
    page.add(
        _table(
            ["name", "sense", "role", "limit in force", "unit", "limit's source"],
            [
                [
                    _e(c.name),
                    a.senses[j],
                    a.roles[j],
                    _f(a.bounds[c.name][1] if a.senses[j] == "min" else a.bounds[c.name][0]),
                    _e(c.unit),
                    _e(c.source + (f": {c.limit_note}" if c.limit_note else "")),
                ]
                for j, c in enumerate(spec.criteria)
            ],
            left=3,
        )
    )
    if spec.constraints:
        page.add("<h3>Functional constraints</h3>")
        page.add(
            _table(
                ["name", "low", "high"],
                [
                    [_e(c.name), _f(a.bounds[c.name][0]), _f(a.bounds[c.name][1])]
                    for c in spec.constraints
                ],
            )
        )


def _counts(page: _Page, a: Analysis) -> None:
    page.h2("Trials, feasible set and Pareto set")
    page.add(
        f'<p class="counts">N = <b>{a.n}</b> &nbsp; ND = <b>{a.n_feasible}</b> &nbsp; '
        f"NP = <b>{a.n_pareto}</b> &nbsp; <span class=muted>(failed {a.n_failed}, meeting the "
        f"functional constraints {a.n_functional})</span></p>"
    )
    bounds = [str(b) for b in a.active_bounds()]
    page.add("<p>Constraints in force: " + (_e(", ".join(bounds)) or "none") + "</p>")
    pure = [a.crit_names[i] for i in a.pure]
    page.add(f"<p>Pareto set over the pure criteria: {_e(', '.join(pure) or '(none)')}</p>")
    if a.n_feasible == 0:
        page.add("<pre>" + _e(a.diagnose_empty().describe()) + "</pre>")


def _sequential(page: _Page, a: Analysis, store: Store) -> None:
    """A sequential store: the sampler, its generations, D's members and ESS under the
    constraints in force, and what the weights apply to."""
    gens = generations(store)
    if not gens:
        return
    spec = store.spec
    limits = {n: a.limits.worse_side(n) for n in a.crit_names}
    state = assess(store, a.trials, limits)
    members = int(state.members.sum())
    wanted = spec.sequential_population
    reached = members >= wanted and state.ess >= ESS_SHARE * wanted
    page.h2("Sampler: sequential")
    page.add(
        f'<p class="sampler">sampler <b>sequential</b>: {sum(state.counts):,} evaluations '
        f"(budget {spec.sequential_budget:,}) in <b>{len(gens)}</b> generations; D at the "
        f"constraints in force holds <b>{members}</b> members, effective sample size "
        f"<b>ESS {state.ess:.0f}</b> (wanted {wanted} members, ESS ≥ "
        f"{ESS_SHARE * wanted:.0f}): "
        + ("<b>D reached</b>" if reached else "<b class=x>D not reached</b>")
        + "</p>"
    )
    note = sample_note(store, a.limits, a.trials)
    if note:
        page.add(f"<p class=note>{_e(note)}</p>")
    moved = a.weighting is not None and a.weighting.kind == "holding"
    page.add(
        "<p>The particles moved by Markov-chain steps inside the limits, so the trials are "
        "not uniform in the box. Densities and statistics of D in this report are "
        "<b>weighted by the particles' holding times</b>: each member of D counts the moves "
        "at the stated limits (after the warm-up) that ended with a particle on it, which "
        "makes D's members a Markov-chain sample of the box's uniform density restricted to D "
        "(correlated, and of the parts of D the particles reached); members never held weigh "
        "0. Counts (N, ND, NP), test tables, the Pareto set and feasible "
        "ranges are counts and extremes of trials, which weights do not change.</p>"
        if moved
        else "<p>Later generations are drawn around the accepted trials, so the trials are not "
        "uniform in the box. Densities and statistics of D in this report (histograms, "
        "correlation, quantiles of the double-tuning proposal, sensitivity) are "
        "<b>importance-weighted</b>: each trial's weight makes D a uniform sample of the box "
        "restricted to it, as a plain Sobol table with unboundedly many trials would give. "
        "Counts (N, ND, NP), test tables, the Pareto set and feasible ranges are counts and "
        "extremes of trials, which weights do not change.</p>"
    )
    rows = []
    for g, n in zip(gens, state.counts):
        sel = state.generation == g.gen
        tol = g.proposal.get("tolerance") or {}
        shown = ", ".join(f"{k} {_f(v)}" for k, v in tol.items() if v is not None)
        rows.append(
            [
                str(g.gen),
                "Sobol" if g.proposal.get("kind") == "sobol" else "kernel",
                f"{n:,}",
                f"{g.seq_start + 1}..{g.seq_start + g.n}",
                str(int(np.sum(state.members & sel))),
                _e(shown or "the stated limits" if g.gen else "-"),
            ]
        )
    page.add(
        _table(
            ["generation", "proposal", "trials", "trial ids", "in D", "limits aimed at"],
            rows,
            left=0,
        )
    )
    for st in store.stages():
        if st.kind == "search":
            page.add(f"<p>Local search: stage {st.stage}, {_e(st.note)}.</p>")


def _test_tables(page: _Page, a: Analysis, top: int) -> None:
    page.h2(f"Test tables (top {top} rows per criterion)")
    tables = a.test_tables()
    head = []
    for t in tables:
        head += [f"{t.name} ({t.sense}) id", "value"]
    page.add(
        "<p class=muted>Each criterion's trials meeting the functional constraints, best first "
        "(seed 000 Fig. 6); <span class=x>red</span>: outside D.</p>"
    )
    rows: list[list[str]] = [[], [], []]
    for t in tables:
        rows[0] += [f"min {_f(t.min)}", ""]
        rows[1] += [f"max {_f(t.max)}", ""]
        rows[2] += [f"limit {'-' if t.limit is None else _f(t.limit)}", ""]
    for i in range(top):
        r = []
        for t in tables:
            if i < len(t.ids):
                cls = "" if t.feasible[i] else ' class="x"'
                r += [f"<span{cls}>{t.ids[i]}</span>", f"<span{cls}>{_f(t.values[i])}</span>"]
            else:
                r += ["", ""]
        rows.append(r)
    page.add(_table(head, rows, left=0))


def _pareto_table(page: _Page, a: Analysis, limit: int = 100) -> None:
    page.h2("Edgeworth–Pareto set")
    rows = np.flatnonzero(a.pareto)
    if len(rows) == 0:
        page.add("<p>The Pareto set is empty under these constraints.</p>")
        return
    if a.pure:
        j = a.pure[0]
        key = a.trials.F[rows, j] * (-1 if a.senses[j] == "max" else 1)
        rows = rows[np.argsort(key, kind="stable")]
    shown = rows[:limit]
    if len(rows) > limit:
        page.add(
            f"<p class=note>showing {limit} of {len(rows)} Pareto trials, best first by "
            f"{_e(a.crit_names[a.pure[0]])}; `vectorid pareto --json` lists all</p>"
        )
    names = a.spec.space.names
    page.add(
        _table(
            ["id", *a.crit_names, *names],
            [
                [str(a.trials.id[i])]
                + [_f(v) for v in a.trials.F[i]]
                + [_f(v) for v in a.trials.X[i]]
                for i in shown
            ],
        )
    )


def _chosen(
    page: _Page, a: Analysis, chosen: Sequence[int], verdicts: Sequence[Any] = ()
) -> list[int]:
    page.h2("Chosen vector")
    best = best_per_criterion(a)
    ids: list[int] = []
    labels: list[str] = []
    if chosen:
        for i in chosen:
            ids.append(int(i))
            labels.append(f"chosen {i}")
    else:
        s = suggest_choice(a)
        if s is not None:
            ids.append(s)
            labels.append(f"suggested {s}")
            page.add(
                f"<p>No vector was named (<code>--chosen ID</code>); trial <b>{s}</b> is "
                "suggested: the Pareto trial closest to the ideal point of the pure criteria, "
                "each normalised over the Pareto set.</p>"
            )
    for name, i in best.items():
        if i not in ids:
            ids.append(i)
            labels.append(f"best {name}")
    if not ids:
        page.add("<p>No feasible trial to choose from.</p>")
        return []
    tab = chosen_table(a, ids)
    page.add(
        "<p class=muted>Criteria of the chosen vector and of the best trial per criterion, with "
        "the minimum and maximum over them (seed 001 Table 4).</p>"
    )
    rows = [["MIN", "", *[_f(v) for v in tab.min]], ["MAX", "", *[_f(v) for v in tab.max]]]
    rows += [[f"№{i}", _e(lab), *[_f(v) for v in f]] for i, lab, f in zip(tab.ids, labels, tab.F)]
    page.add(_table(["trial", "why", *tab.crit_names], rows, left=2))
    page.add("<h3>Parameters</h3>")
    names = a.spec.space.names
    ver = {v.name: v for v in verdicts}  # a variable the data do not identify has no value

    def cell(n: str, x: float) -> str:
        v = ver.get(n)
        return _f(x) if v is None or v.identified else _e(v.value_text())

    page.add(
        _table(
            ["parameter", *[f"№{i}" for i in tab.ids]],
            [[_e(n), *[cell(n, x) for x in tab.X[:, j]]] for j, n in enumerate(names)],
        )
    )
    space = a.spec.space
    spread = parameter_spread(
        tab.X,
        names,
        space.nominal,
        space.lows,
        space.highs,
        labels=[f"№{i} {lab}" for i, lab in zip(tab.ids, labels)],
    )
    page.fig(fg.spread_figure(spread, verdicts=verdicts), "seed 000 Fig. 13")
    return ids


def _own_model_records(page: _Page, a: Analysis, ident: Any, chosen: Sequence[int]) -> None:
    """Each record of an own model's identification against the best trial per criterion
    (and the chosen one): one panel per measured output channel."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    ok = np.flatnonzero(a.ok)
    picks: dict[str, int] = {}
    for j, c in enumerate(a.criteria):
        if len(ok):
            picks[f"best {c.name}"] = int(ok[np.argmin(a.trials.F[ok, j])])
    for i in chosen[:1]:
        hit = np.flatnonzero(a.trials.id == int(i))
        if hit.size:
            picks[f"chosen №{int(i)}"] = int(hit[0])
    page.add(
        f"<p>Model <code>{_e(ident.model.name)}</code> simulated over each record's window "
        f"from its stated initial state, on the comparison grid (step {_f(ident.output_dt)} "
        "s): the measurement and the best trial per criterion.</p>"
    )
    if not picks:
        page.add("<p class=note>No successful trial to show.</p>")
        return
    rows = list(picks.values())
    X = a.trials.X[rows]
    for rec in ident.records:
        res = ident.simulate(X, rec)
        chans = [c for c in ident.model.output_names if c in rec.values]
        fig = make_subplots(rows=len(chans), cols=1, shared_xaxes=True)
        for r, ch in enumerate(chans, start=1):
            unit = ident.model.unit_of(ch)
            fig.add_trace(
                go.Scatter(x=rec.t, y=rec.values[ch], mode="markers", name=f"{ch} measured",
                           marker={"size": 4, "color": "#222"}),
                row=r, col=1,
            )  # fmt: skip
            for k, (label, i) in enumerate(picks.items()):
                fig.add_trace(
                    go.Scatter(x=rec.grid, y=res[ch][k], mode="lines",
                               name=f"{ch} {label} (№{int(a.trials.id[i])})"),
                    row=r, col=1,
                )  # fmt: skip
            fig.update_yaxes(title_text=f"{ch} [{unit}]", row=r, col=1)
        fig.update_xaxes(title_text="t [s]", row=len(chans), col=1)
        fig.update_layout(
            title=f"Record {rec.name}: measured and simulated", height=300 * len(chans)
        )
        page.fig(fig, "the record's samples and the model on the comparison grid")


def _identification(page: _Page, a: Analysis, chosen: Sequence[int], max_envelope: int) -> None:
    """The "Identification" section: trajectories, channels and spectra against the flight
    (seed 000 Fig. 11, seed 001 Figs. 2, 7, 9); numbers from
    :mod:`vectorid.views.trial_runs`."""
    spec = a.spec
    if "identification" not in spec.extra:
        return
    page.h2("Identification")
    try:
        from ..identify import Identification
        from . import trial_runs as vd

        ident = Identification.from_spec(spec)
    except (VectoridError, OSError) as exc:
        page.add(
            "<p class=note>The flight data of this study could not be loaded, so the "
            f"trajectories, channels and spectra are not shown: {_e(exc)}. Data paths are "
            f"relative to the study folder ({_e(spec.base_dir or 'unknown')}; when that folder "
            "is gone, the store's folder): keep the data files there, or write the report "
            "where they are reachable.</p>"
        )
        return
    from ..identify.system import SystemIdentification

    if isinstance(ident, SystemIdentification):  # a model of your own: its records
        _own_model_records(page, a, ident, chosen)
        return
    picks = vd.pick_trials(a, chosen, max_envelope=max_envelope)
    ids = picks.ids()
    rows = vd.rows_of(a, ids)
    X = np.vstack([a.trials.X[rows], vd.nominal_vector(spec, ident)[None, :]])
    labels = [f"№{i}" for i in ids] + ["nominal"]
    at = {i: k for k, i in enumerate(ids)}
    nom = len(ids)
    best_of: dict[int, list[str]] = {}
    for name, i in picks.best.items():
        best_of.setdefault(i, []).append(name)
    chosen_word = "chosen" if chosen else "suggested"
    page.add(
        f"<p>Model <code>{_e(ident.model.name)}</code> simulated over each drop's window from "
        "the measured initial state, in the drop's measured wind, on the comparison grid "
        f"(step {_f(ident.output_dt)} s). Shown: the flight; the best trial per pure criterion "
        f"and the nominal vector; the {chosen_word} vector"
        + (f" №{picks.chosen}" if picks.chosen is not None else "")
        + (f" and the worst trial №{picks.worst}" if picks.worst is not None else "")
        + f"; the envelope over {len(picks.envelope)} trials of the {picks.envelope_set} set"
        + " (nominal: the study's nominal values, else the model's).</p>"
    )
    if ident.wind_realisations > 1:
        page.add(
            f"<p class=note>The criteria are means over {ident.wind_realisations} wind "
            "realisations; the curves here use the measured wind only.</p>"
        )
    for d in ident.drops:
        runs = vd.simulate_trials(ident, X, d, labels=labels)
        if len(ident.drops) > 1:
            page.add(f"<h3>Drop {_e(d.name)}</h3>")
        failed = [labels[k] for k in np.flatnonzero(~runs.ok)]
        if failed:
            page.add(
                f"<p class=note>Simulation failed on drop {_e(d.name)} for "
                f"{_e(', '.join(failed))}; those trials are left out.</p>"
            )
        flight, model = runs.trajectories()
        traj = {}
        for i, names in best_of.items():
            if runs.ok[at[i]]:
                traj[f"best {', '.join(names)} (№{i})"] = model[at[i]]
        if runs.ok[nom]:
            traj["nominal"] = model[nom]
        page.fig(
            fg.trajectory_figure(
                flight, traj, title=f"Trajectories on drop {d.name}: flight, best per criterion"
            ),
            "seed 000 Fig. 11: the flight and the best trial per pure criterion, and the "
            "nominal vector",
        )
        traj3 = {}
        if picks.worst is not None and runs.ok[at[picks.worst]]:
            traj3[f"worst (№{picks.worst})"] = model[at[picks.worst]]
        if picks.chosen is not None and runs.ok[at[picks.chosen]]:
            traj3[f"best: {chosen_word} (№{picks.chosen})"] = model[at[picks.chosen]]
        page.fig(
            fg.trajectory3d_figure(
                flight, traj3, title=f"3-D trajectories on drop {d.name}: flight, worst, best"
            ),
            "seed 001 Fig. 7; worst: the largest sum of the pure criteria, each normalised "
            "over the successful trials",
        )
        env_rows = [at[i] for i in picks.envelope]
        if picks.chosen is not None and at[picks.chosen] not in env_rows:
            env_rows.append(at[picks.chosen])
        chans = [c for c in ("euler", "velocity") if c in runs.measured]
        chans += [c for c in runs.bands if c not in chans]
        for ch in chans:
            h = runs.channel_histories(ch, env_rows)
            hi = (
                [h.labels.index(f"№{picks.chosen}")]
                if picks.chosen is not None and f"№{picks.chosen}" in h.labels
                else []
            )
            if hi:
                h.labels[hi[0]] = f"{chosen_word} №{picks.chosen}"
            page.fig(
                fg.channels_figure(
                    h.t,
                    h.flight,
                    h.runs,
                    labels=h.labels,
                    units={c: h.unit for c in h.flight},
                    show_runs=hi,
                    bands=h.bands or None,
                    title=f"{ch} on drop {d.name}: flight, {chosen_word} vector, "
                    f"{picks.envelope_set} envelope",
                ),
                f"time from the window start; shaded: min–max over {len(h.runs)} trials"
                + (", dashed red: the drop-out envelope" if h.bands else "")
                + " (seed 001 Figs. 2, 9)",
            )
        if "euler" in runs.measured:
            sp_rows = [k for k in (at.get(picks.chosen), nom) if k is not None]
            fl, sims = runs.euler_series(sp_rows)
            sims = {
                (f"{chosen_word} {lab}" if lab == f"№{picks.chosen}" else lab): v
                for lab, v in sims.items()
            }
            page.fig(
                fg.spectra_figure(
                    runs.t, fl, sims, title=f"Power spectra of the Euler angles on drop {d.name}"
                ),
                "Welch, on the comparison grid (Nyquist "
                f"{_f(0.5 / ident.output_dt)} Hz); seed 001 Table I, criteria 13–15",
            )


def _history(page: _Page, store: Store) -> None:
    page.h2("Stages and refine history")
    hist = refine_history(store)
    rows = []
    for h in hist:
        changed = ", ".join(
            f"{c['name']}: [{_f(c['old'][0])}, {_f(c['old'][1])}] → [{_f(c['new'][0])}, "
            f"{_f(c['new'][1])}]"
            for c in h["changed"]
        )
        rows.append(
            [str(h["stage"]), str(h["start_seq"]), str(h["n"]), _e(h["note"]), _e(changed or "-")]
        )
    page.add(_table(["sample stage", "from seq", "trials", "note", "box changes"], rows, left=0))
    _inputs_history(page, store)
    aux = [s for s in store.stages() if s.kind != "sample"]
    if aux:
        page.add("<h3>Auxiliary stages (not in the sample statistics)</h3>")
        page.add(
            _table(
                ["stage", "kind", "trials", "note"],
                [[str(s.stage), s.kind, str(store.count(s.stage)), _e(s.note)] for s in aux],
                left=0,
            )
        )


def _inputs_history(page: _Page, store: Store) -> None:
    """Changes of the model code or data files taken into the store (``--accept-changes``),
    and model errors the runs recovered from (see :mod:`vectorid.store.inputs`)."""
    import time

    from ..store.inputs import history as inputs_history

    entries = inputs_history(store)
    if entries:
        page.add("<h3>Changes of the model code and data files taken into the store</h3>")
        page.add(
            _table(
                ["when", "what", "old sha256", "new sha256", "note"],
                [
                    [
                        time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(e.get("at") or 0)),
                        _e(e.get("what")),
                        _e((e.get("old") or "-")[:12]),
                        _e((e.get("new") or "-")[:12]),
                        _e(e.get("note")),
                    ]
                    for e in entries
                ],
                left=0,
            )
        )
    errors = [
        (r["run"], line)
        for r in store.runs()
        for line in ((r.get("report") or {}).get("model_errors") or [])
    ]
    if errors:
        page.add("<h3>Model errors the runs recovered from</h3>")
        page.add(_table(["run", "what happened"], [[str(n), _e(t)] for n, t in errors], left=0))


def build_report(
    store: Store,
    *,
    limits: Iterable[Bound] | Mapping[str, Any] | None = None,
    roles: Mapping[str, str] | None = None,
    chosen: Sequence[int] = (),
    max_points: int = 3_000,
    top: int = 10,
    seed: int = 0,
    max_envelope: int = 40,
    prediction: Any = None,
) -> tuple[str, _Page]:
    """The report as an HTML string (see :func:`write_report`)."""
    import plotly.offline

    spec = store.spec
    a = Analysis.of_store(store, limits, roles)
    lab = labels_of(spec)
    stages = store.stages()
    page = _Page()
    _definition(page, a, store)
    _counts(page, a)
    _sequential(page, a, store)
    _history(page, store)
    _test_tables(page, a, top)
    _pareto_table(page, a)
    from .identifiability import report_section, verdicts_for_report

    verdicts = verdicts_for_report(a, store)
    ids = _chosen(page, a, chosen, verdicts)
    page.h2("Identifiability")
    page.add(report_section(a, verdicts, ids))

    drawable = a.ok.any()
    names = list(a.crit_names)
    pure = [a.crit_names[i] for i in a.pure] or names
    if drawable and len(names) >= 2:
        page.h2("Criterion vs criterion")
        order = pure + [n for n in names if n not in pure]
        pairs = [(order[i], order[j]) for i in range(len(order)) for j in range(i + 1, len(order))]
        for x, y in pairs[:3]:
            page.fig(
                fg.scatter_figure(a, x, y, max_points=max_points, seed=seed, labels=lab, gl=False),
                "seed 001 Figs. 6, 11; seed 000 Fig. 8; infeasible trials and those of D beyond "
                "the budget as densities (every one of them), the Pareto set as open rings",
            )
        if len(names) >= 3:
            page.fig(
                fg.scatter_matrix_figure(a, max_points=max_points, seed=seed),
                "every pair of criteria",
            )
    if drawable:
        page.h2("Criterion vs parameter")
        p = len(spec.space)
        per_panel = max(200, max_points // max(p, 1))
        for name in names:
            page.fig(
                fg.criterion_vs_parameter_figure(
                    a, name, max_points=per_panel, seed=seed, labels=lab, gl=False
                ),
                "seed 000 Fig. 9",
            )
    if drawable:
        page.h2("Parallel coordinates")
        page.fig(
            fg.parallel_figure(a, lines=min(max_points, 500), seed=seed, labels=lab),
            "criteria, functionals and parameters; the constraints in force are the brushes on "
            "the criterion axes (in the browser UI, brushing an axis sets the constraint)",
        )
        page.h2("History")
        page.fig(
            fg.history_figure(history(a)),
            "ND and NP among the first n trials under the constraints in force: when NP no "
            "longer changes as N grows, more trials in this box add little",
        )
    page.h2("Histograms")
    page.fig(
        fg.histograms_figure(histograms(a), labels=lab),
        "seed 000 Fig. 7, seed 001 Figs. 5, 10; each set on its own scale (share of the set)",
    )
    sample = [s for s in stages if s.kind == "sample"]
    if len(sample) >= 2:
        hist = refine_history(store)
        changed = []
        for h in hist:
            changed += [c["name"] for c in h["changed"] if c["name"] not in changed]
        for name in changed:
            page.fig(
                fg.stage_histograms_figure(stage_histograms(a, sample, name)), "seed 001 Fig. 5"
            )
    page.h2("Double tuning proposal")
    try:
        prop = propose_refine(a, stages)
        page.add(
            "<p>Proposed (not applied) with the default rule; apply with "
            f"<code>vectorid refine {_e(store.path)} --apply</code> and continue with "
            "<code>vectorid run STORE --trials N</code>.</p>"
        )
        boxes = {
            r["name"]: [
                (r["old_low"], r["old_high"], "#7f7f7f", "current box"),
                (r["new_low"], r["new_high"], PROPOSED_COLOUR, "proposed box"),
            ]
            for r in prop.rows()
        }
        page.fig(
            fg.histograms_figure(
                histograms(a),
                labels=lab,
                boxes=boxes,
                title="Double tuning: ranges per parameter, current box (grey), proposed box "
                "(purple)",
            ),
            "each set on its own scale (share of the set); seed 001 Sec. VI",
        )
    except VectoridError as exc:
        page.add(f"<p class=note>{_e(exc)}</p>")
    page.h2("Correlation among near-optimal vectors")
    for subset in ("pareto", "feasible"):
        try:
            corr = correlation_of(a, subset)
        except VectoridError as exc:
            page.add(f"<p class=note>{_e(exc)}</p>")
            continue
        how = ", importance-weighted" if corr.weighted else ""
        page.add(f"<h3>over the {subset} set ({corr.n} trials{how})</h3>")
        if corr.pairs:
            page.add(
                _table(
                    ["a", "b", "r", "fit b ≈ intercept + slope·a", "R²"],
                    [
                        [
                            _e(d["a"]),
                            _e(d["b"]),
                            _f(d["r"]),
                            f"{_f(d['intercept'])} + {_f(d['slope'])}·{_e(d['a'])}",
                            _f(d["r2"]),
                        ]
                        for d in corr.pairs[:30]
                    ],
                    left=2,
                )
            )
        merge = "; ".join("{" + ", ".join(g) + "}" for g in corr.groups) or "none"
        fixed = ", ".join(f"{d['name']} (≈{_f(d['median'])})" for d in corr.fixed) or "none"
        page.add(
            f"<p>Could be merged: {_e(merge)}. Could be fixed (spread ≤ 10% of the box): "
            f"{_e(fixed)}.</p>"
        )
        page.fig(fg.correlation_figure(corr), "seed 000 Fig. 14")
        break
    if drawable:
        page.h2("Sensitivity")
        page.fig(fg.sensitivity_figure(sensitivity(a)))
    secs = load_sections(store)
    if secs:
        page.h2("Sections (type II)")
        for s in secs:
            page.fig(fg.section_figure(s, a.bounds), "seed 000 Fig. 10, seed 001 Fig. 12")
    checks = load_robustness(store, a)
    if checks:
        page.h2("Robustness of chosen vectors")
        page.add(
            _table(
                ["trial", "radius", "points", "verdict", "feasible share"]
                + [f"{n} min..max" for n in checks[0].crit_names],
                [
                    [
                        str(c.trial),
                        _f(c.radius),
                        str(len(c.X)),
                        _e(c.verdict),
                        _f(c.feasible_fraction),
                    ]
                    + [f"{_f(lo)} .. {_f(hi)}" for lo, hi in zip(c.min, c.max)]
                    for c in checks
                ],
                left=0,
            )
        )
        page.fig(fg.robustness_figure(checks), "seed 001 Table 4")
    if prediction is not None:  # what D predicts (vectorid.workflows.predict)
        from .predict import report_parts

        page.h2("Predictions")
        for kind, part in report_parts(prediction):
            page.fig(part) if kind == "figure" else page.add(part)
    # last: its 3-D figure's WebGL context must not be the oldest when every figure is
    # plotted at once (browsers drop the oldest beyond ~16 contexts, and a lost gl3d context
    # throws, while a lost scattergl one only goes blank)
    _identification(page, a, chosen, max_envelope)
    if page.notes:
        page.add(
            "<h2>Thinning</h2><ul>" + "".join(f"<li>{_e(n)}</li>" for n in page.notes) + "</ul>"
        )
    toc = " ".join(f'<a href="#{a_}">{_e(t)}</a>' for a_, t in page.toc)
    title = f"vectorid report: {spec.name}"
    doc = (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>{_e(title)}</title><style>{_CSS}</style>"
        f"<script>{plotly.offline.get_plotlyjs()}</script></head><body>"
        f"<h1>{_e(title)}</h1><p class=muted>written {time.strftime('%Y-%m-%d %H:%M')} by "
        f"vectorid {__version__} from {_e(store.path)}</p><nav>{toc}</nav>"
        + "".join(page.parts)
        + f"<script>{_LOADER}</script></body></html>"
    )
    return doc, page


def write_report(
    store: Store,
    out: str | Path,
    *,
    limits: Iterable[Bound] | Mapping[str, Any] | None = None,
    roles: Mapping[str, str] | None = None,
    chosen: Sequence[int] = (),
    max_points: int = 3_000,
    top: int = 10,
    seed: int = 0,
    max_envelope: int = 40,
    prediction: Any = None,
) -> ReportResult:
    """Write the self-contained HTML report of the study held in ``store``.

    Parameters
    ----------
    store : Store
        Read-only is enough.
    out : path
        The ``.html`` file to write.
    limits, roles
        Constraints and roles for this analysis (as :class:`~vectorid.analysis.Analysis`).
    chosen : sequence of int
        Trial ids of the chosen vector(s); default: the suggestion of
        :func:`~vectorid.analysis.choice.suggest_choice`.
    max_points : int
        Points per set in each point cloud (criterion vs criterion, matrix); the criterion vs
        parameter grids get ``max(200, max_points / p)`` per set and panel. Infeasible
        trials beyond it are drawn as a density of all of them.
    top : int
        Rows of the test tables.
    seed : int
        Seed of the decimation subsets.
    max_envelope : int
        Most trials simulated for the model envelope of the identification channels.
    prediction : Prediction, optional
        What D predicts for new drops (:func:`vectorid.workflows.predict.predict`): a
        "Predictions" section with the bands per channel and the landing dispersion.
    """
    t0 = time.perf_counter()
    doc, page = build_report(
        store,
        limits=limits,
        roles=roles,
        chosen=chosen,
        max_points=max_points,
        top=top,
        seed=seed,
        max_envelope=max_envelope,
        prediction=prediction,
    )
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(doc, encoding="utf-8")
    return ReportResult(
        path=out,
        size=out.stat().st_size,
        figures=page.figures,
        notes=page.notes,
        seconds=time.perf_counter() - t0,
    )
