"""``vectorid demo parafoil``: seed 000 end to end on a drop of a cargo parafoil.

The embedded data (``vectorid/data/demo_parafoil/``, written by the seeded script
``scripts/make_parafoil_demo_data.py``) are one guided drop of the reference cargo parafoil —
a straight glide, a left and a right turn, a symmetric brake — flown by the 8-DoF model with a
richer truth than the identified one (gusts, flap actuator lag, a payload-joint pitch
stiffness the model does not have, an imperfect dropsonde), and logged by a GPS (4 Hz) and a
payload IMU (50 Hz) with noise. The demo runs the seed's workflow on SQLite stores:

1. **Stage 1** — a few gains (the seed's sets 1–5: control effectiveness, lift slope, drag,
   rigging, turn-control and yaw-damping gains) on the eight adequacy criteria of §VII
   (horizontal and vertical trajectory closeness, the roll, pitch and yaw spectra, speed and
   heading profiles, spectral shape of yaw), with double tuning: a coarse run, a box narrowed
   from the feasible set, the main run.
2. **Stage 2** — all 33 gains of Figure 12: the stage-1 gains in their narrowed box, the
   others in [0.2, 2] (additive ones in their boxes), 16,384 trials by default.
3. The **"quasi-optimal sets" table of Figure 12**: Set 0 (nominal), the stage-1 vector and
   the lowest-cost vectors of stage 2 side by side with their cost, and the range each
   parameter takes over the feasible and Pareto sets.
4. **Figure 14 turned into a proposal**: which gains the feasible set does not depend on (fix
   them at nominal) and which pairs are correlated among the near-optimal vectors (tie: keep
   one, fix the other at its median) — then **stage 3** on the reduced set, compared with
   stage 2 on the same cost.
5. **6-DoF against 8-DoF** on the same data and criteria: which spectral peaks of the measured
   payload motion the rigid model cannot produce.

Everything goes into ``--out`` (study files, data, stores, HTML reports), so ``vectorid table``,
``pareto``, ``report``, ``correlation`` and ``ui`` work on the stores afterwards.
"""

from __future__ import annotations

import json
import shutil
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "DEMO_DATA",
    "chosen_values",
    "print_chosen_values",
    "run_parafoil_demo",
    "stage_toml",
]

DEMO_DATA = Path(__file__).resolve().parent / "data" / "demo_parafoil"

#: Stage 1 (the seed's sets 1-5): a few gains with the widest boxes of the seed, [0.2, 2].
STAGE1 = ("delcon", "CLalpha", "CD0", "Rig", "CnDanom", "Cnr")
#: Model options of the identified model: the payload IMU's attitude is compared, and the
#: payload joint is the engineer's estimate of a lightly damped joint (pitch free, twist spring).
MODEL_OPTIONS = {"attitude": "payload", "joint_damping": [600.0, 250.0]}
#: Spectral bands (Hz): the roll mode of the system sits near 0.1 Hz; the payload's pitch and
#: twist modes between 0.4 and 1.1 Hz, above the turns' own frequencies.
BANDS = {"roll": (0.05, 0.5), "pitch": (0.25, 1.5), "yaw": (0.25, 1.5)}
#: The eight criteria of seed 000 §VII: study name, library criterion, role, explicit limit
#: (None: set from the trials, see run_step), unit and meaning. The trajectory and heading
#: criteria are pure; the spectral ones are pseudo-criteria with an engineering tolerance on
#: the peak frequency (the model flies without the drop's gusts, so a spectrum's shape and
#: level cannot match; its modes' frequencies can).
CRITERIA = (
    ("pos_h", "pos_h_abs", "pure", None, "m·s", "horizontal trajectory closeness ∫|ΔP_H| dt"),
    ("pos_v", "pos_v_abs", "pure", None, "m·s", "vertical trajectory closeness ∫|ΔP_V| dt"),
    ("heading", "heading_profile", "pure", None, "rad·s", "course closeness ∫|Δχ| dt"),
    ("speed", "speed_profile", "pseudo", None, "m", "ground-speed closeness ∫|Δ|V_H|| dt"),
    ("turn", "control_response", "pseudo", None, "rad", "turn-rate response ∫|Δψ'| dt"),
    ("peak_roll", "peak_roll@{}-{}", "pseudo", 0.05, "Hz", "roll-rate spectrum peak |Δf|"),
    ("peak_pitch", "peak_pitch@{}-{}", "pseudo", 0.5, "Hz", "pitch-rate spectrum peak |Δf|"),
    ("peak_yaw", "peak_yaw@{}-{}", "pseudo", 0.05, "Hz", "yaw-rate spectrum peak |Δf|"),
)
#: |r| over the feasible set at or above which two gains are tied (one follows the other).
TIE_THRESHOLD = 0.4
#: Why pairs of gains correlate among near-optimal vectors (printed next to Fig. 14's pairs).
MECHANISMS = {
    ("Alpha0", "CLalpha"): "CL = CLalpha (alpha_c + Alpha0): the trim lift fixes a combination",
    ("delcon", "CnDanom"): "yaw control = CnDanom * delcon * delta_a: only the product acts",
    ("CnDanom", "Cnr"): "the steady turn rate goes as CnDanom / Cnr",
    ("delcon", "Cnr"): "the steady turn rate goes as delcon / Cnr",
    ("CD0", "A2"): "CD = CD0 + A2 CL^2: the trim drag fixes a combination",
    ("Alpha0", "Cm0"): "both set the trim angle of attack",
    ("Rig", "Alpha0"): "alpha_c = alpha - Rig: lift depends on Alpha0 - Rig",
}
WINDOW = 150.0  # s of the drop compared, from the event glide_start
OUTPUT_DT = 0.2  # s, comparison grid (5 Hz: spectra up to 2.5 Hz)
DT = 0.05  # s, integration step (RK4; the results agree with dt = 0.02 s to 1e-5)


# -- study files --------------------------------------------------------------------------------


def _toml(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, Sequence):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{k} = {_toml(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {v!r} as TOML")


def _drop_lines(truth: Mapping[str, Any]) -> list[str]:
    gps = {
        "time": "time_s",
        "position": {"north": "north_m", "east": "east_m", "down": "down_m", "unit": "m"},
        "velocity": {
            "north": "v_north_ms",
            "east": "v_east_ms",
            "down": "v_down_ms",
            "unit": "m/s",
        },
        "origin": [32.85, -114.39, truth["origin_altitude_m"]],
        "events": {"glide_start": truth["glide_start_s"]},
    }
    imu = {
        "time": "time_s",
        "euler": {"columns": ["roll_deg", "pitch_deg", "yaw_deg"], "unit": "deg"},
        "rates": {"columns": ["p_rads", "q_rads", "r_rads"], "unit": "rad/s"},
    }
    controls = {"time": "time_s", "controls": {"columns": ["flap_left", "flap_right"]}}
    files = [
        {"file": "data/gps.csv", "mapping": gps},
        {"file": "data/imu.csv", "mapping": imu},
        {"file": "data/controls.csv", "mapping": controls},
    ]
    return [
        "[[identification.drops]]",
        'name = "drop"',
        "files = [",
        *(f"  {_toml(f)}," for f in files),
        "]",
        'wind = "data/wind.csv"',
        'wind_format = "dropsonde"',
        'wind_options = { altitude = "altitude_m", u = "u_ms", v = "v_ms" }',
        f'window = ["glide_start", "glide_start+{WINDOW:g}"]',
        'interpolation = "linear"',
    ]


def stage_toml(
    name: str,
    variables: Sequence[tuple[str, float, float]],
    *,
    truth: Mapping[str, Any],
    trials: int,
    model: str = "parafoil8dof",
    fixed: Mapping[str, float] | None = None,
    comment: str = "",
    limits: bool = True,
) -> str:
    """The study file (TOML) of one stage: ``variables`` are (name, low, high) of model
    parameters; ``fixed`` holds parameters set to a value (the others stay nominal)."""
    lines = [f"# vectorid demo parafoil: {comment}" if comment else "# vectorid demo parafoil"]
    lines += [
        "[study]",
        f'name = "{name}"',
        f'model = "{model}"',
        f"trials = {int(trials)}",
        "seed = 1",
        'executor = "serial"',
        "",
    ]
    for vname, lo, hi in variables:
        lines += ["[[variables]]", f'name = "{vname}"', f"low = {lo!r}", f"high = {hi!r}", ""]
    for cname, _, role, limit, _, _ in CRITERIA:
        lines += ["[[criteria]]", f'name = "{cname}"', f'role = "{role}"']
        if limit is not None and limits:
            lines.append(f"limit = {limit!r}")
        lines.append("")
    options = dict(MODEL_OPTIONS) if model == "parafoil8dof" else {}
    lines += [
        "[identification]",
        f"dt = {DT}",
        f"output_dt = {OUTPUT_DT}",
        "init_span = 1.0",
    ]
    if options:
        lines.append(f"model_options = {_toml(options)}")
    if fixed:
        lines.append(f"parameters = {_toml({k: float(v) for k, v in fixed.items()})}")
    lines.append("")
    for cname, use, _, _, _, _ in CRITERIA:
        if "{}" in use:
            kind = cname.split("_")[-1]
            use = use.format(*BANDS[kind])
        lines += [f"[identification.criteria.{cname}]", f'use = "{use}"', ""]
    lines += _drop_lines(truth)
    return "\n".join(lines) + "\n"


# -- printing helpers ---------------------------------------------------------------------------


@dataclass
class ChosenValue:
    """One parameter's chosen value and how far the data pin it (see :func:`chosen_values`)."""

    name: str
    value: float
    feasible: tuple[float, float]
    pareto: tuple[float, float]
    box: tuple[float, float]
    spread: float
    verdict: str

    @property
    def pinned(self) -> bool:
        return self.verdict == "narrow"


def chosen_values(
    a,
    chosen: Mapping[str, float],
    *,
    wide: float = 0.5,
    boxes: Mapping[str, tuple[float, float]] | None = None,
) -> list[ChosenValue]:
    """Per parameter: the chosen value, its ranges over the feasible and Pareto sets, and a
    plain verdict from the spread of the feasible range relative to the box (``"narrow"``
    below ``wide / 2``, ``"wide"`` above ``wide``, else ``"partly"``).

    ``boxes`` (name -> (low, high)) gives the a-priori box the spread is measured against
    (default: the study's box; a stage that starts from a box narrowed by an earlier stage
    should pass the original one).

    This is the one place that decides whether a value or a range is printed; the
    identifiability verdicts of ``vectorid.analysis.identifiability`` replace ``verdict`` here
    when they are available.
    """
    space = a.spec.space
    X = a.trials.X
    out = []
    for j, v in enumerate(space):
        lo, hi = float(space.lows[j]), float(space.highs[j])
        if boxes is not None and v.name in boxes:
            lo, hi = (float(b) for b in boxes[v.name])
        width = hi - lo if hi > lo else 1.0
        f = X[a.feasible, j]
        p = X[a.pareto, j]
        fr = (float(f.min()), float(f.max())) if f.size else (np.nan, np.nan)
        pr = (float(p.min()), float(p.max())) if p.size else (np.nan, np.nan)
        spread = (fr[1] - fr[0]) / width if f.size else np.nan
        verdict = "wide" if not spread <= wide else ("narrow" if spread < wide / 2 else "partly")
        out.append(
            ChosenValue(
                v.name, float(chosen.get(v.name, np.nan)), fr, pr, (lo, hi), spread, verdict
            )
        )
    return out


def print_chosen_values(
    a,
    chosen: Mapping[str, float],
    *,
    truth: Mapping[str, float] | None = None,
    boxes: Mapping[str, tuple[float, float]] | None = None,
    indent: str = "  ",
) -> list[ChosenValue]:
    """Print :func:`chosen_values` as a table: a value where the feasible set pins the
    parameter, its feasible range where it does not. Returns the rows."""
    rows = chosen_values(a, chosen, boxes=boxes)
    w = max(9, *(len(r.name) for r in rows))
    head = f"{'parameter':<{w}} {'chosen':>8} {'feasible range':>19} {'Pareto range':>19}"
    head += f" {'spread':>6}  {'reading (spread / a-priori box)':<31}"
    if truth is not None:
        head += f" {'truth':>7} in D-range"
    print(indent + head)
    for r in rows:
        shown = f"{r.value:8.3f}" if r.verdict != "wide" else f"{'(range)':>8}"
        reading = {
            "narrow": "pinned by the data",
            "partly": "partly pinned",
            "wide": "not pinned: range, not value",
        }[r.verdict]
        line = (
            f"{r.name:<{w}} {shown} [{r.feasible[0]:7.3f}, {r.feasible[1]:7.3f}] "
            f"[{r.pareto[0]:7.3f}, {r.pareto[1]:7.3f}] {r.spread:6.2f}  {reading:<31}"
        )
        if truth is not None:
            tv = truth.get(r.name, np.nan)
            inside = r.feasible[0] <= tv <= r.feasible[1]
            line += f" {tv:7.3f} {'yes' if inside else 'NO'}"
        print(indent + line)
    return rows


def _legend(model) -> None:
    print("Parameters (seed 000 Fig. 12: gains c1..c33 on the Set-0 coefficients):")
    for i, p in enumerate(model.parameters, start=1):
        meaning = p.meaning.split("; ", 1)[-1]
        ref = model.coefficients.get(p.name)
        unit = model_unit(p.name)
        kind = "+" if p.nominal == 0.0 else "x"
        print(f"  c{i:<2} {p.name:<9} {kind} {ref:>9.4g} {unit:<8} {meaning}")
    print("  (x: coefficient = reference x gain, nominal gain 1; +: reference + gain, nominal 0)")


def model_unit(name: str) -> str:
    from .models.parafoil_aero import GAINS

    for g in GAINS:
        if g.name == name:
            return g.coef_unit
    return "-"


def _criteria_legend() -> None:
    print(f"Criteria (seed 000 §VII; integrals over the {WINDOW:g}-s window, so divide by it for")
    print("the mean error):")
    for cname, use, role, limit, unit, meaning in CRITERIA:
        band = ""
        if "{}" in use:
            band = " in {:g}-{:g} Hz".format(*BANDS[cname.split("_")[-1]])
        lim = f", limit {limit:g} {unit}" if limit is not None else ""
        print(f"  {cname:<10} [{unit:>5}] {role:<6} {meaning}{band}{lim}")


def _rms(ident, x: np.ndarray) -> tuple[float, float]:
    """RMS horizontal and vertical position errors (m) of one design vector on the drop."""
    d = ident.drops[0]
    res = ident.simulate(np.atleast_2d(x), d)
    if res.status[0] != 0:
        return np.nan, np.nan
    pos = np.array(res.position[0])
    pos[:, 2] += d.origin_altitude
    e = pos - d.measured("position")
    return float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2))), float(
        np.sqrt(np.mean(e[:, 2] ** 2))
    )


def _cost(F: np.ndarray, pure: Sequence[int], scale: np.ndarray) -> np.ndarray:
    """The single cost of Fig. 12: the sum over the pure criteria of each one divided by its
    median over stage 2's successful trials (dimensionless; a typical stage-2 trial costs
    about the number of pure criteria)."""
    return np.sum(F[:, pure] / scale[None, :], axis=1)


def _report(store: Path, limits, chosen_id, report: bool) -> None:
    if not report:
        return
    try:
        from .store.sqlite import Store
        from .views.report import write_report

        with Store.open(store) as st:
            rep = write_report(
                st,
                store.with_suffix(".html"),
                limits=limits,
                chosen=[chosen_id] if chosen_id else (),
            )
        print(f"  report      {rep.path}")
    except ImportError as exc:  # pragma: no cover - plotly is a core dependency
        print(f"  (no HTML report: {exc})")


# -- the demo -----------------------------------------------------------------------------------


def _copy_data(out: Path) -> dict:
    data = out / "data"
    data.mkdir(parents=True, exist_ok=True)
    for f in sorted(DEMO_DATA.glob("*")):
        shutil.copyfile(f, data / f.name)
    return json.loads((DEMO_DATA / "truth.json").read_text(encoding="utf-8"))


def _box(model, name: str) -> tuple[float, float]:
    p = model.parameters[model.parameter_names.index(name)]
    return float(p.low), float(p.high)


def _step_header(r, what: str) -> None:
    a = r.analysis
    print()
    print(f"{what}   store {r.store}")
    print(
        f"  N = {a.n}   ND = {a.n_feasible}   NP = {a.n_pareto}   failed {a.n_failed} "
        f"(canopy tucked or diverged)   ({r.elapsed:.1f} s)"
    )
    print(
        "  criteria constraints (explicit, or quantile 0.3 of the trials: the expert's stand-in): "
        + ", ".join(f"{k} <= {v:.3g}" for k, v in r.limits.items())
    )


def _spectral_peaks(ident, x: np.ndarray) -> dict[str, tuple[float, float]]:
    """Whitened-spectrum peak frequency (Hz) and prominence of p, q, r of one vector."""
    from .identify.spectral import peak_prominence, spectral_peak

    d = ident.drops[0]
    res = ident.simulate(np.atleast_2d(x), d)
    return _peaks_of(res.rates[0], 1.0 / OUTPUT_DT, spectral_peak, peak_prominence)


def _peaks_of(rates, fs, spectral_peak, peak_prominence) -> dict[str, tuple[float, float]]:
    out = {}
    for j, kind in enumerate(("roll", "pitch", "yaw")):
        band = BANDS[kind]
        s = rates[:, j]
        out[kind] = (
            float(spectral_peak(s, fs, band=band, whiten=True)),
            float(peak_prominence(s, fs, band=band, whiten=True)),
        )
    return out


def run_parafoil_demo(
    out: Path,
    *,
    trials: int = 16_384,
    stage1_trials: int | None = None,
    stage3_trials: int | None = None,
    progress: bool = True,
    report: bool = True,
) -> int:
    """Run the parafoil demo into folder ``out`` and print its results (module docstring).

    Parameters
    ----------
    out : Path
        Folder for the data copy, study files, stores and reports.
    trials : int
        Stage-2 trials (all 33 gains); the seed's study needs at least 16,384.
    stage1_trials : int, optional
        Stage-1 trials in the refined box (default ``trials // 8``, at most 2048; the coarse
        run adds a quarter of it).
    stage3_trials : int, optional
        Trials of stage 3 in its refined box (default ``trials // 4``; its coarse run adds a
        quarter of it). The 6-DoF comparison runs the same schedule.
    progress : bool
        Progress bars.
    report : bool
        Write an HTML report per store.

    Returns
    -------
    int
        Exit code.
    """
    from . import models
    from .analysis.correlation import correlation_of
    from .analysis.sensitivity import sensitivity
    from .identify import Identification
    from .identify.twostep import run_step
    from .spec import load_study

    t_start = time.perf_counter()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    truth = _copy_data(out)
    true = truth["parameters"]
    if stage1_trials is None:
        stage1_trials = min(2048, max(64, trials // 8))
    stage3_trials = max(64, trials // 4) if stage3_trials is None else int(stage3_trials)
    coarse3 = max(16, stage3_trials // 4)
    model = models.get("parafoil8dof", **MODEL_OPTIONS)
    names = list(model.parameter_names)

    print("vectorid demo parafoil: multicriteria identification of a cargo parafoil (seed 000)")
    print(
        f"  data        {out / 'data'} (scripts/make_parafoil_demo_data.py, seed {truth['seed']}):"
        " one drop, GPS 4 Hz + payload IMU 50 Hz, flap commands, dropsonde wind"
    )
    print(
        "  truth       8-DoF model with Dryden gusts (W20 = "
        f"{truth['w20_ms']:g} m/s), flap lag {truth['actuator_lag_s']:g} s, payload joint "
        f"pitch stiffness {truth['joint_stiffness_Nm_rad'][0]:g} N m/rad (the model has none)"
    )
    print(
        f"  compared    {WINDOW:g} s from glide_start on a {OUTPUT_DT:g}-s grid; model: RK4, "
        f"dt = {DT:g} s, payload attitude, joint damping {MODEL_OPTIONS['joint_damping']} N m s/rad"
    )
    print()
    _legend(model)
    print()
    _criteria_legend()
    sys.stdout.flush()

    # ---- stage 1 -------------------------------------------------------------------------
    v1 = [(n, *_box(model, n)) for n in STAGE1]
    f1 = out / "parafoil-stage1.toml"
    f1.write_text(
        stage_toml("parafoil-stage1", v1, truth=truth, trials=stage1_trials,
                   comment="stage 1, a few gains (the seed's sets 1-5)"),
        encoding="utf-8",
    )  # fmt: skip
    spec1 = load_study(f1)
    coarse = max(64, stage1_trials // 4)
    r1 = run_step(spec1, out / "parafoil-stage1.db", trials=stage1_trials, coarse=coarse,
                  progress=progress, name="stage 1")  # fmt: skip
    _step_header(r1, f"Stage 1: {', '.join(STAGE1)} ({coarse} coarse + {stage1_trials} trials)")
    if r1.proposal is not None:
        print("  double tuning: box after the coarse run (from the feasible set)")
        for row in r1.proposal.rows():
            print(
                f"    {row['name']:<8} [{row['old_low']:.3g}, {row['old_high']:.3g}] -> "
                f"[{row['new_low']:.3g}, {row['new_high']:.3g}]"
            )
    print("  chosen values (Pareto trial nearest the ideal point) against the generator's truth:")
    full_boxes = {n: _box(model, n) for n in names}
    print_chosen_values(r1.analysis, r1.chosen, truth=true, boxes=full_boxes)
    _report(r1.store, r1.limits, r1.chosen_id, report)
    sys.stdout.flush()

    # ---- stage 2: all 33 gains ----------------------------------------------------------
    box1 = {v.name: (float(v.low), float(v.high)) for v in r1.final_box}
    v2 = [(n, *box1.get(n, _box(model, n))) for n in names]
    f2 = out / "parafoil-stage2.toml"
    f2.write_text(
        stage_toml("parafoil-stage2", v2, truth=truth, trials=trials,
                   comment="stage 2, all 33 gains (stage-1 gains in their narrowed box)"),
        encoding="utf-8",
    )  # fmt: skip
    spec2 = load_study(f2)
    r2 = run_step(spec2, out / "parafoil-stage2.db", trials=trials, coarse=0,
                  progress=progress, name="stage 2")  # fmt: skip
    _step_header(r2, f"Stage 2: all 33 gains ({trials} trials)")
    a2 = r2.analysis
    ident8 = Identification.from_spec(spec2)
    pure = a2.pure
    scale = np.nanmedian(a2.trials.F[a2.ok][:, pure], axis=0)
    x_nom = model.nominal
    x_true = np.array([true[n] for n in names])
    F_nom = ident8.evaluate(x_nom[None])[0]
    F_true = ident8.evaluate(x_true[None])[0]
    x1 = x_nom.copy()
    for n, v in r1.chosen.items():
        x1[names.index(n)] = v
    F1 = ident8.evaluate(x1[None])[0]
    cost_all = _cost(a2.trials.F, pure, scale)
    cand = np.flatnonzero(a2.pareto)
    best = cand[np.argsort(cost_all[cand])[:5]]

    # ---- Figure 12 -----------------------------------------------------------------------
    print()
    print("Quasi-optimal sets (seed 000 Fig. 12): Set 0 = nominal gains, Set 1 = stage 1's chosen")
    print("vector, then the five lowest-cost Pareto vectors of stage 2; cost = sum over the pure")
    print(
        "criteria of criterion / its median over stage 2 (a typical stage-2 trial costs about "
        f"{len(pure)})."
    )
    cols = [("Set 0", x_nom, F_nom[0]), ("Set 1", x1, F1[0])]
    cols += [(f"#{int(a2.trials.id[i])}", a2.trials.X[i], a2.trials.F[i]) for i in best]
    header = f"  {'c':>3} {'gain':<9}" + "".join(f"{c[0]:>9}" for c in cols) + f"{'truth':>9}"
    print(header)
    for j, n in enumerate(names):
        row = f"  {j + 1:>3} {n:<9}" + "".join(f"{c[1][j]:9.3f}" for c in cols)
        print(row + f"{x_true[j]:9.3f}")
    costs = [_cost(c[2][None], pure, scale)[0] for c in cols]
    cost_true = _cost(F_true, pure, scale)[0]
    print(f"  {'':>3} {'cost':<9}" + "".join(f"{c:9.3f}" for c in costs) + f"{cost_true:9.3f}")
    spread = np.ptp(np.stack([c[1] for c in cols[2:]]), axis=0)
    quasi = np.stack([c[1] for c in cols[2:]])
    twofold = [
        n
        for j, n in enumerate(names)
        if x_nom[j] != 0 and quasi[:, j].max() >= 2 * quasi[:, j].min()
    ]
    print(
        f"  the five stage-2 sets cost {min(costs[2:]):.2f}-{max(costs[2:]):.2f} yet differ: "
        f"{len(twofold)} gains vary twofold or more among them ({', '.join(twofold[:12])}"
        f"{', ...' if len(twofold) > 12 else ''}); largest spread {spread.max():.2f}"
    )
    print("  parameter ranges over stage 2's feasible and Pareto sets (a range where the data do")
    print("  not pin the value):")
    print_chosen_values(a2, r2.chosen, truth=true, boxes=full_boxes)
    _report(r2.store, r2.limits, r2.chosen_id, report)
    sys.stdout.flush()

    # ---- Figure 14 -> tie / fix proposal -> stage 3 --------------------------------------
    sens = sensitivity(a2)
    corr = correlation_of(a2, "feasible", threshold=0.25, spread_threshold=0.0)
    trajectory = [j for j, c in enumerate(CRITERIA) if not c[0].startswith("peak_")]
    rho = np.abs(sens.spearman[:, trajectory]).max(axis=1)
    insensitive = [
        n for n, r, p in zip(sens.params, rho, sens.ks_pvalue)
        if n not in STAGE1 and r < 0.1 and not p < 0.05
    ]  # fmt: skip
    ks = dict(zip(sens.params, sens.ks))
    ties: list[tuple[str, str, float]] = []
    used = set(insensitive)
    for pr in corr.pairs if a2.n_feasible >= 30 else []:
        a_, b_ = pr["a"], pr["b"]
        if abs(pr["r"]) < TIE_THRESHOLD or a_ in used or b_ in used:
            continue
        keep, drop = (a_, b_) if ks[a_] >= ks[b_] else (b_, a_)
        ties.append((keep, drop, float(pr["r"])))
        used.add(drop)
    print()
    print("Correlation and sensitivity over stage 2 (seed 000 Fig. 14), turned into a proposal:")
    print(
        f"  over {int(a2.ok.sum())} successful trials: Spearman's rho of each gain with the "
        "trajectory criteria; over D"
    )
    print(
        f"  ({a2.n_feasible} trials): the Kolmogorov-Smirnov test of its values in D against the "
        "rest, and the correlation of"
    )
    print("  the gains among the near-optimal vectors (Fig. 14)")
    order = np.argsort(-rho)
    print(
        "  influence (max |rho|): "
        + ", ".join(f"{sens.params[j]} {rho[j]:.2f}" for j in order[:12])
        + ", ..."
    )
    print(
        f"  fix at nominal ({len(insensitive)}; |rho| < 0.1 and D does not depend on them, "
        f"p >= 0.05): {', '.join(insensitive) or '(none)'}"
    )
    print(
        "  (stage-1 gains are kept: their narrowed box, not a lack of influence, makes their "
        "rho small)"
    )
    print("  strongest correlations among the near-optimal vectors (D):")
    for pr in corr.pairs[:5]:
        why = MECHANISMS.get((pr["a"], pr["b"])) or MECHANISMS.get((pr["b"], pr["a"])) or ""
        print(f"    {pr['a']:>8} ~ {pr['b']:<8} r = {pr['r']:+.2f}  {why}")
    for keep, drop, r in ties:
        print(
            f"  tie: {drop} follows {keep} (r = {r:+.2f} over D): fix {drop} at its median, "
            f"vary {keep}"
        )
    if not ties:
        print(f"  tie: no pair with |r| >= {TIE_THRESHOLD} over D")
    fixed = {n: float(x_nom[names.index(n)]) for n in insensitive}
    med = dict(zip(names, np.median(a2.trials.X[a2.feasible], axis=0)))
    fixed.update({drop: float(med[drop]) for _, drop, _ in ties})
    v3 = [v for v in v2 if v[0] not in fixed]
    reduction = 1 - len(v3) / len(v2)
    print(
        f"  reduced set: {len(v3)} of {len(v2)} gains ({100 * reduction:.0f} % fewer; "
        "the seed: about 30 %)"
    )
    f3 = out / "parafoil-stage3.toml"
    f3.write_text(
        stage_toml("parafoil-stage3", v3, truth=truth, trials=stage3_trials, fixed=fixed,
                   comment="stage 3, the reduced set (fixed and tied gains under parameters)"),
        encoding="utf-8",
    )  # fmt: skip
    spec3 = load_study(f3)
    r3 = run_step(spec3, out / "parafoil-stage3.db", trials=stage3_trials, coarse=coarse3,
                  progress=progress, name="stage 3")  # fmt: skip
    _step_header(
        r3,
        f"Stage 3: the reduced set, {len(v3)} gains ({coarse3} coarse + {stage3_trials} trials, "
        "double tuning)",
    )
    a3 = r3.analysis
    ident3 = Identification.from_spec(spec3)
    cost3 = _cost(a3.trials.F, a3.pure, scale)
    print(
        "  is the fit kept? (same cost scale as stage 2; best values among the successful trials)"
    )
    print(f"    {'':<22}{'stage 2':>12}{'stage 3':>12}")
    print(f"    {'lowest cost':<22}{np.nanmin(cost_all):12.3f}{np.nanmin(cost3):12.3f}")
    for j, (cname, _, _, _, unit, _) in enumerate(CRITERIA):
        b2 = np.nanmin(a2.trials.F[a2.ok, j])
        b3 = np.nanmin(a3.trials.F[a3.ok, j])
        print(f"    {'best ' + cname + ' [' + unit + ']':<22}{b2:12.4g}{b3:12.4g}")
    x2c = np.array([r2.chosen[n] for n in names])
    x3c = ident3.parameters(np.array([[r3.chosen[v[0]] for v in v3]]))[0]
    vectors = (("Set 0", x_nom), ("stage 2 chosen", x2c), ("stage 3 chosen", x3c))
    rms = {lab: _rms(ident8, x) for lab, x in (*vectors, ("truth", x_true))}
    print("  trajectory error of chosen vectors against the GPS track (RMS over the window, m):")
    for lab, (h, v) in rms.items():
        print(f"    {lab:<16} horizontal {h:7.1f}   vertical {v:6.2f}")
    print("  chosen values of stage 3 (fixed gains keep their value):")
    print_chosen_values(a3, r3.chosen, truth=true, boxes=full_boxes)
    _report(r3.store, r3.limits, r3.chosen_id, report)
    sys.stdout.flush()

    # ---- 6-DoF against 8-DoF ------------------------------------------------------------
    f6 = out / "parafoil-6dof.toml"
    f6.write_text(
        stage_toml("parafoil-6dof", v3, truth=truth, trials=stage3_trials, fixed=fixed,
                   model="parafoil6dof", limits=False,
                   comment="the rigid 6-DoF model on the same data, criteria and reduced set"),
        encoding="utf-8",
    )  # fmt: skip
    spec6 = load_study(f6)
    r6 = run_step(spec6, out / "parafoil-6dof.db", trials=stage3_trials, coarse=coarse3,
                  progress=progress, name="6-DoF")  # fmt: skip
    _step_header(
        r6, f"6-DoF model, the reduced set, stage 3's schedule ({coarse3} + {stage3_trials} trials)"
    )
    a6 = r6.analysis
    x6c = Identification.from_spec(spec6).parameters(np.array([[r6.chosen[v[0]] for v in v3]]))[0]
    table6 = {k: v for k, v in spec6.extra["identification"].items() if k != "parameters"}
    ident6 = Identification.from_table(
        table6, variables=names, criteria=spec6.criterion_names, base_dir=spec6.base_dir,
        default_model="parafoil6dof",
    )  # fmt: skip
    from .identify.spectral import peak_prominence, spectral_peak

    meas = _peaks_of(ident8.drops[0].measured("rates"), 1.0 / OUTPUT_DT, spectral_peak,
                     peak_prominence)  # fmt: skip
    p8 = _spectral_peaks(ident8, x3c)
    p6 = _spectral_peaks(ident6, x6c)
    n6 = min(len(a6.trials.F[a6.ok]), len(a3.trials.F[a3.ok]))
    print(
        f"  best criteria over the first {n6} successful trials of each (same schedule), 8-DoF "
        "(stage 3) vs "
        "6-DoF, and how many meet"
    )
    print("  the spectral tolerances of the 8-DoF studies:")
    print(f"    {'criterion':<20}{'8-DoF':>12}{'6-DoF':>12}{'8-DoF meet':>12}{'6-DoF meet':>12}")
    for j, (cname, _, _, limit, unit, _) in enumerate(CRITERIA):
        c8 = a3.trials.F[a3.ok, j][:n6]
        c6 = a6.trials.F[a6.ok, j][:n6]
        line = f"    {cname + ' [' + unit + ']':<20}{np.nanmin(c8):12.4g}{np.nanmin(c6):12.4g}"
        if limit is not None:
            line += f"{int((c8 <= limit).sum()):>12}{int((c6 <= limit).sum()):>12}"
        print(line)
    print("  spectral peaks of the payload rates (whitened PSD: frequency Hz / prominence):")
    print(f"    {'channel':<8}{'band Hz':>12}{'measured':>16}{'8-DoF':>16}{'6-DoF':>16}")
    for kind in ("roll", "pitch", "yaw"):
        band = "{:g}-{:g}".format(*BANDS[kind])
        cells = [f"{p[kind][0]:.3f} / {p[kind][1]:4.0f}" for p in (meas, p8, p6)]
        print(f"    {kind:<8}{band:>12}" + "".join(f"{c:>16}" for c in cells))
    print("  which measured peaks each model can produce (share of its trials within tolerance):")
    for j, (cname, _, _, limit, unit, _) in enumerate(CRITERIA):
        if not cname.startswith("peak_"):
            continue
        kind = cname.split("_")[1]
        f8 = float(np.mean(a3.trials.F[a3.ok, j][:n6] <= limit))
        f6 = float(np.mean(a6.trials.F[a6.ok, j][:n6] <= limit))
        verdict = (
            "the 6-DoF cannot produce it"
            if f6 < 0.1 * max(f8, 1e-9) and f8 > 0.05
            else "both can"
            if f6 > 0.05 and f8 > 0.05
            else "neither reproduces it well"
            if f6 <= 0.05 and f8 <= 0.05
            else "the 8-DoF cannot produce it"
        )
        print(
            f"    {kind:<6} peak at {meas[kind][0]:.2f} Hz (within {limit:g} {unit}): 8-DoF "
            f"{100 * f8:4.1f} %, 6-DoF {100 * f6:4.1f} %  -> {verdict}"
        )
    print(
        "  (the 8-DoF has the payload's twist and pitch-pendulum modes, the rigid model has "
        "neither; the\n   measured pitch peak also carries the joint stiffness the model lacks, "
        "hence its loose tolerance)"
    )
    _report(r6.store, r6.limits, r6.chosen_id, report)
    print()
    print(f"Done in {time.perf_counter() - t_start:.1f} s. Next:")
    print(f"  vectorid table       {r2.store} --top 7")
    print(f"  vectorid correlation {r2.store} --set feasible")
    print(f"  vectorid report      {r3.store} --out report.html")
    print(f"  vectorid ui          {r2.store}")
    sys.stdout.flush()
    return 0
