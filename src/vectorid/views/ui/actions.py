"""Background jobs started from the browser: validating the values of the job buttons,
starting the job (:class:`~vectorid.views.ui.jobs.JobManager`), the job bar's text, and the
constraints to save with the study."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ...analysis.refine import propose_refine
from ...errors import StudyDefinitionError, VectoridError
from .context import UIContext, analysis_of
from .data import page_table, parse_constraints, parse_number, parse_trial_id
from .jobs import JobBusy
from .refine import _overrides, _refine_args
from .verdicts import sources_to_save

__all__ = ["job_action", "job_message", "job_view", "limits_to_save", "start_job"]


def limits_to_save(
    ctx: UIContext, limit_texts: Any, roles: Any = None, functional: Any = None
) -> dict[str, Any]:
    """The constraints in force, as :meth:`~vectorid.store.Store.set_limits` saves
    them (the rule of ``vectorid table --save``: a criterion's saved limit is its worse-side
    bound; functional constraints keep both bounds), with where each limit came from: a
    limit still equal to the saved one keeps its source and note (a noise floor stays a
    noise floor), one set in this page is the expert's, noted "set in the browser UI".

    Returns
    -------
    dict
        ``criteria`` (name -> limit or None), ``constraints`` (name -> [low, high], None for
        no bound), ``sources`` (name -> [limit_source, limit_note]) and ``text`` (the bounds
        in words).

    Raises
    ------
    StudyDefinitionError
        When a field does not parse (nothing is saved while one is marked red), or a
        criterion has a better-side bound (which a study cannot hold).
    """
    a, c = analysis_of(ctx, limit_texts, roles, functional)
    if c.errors:
        raise StudyDefinitionError(
            "save constraints",
            f"{len(c.errors)} field(s) do not hold a number: " + "; ".join(c.errors.values()),
            "correct or clear the fields outlined in red, then save",
        )
    criteria, kept = a.limits.for_saving("save constraints", "remove that bound before saving")
    constraints = {name: list(bounds) for name, bounds in kept.items()}
    text = ", ".join(str(b) for b in a.active_bounds()) or "no limits"
    sources = {k: list(v) for k, v in sources_to_save(ctx, a, c).items()}
    return {"criteria": criteria, "constraints": constraints, "sources": sources, "text": text}


def start_job(ctx: UIContext, kind: str, **values: Any) -> str:
    """Validate the browser's values for a job and start it in the background.

    Parameters
    ----------
    kind : {"section", "robustness", "refine", "continue", "limits"}
    values
        ``trial`` (text), ``param``, ``points``, ``lo``, ``hi`` (section); ``trial``,
        ``radius``, ``points`` (robustness); ``limit_texts``, ``roles``, ``basis``,
        ``quantile``, ``margin``, ``rows``, ``trials`` (refine); ``trials`` (continue);
        ``limit_texts``, ``roles`` (robustness, refine, limits) and ``functional``
        (robustness, refine, limits: ``(low, high)`` field texts per functional constraint).

    Returns
    -------
    str
        What was started.

    Raises
    ------
    JobBusy
        When another job runs.
    StudyDefinitionError
        For a malformed value.
    """
    if kind == "section":
        tid = parse_trial_id(values.get("trial"))
        ctx.cache.row_of(tid)
        param = ctx.cache.check_name(values.get("param"), "parameter")
        points = parse_number(values.get("points"), "points", allow_empty=False, example="21")
        assert points is not None
        if not (points.is_integer() and 2 <= points <= 10_000):
            raise StudyDefinitionError("points", f"expected 2..10000, got {points:g}", "e.g. 21")
        lo = parse_number(values.get("lo"), f"range low of {param}", empty_means="the full box")
        hi = parse_number(values.get("hi"), f"range high of {param}", empty_means="the full box")
        rng = None
        if (lo is None) != (hi is None):
            raise StudyDefinitionError(
                "section range", "only one end of the range was given", "give both or neither"
            )
        if lo is not None and hi is not None:
            if not lo < hi:
                raise StudyDefinitionError(
                    "section range", f"expected low < high, got {lo:g} .. {hi:g}", "swap them"
                )
            rng = [lo, hi]
        params = {"trial": tid, "param": param, "points": int(points), "range": rng}
        label = f"section through trial {tid} along {param} ({int(points)} points)"
    elif kind == "robustness":
        tid = parse_trial_id(values.get("trial"))
        ctx.cache.row_of(tid)
        radius = parse_number(values.get("radius"), "radius", allow_empty=False, example="0.02")
        points = parse_number(values.get("points"), "points", allow_empty=False, example="32")
        assert radius is not None and points is not None
        if not 0 < radius <= 1:
            raise StudyDefinitionError(
                "radius", f"expected 0 < radius <= 1, got {radius:g}", "0.02"
            )
        if not (points.is_integer() and 4 <= points <= 4096):
            raise StudyDefinitionError("points", f"expected 4..4096, got {points:g}", "e.g. 32")
        c = parse_constraints(
            ctx.spec, values.get("limit_texts"), values.get("roles"), values.get("functional")
        )
        params = {
            "trial": tid,
            "radius": radius,
            "points": int(points),
            "limits": c.overrides,
            "roles": c.roles,
        }
        label = f"robustness check of trial {tid} (radius {radius:g}, {int(points)} points)"
    elif kind in ("refine", "continue"):
        n = parse_number(values.get("trials"), "trials", allow_empty=False, example="1024")
        assert n is not None
        if not (n.is_integer() and 1 <= n <= 100_000_000):
            raise StudyDefinitionError("trials", f"expected a whole number >= 1, got {n:g}", "1024")
        params = {"trials": int(n)}
        label = f"{int(n)} more trials in the current box"
        if kind == "refine":
            args = _refine_args(values.get("basis"), values.get("quantile"), values.get("margin"))
            a, c = analysis_of(
                ctx, values.get("limit_texts"), values.get("roles"), values.get("functional")
            )
            _, _, stages = ctx.cache.state()
            bounds = _overrides(ctx, a, stages, args, values.get("rows"))
            propose_refine(a, stages, bounds=bounds, **args)  # validate here, visibly
            params.update(args, bounds=bounds, limits=c.overrides, roles=c.roles)
            label = f"new stage in the refined box, {int(n)} trials" + (
                f" (edited: {', '.join(bounds)})" if bounds else ""
            )
    elif kind == "limits":
        params = limits_to_save(
            ctx, values.get("limit_texts"), values.get("roles"), values.get("functional")
        )
        label = "saving the constraints in force with the study"
    else:
        raise StudyDefinitionError("job", f"unknown job {kind!r}", "use the buttons")
    ctx.jobs.start(kind, params, label)
    return f"started: {label}"


def job_action(ctx: UIContext, action: str, **values: Any) -> dict[str, Any]:
    """A job button pressed: start the job (:func:`start_job`) or, for ``"stop"``, stop the
    running one; never raises for what a user can cause.

    Returns
    -------
    dict
        ``text`` (the message to show) and ``busy``: the id of the running job when the
        request was refused because that job runs (the message then lasts only while it
        runs, see :func:`job_message`), else None.
    """
    try:
        if action == "stop":
            text = "stopping the job…" if ctx.jobs.stop() else "no job is running"
            return {"text": text, "busy": None}
        return {"text": start_job(ctx, action, **values), "busy": None}
    except JobBusy as exc:
        return {"text": str(exc), "busy": ctx.jobs.status().id}
    except VectoridError as exc:
        return {"text": str(exc), "busy": None}


def job_message(ctx: UIContext, note: Mapping[str, Any] | None) -> str:
    """The message under the job bar for a note of :func:`job_action`: its text, except
    that "a job is already running" clears once the job it names is no longer running."""
    note = page_table(note, "job note")
    if not note:
        return ""
    busy = note.get("busy")
    if busy is not None:
        st = ctx.jobs.status()
        if st.id != busy or not st.running:
            return ""
    return str(note.get("text", ""))


def job_view(ctx: UIContext) -> dict[str, Any]:
    """The job's status for the progress bar: ``state``, ``label``, ``message``,
    ``progress`` (0..1 or None), ``elapsed`` (s), ``id``, and ``text`` (one line)."""
    st = ctx.jobs.status().to_dict()
    if st["state"] == "idle":
        text = "no background job"
    elif st["state"] == "running":
        pct = "" if st["progress"] is None else f" {100 * st['progress']:.0f}%"
        text = f"running{pct}: {st['label']} ({st['elapsed']:.0f} s)"
    else:
        text = f"{st['state']}: {st['label']} — {st['message']} ({st['elapsed']:.1f} s)"
    st["text"] = text
    return st
