"""The demonstration study (``vectorid demo``).

Until the flight-data identification demo exists, the demo runs a PSI study of the
constrained Binh–Korn problem (two criteria, two functional constraints, known Pareto set):
it writes the study file and its SQLite store into ``--out``, prints the test tables, the
counts N / ND / NP under a criteria constraint, the Edgeworth–Pareto set, and how close the
Pareto trials are to the known Pareto front. ``vectorid table``, ``pareto``, ``info`` and
``export`` then work on the store it leaves behind.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from . import analytic

__all__ = ["DEMO_PROBLEM", "run_demo", "study_toml"]

DEMO_PROBLEM = "binh-korn"


def _num(v: float) -> str:
    return repr(float(v))


def study_toml(
    problem: str, *, trials: int = 2048, seed: int = 1, limits: dict | None = None
) -> str:
    """A study file (TOML text) for a built-in analytic problem.

    Parameters
    ----------
    problem : str
        Name from :func:`vectorid.analytic.available`.
    trials, seed : int
    limits : dict, optional
        Criteria constraints Φ** by criterion name.
    """
    prob = analytic.get(problem)
    limits = limits or {}
    lines = [
        f"# {prob.title}",
        "# Written by `vectorid init`; edit freely.",
        "[study]",
        f'name = "{prob.name}"',
        f'model = "{prob.name}"',
        f"trials = {int(trials)}",
        f"seed = {int(seed)}",
        "",
    ]
    for name, lo, hi in prob.variables:
        lines += [
            "[[variables]]",
            f'name = "{name}"',
            f"low = {_num(lo)}",
            f"high = {_num(hi)}",
            "",
        ]
    for name, sense in prob.criteria:
        lines += ["[[criteria]]", f'name = "{name}"', f'sense = "{sense}"', 'role = "pure"']
        if name in limits:
            lines.append(f"limit = {_num(limits[name])}")
        lines.append("")
    for name, lo, hi in prob.constraints:
        lines += ["[[constraints]]", f'name = "{name}"']
        if lo is not None:
            lines.append(f"low = {_num(lo)}")
        if hi is not None:
            lines.append(f"high = {_num(hi)}")
        lines.append("")
    return "\n".join(lines)


def run_demo(out: Path, *, trials: int = 2048, progress: bool = True) -> int:
    """Run the demo study into folder ``out`` and print its results. Returns an exit code."""
    from .analysis import Analysis
    from .spec import load_study
    from .study import Study

    out.mkdir(parents=True, exist_ok=True)
    study_file = out / f"{DEMO_PROBLEM}.toml"
    limit = {"f1": 60.0}
    if not study_file.exists():
        study_file.write_text(study_toml(DEMO_PROBLEM, trials=trials, limits=limit), "utf-8")
    spec = load_study(study_file)
    store = out / f"{DEMO_PROBLEM}.db"
    prob = analytic.get(DEMO_PROBLEM)
    print(f"vectorid demo: PSI study of {prob.title}")
    print(f"  study file  {study_file}")
    print(f"  store       {store}")
    with Study.create_or_open(spec, store) as study:
        summary = study.run(trials=trials, executor="serial", progress=progress)
        print(f"  {summary.describe()}")
        a = study.analysis()
        print()
        print(f"Test tables (best first)   N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto}")
        tables = a.test_tables()
        print("  " + "".join(f"{'vector':>8} {t.name + ' (' + t.sense + ')':<16}" for t in tables))
        print("  " + "".join(f"{'':>8} {'min ' + format(t.min, '.4g'):<16}" for t in tables))
        print("  " + "".join(f"{'':>8} {'max ' + format(t.max, '.4g'):<16}" for t in tables))
        for i in range(7):
            print("  " + "".join(f"{t.ids[i]:>8} {t.values[i]:<16.10g}" for t in tables))
        print()
        print("Criteria constraints: " + ", ".join(str(b) for b in a.active_bounds()))
        for lim in (None, 40.0, 20.0):
            b = a if lim is None else Analysis(spec, a.trials, {"f1": lim})
            tag = "study limit f1 <= 60" if lim is None else f"tightened f1 <= {lim:g}"
            print(f"  {tag:<24} N = {b.n:5d}   ND = {b.n_feasible:5d}   NP = {b.n_pareto:4d}")
        rows = sorted(a.rows(a.pareto), key=lambda r: r["criteria"]["f1"])
        print()
        step = max(1, len(rows) // 12)
        print(f"Edgeworth–Pareto set ({len(rows)} trials; every {step}th shown)")
        print(f"  {'vector':>8} {'f1':>10} {'f2':>10} {'x1':>8} {'x2':>8}")
        for r in rows[::step]:
            c, p = r["criteria"], r["params"]
            print(
                f"  {r['id']:>8} {c['f1']:>10.4f} {c['f2']:>10.4f} {p['x1']:>8.4f} {p['x2']:>8.4f}"
            )
        X = a.trials.X[a.pareto]
        F = a.trials.F[a.pareto]
        resid = prob.pareto_set_residual(X)
        front = prob.pareto_front(4000)
        dist = np.sqrt(((F[:, None, :] - front[None, :, :]) ** 2).sum(-1)).min(axis=1)
        print()
        print("Known answer check (Binh–Korn Pareto set: x1 = x2 in [0, 3], then x2 = 3):")
        print(
            f"  distance of Pareto trials to the true front: mean {dist.mean():.3f}, "
            f"max {dist.max():.3f} (criteria units; f1 spans 0..136)"
        )
        print(f"  parameter-space residual: mean {resid.mean():.3f}, max {resid.max():.3f}")
    print()
    print("Next: vectorid table", store, "--limit 'f1<=40'   |   vectorid pareto", store, "--json")
    sys.stdout.flush()
    return 0
