"""``vectorid demo parafoil --next-drop``: fly the best planned second drop on the twin and
identify the 33 gains again with both drops (issue 34, item 4).

The default demo ranks planned second drops by their worth for stage 2's D
(:func:`vectorid.workflows.design.design`: the share of D their data would keep). With
``--next-drop`` it then does what the ranking only estimates:

1. **Fly the best plan** (rank 1) with the generator's truth
   (``scripts/make_parafoil_demo_data.py``, whose settings the data folder's ``truth.json``
   states): its gains, the flap actuator lag, the payload joint's pitch stiffness the model
   lacks and seeded Dryden gusts (``truth["seed"]`` + :data:`NEXT_SEED_OFFSET`), in the
   dropsonde's wind, from the plan's initial state; recorded at the plan's channels and rates
   with the generator's sensor noise (the plan states it: Gauss-Markov GPS position plus white
   noise, velocity, IMU attitude and rates) and the flap commands logged at 10 Hz. The record
   ends at the plan's duration or where the payload reaches the ground. Files: ``data-next/``
   (one CSV per channel, ``controls.csv``, ``flight.json`` saying what was flown).
2. **Identify again with both drops**: stage 2's study (33 gains in their full boxes, the
   sequential sampler) with the eight criteria on drop 1 and the plan's criteria (those the
   ranking judged it by) on drop 2, every limit the noise floor at the study's joint 95 %
   coverage over all of them plus the same discrepancy allowance (a drop-2 criterion gets
   its drop-1 namesake's), written as ``parafoil-two-drops.toml`` (``vectorid run`` reruns
   it). Drop 2 is compared over the span the ranking judged it on (its start to where the
   first member of D would land), so the two judge the same data.
3. **Print one drop against two**: the gains' verdicts (counts, the names that changed), the
   combinations identified, whether the truth lies inside every gain's and every
   combination's range, N / members of D / evaluations; and the direct check of the
   ranking: the weighted share of stage 2's D that meets drop 2's limits on the flown data,
   against the ranking's estimate and its interval.

If every plan would reject the truth, or none would shrink D, nothing is flown and the demo
says so.
"""

from __future__ import annotations

import json
import math
import re
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._toml import toml_value
from ..analysis.combinations import identifiable_combinations
from ..analysis.identifiability import VERDICTS
from ..analysis.weights import trial_weights
from ..workflows.stages import IdentificationStage, print_stage_limits, run_stage
from ..workflows.truth import truth_in_ranges
from .g12 import DEMO_EXECUTOR
from .parafoil import (
    BANDS,
    CRITERIA,
    DEMO_DISCREPANCY,
    DT,
    HINTS,
    MODEL_OPTIONS,
    OUTPUT_DT,
    SHORT,
    _drop_lines,
    _lagged,
    gain_meanings,
    gain_unit,
    truth_model,
)

__all__ = [
    "NEXT_DATA",
    "NEXT_SEED_OFFSET",
    "FlownDrop",
    "fly_plan",
    "run_next_drop",
    "two_drop_toml",
]

#: Drop 2's gusts and sensor noise draw with the embedded drop's seed plus this (stated in
#: the output and in ``flight.json``; never the embedded drop's own seed).
NEXT_SEED_OFFSET = 1000
#: The truth's integration and output step, s (the generator's: 100 Hz).
RECORD_DT = 0.01
#: Flap commands logged, Hz (the generator's).
CONTROLS_HZ = 10.0
#: The folder, under the demo's, that holds the flown drop's files.
NEXT_DATA = "data-next"
#: Channels a flown record is written for and compared on (CSV per channel).
RECORDED = {
    "position": (("north", "east", "down"), "m"),
    "velocity": (("north", "east", "down"), "m/s"),
    "euler": (("roll", "pitch", "yaw"), "deg"),
    "rates": (("p", "q", "r"), "rad/s"),
}
#: The store of the two-drop identification.
TWO_DROPS = "parafoil-two-drops"
#: Twins of the plan that drop 2's allowance is read from (:func:`plan_allowance`), their
#: seeds' offset from the embedded drop's (other than :data:`NEXT_SEED_OFFSET`'s), and the
#: share of them in which the truth must meet every drop-2 limit (the rule of drop 1's
#: allowance, ``scripts/parafoil_discrepancy.py``: 45 of 50 twins).
PLAN_TWINS = 20
TWIN_SEED_OFFSET = 2000
TWIN_COVERAGE = 0.9


@dataclass
class FlownDrop:
    """A planned drop flown by the generator's truth and recorded (:func:`fly_plan`).

    Attributes
    ----------
    name : str
        The plan's drop name (drop 2's name in the two-drop study).
    folder : Path
        Where its files are.
    files : list of dict
        The ``files = [...]`` entries of a study's ``[[identification.drops]]`` table, paths
        relative to the folder above ``folder`` (the demo's).
    channels : dict of str to float
        Channel -> rate, Hz, of the record.
    samples : dict of str to int
        Channel -> samples recorded.
    span : float
        s of record (from the release).
    landed : float or None
        s from the release at which the payload reached the ground (None: still flying at
        the plan's duration).
    seed : int
        The gusts' and the noise's seed.
    not_recorded : list of str
        The plan's channels no file is written for (no CSV mapping for them here).
    """

    name: str
    folder: Path
    files: list[dict[str, Any]]
    channels: dict[str, float]
    samples: dict[str, int]
    span: float
    landed: float | None
    seed: int
    not_recorded: list[str] = field(default_factory=list)


def _write_csv(path: Path, header: Sequence[str], cols: Sequence[np.ndarray], fmt: str) -> None:
    lines = [",".join(header)]
    lines += [",".join(fmt.format(v) for v in row) for row in zip(*cols)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def fly_plan(
    plan: str | Path,
    truth: Mapping[str, Any],
    folder: str | Path,
    *,
    seed: int,
    noise: bool = True,
    base: str | Path | None = None,
) -> FlownDrop:
    """Fly a planned drop (a drop file of one planned drop, :mod:`vectorid.identify.planned`)
    with the generator's truth and write its noisy record into ``folder``.

    Parameters
    ----------
    plan : path
        The plan's drop file (its initial state, duration, channels and rates in Hz, flap
        schedule, wind file and sensor noise).
    truth : mapping
        The data folder's ``truth.json``: true gains (``parameters``), ``actuator_lag_s`` (s),
        ``joint_stiffness_Nm_rad``, ``joint_damping_Nms_rad``, ``w20_ms`` (m/s),
        ``origin_altitude_m`` (m above sea level).
    folder : path
        Where the CSV files and ``flight.json`` go (created); a study one level up reads them.
    seed : int
        Seeds the Dryden gusts and the sensor noise.
    noise : bool
        Add the plan's sensor noise (default); False writes the truth's exact outputs in the
        same gusts (the same seed), to check a record's noise against.
    base : path, optional
        The folder the study that reads the files is in (default: the one above ``folder``).

    Returns
    -------
    FlownDrop
    """
    from ..errors import StudyDefinitionError
    from ..identify.identification import sim_channel
    from ..identify.planned import read_drop_file
    from ..identify.twins import ZeroMeanUpdraft
    from ..models import Wind, flap_deflections
    from ..models import get as get_model

    plan, folder = Path(plan), Path(folder)
    model = get_model("parafoil8dof", **MODEL_OPTIONS)
    drops = read_drop_file(plan, model, study_noise=truth["sensor_noise"], output_dt=OUTPUT_DT,
                           init_span=1.0, dt=DT)  # fmt: skip
    if len(drops) != 1 or drops[0].kind != "planned":
        raise StudyDefinitionError(
            plan.name, f"expected one planned drop, got {len(drops)} drop(s)",
            "give a drop file of one planned drop (initial = ..., no data files)",
        )  # fmt: skip
    d = drops[0]
    if d.noise is None:
        raise StudyDefinitionError(
            f"{plan.name}: noise", "the plan states no sensor noise, so no record can be made",
            "state noise = { ... } for its sensors",
        )  # fmt: skip
    tm, x = truth_model(truth)
    n = round(d.duration / RECORD_DT)
    t = np.arange(n + 1) * RECORD_DT
    if d.inputs is not None:
        cmd = d.inputs(t)
        chans = list(d.inputs.channels)
        left = cmd[:, chans.index("flap_left")] if "flap_left" in chans else np.zeros_like(t)
        right = cmd[:, chans.index("flap_right")] if "flap_right" in chans else np.zeros_like(t)
    else:
        left = right = np.zeros_like(t)
    lag = float(truth["actuator_lag_s"])
    inputs = flap_deflections(t, _lagged(t, left, lag), _lagged(t, right, lag))
    origin = float(d.origin_altitude)
    ground = float(d.ground_altitude if d.ground_altitude is not None else origin)
    rng = np.random.default_rng(seed)
    turb = ZeroMeanUpdraft(w20=float(truth["w20_ms"]), seed=rng, v_ref=15.0, dt=0.05,
                           ground_altitude=ground)  # fmt: skip
    res = tm.simulate(x[None, :], t_final=float(t[-1]), dt=RECORD_DT, inputs=inputs,
                      wind=Wind(d.wind, turb), output_dt=RECORD_DT, initial=d.initial)  # fmt: skip
    if res.status[0] != 0:
        raise RuntimeError(f"the truth failed to fly {plan.name}: {res.messages[0]}")
    pos = sim_channel(res, "position", origin)[0]
    height = -pos[:, 2] - (ground - origin)
    below = np.flatnonzero(height <= 0.0)
    landed = float(res.t[below[0]]) if below.size else None
    keep = res.t < landed if landed is not None else np.ones(res.t.size, dtype=bool)
    folder.mkdir(parents=True, exist_ok=True)
    rel = folder.relative_to(Path(base) if base is not None else folder.parent).as_posix()
    files: list[dict[str, Any]] = []
    rates: dict[str, float] = {}
    samples: dict[str, int] = {}
    not_recorded = []
    for ch, hz in d.channels.items():
        if ch not in RECORDED:
            not_recorded.append(ch)
            continue
        comps, unit = RECORDED[ch]
        step = round(1.0 / (float(hz) * RECORD_DT))
        k = np.arange(0, res.t.size, step)
        k = k[keep[k]]
        tk = res.t[k]
        y = sim_channel(res, ch, origin)[0][k].copy()
        for j in range(y.shape[1]):
            c = d.noise.component(ch, j)
            if c is not None and noise:
                y[:, j] += c.draw(tk, 1, rng)[0]
        if ch == "euler":
            y = np.rad2deg(y)
            y[:, 2] = np.mod(y[:, 2], 360.0)  # the IMU logs heading in [0, 360)
        cols = [f"{comp}_{unit.replace('/', '')}" for comp in comps]
        _write_csv(folder / f"{ch}.csv", ["time_s", *cols], [tk, *y.T], "{:.6g}")
        mapping: dict[str, Any] = {"time": "time_s", "time_unit": "s"}
        if ch in ("position", "velocity"):
            mapping[ch] = {**dict(zip(comps, cols)), "unit": unit}
        else:
            mapping[ch] = {"columns": cols, "unit": unit}
        if ch == "position":
            mapping["origin"] = [32.85, -114.39, origin]
            mapping["events"] = {"release": 0.0}
        files.append({"file": f"{rel}/{ch}.csv", "mapping": mapping})
        rates[ch] = float(hz)
        samples[ch] = int(k.size)
    kc = np.arange(0, res.t.size, round(1.0 / (CONTROLS_HZ * RECORD_DT)))
    kc = kc[keep[kc]]
    _write_csv(folder / "controls.csv", ["time_s", "flap_left", "flap_right"],
               [res.t[kc], left[kc], right[kc]], "{:.4g}")  # fmt: skip
    files.append({"file": f"{rel}/controls.csv", "mapping": {
        "time": "time_s", "time_unit": "s",
        "controls": {"columns": ["flap_left", "flap_right"], "unit": "1"}}})  # fmt: skip
    span = float(res.t[keep][-1])
    (folder / "flight.json").write_text(
        json.dumps(
            {
                "plan": plan.name,
                "drop": d.name,
                "seed": int(seed),
                "flown_by": "the generator's truth (scripts/make_parafoil_demo_data.py): its "
                "gains, flap lag, payload joint stiffness and Dryden gusts, in the dropsonde's "
                "wind",
                "parameters": dict(truth["parameters"]),
                "actuator_lag_s": lag,
                "joint_stiffness_Nm_rad": list(truth["joint_stiffness_Nm_rad"]),
                "joint_damping_Nms_rad": list(truth["joint_damping_Nms_rad"]),
                "w20_ms": float(truth["w20_ms"]),
                "wind": d.wind_text,
                "channels_hz": rates,
                "samples": samples,
                "not_recorded": not_recorded,
                "sensor_noise": truth["sensor_noise"],
                "record_s": span,
                "landed_s": landed,
                "origin_altitude_m": origin,
            },
            indent=1,
        )
        + "\n",
        encoding="utf-8",
    )
    return FlownDrop(d.name, folder, files, rates, samples, span, landed, int(seed), not_recorded)


def _judged_span(candidate: Any, flown: FlownDrop) -> float:
    """The span (s) drop 2 is compared over: the ranking's (its note "judged over its first
    T s" where a member of D would land first) within the record, on the study's grid."""
    end = flown.span
    for note in candidate.notes:
        m = re.search(r"judged over its first ([0-9.eE+-]+) s", note)
        if m:
            end = min(end, float(m.group(1)))
    return math.floor(end / OUTPUT_DT + 1e-9) * OUTPUT_DT


def plan_criteria(candidate: Any) -> list[tuple[str, str, str, str, str]]:
    """The drop-2 criteria of the two-drop study: (name, library criterion, role, unit, the
    drop-1 criterion it comes from), one per criterion the ranking judged the plan by."""
    meta = {c[0]: c for c in CRITERIA}
    out = []
    for key, v in candidate.criteria.items():
        src = v["from"]
        use = key.rsplit("@", 1)[0]
        _, _, role, unit, _ = meta[src]
        out.append((f"{src}_2", use, role, unit, src))
    return out


def two_drop_toml(
    truth: Mapping[str, Any],
    flown: FlownDrop,
    criteria2: Sequence[tuple[str, str, str, str, str]],
    *,
    window_end: float,
    trials: int,
    budget: int,
    population: int,
    plan: str = "",
    allowance: Mapping[str, float] | None = None,
    allowance_note: str = "",
) -> str:
    """The two-drop study (TOML): stage 2's 33 gains in their full boxes, the sequential
    sampler, the demo's eight criteria on drop 1 and ``criteria2`` (:func:`plan_criteria`)
    on the flown drop 2 over ``[0, window_end]`` s, every limit the noise floor at the joint
    95 % coverage over all of them plus the demo's discrepancy allowance (a drop-2 criterion
    gets its drop-1 namesake's); ``allowance`` (drop-2 criterion -> allowance in its unit)
    replaces a drop-2 criterion's own (:func:`plan_allowance`), ``allowance_note`` says
    where it comes from."""
    from ..models import get as get_model

    model = get_model("parafoil8dof", **MODEL_OPTIONS)
    meanings = gain_meanings()
    lines = [
        f"# vectorid demo parafoil --next-drop: stage 2's 33 gains identified with the demo's "
        f"drop and the flown plan {plan}",
        "# (drop 2: the generator's truth flown on the plan, recorded with its sensor noise; "
        f"{NEXT_DATA}/flight.json)",
        "[study]",
        f'name = "{TWO_DROPS}"',
        'model = "parafoil8dof"',
        f"trials = {int(trials)}",
        "seed = 1",
        'sampler = "sequential"',
        f"budget = {int(budget)}",
        f"population = {int(population)}",
        f'executor = "{DEMO_EXECUTOR}"  # one model process: its kernel runs a batch on all cores',
        "",
    ]
    for p in model.parameters:
        lines += ["[[variables]]", f'name = "{p.name}"', f"low = {float(p.low)!r}",
                  f"high = {float(p.high)!r}", f"nominal = {float(p.nominal)!r}",
                  f"unit = {json.dumps(gain_unit(p.name))}",
                  f"description = {json.dumps(meanings.get(p.name, ''))}", ""]  # fmt: skip
    for cname, _, role, unit, _ in CRITERIA:
        lines += ["[[criteria]]", f'name = "{cname}"', f'role = "{role}"', f'unit = "{unit}"', ""]
    for cname, _, role, unit, _ in criteria2:
        lines += ["[[criteria]]", f'name = "{cname}"', f'role = "{role}"', f'unit = "{unit}"', ""]
    disc = dict(DEMO_DISCREPANCY)
    for cname, _, _, _, src in criteria2:
        if src in DEMO_DISCREPANCY:
            disc[cname] = DEMO_DISCREPANCY[src]
    disc.update({k: float(v) for k, v in (allowance or {}).items()})
    lines += [
        "[identification]",
        f"dt = {DT}",
        f"output_dt = {OUTPUT_DT}",
        "init_span = 1.0",
        f"model_options = {toml_value(dict(MODEL_OPTIONS))}",
        "# the sensor noise the generator added (scripts/make_parafoil_demo_data.py), the same",
        "# sensors on both drops:",
        f"noise = {toml_value(truth['sensor_noise'])}",
        'limits = "noise"     # each criterion: its noise floor (joint 95 % over all) + allowance',
        "# the demo's allowance; a drop-2 criterion (NAME_2) gets its drop-1 namesake's"
        + (f",\n# {allowance_note}" if allowance_note else "")
        + ":",
        f"discrepancy = {toml_value(disc)}",
        "",
    ]
    for cname, use, _, _, _ in CRITERIA:
        if "{}" in use:
            use = use.format(*BANDS[cname.split("_")[-1]])
        lines += [f"[identification.criteria.{cname}]", f'use = "{use}"', 'drops = ["drop"]', ""]
    for cname, use, _, _, _ in criteria2:
        lines += [f"[identification.criteria.{cname}]", f'use = "{use}"',
                  f"drops = [{json.dumps(flown.name)}]", ""]  # fmt: skip
    lines += _drop_lines(truth)
    lines += [
        "",
        "[[identification.drops]]",
        f"name = {json.dumps(flown.name)}",
        "files = [",
        *(f"  {toml_value(f)}," for f in flown.files),
        "]",
        'wind = "data/wind.csv"',
        'wind_format = "dropsonde"',
        'wind_options = { altitude = "altitude_m", u = "u_ms", v = "v_ms" }',
        f"window = [0.0, {float(window_end)!r}]   # s from the release: the span the ranking "
        "judged",
        'interpolation = "linear"',
    ]
    return "\n".join(lines) + "\n"


def _criteria_table(spec: Any, names: Sequence[str]) -> dict[str, Any]:
    """The study's ``[identification]`` table to evaluate its criteria ``names`` alone with
    (no limits: the allowance names criteria left out)."""
    skip = {"parameters", "discrepancy", "limits"}
    table = {k: v for k, v in spec.extra["identification"].items() if k not in skip}
    table["criteria"] = {k: v for k, v in table["criteria"].items() if k in names}
    return table


def _round_up(v: float) -> float:
    """``v`` rounded up to two significant digits (an allowance is stated, not fitted)."""
    if v <= 0:
        return 0.0
    e = math.floor(math.log10(v)) - 1
    return float(f"{math.ceil(v / 10.0**e - 1e-9) * 10.0**e:.12g}")


def plan_allowance(
    plan: Path,
    truth: Mapping[str, Any],
    out: Path,
    criteria2: Sequence[tuple[str, str, str, str, str]],
    limits: Mapping[str, float],
    *,
    window_end: float,
    twins: int = 20,
    coverage: float = 0.9,
) -> tuple[dict[str, float], dict[str, float], float]:
    """How much more allowance than drop 1's each drop-2 criterion needs for the generator's
    truth to meet its limit on this plan, read from ``twins`` twins of the plan (the truth
    flown with other gusts and sensor noise: seeds ``truth["seed"]`` +
    :data:`TWIN_SEED_OFFSET` + k, never the flown drop's), as the demo's allowance was read
    for drop 1 (``scripts/parafoil_discrepancy.py``): per criterion the largest excess of the
    model at the true gains over its limit, after leaving out the (1 - ``coverage``) share of
    twins whose exclusion lowers the excesses most.

    Returns
    -------
    extra : dict
        Drop-2 criterion -> the extra allowance it needs, in its unit (0: none).
    worst : dict
        Drop-2 criterion -> the largest value / limit over the twins under ``limits``.
    met : float
        Share of the twins in which the truth meets every drop-2 limit of ``limits``.
    """
    import shutil
    import tomllib

    from ..identify import Identification
    from ..spec import StudySpec

    names = [c[0] for c in criteria2]
    folder = out / f"{NEXT_DATA}-twins"
    rows = []
    try:
        for k in range(twins):
            seed = int(truth["seed"]) + TWIN_SEED_OFFSET + k
            f = fly_plan(plan, truth, folder / f"t{k}", seed=seed, base=out)
            text = two_drop_toml(truth, f, criteria2, window_end=window_end, trials=64,
                                 budget=64, population=20)  # fmt: skip
            spec = StudySpec.from_dict(tomllib.loads(text), base_dir=out)
            table = _criteria_table(spec, names)
            ident = Identification.from_table(
                table, variables=list(spec.space.names), criteria=names, base_dir=out,
                default_model="parafoil8dof",
            )  # fmt: skip
            x = np.array([[truth["parameters"].get(n, v.nominal) for n, v in
                           zip(spec.space.names, spec.space, strict=True)]])  # fmt: skip
            rows.append(ident.evaluate(x)[0][0])
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    F = np.array(rows)
    L = np.array([limits[n] for n in names])
    A = np.maximum(np.nan_to_num(F - L[None, :], nan=np.inf), 0.0)
    keep = np.ones(len(A), dtype=bool)
    scale = np.where(np.isfinite(A.max(axis=0)) & (A.max(axis=0) > 0), A.max(axis=0), 1.0)
    for _ in range(int(np.floor((1.0 - coverage) * len(A) + 1e-9))):
        cost = []
        for i in np.flatnonzero(keep):
            kk = keep.copy()
            kk[i] = False
            cost.append((float(np.sum(np.minimum(A[kk].max(axis=0) / scale, 1e12))), int(i)))
        keep[min(cost)[1]] = False
    extra = {n: float(v) for n, v in zip(names, A[keep].max(axis=0), strict=True)}
    worst = {n: float(np.nanmax(F[:, j]) / L[j]) for j, n in enumerate(names)}
    met = float(np.mean(np.all(F <= L[None, :], axis=1)))
    return extra, worst, met


def _counts(verdicts: Sequence[Any]) -> dict[str, int]:
    return {k: sum(v.verdict == k for v in verdicts) for k in VERDICTS}


def _combos_inside(combos: Sequence[Any], true: Mapping[str, float]) -> list[bool]:
    out = []
    for c in combos:
        v = c.value_of(true)
        out.append(bool(c.range[0] <= v <= c.range[1]))
    return out


def _flown_criteria(
    a2: Any, spec_two: Any, criteria2: Sequence[tuple[str, ...]]
) -> tuple[np.ndarray, np.ndarray]:
    """Drop 2's criteria (``criteria2``) of stage 2's D's members on the flown data, (m, q),
    and the members' weights (mean 1)."""
    from ..identify import Identification

    names = [c[0] for c in criteria2]
    table = _criteria_table(spec_two, names)
    ident = Identification.from_table(
        table, variables=list(spec_two.space.names), criteria=names,
        base_dir=spec_two.base_dir, default_model="parafoil8dof",
    )  # fmt: skip
    rows = np.flatnonzero(a2.feasible)
    w = trial_weights(a2, a2.feasible)
    w = np.ones(rows.size) if w is None else np.asarray(w, dtype=float)
    return ident.evaluate(a2.trials.X[rows])[0], w


def _kept(
    F: np.ndarray, w: np.ndarray, names: Sequence[str], limits: Mapping[str, float]
) -> tuple[float, int, dict[str, float]]:
    """The weighted share of the members that meet every limit (a failed flight, NaN, meets
    none), how many do, and per criterion the weighted share that fails it."""
    L = np.array([limits[n] for n in names])
    ok = F <= L[None, :]
    meet = np.all(ok, axis=1)
    fails = {n: float(w[~ok[:, j]].sum() / w.sum()) for j, n in enumerate(names)}
    return float(w[meet].sum() / w.sum()), int(meet.sum()), fails


def run_next_drop(
    out: Path,
    truth: Mapping[str, Any],
    st2: IdentificationStage,
    design: Any,
    *,
    trials: int,
    budget: int,
    population: int,
    progress: bool = True,
    executor: str | None = None,
) -> dict[str, Any] | None:
    """Fly the ranking's best plan on the twin, identify again with both drops and print one
    drop against two (module docstring).

    Parameters
    ----------
    out : Path
        The demo's folder (the plans, ``data/``, stage 2's store).
    truth : mapping
        The data folder's ``truth.json``.
    st2 : IdentificationStage
        Stage 2 (one drop).
    design : vectorid.workflows.design.Design or None
        The ranking of the planned drops (None: there was none).
    trials, budget, population : int
        The two-drop study's first generation, most evaluations and members of D wanted
        (stage 2's).
    progress : bool
    executor : str, optional

    Returns
    -------
    dict or None
        What was printed, as numbers (also written to ``next-drop.json``); None when no plan
        was flown.
    """
    from ..spec import load_study
    from .parafoil import _truth_in_d

    t0 = time.perf_counter()
    print()
    print("--next-drop: fly the best planned drop on the twin and identify again with both drops")
    if design is None:
        print("  nothing to fly: there is no ranking (stage 2's D is empty)")
        return None
    cands = sorted(design.candidates, key=lambda c: c.rank)
    if all(c.rejects_truth for c in cands):
        print("  nothing flown: every plan would reject the truth (see the ranking above)")
        return None
    if design.none_shrinks:
        print("  nothing flown: no plan would shrink D (see the ranking above)")
        return None
    best = cands[0]
    plan = Path(best.file)
    seed = int(truth["seed"]) + NEXT_SEED_OFFSET
    flown = fly_plan(plan, truth, out / NEXT_DATA, seed=seed)
    end = _judged_span(best, flown)
    duration = _plan_duration(plan)
    landed = (
        f"it lands at {flown.landed:.1f} s of the plan's {duration:g} s"
        if flown.landed is not None
        else f"it is still flying at the plan's end, {duration:g} s"
    )
    print(
        f"  flown: {best.name} (rank 1: keeps {100 * best.expected_fraction_kept:.1f} % of D "
        f"[{100 * best.interval[0]:.1f}, {100 * best.interval[1]:.1f}] by the ranking)\n"
        f"    by the generator's truth: its gains, {truth['actuator_lag_s']:g}-s flap lag, "
        f"payload joint stiffness\n    {truth['joint_stiffness_Nm_rad'][0]:g} N m/rad, Dryden "
        f"gusts W20 = {truth['w20_ms']:g} m/s (seed {seed}), in the dropsonde's wind;\n"
        f"    {landed}; recorded with the generator's noise (samples): "
        + ", ".join(f"{c} {hz:g} Hz ({flown.samples[c]})" for c, hz in flown.channels.items())
        + f"\n    files in {flown.folder} (flight.json: what was flown)"
    )
    if flown.not_recorded:
        print(f"    not recorded (no file mapping here): {', '.join(flown.not_recorded)}")
    crit2 = plan_criteria(best)
    # the ranking judged the plan with the study's allowance, read on drop 1's manoeuvre; the
    # truth's own twins of the plan say whether it covers what the model lacks on this one
    lim_rank = {f"{v['from']}_2": float(v["limit"]) for v in best.criteria.values()}
    extra, worst, met = plan_allowance(plan, truth, out, crit2, lim_rank, window_end=end,
                                       twins=PLAN_TWINS, coverage=TWIN_COVERAGE)  # fmt: skip
    units = {c[0]: c[3] for c in crit2}
    own = {c[0]: DEMO_DISCREPANCY.get(c[4], 0.0) for c in crit2}
    widened = {n: _round_up(own[n] + e) for n, e in extra.items() if e > 0}
    seeds = f"seeds {int(truth['seed']) + TWIN_SEED_OFFSET}-" + str(
        int(truth["seed"]) + TWIN_SEED_OFFSET + PLAN_TWINS - 1
    )
    print(
        f"  does drop 1's allowance cover what the model lacks on this plan? {PLAN_TWINS} twins "
        f"of the plan\n    (the truth flown in other gusts and noise, {seeds}): at the true "
        f"gains every drop-2 limit of the\n    ranking holds in {100 * met:.0f} % of them"
    )
    for n, a in widened.items():
        print(
            f"    {n}: the truth reaches {worst[n]:.3g}x its limit; its allowance in {units[n]} "
            f"{own[n]:g} -> {a:g} (beside any channel's;\n      covers "
            f"{100 * TWIN_COVERAGE:.0f} % of the twins, rounded up)"
        )
    if not widened:
        cover = f"{100 * TWIN_COVERAGE:.0f} %"
        print(f"    it does: drop 1's allowance stands (covers {cover} of the twins)")
    note = (
        f"allowances of {', '.join(widened)} read from {PLAN_TWINS} twins of the plan ({seeds}; "
        f"the truth meets every drop-2 limit in {100 * TWIN_COVERAGE:.0f} % of them)"
        if widened
        else ""
    )
    f_two = out / f"{TWO_DROPS}.toml"
    f_two.write_text(
        two_drop_toml(truth, flown, crit2, window_end=end, trials=trials, budget=budget,
                      population=population, plan=plan.name, allowance=widened,
                      allowance_note=note),
        encoding="utf-8",
    )  # fmt: skip
    print(
        f"  study {f_two.name}: stage 2's 33 gains, the eight criteria on drop 1 and "
        f"{len(crit2)} on drop 2\n    ({', '.join(c[0] for c in crit2)});\n    drop 2 "
        f"compared over its first {end:g} s (the span the ranking judged); limits: each "
        f"noise floor\n    at the joint 95 % over all {len(CRITERIA) + len(crit2)} criteria "
        f"+ the allowance above\n    (rerun: cd {out} && vectorid run {f_two.name})"
    )
    sys.stdout.flush()
    spec = load_study(f_two)
    st = run_stage(spec, out / f"{TWO_DROPS}.db", trials=trials, budget=budget,
                   population=population, sampler="sequential", progress=progress,
                   name="two drops", meanings=SHORT, hints=HINTS,
                   executor=executor)  # fmt: skip
    r, r1 = st.result, st2.result
    a, a1 = r.analysis, r1.analysis
    true = truth["parameters"]
    print(f"  two drops   store {r.store}   ({r.elapsed:.1f} s)")
    print_stage_limits(st, indent="    ")
    from ..identify import Identification

    ratio = [st.noise_limits[c[0]] / st2.noise_limits[c[0]] for c in CRITERIA
             if c[0] in st.noise_limits and st2.noise_limits.get(c[0])]  # fmt: skip
    if ratio:
        print(
            f"    drop 1's limits are {min(ratio):.2f}-{max(ratio):.2f}x stage 2's (the joint "
            f"95 % now spans {len(st.noise_limits)} criteria, not {len(st2.noise_limits)})"
        )
    ok_d, text = _truth_in_d(st, Identification.from_spec(r.spec), true)
    print(f"    the generator's truth {text}")
    # ---- one drop against two -------------------------------------------------------
    c1, c2 = _counts(r1.verdicts), _counts(r.verdicts)
    v1 = {v.name: v for v in r1.verdicts}
    changed = [(v.name, v1[v.name].verdict, v.verdict) for v in r.verdicts
               if v.name in v1 and v.verdict != v1[v.name].verdict]  # fmt: skip
    in1, in2 = truth_in_ranges(r1.verdicts, true), truth_in_ranges(r.verdicts, true)
    co1 = identifiable_combinations(a1)
    co2 = identifiable_combinations(a)
    ci1, ci2 = _combos_inside(co1, true), _combos_inside(co2, true)
    e1 = st2.sequential.evaluations if st2.sequential is not None else a1.n
    e2 = st.sequential.evaluations if st.sequential is not None else a.n
    print()
    print("  one drop against two (the 33 gains; verdicts by the same rules):")
    print(f"    {'':<36}{'one drop':>12}{'two drops':>12}")
    for k in VERDICTS:
        print(f"    {'gains ' + k:<36}{c1[k]:>12}{c2[k]:>12}")
    n_id1 = sum(c.identified for c in co1)
    n_id2 = sum(c.identified for c in co2)
    rows = [
        ("combinations identified", n_id1, n_id2),
        ("combinations weak", len(co1) - n_id1, len(co2) - n_id2),
        ("truth inside the gains' ranges", f"{sum(bool(x) for x in in1.values())}/{len(in1)}",
         f"{sum(bool(x) for x in in2.values())}/{len(in2)}"),
        ("truth inside the combinations' ranges", f"{sum(ci1)}/{len(ci1)}",
         f"{sum(ci2)}/{len(ci2)}"),
        ("N (trials)", a1.n, a.n),
        ("members of D", a1.n_feasible, a.n_feasible),
        ("model evaluations", e1, e2),
    ]  # fmt: skip
    for label, x1, x2 in rows:
        print(f"    {label:<36}{x1!s:>12}{x2!s:>12}")
    if changed:
        print("    verdicts that changed: " + ", ".join(f"{n} {o} -> {w}" for n, o, w in changed))
    else:
        print("    no gain's verdict changed")
    miss = [n for n, x in in2.items() if x is False]
    if miss:
        v2 = {v.name: v for v in r.verdicts}
        far = [f"{n} {true[n]:.4g} not in [{v2[n].feasible[0]:.4g}, {v2[n].feasible[1]:.4g}]"
               for n in miss]  # fmt: skip
        print("    the truth lies OUTSIDE the two-drop range of: " + ", ".join(far))
    if (miss or not all(ci2)) and ok_d:
        print(
            "    yet the truth meets every limit, so it is in D: the members sampled miss the "
            "part of D it lies\n    in (near D's boundary; the truth nearly binds a limit), "
            "so read those ranges as too narrow"
        )
    gained = (c2["identified"] + c2["weak"]) - (c1["identified"] + c1["weak"])
    if gained > 0:
        print(
            f"    with the second drop {c2['identified'] + c2['weak']} gains are identified or "
            f"weak against {c1['identified'] + c1['weak']} with one"
        )
    else:
        print(
            f"    the second drop identifies no more gains: {c2['identified'] + c2['weak']} "
            f"identified or weak against {c1['identified'] + c1['weak']} with one drop"
            + (f"; it pins {n_id2 - n_id1} more combination(s)" if n_id2 > n_id1 else "")
        )
    if co2:
        print("    the narrowest combinations with both drops (z(g) = (g - low)/(high - low)):")
        for k, (c, ins) in enumerate(zip(co2[:4], ci2[:4]), 1):
            print(
                f"      c{k} {c.text(terms=4)}\n         range [{c.range[0]:.3f}, "
                f"{c.range[1]:.3f}], width {c.width_fraction:.0%} of a box side, {c.verdict}; "
                f"the truth {c.value_of(true):.3f}: {'inside' if ins else 'OUTSIDE'}"
            )
    # ---- the direct check of the ranking ------------------------------------------------
    lim2 = {c[0]: st.noise_limits[c[0]] for c in crit2}
    names2 = [c[0] for c in crit2]
    F2, w2 = _flown_criteria(a1, r.spec, crit2)
    n_eval = F2.shape[0]
    share, n_meet, _ = _kept(F2, w2, names2, lim2)
    share_r, n_meet_r, fails_r = _kept(F2, w2, names2, lim_rank)
    lo, hi = best.interval
    print(
        f"  the check of the ranking: the share of stage 2's D ({n_eval} members, weighted) "
        "that the flown drop 2\n    keeps, against the ranking's estimate "
        f"{100 * best.expected_fraction_kept:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}]:"
    )
    for label, sh, nm in (("under the ranking's limits (drop 1's allowance)", share_r, n_meet_r),
                          ("under the two-drop study's limits", share, n_meet)):  # fmt: skip
        where = "inside" if lo <= sh <= hi else ("below" if sh < lo else "above")
        print(f"    {label:<50}{100 * sh:6.1f} % ({nm} members), {where} its interval")
    worst_c = max(fails_r, key=fails_r.get)
    if share_r < lo and fails_r[worst_c] > 0.5:
        print(
            f"    under the ranking's limits {worst_c} alone fails for "
            f"{100 * fails_r[worst_c]:.0f} % of D: what the model lacks on this plan, which "
            "no member\n    playing the truth could show the ranking"
        )
    print(
        "    (the estimate averages over D's members playing the truth, each a model without "
        "what the\n    generator adds; the flown share is the generator's truth in one gust "
        "and noise realisation)"
    )
    took = time.perf_counter() - t0
    print(f"  (--next-drop took {took:.0f} s)")
    summary = {
        "plan": best.name,
        "seed": seed,
        "record_s": flown.span,
        "landed_s": flown.landed,
        "compared_s": end,
        "one_drop": {"verdicts": c1, "combinations_identified": n_id1,
                     "combinations": len(co1), "n": int(a1.n),
                     "n_feasible": int(a1.n_feasible), "evaluations": int(e1)},
        "two_drops": {"verdicts": c2, "combinations_identified": n_id2,
                      "combinations": len(co2), "n": int(a.n),
                      "n_feasible": int(a.n_feasible), "evaluations": int(e2),
                      "truth_in_d": bool(ok_d),
                      "truth_in_ranges": {k: bool(v) for k, v in in2.items() if v is not None},
                      "truth_in_combinations": f"{sum(ci2)}/{len(ci2)}",
                      "limits": {k: float(v) for k, v in st.noise_limits.items()}},
        "changed": [list(c) for c in changed],
        "flown_share_kept": share,
        "flown_share_kept_ranking_limits": share_r,
        "allowance_widened": widened,
        "twins_truth_meets_ranking_limits": met,
        "estimate": best.expected_fraction_kept,
        "interval": [float(lo), float(hi)],
        "seconds": took,
    }  # fmt: skip
    (out / "next-drop.json").write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    print(f"  (the numbers: {out / 'next-drop.json'})")
    sys.stdout.flush()
    return summary


def _plan_duration(plan: Path) -> float:
    import tomllib

    doc = tomllib.loads(plan.read_text(encoding="utf-8"))
    return float(doc["identification"]["drops"][0]["duration"])
