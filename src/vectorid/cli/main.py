"""The ``vectorid`` command line.

Verbs (a contract; more may be added)::

    vectorid run STUDY.toml|STORE [--trials N] [--store PATH]
                                  [--executor serial|processes|dask|inline] [--scheduler tcp://H:P]
                                  [--timeout SECONDS] [--workers N] [--batch-size N] [--quiet]
    vectorid info STORE [--json]
    vectorid verify STORE [--json]
    vectorid repair STORE [--executor ...] [--workers N] [--quiet]
    vectorid table STORE [--limit 'NAME<=VALUE' ...] [--top K] [--feasible] [--json]
    vectorid pareto STORE [--limit 'NAME<=VALUE' | 'NAME>=VALUE' ...] [--role NAME=pseudo] [--json]
    vectorid export STORE [--format csv|json|parquet] [--out PATH] [--limit ...] [--constraints]
    vectorid init PROBLEM [--out FILE] [--trials N]
    vectorid demo [g12|parafoil] [--out DIR] [--trials N] [--analytic] [--next-drop]
    vectorid descent LOG --mass KG [--columns time=COL,altitude=COL] [...] [--json]
    vectorid predict STORE DROP.toml... [--members N] [--seed S] [--json] [--out DIR]

Errors in user input print one line saying what was expected, what came and how to fix it,
and exit with status 2 (never a traceback: a damaged store, a file that cannot be read or
written, a full disk are input errors too); a store being written by another process exits
with 3; ``verify`` exits with 1 when it finds damage; an interrupted run exits with 130
after storing what it finished. Warnings (damaged batches left out, more workers than cores)
and notes (study-file changes taken into the store) print one ``warning:`` / ``note:`` line
each on standard error.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import StoreError, StoreLockedError, VectoridError, plural
from ..limits import Limits, parse_user_limits
from ..sampler_kinds import sampler_names

__all__ = ["main"]

EXIT_USAGE = 2
EXIT_LOCKED = 3
EXIT_INTERRUPTED = 130


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a number >= 1, got {value}")
    return value


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not (0 < value < math.inf):
        raise argparse.ArgumentTypeError(f"expected a positive number of seconds, got {text}")
    return value


#: Help of the options several verbs take: one meaning, word for word, on every verb
#: (tests/cli/test_consistency.py checks it). A verb adds them with the helpers below, so a
#: new verb inherits them.
QUIET_HELP = (
    "no progress on standard error (no bar, no per-generation lines, no compile notices); "
    "the results still print"
)
JSON_HELP = (
    "print the result as one JSON document on standard output (notes and warnings stay on "
    "standard error)"
)
SAVE_HELP = (
    "save the constraints in force (the study's, changed by --limit) in the study, so that "
    "later analyses use them"
)
EXECUTOR_HELP = (
    "where the model runs: processes (one worker per core), serial (one model process), "
    "dask (a cluster), inline (this process, no protection); default: the study's, else "
    "processes"
)
WORKERS_HELP = "worker processes (default: all cores; processes and dask only)"
SCHEDULER_HELP = "Dask scheduler to run on (implies --executor dask; default: a local cluster)"
TIMEOUT_HELP = (
    "most seconds one trial may take (default: the study's, else no limit): a batch of N "
    "trials may run N x SECONDS; one that runs longer is stopped and re-run one trial at a "
    "time, and a trial that takes more than SECONDS is stored as failed, 'timed out after X s'"
)
STORE_HELP = "the study store (.db) a run wrote"
#: The executors a verb that runs a model may name (``--executor``).
EXECUTOR_CHOICES = ("processes", "serial", "dask", "inline")


def add_store_argument(sp: argparse.ArgumentParser) -> None:
    """Add the positional ``store`` (the study store a verb reads)."""
    sp.add_argument("store", help=STORE_HELP)


def add_quiet_option(sp: argparse.ArgumentParser) -> None:
    """Add ``--quiet`` (every verb that shows progress while it runs a model)."""
    sp.add_argument("--quiet", action="store_true", help=QUIET_HELP)


def add_json_option(sp: argparse.ArgumentParser) -> None:
    """Add ``--json`` (every verb whose result is data)."""
    sp.add_argument("--json", action="store_true", help=JSON_HELP)


def add_save_option(sp: argparse.ArgumentParser) -> None:
    """Add ``--save``: :func:`main` saves the limits in force before the verb runs, the same
    way for every verb that has it (see :func:`save_limits`)."""
    sp.add_argument("--save", action="store_true", help=SAVE_HELP)


def add_executor_options(
    sp: argparse.ArgumentParser, *, scheduler: bool = True, timeout: bool = True
) -> None:
    """Add ``--executor`` and ``--workers`` (and ``--scheduler``, ``--timeout``): every verb
    that evaluates a model's trials. The command passes them to the run as
    ``executor_options(scheduler=..., timeout=...)`` and ``executor=``/``workers=``
    (:func:`executor_of` gives the executor)."""
    sp.add_argument("--executor", choices=EXECUTOR_CHOICES, help=EXECUTOR_HELP)
    sp.add_argument("--workers", type=positive_int, help=WORKERS_HELP)
    if scheduler:
        sp.add_argument("--scheduler", metavar="tcp://HOST:PORT", help=SCHEDULER_HELP)
    if timeout:
        sp.add_argument("--timeout", type=positive_float, metavar="SECONDS", help=TIMEOUT_HELP)


def _progress(args: argparse.Namespace) -> bool:
    """Progress for a verb that runs a model, unless ``--quiet``: the sampler's lines always
    (they belong in a log too), the bar only on a terminal or in a notebook
    (:func:`vectorid.run.loop.run_store`), so a log file does not fill with bars."""
    return not args.quiet


def executor_of(args: argparse.Namespace) -> str | None:
    """The executor the options name: ``--executor``, else dask with ``--scheduler``."""
    executor = getattr(args, "executor", None)
    if executor is None and getattr(args, "scheduler", None):
        return "dask"
    return executor


def add_limit_options(sp: argparse.ArgumentParser, *, save: bool = True, role: bool = True) -> None:
    """Add ``--limit`` and ``--role`` (shared by every analysis verb), and ``--save``
    (``role=False``: a verb that reads only D, which roles do not change)."""
    sp.add_argument(
        "--limit",
        action="append",
        default=[],
        metavar="'NAME<=VALUE'",
        help="criteria or functional constraint, in the quantity's unit, e.g. 'f1<=40' or "
        "'f2>=0.5' (repeatable; 'f1<=inf' removes a limit)",
    )
    if role:
        sp.add_argument(
            "--role",
            action="append",
            default=[],
            metavar="NAME=pure|pseudo",
            help="override a criterion's role for this analysis",
        )
    if save:
        add_save_option(sp)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="vectorid",
        description="Multicriteria parametric identification by the Parameter Space "
        "Investigation (PSI) method.",
    )
    p.add_argument("--version", action="version", version=f"vectorid {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    r = sub.add_parser("run", help="run, resume or extend a study")
    r.add_argument("study", help="study file (.toml) or an existing store (.db) to resume/extend")
    r.add_argument(
        "--trials",
        type=positive_int,
        help="total number of trials the study holds; sequential sampler: the size of "
        "generation 0 (default: the population rounded up to a power of two)",
    )
    r.add_argument("--store", help="store path (default: the study's, else STUDY.db)")
    add_executor_options(r)
    r.add_argument("--batch-size", type=positive_int, help="trials per batch (default: auto)")
    r.add_argument(
        "--accept-changes",
        action="store_true",
        help="when a data file or the model's code changed since the stored trials were "
        "computed, go on and record the change (what, old/new hash, when) in the store's "
        "history (default: stop and name the change)",
    )
    r.add_argument(
        "--keep-going",
        action="store_true",
        help="store the first batches even when every one of their trials failed "
        "(default: stop with the reason and store none)",
    )
    add_quiet_option(r)
    add_json_option(r)
    r.add_argument(
        "--sampler",
        choices=sampler_names(),
        help="a new study's sampler (default: the study file's)",
    )
    r.add_argument(
        "--budget",
        type=positive_int,
        help="sampler 'sequential': most model evaluations (default: the study's, else 50000)",
    )
    r.add_argument(
        "--population",
        type=positive_int,
        help="sampler 'sequential': members of D wanted (default: the study's, else 200)",
    )

    v = sub.add_parser("verify", help="check a store: SQLite pages and every batch's checksum")
    add_store_argument(v)
    add_json_option(v)

    rp = sub.add_parser(
        "repair", help="drop the damaged batches of a store and recompute them (see verify)"
    )
    add_store_argument(rp)
    add_executor_options(rp)
    rp.add_argument(
        "--study",
        metavar="STUDY.toml",
        help="write the study definition back from this file (when the stored one is damaged)",
    )
    add_quiet_option(rp)
    add_json_option(rp)

    i = sub.add_parser("info", help="study definition, stages, counts, failures, runs")
    add_store_argument(i)
    add_json_option(i)

    t = sub.add_parser("table", help="test tables: each criterion's trials, best first")
    add_store_argument(t)
    add_limit_options(t)
    t.add_argument("--top", type=positive_int, default=10, help="rows per criterion (default 10)")
    t.add_argument("--feasible", action="store_true", help="only trials in the feasible set D")
    add_json_option(t)

    pa = sub.add_parser("pareto", help="feasible set D and Edgeworth–Pareto set")
    add_store_argument(pa)
    add_limit_options(pa)
    add_json_option(pa)

    e = sub.add_parser("export", help="every trial, one row each, with its D and Pareto flags")
    add_store_argument(e)
    e.add_argument(
        "--format",
        choices=["csv", "json", "parquet"],
        default=None,
        help="file format (default csv; json with --json)",
    )
    e.add_argument("--out", help="output file (default: standard output; required for parquet)")
    add_limit_options(e)
    e.add_argument(
        "--constraints",
        action="store_true",
        help="write the constraints in force instead (bound, unit, source of each limit)",
    )
    add_json_option(e)

    n = sub.add_parser(
        "init",
        help="write a study file for a built-in analytic problem, or (own-model) a starting "
        "point for identifying a model of your own",
    )
    n.add_argument(
        "problem",
        help="e.g. binh-korn, zdt1, dtlz2-3, tanaka, osyczka-kundu; or own-model (a folder "
        "with a numpy model package, a CSV record with stated noise and a study file)",
    )
    n.add_argument(
        "--out",
        help="file to write (default: PROBLEM.toml); own-model: folder (default: own-model)",
    )
    n.add_argument(
        "--trials",
        type=positive_int,
        default=None,
        help="trials (default 2048; own-model: as its study file says)",
    )

    d = sub.add_parser(
        "demo", help="run the two-step identification demo (or --analytic) and print its results"
    )
    d.add_argument(
        "which", nargs="?", default="g12", choices=("g12", "parafoil"),
        help="g12 (default): the G-12 parachute of seed 001; parafoil: seed 000's parafoil",
    )  # fmt: skip
    d.add_argument("--out", default="vectorid-demo", help="folder for the stores and files")
    d.add_argument(
        "--trials",
        type=positive_int,
        default=None,
        help="trials per identification step in its refined box (default 2048; parafoil: "
        "stage 2's first generation of Sobol trials, default 4096)",
    )
    d.add_argument("--analytic", action="store_true", help="the analytic Binh–Korn demo instead")
    add_quiet_option(d)
    add_executor_options(d, scheduler=False, timeout=False)
    d.add_argument(
        "--budget", type=positive_int, default=40_000,
        help="parafoil: stage 2's sequential sampler, most model evaluations (default 40000, "
        "a few minutes; 250000 is the full-size run, about 20 minutes on 2 cores)",
    )  # fmt: skip
    d.add_argument(
        "--population", type=positive_int, default=200,
        help="parafoil: members of D wanted per stage (default 200)",
    )  # fmt: skip
    d.add_argument(
        "--next-drop", action="store_true",
        help="parafoil: then fly the best-ranked second drop on the twin and identify the 33 "
        "gains again with both drops (one drop against two; adds minutes)",
    )  # fmt: skip
    for module in _extensions():
        module.add_parsers(sub)
    _group_verbs(p, sub)
    return p


#: ``vectorid --help`` lists the verbs in the order of the work. A new verb goes into one of
#: these groups (tests/test_cli.py checks that every verb has one; until then it is listed
#: under "other").
VERB_GROUPS = (
    ("set up", ("init", "demo")),
    ("run", ("run", "info", "verify", "repair")),
    ("analyse", ("table", "pareto", "section", "refine", "robustness", "correlation",
                 "sensitivity", "export")),
    ("identify from flight data", ("identifiability", "step", "descent", "predict",
                                   "design")),
    ("view", ("hist", "plot", "report", "ui")),
)  # fmt: skip


def _group_verbs(p: argparse.ArgumentParser, sub: Any) -> None:
    """Replace argparse's flat list of verbs by :data:`VERB_GROUPS`, in the description."""
    import shutil
    import textwrap

    helps = {a.dest: a.help or "" for a in sub._choices_actions}
    groups = [(title, [v for v in verbs if v in helps]) for title, verbs in VERB_GROUPS]
    grouped = {v for _, verbs in groups for v in verbs}
    other = [v for v in helps if v not in grouped]
    if other:
        groups.append(("other", other))
    width = min(shutil.get_terminal_size((100, 24)).columns, 100) - 2
    lines = [textwrap.fill(p.description or "", width), ""]
    for title, verbs in groups:
        lines.append(f"{title}:")
        for v in verbs:
            text = textwrap.wrap(helps[v], max(width - 19, 30)) or [""]
            head = f"  {v:<16} " if len(v) <= 16 else f"  {v}\n{'':19}"
            lines.append(head + text[0])
            lines += [f"{'':19}{t}" for t in text[1:]]
        lines.append("")
    lines.append("`vectorid COMMAND --help` gives a command's options.")
    p.description = "\n".join(lines)
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.usage = "%(prog)s [-h] [--version] COMMAND ..."
    sub.help = argparse.SUPPRESS  # listed above, by group


#: Modules adding verbs: each has ``add_parsers(subparsers)`` and ``COMMANDS`` (verb -> function
#: taking the parsed arguments and returning an exit code).
_EXTENSION_MODULES = (
    "vectorid.cli.analysis",
    "vectorid.cli.ui",
    "vectorid.cli.descent",
    "vectorid.cli.step",
    "vectorid.cli.predict",
    "vectorid.cli.design",
)


def _extensions() -> list[Any]:
    import importlib

    out = []
    for name in _EXTENSION_MODULES:
        try:
            out.append(importlib.import_module(name))
        except ModuleNotFoundError as exc:
            if exc.name != name:
                raise
    return out


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings as one line: ``warning: ...`` (``note: ...`` for notes)."""
    from ..errors import VectoridNote, VectoridWarning

    if issubclass(category, VectoridNote):
        text = f"note: {message}"
    elif issubclass(category, VectoridWarning):
        text = f"warning: {message}"
    else:
        text = f"warning: {category.__name__}: {message} ({Path(filename).name}:{lineno})"
    try:
        print(text, file=sys.stderr)
    except (OSError, ValueError):
        pass


def _output_paths(args: argparse.Namespace) -> list[Path]:
    """Files a verb writes (to remove a partial one when writing fails)."""
    out = getattr(args, "out", None)
    if not isinstance(out, str) or not out:
        return []
    p = Path(out)
    return [] if p.exists() else [p]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``vectorid`` console script."""
    import sqlite3
    import warnings

    args = _parser().parse_args(argv)
    commands = dict(_COMMANDS)
    for module in _extensions():
        commands.update(module.COMMANDS)
    new_files = _output_paths(args)

    def clean_partial() -> None:
        for p in new_files:
            try:
                if p.is_file():
                    p.unlink()
            except OSError:
                pass

    from .._hints import quiet_notices

    # --quiet: no progress and no waiting notices, here and in the workers the verb starts
    with warnings.catch_warnings(), quiet_notices(bool(getattr(args, "quiet", False))):
        from ..errors import VectoridWarning

        warnings.simplefilter("always", VectoridWarning)
        warnings.showwarning = _show_warning
        try:
            if getattr(args, "save", False):
                save_limits(args)
            return commands[args.command](args)
        except StoreLockedError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return EXIT_LOCKED
        except VectoridError as exc:
            clean_partial()
            print(f"error: {exc}", file=sys.stderr)
            return EXIT_USAGE
        except BrokenPipeError:
            _quiet_stdout()
            return 0
        except KeyboardInterrupt:
            clean_partial()
            print("\ninterrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        except sqlite3.DatabaseError as exc:
            path = getattr(args, "store", None) or getattr(args, "study", None) or "the store"
            print(
                f"error: store {path} is damaged (SQLite: {exc}); `vectorid verify {path}` "
                f"shows what is readable, `vectorid repair {path}` rebuilds it",
                file=sys.stderr,
            )
            return EXIT_USAGE
        except OSError as exc:
            clean_partial()
            what = f"{exc.filename}: " if exc.filename else ""
            reason = exc.strerror or str(exc)
            print(
                f"error: {what}{reason}; nothing was written there — check the path, its "
                "permissions and the free disk space, then run the command again",
                file=sys.stderr,
            )
            return EXIT_USAGE
        except MemoryError:
            print(
                "error: out of memory; use fewer trials or workers, or a machine with more memory",
                file=sys.stderr,
            )
            return EXIT_USAGE


def _quiet_stdout() -> None:
    """After a closed pipe (``vectorid export ... | head``): no second error at exit."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


# -- helpers --------------------------------------------------------------------------------


def _is_store(path: Path) -> bool:
    try:
        with open(path, "rb") as fh:
            return fh.read(16) == b"SQLite format 3\x00"
    except OSError:
        return False


def open_study(path: str, write: bool = False):
    from ..study import Study

    p = Path(path)
    if not p.exists():
        raise StoreError(
            f"no store at {p}; run a study first (`vectorid run STUDY.toml`) or check the path"
        )
    return Study.open(p, write=write)


def parse_limits_for(spec: Any, texts: Sequence[str]) -> list[Any]:
    """Parse ``--limit`` options (:func:`vectorid.limits.parse_user_limits`)."""

    return parse_user_limits(spec, texts)


def _analysis(args: argparse.Namespace):
    from ..errors import StudyDefinitionError

    roles = {}
    for text in args.role:
        name, sep, role = text.partition("=")
        if not sep:
            raise StudyDefinitionError(
                "--role", f"cannot read {text!r}", "write NAME=pure or NAME=pseudo"
            )
        roles[name.strip()] = role.strip()
    study = open_study(args.store)
    try:
        return study.analysis(parse_limits_for(study.spec, args.limit), roles)
    finally:
        study.close()


def _sampler_note(args: argparse.Namespace, a: Any) -> str | None:
    """The sampler's line for table/pareto (a sequential store: D's members and ESS), and that
    the counts above are trials (weights change densities, not which trials are in D)."""
    from ..samplers import sampler_for

    study = open_study(args.store)
    try:
        note = sampler_for(study.spec).describe(study.store, a.limits, a.trials)
    finally:
        study.close()
    if note is None:
        return None
    return f"{note}\n  N, ND, NP count trials (unweighted); densities of D use the weights"


def save_limits(args: argparse.Namespace) -> None:
    """``--save``: save the constraints in force (the study's, changed by ``--limit``) into
    the study held by ``args.store``, before the verb runs (so the verb reads them back). The
    same for every verb that takes ``--save`` (:func:`add_save_option`)."""
    study = open_study(args.store, write=True)
    with study:
        limits = Limits(study.spec, parse_limits_for(study.spec, args.limit))
        criteria, constraints = limits.for_saving()
        study.store.set_limits(criteria, constraints)
        shown = ", ".join(str(b) for b in limits.active())
    print(f"saved in {args.store}: {shown or 'no limits'}", file=sys.stderr)


def _fmt(v: float) -> str:
    if isinstance(v, float) and math.isnan(v):
        return "nan"
    return f"{v:.6g}"


def print_json(obj: Any) -> None:
    def default(o: Any) -> Any:
        if isinstance(o, np.generic):
            return o.item()
        raise TypeError(type(o).__name__)

    def clean(o: Any) -> Any:
        if isinstance(o, float) and not math.isfinite(o):
            return None
        if isinstance(o, dict):
            return {k: clean(v) for k, v in o.items()}
        if isinstance(o, list | tuple):
            return [clean(v) for v in o]
        return o

    json.dump(clean(obj), sys.stdout, indent=2, default=default)
    sys.stdout.write("\n")


# -- commands -------------------------------------------------------------------------------


def _cmd_run(args: argparse.Namespace) -> int:
    from ..run.executors import executor_options
    from ..run.loop import RunInterrupted
    from ..spec import load_study
    from ..study import Study, default_store_path

    src = Path(args.study)
    if _is_store(src) or (src.suffix.lower() in (".db", ".sqlite", ".sqlite3") and src.is_file()):
        if args.store:
            print("note: --store is ignored when running a store directly", file=sys.stderr)
        if args.sampler:
            print(
                "note: --sampler is ignored when running a store (its trials were drawn by "
                "the study's sampler); start a new study to change it",
                file=sys.stderr,
            )
        study = Study.open(src, write=True)
    else:
        spec = load_study(src)
        if args.sampler and args.sampler != spec.sampler:
            spec = _with_sampler(spec, args.sampler)
        store = Path(args.store) if args.store else default_store_path(spec, src)
        study = Study.create_or_open(
            spec, store, study_file=src, accept_changes=args.accept_changes
        )
    executor = executor_of(args)
    with study:
        print(f"study {study.spec.name!r} -> {study.store.path}", file=sys.stderr)
        _warn_damage(study.store)
        try:
            with executor_options(scheduler=args.scheduler, timeout=args.timeout):
                summary = study.run(
                    trials=args.trials,
                    executor=executor,
                    workers=args.workers,
                    batch_size=args.batch_size,
                    progress=_progress(args),
                    keep_going=args.keep_going,
                    budget=args.budget,
                    population=args.population,
                    accept_changes=args.accept_changes,
                )
        except RunInterrupted as exc:
            print(f"\n{exc}", file=sys.stderr)
            print(exc.summary.describe(), file=sys.stderr)
            return EXIT_INTERRUPTED
        if args.json:
            print_json(summary.to_dict())
        else:
            print(summary.describe())
    return 0


def _with_sampler(spec: Any, sampler: str) -> Any:
    """The study file's spec with ``--sampler`` (validated as the file's key would be)."""
    from ..sampler_kinds import SAMPLER_OPTIONS, sampler_kind
    from ..spec import StudySpec

    data = spec.to_dict()
    data["study"]["sampler"] = sampler
    for key in SAMPLER_OPTIONS:  # the options the new sampler does not take
        if key not in sampler_kind(sampler, "--sampler").options:
            data["study"].pop(key, None)
    return StudySpec.from_dict(data, base_dir=spec.base_dir)


def _warn_damage(store: Any) -> None:
    """Say before a run which stored batches are damaged (the run leaves them alone)."""
    import warnings

    from ..errors import VectoridWarning
    from ..store.records import damage_warning

    damaged = store.check_batches()
    if damaged:
        warnings.warn(VectoridWarning(damage_warning(store.path, damaged)), stacklevel=2)


def _cmd_info(args: argparse.Namespace) -> int:
    from ..analysis import Analysis
    from ..run.loop import group_failures
    from ..samplers import sampler_for
    from ..store.inputs import history as input_history

    study = open_study(args.store)
    with study:
        st = study.store
        spec = study.spec
        with st.snapshot():
            trials = st.load()
            stages = st.stages()
            runs = st.runs()
            counts = {s.stage: st.count(s.stage) for s in stages}
            schema = st.meta().get("schema_version", "?")
            history = input_history(st)
            sampler = sampler_for(spec)
            missing = st.missing_in(sampler.planned(st))
        a = Analysis(spec, trials, weighting=sampler.weighting(st, trials))
        ids = {(int(s), int(q)): int(i) for s, q, i in zip(trials.stage, trials.seq, trials.id)}
        groups = group_failures(trials.messages, ids)
        reasons = {g.message: g.count for g in groups}
        info = {
            "store": str(st.path),
            "study": spec.to_dict(),
            "stages": [
                {
                    "stage": s.stage,
                    "kind": s.kind,
                    "start_seq": s.start_seq,
                    "n": counts[s.stage],
                    "note": s.note,
                    "box": s.space.to_list(),
                }
                for s in stages
            ],
            "n": a.n,
            "n_failed": a.n_failed,
            "n_feasible": a.n_feasible,
            "n_pareto": a.n_pareto,
            "failures": reasons,
            "failure_groups": [
                {"count": g.count, "example": g.message, "trial": g.trial} for g in groups
            ],
            "damaged": [
                {
                    "block": d.block,
                    "stage": d.stage,
                    "first_id": d.first_id,
                    "last_id": d.last_id,
                    "n": d.n,
                    "reason": d.reason,
                }
                for d in trials.damaged
            ],
            "schema": schema,
            "wall_time_per_trial_mean": float(trials.wall.mean()) if len(trials) else None,
            "runs": runs,
            "history": history,
            "missing": missing,
        }
        if args.json:
            print_json(info)
            return 0
        print(f"store      {st.path}")
        print(f"study      {spec.name}  (model {spec.to_dict()['study']['model']})")
        held = a.n + sum(d.n for d in trials.damaged if stage_kind(stages, d.stage) == "sample")
        for line in sampler.status_lines(st, held, a.n_failed):
            print(line)
        if missing:
            print(
                f"MISSING    {missing} planned trials are not stored (an interrupted run or "
                f"repair); `vectorid run {st.path}` computes them"
            )
        if trials.damaged:
            lost = sum(d.n for d in trials.damaged)
            print(
                f"DAMAGED    {plural(len(trials.damaged), 'batch')} ({plural(lost, 'trial')}) "
                f"left out of the counts below; `vectorid repair {st.path}` recomputes them:"
            )
            for d in trials.damaged:
                print(f"  {d.describe()}")
        print(f"sampler    {spec.sampler}{' scrambled' if spec.scramble else ''}, seed {spec.seed}")
        print(f"sets       N={a.n}  ND={a.n_feasible}  NP={a.n_pareto}  (study limits)")
        print("variables")
        for v in spec.space:
            unit = f" [{v.unit}]" if v.unit else ""
            nom = "" if v.nominal is None else f"  nominal {_fmt(v.nominal)}"
            print(f"  {v.name:<16} {v.kind:<10} [{_fmt(v.low)}, {_fmt(v.high)}]{unit}{nom}")
        print("criteria")
        for c in spec.criteria:
            lim = c.describe_limit()  # the limit, its unit and where it came from
            print(f"  {c.name:<16} {c.sense:<4} {c.role:<7}{'  limit ' + lim if lim else ''}")
        if spec.constraints:
            print("constraints")
            for c in spec.constraints:
                lo = "-inf" if c.low is None else _fmt(c.low)
                hi = "inf" if c.high is None else _fmt(c.high)
                print(f"  {c.name:<16} [{lo}, {hi}]")
        print("stages")
        for s in info["stages"]:
            print(
                f"  {s['stage']}: {s['kind']:<7} from seq {s['start_seq']:<8} {s['n']:>8} trials"
                f"  {s['note']}"
            )
        if groups:
            print("failures")
            for g in groups:
                print(f"  {g.count:>7} × {g.message} (e.g. trial {g.trial})")
        if runs:
            print("runs")
            for r in runs:
                if r["executor"] == "repair":
                    print(f"  #{r['run']} {r['outcome']}")
                    continue
                dur = "" if r["finished"] is None else f"{r['finished'] - r['started']:.1f} s"
                print(
                    f"  #{r['run']} {r['executor']} × {r['workers']}  target {r['target']}  "
                    f"{r['outcome']}  {dur}"
                )
                for line in (r.get("report") or {}).get("model_errors") or []:
                    print(f"      model error: {line}")
        if history:
            import time as _time

            print("history")
            for e in history:
                when = _time.strftime("%Y-%m-%d %H:%M:%S", _time.localtime(e.get("at") or 0))
                old, new = e.get("old"), e.get("new")
                hashes = (
                    f": sha256 {(old or '(absent)')[:12]} -> {(new or '(absent)')[:12]}"
                    if old or new
                    else ""
                )
                print(f"  {when}  {e.get('what')}{hashes}  ({e.get('note')})")
    return 0


def stage_kind(stages: Sequence[Any], stage: int) -> str:
    for s in stages:
        if s.stage == stage:
            return str(s.kind)
    return "sample"


def _cmd_verify(args: argparse.Namespace) -> int:
    from ..errors import StoreDamagedError
    from ..run.repair import verify_store
    from ..store import Store, VerifyReport

    path = Path(args.store)
    try:
        st = Store.open(path)
    except StoreDamagedError as exc:
        rep = VerifyReport(path, sqlite=["not checked"], problems=[str(exc)])
    else:
        with st:
            rep = verify_store(st)
    if args.json:
        print_json(
            {
                "store": str(rep.path),
                "ok": rep.ok,
                "schema": rep.schema,
                "sqlite": rep.sqlite,
                "problems": rep.problems,
                "batches": rep.batches,
                "trials": rep.trials,
                "unverified": rep.unverified,
                "sound": rep.sound,
                "planned": rep.planned,
                "missing": rep.missing,
                "damaged": [
                    {
                        "block": d.block,
                        "stage": d.stage,
                        "first_id": d.first_id,
                        "last_id": d.last_id,
                        "n": d.n,
                        "reason": d.reason,
                    }
                    for d in rep.damaged
                ],
            }
        )
    else:
        print(rep.describe())
    return 0 if rep.sound else 1


def _cmd_repair(args: argparse.Namespace) -> int:
    from ..run.executors import executor_options
    from ..run.repair import repair_store

    with executor_options(scheduler=args.scheduler, timeout=args.timeout):
        report = repair_store(
            Path(args.store),
            executor=executor_of(args),
            workers=args.workers,
            progress=_progress(args),
            study=args.study,
        )
    if args.json:
        print_json(report.to_dict())
    else:
        print(report.describe())
    return 0


def _cmd_table(args: argparse.Namespace) -> int:
    a = _analysis(args)
    tables = a.test_tables(feasible_only=args.feasible)
    if args.json:
        out = a.summary()
        out["tables"] = [t.to_dict(args.top) for t in tables]
        print_json(out)
        return 0
    print(
        f"N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto}   (failed {a.n_failed}, "
        f"meeting functional constraints {a.n_functional})"
    )
    note = _sampler_note(args, a)
    if note:
        print(note)
    crit = {c.name: c for c in a.criteria}
    for b in a.active_bounds():
        print(f"  constraint {b}{_source(crit.get(b.name), b.value)}")
    width = 26
    for g in range(0, len(tables), 4):
        group = tables[g : g + 4]
        print()
        print("".join(f"{t.name + ' (' + t.sense + ')':<{width}}" for t in group))
        print("".join(f"{'min ' + _fmt(t.min):<{width}}" for t in group))
        print("".join(f"{'max ' + _fmt(t.max):<{width}}" for t in group))
        print(
            "".join(
                f"{'limit ' + ('-' if t.limit is None else _fmt(t.limit)):<{width}}" for t in group
            )
        )
        print("".join(f"{'-' * (width - 2):<{width}}" for t in group))
        rows = max((min(args.top, len(t.ids)) for t in group), default=0)
        for i in range(rows):
            cells = []
            for t in group:
                if i < min(args.top, len(t.ids)):
                    mark = " " if t.feasible[i] else "x"
                    cells.append(f"{t.ids[i]:>8} {_fmt(float(t.values[i])):<14}{mark}")
                else:
                    cells.append("")
                cells[-1] = f"{cells[-1]:<{width}}"
            print("".join(cells))
    print("\n(x: outside the feasible set D under the constraints above)")
    return 0


def _source(c: Any, value: float) -> str:
    """Where a criterion's bound in force came from, for the table header."""
    if c is None:
        return ""
    unit = f" {c.unit}" if c.unit else ""
    if c.limit is None or not math.isclose(c.limit, value):
        return f"{unit}  (this analysis, --limit)"
    return f"{unit}  ({c.source}{': ' + c.limit_note if c.limit_note else ''})"


def _cmd_pareto(args: argparse.Namespace) -> int:
    a = _analysis(args)
    if args.json:
        print_json(a.pareto_json())
        return 0
    print(f"N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto}   (failed {a.n_failed})")
    note = _sampler_note(args, a)
    if note:
        print(note)
    for b in a.active_bounds():
        print(f"  constraint {b}")
    pure = [a.crit_names[i] for i in a.pure]
    print(f"  Pareto over pure criteria: {', '.join(pure) or '(none)'}")
    if a.n_feasible == 0:
        print()
        print(a.diagnose_empty().describe())
        return 0
    rows = a.rows(a.pareto)
    names = a.crit_names + a.spec.space.names
    print()
    print(f"{'id':>8}  " + "  ".join(f"{n:>12}" for n in names))
    for r in sorted(rows, key=lambda r: r["criteria"][a.crit_names[a.pure[0]]] if a.pure else 0):
        vals = [r["criteria"][n] for n in a.crit_names] + [
            r["params"][n] for n in a.spec.space.names
        ]
        print(f"{r['id']:>8}  " + "  ".join(f"{_fmt(v):>12}" for v in vals))
    return 0


def _cmd_export(args: argparse.Namespace) -> int:
    from ..analysis.export import write_analysis
    from ..errors import StudyDefinitionError

    fmt = args.format or ("json" if args.json else "csv")
    if args.json and fmt != "json":
        raise StudyDefinitionError(
            "--json", f"--json asks for JSON, --format for {fmt}", "give one of the two"
        )
    if fmt == "parquet" and not args.out:
        raise StudyDefinitionError("--out", "parquet needs a file", "add --out trials.parquet")
    a = _analysis(args)  # the flags follow --limit/--role, as in table and pareto
    n = write_analysis(a, fmt, args.out or sys.stdout, constraints=args.constraints)
    if args.out:
        what = "constraints" if args.constraints else "trials"
        print(f"{n} {what} written to {args.out}", file=sys.stderr)
    return 0


def _cmd_init(args: argparse.Namespace) -> int:
    from .. import analytic
    from ..demos.g12 import study_toml
    from ..errors import StudyDefinitionError

    if args.problem == "own-model":
        from .._hints import command_name
        from ..demos.own_model import write_own_model

        folder = Path(args.out or "own-model")
        files = write_own_model(folder)
        study = folder / "study.toml"
        if args.trials is not None:
            text = study.read_text(encoding="utf-8")
            text = re.sub(r"(?m)^trials = \d+", f"trials = {args.trials}", text, count=1)
            study.write_text(text, encoding="utf-8")
        for f in files:
            print(f"wrote {f}")
        print(f"run it with: {command_name()} run {study}")
        return 0

    try:
        analytic.get(args.problem)
    except ValueError as exc:  # unknown name: the message lists the names and the nearest one
        raise StudyDefinitionError(
            "PROBLEM",
            str(exc),
            "e.g. `vectorid init binh-korn`, or `vectorid init own-model` for a model of your "
            "own (docs/own-model.md)",
        ) from None
    out = Path(args.out or f"{args.problem}.toml")
    if out.exists():
        raise StudyDefinitionError(
            "--out", f"{out} exists already", "choose another --out or remove it"
        )
    out.write_text(study_toml(args.problem, trials=args.trials or 2048), encoding="utf-8")
    from .._hints import command_name

    print(f"wrote {out}; run it with: {command_name()} run {out}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from ..demos.g12 import run_demo

    if args.which == "parafoil":
        from ..demos.parafoil import run_parafoil_demo

        next_drop = None
        if args.next_drop:
            from ..demos.parafoil_next import run_next_drop as next_drop
        return run_parafoil_demo(
            Path(args.out), trials=args.trials or 4096, progress=_progress(args),
            budget=args.budget, population=args.population, executor=args.executor,
            workers=args.workers, next_drop=next_drop,
        )  # fmt: skip
    if args.next_drop:
        from ..errors import StudyDefinitionError

        raise StudyDefinitionError(
            "--next-drop", "only the parafoil demo ranks and flies a second drop",
            "run vectorid demo parafoil --next-drop",
        )  # fmt: skip
    return run_demo(
        Path(args.out), trials=args.trials or 2048, progress=_progress(args),
        analytic=args.analytic, executor=args.executor, workers=args.workers,
    )  # fmt: skip


_COMMANDS = {
    "run": _cmd_run,
    "info": _cmd_info,
    "verify": _cmd_verify,
    "repair": _cmd_repair,
    "table": _cmd_table,
    "pareto": _cmd_pareto,
    "export": _cmd_export,
    "init": _cmd_init,
    "demo": _cmd_demo,
}


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
