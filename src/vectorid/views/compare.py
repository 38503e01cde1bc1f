"""Two models side by side on the same data (``vectorid ui A.db B.db``, ``vectorid report
A.db B.db``): seed 000's comparison of the 8-DoF and the 6-DoF parafoil models, for any two
studies with criteria in common.

:func:`compare_stores` reads both stores and returns a :class:`Comparison`: whether the two
studies compare the same drop (the flight files' contents, the window), N / ND / NP of each
under its own saved limits and under the *common* limits (each criterion's stated limit: the
limit saved with the first study, or, where a stage relaxed it as the last resort, the stated
one it relaxed), per criterion each model's limit in force (with where it came from), its best
value and how many of its successful trials meet the common limit, and — where criteria are
spectral peaks — the measured peak and the peak each model's suggested vector flies.

:func:`comparison_html` writes it as an HTML fragment (the report), :func:`comparison_figure`
draws each model's best value over the common limit per criterion (below 1: the model can
meet it), and :func:`write_comparison` writes the self-contained comparison report.
"""

from __future__ import annotations

import hashlib
import html
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..analysis.choice import suggest_choice
from ..analysis.results import Analysis
from ..errors import StudyDefinitionError
from ..store import Store
from .labels import labels_of, relaxed_of

__all__ = [
    "Comparison",
    "Side",
    "compare_stores",
    "comparison_figure",
    "comparison_html",
    "spectral_peaks",
    "write_comparison",
]

#: Spectral criteria by library name: kind -> (channel, column).
_PEAK_KINDS = {
    "roll": ("rates", 0),
    "pitch": ("rates", 1),
    "yaw": ("rates", 2),
    "phi": ("euler", 0),
    "theta": ("euler", 1),
    "psi": ("euler", 2),
}


@dataclass
class Side:
    """One model of a :class:`Comparison`.

    Attributes
    ----------
    label : str
        The store's name and the model, e.g. ``parafoil-6dof (parafoil6dof)``.
    path : str
    model : str
    n, nd, np, failed : int
        Trials, members of D and of the Pareto set under the study's own saved limits, and
        the failed trials.
    nd_common, np_common : int
        The same under the common limits.
    relaxed : float or None
        The common factor its saved limits were relaxed by (None: not relaxed).
    limit : dict
        Criterion -> (limit in force, where it came from in words); None where it has none.
    best : dict
        Criterion -> best value over its successful trials (the criterion's unit).
    meets : dict
        Criterion -> successful trials meeting the common limit.
    ok : int
        Successful trials.
    chosen : int or None
        The suggested vector's trial id (the Pareto trial nearest the ideal point), whose
        spectral peaks are shown.
    peaks : dict
        Spectral kind -> (frequency Hz, prominence) of the chosen vector's simulated
        signal; empty where not computed.
    """

    label: str
    path: str
    model: str
    n: int
    nd: int
    np: int
    failed: int
    nd_common: int
    np_common: int
    relaxed: float | None
    limit: dict[str, tuple[float, str] | None]
    best: dict[str, float]
    meets: dict[str, int]
    ok: int
    chosen: int | None
    peaks: dict[str, tuple[float, float]] = field(default_factory=dict)


@dataclass
class Comparison:
    """Two studies' criteria side by side (see :func:`compare_stores`).

    Attributes
    ----------
    a, b : Side
    criteria : list of str
        The criteria both studies have, in the first study's order.
    only : dict
        ``"a"`` / ``"b"`` -> criteria only that study has (not compared).
    units, senses : dict
        Criterion -> unit ("" where none is given), sense.
    common : dict
        Criterion -> (common limit or None, where it came from in words).
    drop : str
        Whether both compare the same drop, in words.
    same_drop : bool or None
        True / False where the flight files could be read, None otherwise.
    spectral : dict
        Criterion -> (kind, band (low, high) Hz) for the spectral-peak criteria.
    measured : dict
        Kind -> (frequency Hz, prominence) of the measured signal; empty where not computed.
    peaks_note : str
        Why peaks are missing, or how they were computed.
    """

    a: Side
    b: Side
    criteria: list[str]
    only: dict[str, list[str]]
    units: dict[str, str]
    senses: dict[str, str]
    common: dict[str, tuple[float | None, str]]
    drop: str
    same_drop: bool | None
    spectral: dict[str, tuple[str, tuple[float, float]]]
    measured: dict[str, tuple[float, float]] = field(default_factory=dict)
    peaks_note: str = ""

    def meets(self, side: Side, name: str) -> bool | None:
        """Whether ``side``'s best value meets the common limit on ``name`` (None: no
        limit, or no successful trial)."""
        lim = self.common[name][0]
        best = side.best.get(name, math.nan)
        if lim is None or not math.isfinite(best):
            return None
        return best <= lim if self.senses[name] == "min" else best >= lim


def _stated(c: Any) -> tuple[float | None, str]:
    """A criterion's stated limit and its source in words: the saved limit, or the one a
    relaxation started from."""
    rel = relaxed_of(c)
    if rel is not None and rel.stated is not None:
        why = f" ({rel.why})" if rel.why else ""
        return rel.stated, f"stated limit{why}, before the relaxation x{rel.factor:g}"
    if c.limit is None:
        return None, "no limit"
    src = {"noise": "noise floor", "quantile": "quantile stand-in"}.get(c.source, c.source)
    return float(c.limit), src + (f": {c.limit_note}" if c.limit_note else "")


def _in_force(c: Any) -> tuple[float, str] | None:
    if c.limit is None:
        return None
    rel = relaxed_of(c)
    if rel is not None:
        return float(c.limit), rel.label()
    src = {"noise": "noise floor", "quantile": "quantile stand-in"}.get(c.source, c.source)
    return float(c.limit), src


def _file_digest(path: Path) -> str | None:
    try:
        return hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        return None


def _drops(spec: Any) -> list[dict[str, Any]] | None:
    """Each drop of an ``[identification]`` table: name, window, files and their digests
    (None for a study without one)."""
    table = spec.extra.get("identification") if isinstance(spec.extra, Mapping) else None
    if not isinstance(table, Mapping):
        return None
    base = Path(spec.base_dir) if spec.base_dir else Path.cwd()
    out = []
    for d in table.get("drops") or []:
        if not isinstance(d, Mapping):
            continue
        files = [d["file"]] if isinstance(d.get("file"), str) else []
        files += [f["file"] for f in d.get("files") or [] if isinstance(f, Mapping) and "file" in f]
        if isinstance(d.get("wind"), str):
            files.append(d["wind"])
        out.append(
            {
                "name": str(d.get("name", "")),
                "window": [str(w) for w in d.get("window") or []],
                "files": {Path(f).name: _file_digest(base / f) for f in files},
            }
        )
    return out


def _same_drop(a: Any, b: Any) -> tuple[str, bool | None]:
    da, db = _drops(a), _drops(b)
    if da is None and db is None:
        return "no flight data in either study: the criteria are compared by name", None
    if da is None or db is None:
        return "only one study has flight data: its criteria are compared by name only", False
    if any(v is None for d in da + db for v in d["files"].values()):
        names = [d["name"] for d in da] == [d["name"] for d in db]
        return (
            "the flight files could not all be read from the studies' folders; drops named "
            + ("alike" if names else "differently")
            + ": "
            + ", ".join(d["name"] for d in da),
            None,
        )
    if da == db:
        d = da[0] if da else {"name": "", "window": [], "files": {}}
        return (
            (
                f"same drop{'s' if len(da) > 1 else ''}: "
                + "; ".join(
                    f"{x['name']} (window {' .. '.join(x['window']) or 'whole'}; files "
                    f"{', '.join(x['files'])}, same contents)"
                    for x in da
                ),
                True,
            )
            if d
            else ("same (empty) drop list", True)
        )
    return (
        "DIFFERENT drops or windows: "
        + "; ".join(f"{x['name']} {x['window']}" for x in da)
        + " against "
        + "; ".join(f"{x['name']} {x['window']}" for x in db)
        + " — the criteria do not measure the same thing",
        False,
    )


def _spectral(spec: Any) -> dict[str, tuple[str, tuple[float, float]]]:
    """Criterion -> (kind, band Hz) for the spectral-peak criteria of an identification."""
    from ..identify.criteria import DEFAULT_SPECTRAL_BAND

    table = spec.extra.get("identification") if isinstance(spec.extra, Mapping) else None
    if not isinstance(table, Mapping):
        return {}  # no flight data: a criterion named "peak_..." is not a spectral peak
    crits = table.get("criteria")
    out = {}
    for c in spec.criteria:
        use = c.name
        if isinstance(crits, Mapping) and isinstance(crits.get(c.name), Mapping):
            use = str(crits[c.name].get("use", c.name))
        base, _, band = use.partition("@")
        if not base.startswith("peak_") or base[5:] not in _PEAK_KINDS:
            continue
        lo, hi = DEFAULT_SPECTRAL_BAND
        if band:
            try:
                lo, hi = (float(x) for x in band.split("-"))
            except ValueError:
                continue
        out[c.name] = (base[5:], (float(lo), float(hi if hi is not None else math.inf)))
    return out


def _side(store: Store, a: Analysis, common: Mapping[str, float | None], names: list[str]) -> Side:
    spec = store.spec
    crit = {c.name: c for c in spec.criteria}
    lim = {k: v for k, v in common.items() if v is not None and k in crit}
    ac = Analysis.of_store(store, lim)
    best, meets = {}, {}
    for name in names:
        j = a.crit_names.index(name)
        col = a.trials.F[a.ok, j]
        col = col[np.isfinite(col)]
        sense = a.senses[j]
        best[name] = float(col.min() if sense == "min" else col.max()) if len(col) else math.nan
        L = common.get(name)
        if L is None:
            meets[name] = len(col)
        else:
            meets[name] = int((col <= L).sum() if sense == "min" else (col >= L).sum())
    rels = {relaxed_of(c).factor for c in spec.criteria if relaxed_of(c) is not None}
    model = spec.model if isinstance(spec.model, str) else type(spec.model).__name__
    return Side(
        label=f"{Path(store.path).stem} ({model})",
        path=str(store.path),
        model=model,
        n=a.n,
        nd=a.n_feasible,
        np=a.n_pareto,
        failed=a.n_failed,
        nd_common=ac.n_feasible,
        np_common=ac.n_pareto,
        relaxed=max(rels) if rels else None,
        limit={n: _in_force(crit[n]) for n in names},
        best=best,
        meets=meets,
        ok=int(a.ok.sum()),
        chosen=suggest_choice(a),
    )


def spectral_peaks(
    store: Store, trial: int | None, spectral: Mapping[str, Any]
) -> tuple[dict[str, tuple[float, float]], dict[str, tuple[float, float]]]:
    """The spectral peaks (frequency Hz, prominence) of the measured signal and of trial
    ``trial`` simulated on the study's first drop, for each kind of ``spectral``
    (:func:`vectorid.identify.spectral.rate_peaks`, whitened, in the criterion's band).

    Returns
    -------
    measured, simulated : dict
        Kind -> (Hz, prominence); ``simulated`` is empty when the trial is None or its
        simulation failed.
    """
    from ..identify.identification import Identification
    from ..identify.spectral import rate_peaks
    from .trial_runs import simulate_trials

    ident = Identification.from_spec(store.spec)
    kinds = {k: band for k, band in spectral.values()}
    channels = sorted({_PEAK_KINDS[k][0] for k in kinds})
    X = np.empty((0, len(store.spec.space)))
    if trial is not None:
        t = store.load()
        hit = np.flatnonzero(t.id == int(trial))
        if hit.size:
            X = t.X[hit[:1]]
    runs = simulate_trials(ident, X if len(X) else np.full((1, len(store.spec.space)), np.nan),
                           channels=channels)  # fmt: skip
    fs = 1.0 / ident.output_dt
    measured: dict[str, tuple[float, float]] = {}
    simulated: dict[str, tuple[float, float]] = {}
    for ch in channels:
        ks = [k for k in kinds if _PEAK_KINDS[k][0] == ch]
        cols = [_PEAK_KINDS[k][1] for k in ks]
        bands = {k: (kinds[k][0], min(kinds[k][1], fs / 2)) for k in ks}
        if ch in runs.measured:
            measured.update(rate_peaks(runs.measured[ch][:, cols], fs, bands))
        if len(X) and runs.ok[0] and ch in runs.simulated:
            simulated.update(rate_peaks(runs.simulated[ch][0][:, cols], fs, bands))
    return measured, simulated


def compare_stores(path_a: str | Path, path_b: str | Path, *, peaks: bool = True) -> Comparison:
    """Read two study stores and compare their common criteria (see the module docstring).

    Parameters
    ----------
    path_a, path_b : path
        The two stores; the first one's stated limits are the common limits.
    peaks : bool
        Simulate each model's suggested vector to find its spectral peaks (where criteria
        are spectral; the models are run, a few seconds).

    Raises
    ------
    StudyDefinitionError
        When the two studies have no criterion in common.
    """
    with Store.open(path_a) as sa, Store.open(path_b) as sb:
        spa, spb = sa.spec, sb.spec
        na, nb = spa.criterion_names, spb.criterion_names
        names = [n for n in na if n in nb]
        if not names:
            raise StudyDefinitionError(
                "compare",
                f"the two studies have no criterion in common ({', '.join(na)} against "
                f"{', '.join(nb)})",
                "compare two studies of the same data and criteria (e.g. two models of one drop)",
            )
        ca = {c.name: c for c in spa.criteria}
        cb = {c.name: c for c in spb.criteria}
        common: dict[str, tuple[float | None, str]] = {}
        for n in names:
            va, why = _stated(ca[n])
            vb, _ = _stated(cb[n])
            if va is not None and vb is not None and not math.isclose(va, vb, rel_tol=1e-6):
                why += f"; the second study states {vb:.5g}"
            if va is None and vb is not None:
                va, why = vb, "the second study's " + _stated(cb[n])[1]
            common[n] = (va, why)
        lim = {n: v for n, (v, _) in common.items()}
        sides = [_side(st, Analysis.of_store(st), lim, names) for st in (sa, sb)]
        lab = labels_of(spa)
        drop, same = _same_drop(spa, spb)
        spectral = {n: v for n, v in _spectral(spa).items() if n in names}
        c = Comparison(
            a=sides[0],
            b=sides[1],
            criteria=names,
            only={"a": [n for n in na if n not in nb], "b": [n for n in nb if n not in na]},
            units={n: lab.unit.get(n, "") for n in names},
            senses={n: ca[n].sense for n in names},
            common=common,
            drop=drop,
            same_drop=same,
            spectral=spectral,
        )
        if spectral and peaks:
            add_peaks(c, sa, sb)
        elif spectral:
            c.peaks_note = "not computed yet"
    return c


def add_peaks(c: Comparison, sa: Store, sb: Store) -> None:
    """Fill the spectral peaks of ``c`` (measured, and each model's suggested vector)."""
    try:
        c.measured, c.a.peaks = spectral_peaks(sa, c.a.chosen, c.spectral)
        _, c.b.peaks = spectral_peaks(sb, c.b.chosen, c.spectral)
        c.peaks_note = (
            "whitened Welch spectrum of the signal on the comparison grid, peak in the "
            "criterion's band; each model's suggested vector (the Pareto trial nearest the "
            "ideal point) simulated on the first drop"
        )
    except Exception as exc:  # data not found next to the stores, a model missing
        c.measured, c.a.peaks, c.b.peaks = {}, {}, {}
        c.peaks_note = f"not computed: {type(exc).__name__}: {exc}"


def _e(x: Any) -> str:
    return html.escape(str(x))


def _g(v: Any) -> str:
    if v is None:
        return "-"
    v = float(v)
    return "-" if not math.isfinite(v) else f"{v:.4g}"


def _peak(p: tuple[float, float] | None) -> str:
    if not p or not math.isfinite(p[0]):
        return "-"
    return f"{p[0]:.3f} Hz / {p[1]:.0f}"


def comparison_rows(c: Comparison) -> dict[str, list[list[str]]]:
    """The comparison's tables as rows of text: ``counts``, ``criteria``, ``peaks``."""
    a, b = c.a, c.b
    counts = [
        ["trials N", f"{a.n:,}", f"{b.n:,}"],
        ["failed", f"{a.failed:,}", f"{b.failed:,}"],
        ["ND / NP under its own saved limits", f"{a.nd:,} / {a.np:,}", f"{b.nd:,} / {b.np:,}"],
        [
            "its saved limits",
            "stated"
            if a.relaxed is None
            else f"relaxed x{a.relaxed:g} (last resort: D not reached at the stated limits)",
            "stated"
            if b.relaxed is None
            else f"relaxed x{b.relaxed:g} (last resort: D not reached at the stated limits)",
        ],
        [
            "ND / NP under the common limits",
            f"{a.nd_common:,} / {a.np_common:,}",
            f"{b.nd_common:,} / {b.np_common:,}",
        ],
    ]
    crit = []
    for n in c.criteria:
        u = c.units[n]
        lim, why = c.common[n]
        side = "<=" if c.senses[n] == "min" else ">="
        row = [f"{n} [{u or 'no unit given'}]", f"{side} {_g(lim)}" if lim is not None else "none"]
        for s in (a, b):
            m = c.meets(s, n)
            verdict = "-" if m is None else ("meets" if m else "misses")
            share = f"{s.meets[n]:,} of {s.ok:,}"
            row += [_g(s.best[n]), verdict, share]
        li = [f"{_g(s.limit[n][0])} ({s.limit[n][1]})" if s.limit[n] else "none" for s in (a, b)]
        crit.append(row + li + [why])
    peaks = []
    for n, (kind, band) in c.spectral.items():
        peaks.append(
            [
                f"{n} ({kind}, {band[0]:g}-{band[1]:g} Hz)",
                _peak(c.measured.get(kind)),
                _peak(a.peaks.get(kind)),
                _peak(b.peaks.get(kind)),
            ]
        )
    return {"counts": counts, "criteria": crit, "peaks": peaks}


#: Headers of :func:`comparison_rows`' tables (the two models' labels are added).
def comparison_heads(c: Comparison) -> dict[str, list[str]]:
    """Column headers of :func:`comparison_rows`' tables."""
    a, b = c.a.label, c.b.label
    return {
        "counts": ["", a, b],
        "criteria": [
            "criterion [unit]",
            "common limit",
            f"best: {a}",
            "meets",
            "trials meeting",
            f"best: {b}",
            "meets",
            "trials meeting",
            f"limit in force: {a}",
            f"limit in force: {b}",
            "common limit from",
        ],
        "peaks": ["criterion (kind, band)", "measured", f"{a} (chosen)", f"{b} (chosen)"],
    }


def _table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    out = ["<div class=scroll><table><tr>"]
    out += [f"<th class=l>{_e(h)}</th>" for h in head]
    out.append("</tr>")
    for r in rows:
        out.append("<tr>" + "".join(f"<td class=l>{_e(x)}</td>" for x in r) + "</tr>")
    out.append("</table></div>")
    return "".join(out)


def comparison_html(c: Comparison) -> str:
    """The comparison as an HTML fragment: the drop, the counts, the criteria, the peaks."""
    rows, heads = comparison_rows(c), comparison_heads(c)
    parts = [
        f"<p><b>Data:</b> {_e(c.drop)}</p>",
        f"<p>Compared: {_e(', '.join(c.criteria))}"
        + (f"; only in the first: {_e(', '.join(c.only['a']))}" if c.only["a"] else "")
        + (f"; only in the second: {_e(', '.join(c.only['b']))}" if c.only["b"] else "")
        + ". Common limits: each criterion's stated limit (the first study's; where its "
        "stage relaxed them as the last resort, the stated limits it started from), the "
        "same for both models.</p>",
        _table(heads["counts"], rows["counts"]),
        "<h3>Per criterion: best value, whether it meets the common limit, and how many "
        "successful trials do</h3>",
        _table(heads["criteria"], rows["criteria"]),
    ]
    if c.spectral:
        parts.append("<h3>Spectral peaks (frequency / prominence)</h3>")
        parts.append(_table(heads["peaks"], rows["peaks"]))
        parts.append(f"<p class=muted>{_e(c.peaks_note)}</p>")
    return "\n".join(parts)


def comparison_figure(c: Comparison) -> Any:
    """Each model's best value over the common limit per criterion (log scale; the dashed
    line at 1: below it, for a criterion to minimise, the model meets the limit)."""
    import plotly.graph_objects as go

    names = [n for n in c.criteria if c.common[n][0]]
    fig = go.Figure()
    for s, colour in ((c.a, "#1f77b4"), (c.b, "#ff7f0e")):
        ratio = []
        for n in names:
            lim = c.common[n][0]
            best = s.best[n]
            r = best / lim if lim and math.isfinite(best) else math.nan
            ratio.append(r if c.senses[n] == "min" else (1 / r if r else math.nan))
        fig.add_trace(
            go.Bar(
                x=[f"{n} [{c.units[n] or 'no unit given'}]" for n in names],
                y=ratio,
                name=s.label,
                marker_color=colour,
                hovertemplate="%{x}: best / limit %{y:.3g}<extra>" + s.label + "</extra>",
            )
        )
    fig.add_hline(y=1.0, line_dash="dash", line_color="#444")
    fig.update_layout(
        barmode="group",
        title={"text": "Best value over the common limit, per criterion (≤ 1: meets it)"},
        yaxis={"title": {"text": "best / common limit [-]"}, "type": "log"},
        height=380,
        margin={"t": 50, "l": 70, "r": 20, "b": 90},
        font={"size": 12},
        legend={"orientation": "h", "y": -0.35},
    )
    return fig


def write_comparison(
    path_a: str | Path, path_b: str | Path, out: str | Path, *, peaks: bool = True
) -> Any:
    """Write the self-contained comparison report of two stores (``vectorid report A.db
    B.db --out compare.html``).

    Returns
    -------
    ReportResult
    """
    import plotly.offline

    from .report import _CSS, _LOADER, ReportResult

    t0 = time.perf_counter()
    c = compare_stores(path_a, path_b, peaks=peaks)
    fig = comparison_figure(c)
    payload = fig.to_json().replace("</", "<\\/")
    title = f"vectorid comparison: {c.a.label} and {c.b.label}"
    doc = (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>{_e(title)}</title><style>{_CSS}</style>"
        f"<script>{plotly.offline.get_plotlyjs()}</script></head><body>"
        f"<h1>{_e(title)}</h1><p class=muted>written {time.strftime('%Y-%m-%d %H:%M')} by "
        f"vectorid {__version__} from {_e(c.a.path)} and {_e(c.b.path)}</p>"
        + comparison_html(c)
        + '<div class="fig" id="fig0" style="min-height:380px"></div>'
        f'<script type="application/json" id="fig0-json">{payload}</script>'
        + f"<script>{_LOADER}</script></body></html>"
    )
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(doc, encoding="utf-8")
    return ReportResult(
        path=out,
        size=out.stat().st_size,
        figures=[fig.layout.title.text],
        notes=[c.peaks_note] if c.peaks_note else [],
        seconds=time.perf_counter() - t0,
    )
