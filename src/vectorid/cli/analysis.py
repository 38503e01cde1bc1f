"""Analysis verbs of the ``vectorid`` command line (loaded by :mod:`vectorid.cli`).

::

    vectorid section STORE --trial ID --param NAME [--points N] [--range LO HI] [--out FIG.html]
    vectorid refine STORE [--limit ...] [--pareto] [--quantile Q] [--margin F]
                          [--bound NAME=LO:HI ...] [--apply] [--out FIG.html] [--json]
    vectorid robustness STORE --trial ID [--trial ID ...] [--radius R] [--points N] [--seed S]
    vectorid report STORE [OTHER] [--limit ...] [--chosen ID ...] [--max-points N]
                          [--predict DROP.toml] --out report.html
    vectorid correlation STORE [--limit ...] [--set pareto|feasible] [--method pearson|spearman]
    vectorid sensitivity STORE [--limit ...]
    vectorid hist STORE [--limit ...] [--param NAME ...] [--bins N] [--by-stage] [--out FIG.html]
    vectorid plot STORE (--x A --y B | --matrix | --vs-params CRIT | --spread ID ...) --out FIG.html
    vectorid identifiability STORE [--limit ...] [--json]

Every data verb takes ``--json``; ``--out`` writes a standalone figure (needs plotly).
Errors in input exit with status 2 and say what was expected, what came and how to fix it.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from .._hints import install_hint
from ..builders import variable_meanings
from ..errors import StudyDefinitionError
from .main import (
    add_json_option,
    add_limit_options,
    add_store_argument,
    parse_limits_for,
    positive_int,
)

__all__ = ["COMMANDS", "add_parsers"]


def _sampler_note(study: Any, a: Any) -> str | None:
    """The study's sampler's line on the sample analysed (None: nothing to say)."""
    from ..samplers import sampler_for

    return sampler_for(study.spec).describe(study.store, a.limits, a.trials)


def add_parsers(sub: Any) -> None:
    """Add the analysis verbs to the ``vectorid`` sub-parsers."""
    s = sub.add_parser("section", help="criteria along one parameter through a trial (type II)")
    add_store_argument(s)
    s.add_argument("--trial", type=int, required=True, help="id of the trial to pass through")
    s.add_argument("--param", required=True, help="variable to vary")
    s.add_argument("--points", type=positive_int, default=21, help="grid points (default 21)")
    s.add_argument(
        "--range", nargs=2, type=float, metavar=("LO", "HI"),
        help="range of PARAM, in its unit (default: its box)",
    )  # fmt: skip
    add_limit_options(s)
    s.add_argument("--out", help="write the section figure to this .html file")
    add_json_option(s)

    r = sub.add_parser("refine", help="double tuning: propose (and --apply) a narrowed box")
    add_store_argument(r)
    add_limit_options(r)
    r.add_argument("--pareto", action="store_true", help="envelope of the Pareto set, not of D")
    r.add_argument(
        "--quantile", type=float, default=0.05,
        help="envelope quantile, a share of the set's trials on each side (default 0.05)",
    )  # fmt: skip
    r.add_argument(
        "--margin", type=float, default=0.1,
        help="margin added on each side, a share of the envelope's width (default 0.1)",
    )  # fmt: skip
    r.add_argument(
        "--bound",
        action="append",
        default=[],
        metavar="NAME=LO:HI",
        help="set a variable's new bounds explicitly, in its unit (repeatable)",
    )
    r.add_argument("--apply", action="store_true", help="add the box as a new sample stage")
    r.add_argument("--out", help="write the old-vs-new box figure to this .html file")
    add_json_option(r)

    b = sub.add_parser("robustness", help="criteria in a small neighbourhood of chosen trials")
    add_store_argument(b)
    b.add_argument(
        "--trial", type=int, action="append", required=True,
        help="id of a chosen trial (repeatable)",
    )  # fmt: skip
    b.add_argument(
        "--radius", type=float, default=0.02,
        help="neighbourhood half-width, a share of each box width (default 0.02)",
    )  # fmt: skip
    b.add_argument("--points", type=positive_int, help="neighbours, multiple of 4 (default 32)")
    b.add_argument("--seed", type=int, default=0, help="seed of the neighbours' draw (default 0)")
    add_limit_options(b)
    b.add_argument("--out", help="write the robustness figure to this .html file")
    add_json_option(b)

    p = sub.add_parser(
        "report", help="self-contained HTML report of the study (or two models compared)"
    )
    add_store_argument(p)
    p.add_argument(
        "other",
        nargs="?",
        help="a second store: write the comparison of the two models instead (the same "
        "criteria on the same data: N/ND/NP, limits met, best values, spectral peaks)",
    )
    add_limit_options(p)
    p.add_argument("--out", required=True, help="the .html file to write")
    p.add_argument(
        "--chosen", type=int, action="append", default=[],
        help="id of a chosen trial to show (repeatable)",
    )  # fmt: skip
    p.add_argument(
        "--max-points",
        type=positive_int,
        default=3_000,
        help="points per set in each point cloud (default 3000)",
    )
    p.add_argument("--top", type=positive_int, default=10, help="test table rows (default 10)")
    p.add_argument(
        "--predict",
        action="append",
        default=[],
        metavar="DROP.toml",
        help="add what D predicts for these drops (vectorid predict; repeatable)",
    )
    p.add_argument(
        "--members", type=positive_int, help="members flown for --predict (default: all)"
    )

    c = sub.add_parser("correlation", help="parameter correlation among near-optimal vectors")
    add_store_argument(c)
    add_limit_options(c)
    c.add_argument(
        "--set", choices=["pareto", "feasible"], default="pareto",
        help="the trials correlated: the Pareto set (default) or the feasible set D",
    )  # fmt: skip
    c.add_argument(
        "--method", choices=["pearson", "spearman"], default="pearson",
        help="correlation coefficient (default pearson)",
    )  # fmt: skip
    c.add_argument("--threshold", type=float, default=0.8, help="|r| called strong (default 0.8)")
    c.add_argument("--out", help="write the heatmap to this .html file")
    add_json_option(c)

    e = sub.add_parser("sensitivity", help="rank correlation and KS filtering per parameter")
    add_store_argument(e)
    add_limit_options(e)
    e.add_argument("--out", help="write the figure to this .html file")
    add_json_option(e)

    h = sub.add_parser("hist", help="histograms of feasible and Pareto trials per parameter")
    add_store_argument(h)
    add_limit_options(h)
    h.add_argument("--param", action="append", help="variable (repeatable; default all)")
    h.add_argument("--bins", type=positive_int, help="bins per histogram (default: automatic)")
    h.add_argument("--by-stage", action="store_true", help="one histogram per sample stage")
    h.add_argument("--out", help="write the figure to this .html file")
    add_json_option(h)

    i = sub.add_parser(
        "identifiability", help="which variables the data determine, and within what range"
    )
    add_store_argument(i)
    add_limit_options(i)
    i.add_argument(
        "--identified", type=float, default=0.25,
        help="identified: D spans at most this share of the box's width (default 0.25)",
    )  # fmt: skip
    i.add_argument(
        "--weak", type=float, default=0.6,
        help="not identified: D spans more than this share of the box's width (default 0.6)",
    )  # fmt: skip
    i.add_argument(
        "--combinations", action="store_true",
        help="also the combinations of variables D pins down (docs/identification.md)",
    )  # fmt: skip
    add_json_option(i)

    g = sub.add_parser("plot", help="write one figure: pair, matrix, vs-params or spread")
    add_store_argument(g)
    add_limit_options(g)
    g.add_argument("--x", help="criterion/parameter on x (with --y)")
    g.add_argument("--y", help="criterion/parameter on y (with --x)")
    g.add_argument("--matrix", action="store_true", help="all criterion pairs")
    g.add_argument("--vs-params", metavar="CRITERION", help="criterion vs every parameter")
    g.add_argument("--spread", type=int, nargs="+", metavar="ID", help="trials vs nominal")
    g.add_argument("--max-points", type=positive_int, help="decimate point clouds")
    g.add_argument("--out", required=True, help="the .html file to write")


# -- helpers --------------------------------------------------------------------------------


def _roles(args: argparse.Namespace) -> dict[str, str]:
    roles = {}
    for text in args.role:
        name, sep, role = text.partition("=")
        if not sep:
            raise StudyDefinitionError(
                "--role", f"cannot read {text!r}", "write NAME=pure or NAME=pseudo"
            )
        roles[name.strip()] = role.strip()
    return roles


def _open(path: str, write: bool = False):
    from .main import open_study

    return open_study(path, write=write)


def _analysis(study: Any, args: argparse.Namespace):
    return study.analysis(parse_limits_for(study.spec, args.limit), _roles(args))


def _json(obj: Any) -> None:
    from .main import print_json

    print_json(obj)


def _fmt(v: float) -> str:
    v = float(v)
    return "nan" if math.isnan(v) else f"{v:.6g}"


def _figures():
    try:
        from ..views import figures
    except ImportError as exc:
        raise StudyDefinitionError(
            "--out", f"figures need plotly ({exc})", install_hint("plot")
        ) from None
    return figures


def _write_fig(fig: Any, out: str) -> None:
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.write_html(path, include_plotlyjs=True, full_html=True)
    print(f"figure written to {path}", file=sys.stderr)


def _weighted_words() -> str:
    from ..analysis.weights import WEIGHTED_NOTE

    return WEIGHTED_NOTE


# -- commands -------------------------------------------------------------------------------


def _cmd_section(args: argparse.Namespace) -> int:
    from ..workflows.extra import run_section

    study = _open(args.store, write=True)
    with study:
        sec = run_section(
            study.store, args.trial, args.param, points=args.points, value_range=args.range
        )
        a = _analysis(study, args) if args.out else None
    if args.json:
        _json(sec.to_dict())
    else:
        print(f"section {sec.stage}: trial {sec.trial} along {sec.param}, {len(sec.values)} points")
        print(f"{sec.param:>14}  " + "  ".join(f"{n:>14}" for n in sec.crit_names))
        for i, v in enumerate(sec.values):
            mark = " <- trial" if np.all(sec.X[i] == sec.x0) else ""
            cells = (
                [f"{_fmt(x):>14}" for x in sec.F[i]]
                if sec.status[i] == 0
                else [f"{'failed':>14}"] * len(sec.crit_names)
            )
            print(f"{_fmt(v):>14}  " + "  ".join(cells) + mark)
    if args.out:
        _write_fig(_figures().section_figure(sec, a.bounds if a else None), args.out)
    return 0


def _parse_bounds(texts: list[str]) -> dict[str, tuple[float, float]]:
    out = {}
    for text in texts:
        name, sep, rest = text.partition("=")
        lo, sep2, hi = rest.partition(":")
        try:
            if not (sep and sep2):
                raise ValueError
            out[name.strip()] = (float(lo), float(hi))
        except ValueError:
            raise StudyDefinitionError(
                "--bound", f"cannot read {text!r}", "write NAME=LO:HI, e.g. --bound x6=0.3:1.0"
            ) from None
    return out


def _cmd_refine(args: argparse.Namespace) -> int:
    from ..analysis.refine import propose_refine
    from ..workflows.extra import apply_refine

    study = _open(args.store, write=args.apply)
    with study:
        a = _analysis(study, args)
        prop = propose_refine(
            a,
            study.store.stages(),
            basis="pareto" if args.pareto else "feasible",
            quantile=args.quantile,
            margin=args.margin,
            bounds=_parse_bounds(args.bound),
        )
        stage = apply_refine(study.store, prop) if args.apply else None
    if args.json:
        doc = prop.to_dict()
        doc["applied_stage"] = None if stage is None else stage.stage
        doc["start_seq"] = None if stage is None else stage.start_seq
        _json(doc)
    else:
        print(
            f"basis: {prop.basis} set ({prop.n_basis} trials); quantile {prop.quantile:g}, "
            f"margin {prop.margin:g}; constraints: {', '.join(prop.limits) or 'study'}"
        )
        print(f"{'variable':<16}{'current box':>28}{'proposed box':>28}{'width':>8}")
        for r in prop.rows():
            star = " (set)" if r["override"] else ""
            print(
                f"{r['name']:<16}{'[' + _fmt(r['old_low']) + ', ' + _fmt(r['old_high']) + ']':>28}"
                f"{'[' + _fmt(r['new_low']) + ', ' + _fmt(r['new_high']) + ']':>28}"
                f"{r['width_ratio']:>8.3f}{star}"
            )
        print(
            f"volume ratio {prop.volume_ratio:.4g}; feasible trials inside {prop.feasible_inside} "
            f"of {prop.n_feasible}; Pareto trials outside {prop.pareto_outside} of {prop.n_pareto}"
        )
        if stage is None:
            print("not applied: add --apply to continue the study in this box")
        else:
            print(
                f"applied: sample stage {stage.stage} starts at sequence index {stage.start_seq};"
                f" continue with: vectorid run {args.store} --trials N  (N > {stage.start_seq})"
            )
    if args.out:
        _write_fig(_figures().refine_figure(prop, a), args.out)
    return 0


def _cmd_robustness(args: argparse.Namespace) -> int:
    from ..analysis.robustness import chosen_table
    from ..workflows.extra import run_robustness

    study = _open(args.store, write=True)
    with study:
        a = _analysis(study, args)
        checks = [
            run_robustness(
                study.store,
                t,
                radius=args.radius,
                points=args.points,
                seed=args.seed,
                analysis=a,
            )
            for t in args.trial
        ]
        sample_ids = [t for t in args.trial if t < 1_000_000_000]
        table = chosen_table(a, sample_ids) if sample_ids else None
    if args.json:
        _json(
            {
                "chosen": None if table is None else table.to_dict(),
                "checks": [c.to_dict() for c in checks],
            }
        )
    else:
        names = a.crit_names
        if table is not None:
            print("criteria of the chosen trials (seed 001 Table 4)")
            print(f"{'':>10}" + "".join(f"{n:>16}" for n in names))
            print(f"{'MIN:':>10}" + "".join(f"{_fmt(v):>16}" for v in table.min))
            print(f"{'MAX:':>10}" + "".join(f"{_fmt(v):>16}" for v in table.max))
            for i, f in zip(table.ids, table.F):
                print(f"{'№' + str(i):>10}" + "".join(f"{_fmt(v):>16}" for v in f))
            print()
        for c in checks:
            print(
                f"trial {c.trial}: {len(c.X)} runs within ±{c.radius:g} of the box (stage "
                f"{c.stage}); verdict {c.verdict}; feasible share {c.feasible_fraction:.2f}"
            )
            for j, n in enumerate(names):
                print(
                    f"  {n:<14} value {_fmt(c.f0[j]):>12}  range [{_fmt(c.min[j])}, "
                    f"{_fmt(c.max[j])}]  relative {_fmt(c.relative_range[j])}  "
                    f"score {_fmt(c.score[j])}  {c.verdicts[j]}"
                )
    if args.out:
        _write_fig(_figures().robustness_figure(checks), args.out)
    return 0


def _cmd_report(args: argparse.Namespace) -> int:

    try:
        from ..views.report import write_report
    except ImportError as exc:
        raise StudyDefinitionError(
            "report", f"the report needs plotly ({exc})", install_hint("plot")
        ) from None
    if args.other:
        from ..views.compare import write_comparison

        for path in (args.store, args.other):
            _open(path).close()  # one-line errors for a missing or damaged store
        res = write_comparison(args.store, args.other, args.out)
        print(f"comparison written to {res.path} ({res.size / 1e6:.1f} MB, {res.seconds:.1f} s)")
        for n in res.notes:
            print(f"  spectral peaks: {n}")
        return 0
    study = _open(args.store)
    with study:
        prediction = None
        if args.predict:
            from ..workflows.predict import predict

            limits = parse_limits_for(study.spec, args.limit)
            prediction = predict(study, args.predict, members=args.members, limits=limits or None)
        res = write_report(
            study.store,
            args.out,
            limits=parse_limits_for(study.spec, args.limit),
            roles=_roles(args),
            chosen=args.chosen,
            max_points=args.max_points,
            top=args.top,
            prediction=prediction,
        )
        a = _analysis(study, args)
        note = _sampler_note(study, a)
    if note:
        from ..analysis.weights import how_weighted

        print(f"{note}; the report's densities of D are {how_weighted(a)}")
    print(
        f"report written to {res.path} ({res.size / 1e6:.1f} MB, {len(res.figures)} figures, "
        f"{res.seconds:.1f} s)"
    )
    for n in res.notes:
        print(f"  {n}")
    return 0


def _cmd_correlation(args: argparse.Namespace) -> int:
    from ..analysis.correlation import correlation_of

    study = _open(args.store)
    with study:
        a = _analysis(study, args)
        note = None if args.json else _sampler_note(study, a)
    corr = correlation_of(a, args.set, method=args.method, threshold=args.threshold)
    if args.json:
        _json(corr.to_dict())
    else:
        if note:
            print(note)
        how = "; " + _weighted_words() if corr.weighted else ""
        print(f"{corr.method} correlation over the {args.set} set ({corr.n} trials{how})")
        if not corr.pairs:
            print(f"no pair with |r| >= {corr.threshold:g}")
        for d in corr.pairs:
            print(
                f"  {d['a']:<12} {d['b']:<12} r = {d['r']:+.3f}   {d['b']} ≈ "
                f"{_fmt(d['intercept'])} + {_fmt(d['slope'])}·{d['a']}  (R² {d['r2']:.3f})"
            )
        groups = "; ".join("{" + ", ".join(g) + "}" for g in corr.groups) or "none"
        print(f"could be merged: {groups}")
        fixed = ", ".join(
            f"{d['name']} (spread {d['spread']:.3f}, median {_fmt(d['median'])})"
            for d in corr.fixed
        )
        print(f"could be fixed: {fixed or 'none'}")
    if args.out:
        _write_fig(_figures().correlation_figure(corr), args.out)
    return 0


def _cmd_sensitivity(args: argparse.Namespace) -> int:
    from ..analysis.sensitivity import sensitivity

    study = _open(args.store)
    with study:
        a = _analysis(study, args)
        note = None if args.json else _sampler_note(study, a)
    s = sensitivity(a)
    if args.json:
        _json(s.to_dict())
    else:
        if note:
            print(note)
        print(
            f"KS statistic between D ({s.n_behavioural} trials) and the rest ({s.n_other}), "
            "and Spearman ρ with each criterion"
            + (
                f"; {_weighted_words()}: effective sizes {s.ess_behavioural:.0f} and "
                f"{s.ess_other:.0f}"
                + (f" (1 in {s.stride:.3g} trials outside D weighed)" if s.stride > 1 else "")
                if s.weighted
                else ""
            )
        )
        print(f"{'parameter':<16}{'KS':>8}{'p':>10}" + "".join(f"{n:>12}" for n in s.criteria))
        for name, _ in s.ranking():
            j = s.params.index(name)
            print(
                f"{name:<16}{s.ks[j]:>8.3f}{s.ks_pvalue[j]:>10.2g}"
                + "".join(f"{v:>12.3f}" for v in s.spearman[j])
            )
    if args.out:
        _write_fig(_figures().sensitivity_figure(s), args.out)
    return 0


def _cmd_hist(args: argparse.Namespace) -> int:
    from ..analysis.histograms import histograms, stage_histograms

    study = _open(args.store)
    with study:
        a = _analysis(study, args)
        stages = [s for s in study.store.stages() if s.kind == "sample"]
        note = None if args.json else _sampler_note(study, a)
    if note:
        print(note)
    params = args.param or a.spec.space.names
    if args.by_stage:
        hists = [h for p in params for h in stage_histograms(a, stages, p, bins=args.bins)]
    else:
        hists = histograms(a, params, bins=args.bins)
    if args.json:
        _json({"histograms": [h.to_dict() for h in hists]})
    else:
        units = {v.name: v.unit for v in a.spec.space}
        for h in hists:
            where = "" if h.stage is None else f" stage {h.stage}"
            unit = f" [{units[h.param]}]" if units.get(h.param) else ""
            print(
                f"{h.param}{unit}{where}: {int(h.all.sum())} trials, {int(h.feasible.sum())} "
                f"feasible (in D), {int(h.pareto.sum())} Pareto, over [{_fmt(h.low)}, "
                f"{_fmt(h.high)}]"
            )
            label = f"bin of {h.param}{unit}"
            if h.weighted:  # a sequential store: D's density needs the importance weights
                print(
                    f"  {label:<25}  {'feasible':>8} {'Pareto':>7} {'weighted':>8}  # = D's "
                    f"density, {h.weighted_by} (sequential sampler)"
                )
                peak_w = max(1e-300, float(h.feasible_weighted.max()))
                for lo, hi, f, p, fw in zip(
                    h.edges[:-1], h.edges[1:], h.feasible, h.pareto, h.feasible_weighted
                ):
                    bar = "#" * round(30 * fw / peak_w)
                    print(f"  [{_fmt(lo):>10}, {_fmt(hi):>10})  {f:>8} {p:>7} {fw:>8.1f}  {bar}")
                continue
            print(f"  {label:<25}  {'feasible':>8} {'Pareto':>7}  # = feasible trials")
            peak = max(1, int(h.feasible.max()) if len(h.feasible) else 1)
            for lo, hi, f, p in zip(h.edges[:-1], h.edges[1:], h.feasible, h.pareto):
                bar = "#" * round(30 * f / peak)
                print(f"  [{_fmt(lo):>10}, {_fmt(hi):>10})  {f:>8} {p:>7}  {bar}")
    if args.out:
        fg = _figures()
        if args.by_stage:
            figs = [fg.stage_histograms_figure([h for h in hists if h.param == p]) for p in params]
            fig = figs[0] if len(figs) == 1 else fg.histograms_figure(hists, cols=len(stages))
        else:
            fig = fg.histograms_figure(hists)
        _write_fig(fig, args.out)
    return 0


def _cmd_plot(args: argparse.Namespace) -> int:
    fg = _figures()
    study = _open(args.store)
    with study:
        a = _analysis(study, args)
    chosen = [args.matrix, bool(args.vs_params), bool(args.spread), bool(args.x or args.y)]
    if sum(chosen) != 1 or (bool(args.x) != bool(args.y)):
        raise StudyDefinitionError(
            "plot",
            "expected exactly one of --x A --y B, --matrix, --vs-params CRITERION, --spread ID",
            "e.g. vectorid plot STORE --x f1 --y f2 --out f1f2.html",
        )
    if args.matrix:
        fig = fg.scatter_matrix_figure(a, max_points=args.max_points)
    elif args.vs_params:
        fig = fg.criterion_vs_parameter_figure(a, args.vs_params, max_points=args.max_points)
    elif args.spread:
        from ..analysis.correlation import parameter_spread
        from ..analysis.robustness import chosen_table

        tab = chosen_table(a, args.spread)
        sp = a.spec.space
        fig = fg.spread_figure(
            parameter_spread(
                tab.X, sp.names, sp.nominal, sp.lows, sp.highs, [f"trial {i}" for i in tab.ids]
            )
        )
    else:
        fig = fg.scatter_figure(a, args.x, args.y, max_points=args.max_points)
    _write_fig(fig, args.out)
    return 0


def _span(p: tuple[float, float] | None, unit: str = "") -> str:
    return "-" if p is None else f"[{_fmt(p[0])}, {_fmt(p[1])}]{unit}"


def _cmd_identifiability(args: argparse.Namespace) -> int:
    from ..analysis.combinations import (
        combinations_json,
        combinations_text,
        identifiable_combinations,
    )
    from ..analysis.identifiability import identifiability, verdicts_json

    if not (0 < args.identified <= args.weak <= 1):
        raise StudyDefinitionError(
            "--identified/--weak",
            f"expected 0 < identified <= weak <= 1, got {args.identified} and {args.weak}",
            "e.g. --identified 0.25 --weak 0.6",
        )
    study = _open(args.store)
    with study:
        a = _analysis(study, args)
        spec = study.spec
        meanings = variable_meanings(spec)  # the model's parameter meanings, from the builder
        verdicts = identifiability(a, identified=args.identified, weak=args.weak, meanings=meanings)
        note = _sampler_note(study, a)
        combos = None
        if args.combinations:
            combos = identifiable_combinations(a, identified=args.identified, weak=args.weak)
    if args.json:
        out = verdicts_json(verdicts)
        out["n"], out["n_feasible"], out["n_pareto"] = a.n, a.n_feasible, a.n_pareto
        out["constraints_in_force"] = [str(b) for b in a.active_bounds()]
        if combos is not None:
            out.update(combinations_json(combos))
        _json(out)
        return 0
    print(f"N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto}")
    if verdicts and verdicts[0].thin:
        print(
            f"  thin: D holds {a.n_feasible} trials, fewer than the {verdicts[0].n_needed} a "
            "verdict needs to show a spread; run more trials, or use the sequential sampler "
            '([study] sampler = "sequential")'
        )
    if note:
        print(note)
        print("  feasible ranges are min-max over D's members: the weights do not change them")
    crit = {c.name: c for c in spec.criteria}
    for b in a.active_bounds():
        c = crit.get(b.name)
        src = ""
        if c is not None and c.limit is not None and math.isclose(c.limit, b.value):
            src = f"   ({c.source}{': ' + c.limit_note if c.limit_note else ''})"
        elif c is not None:
            src = "   (--limit)"
        unit = f" {c.unit}" if c is not None and c.unit else ""
        print(f"  constraint {b}{unit}{src}")
    print()
    for v in verdicts:
        print(f"{v.label()}")
        print(f"  verdict      {v.verdict}: {v.reason}")
        u = f" {v.unit}" if v.unit and v.unit != "-" else ""
        print(f"  feasible     {_span(v.feasible, u)}")
        print(f"  pareto       {_span(v.pareto, u)}")
        print(f"  box          {_span(v.box, u)}")
        print(f"  constrained by {', '.join(v.constrained_by) or '-'}")
        if v.suggestion:
            print(f"  to identify it: {v.suggestion}")
    print(
        "\n(identified: D spans <= "
        f"{args.identified:.0%} of the box, off its edges; not identified: > {args.weak:.0%})"
    )
    if combos is not None:
        print()
        limited = any(b.name in a.crit_names for b in a.active_bounds())
        print(combinations_text(combos, a.n_feasible, limited))
    return 0


COMMANDS = {
    "section": _cmd_section,
    "refine": _cmd_refine,
    "robustness": _cmd_robustness,
    "report": _cmd_report,
    "correlation": _cmd_correlation,
    "sensitivity": _cmd_sensitivity,
    "hist": _cmd_hist,
    "plot": _cmd_plot,
    "identifiability": _cmd_identifiability,
}
