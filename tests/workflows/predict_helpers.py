"""Shared builders of the prediction tests: a store of the closed-form kinematic model and
drop files (TOML) written from tables."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vectorid._toml import toml_value
from vectorid.spec import StudySpec
from vectorid.study import Study

MODEL = "tests.workflows.kinematic:Kinematic"
ORIGIN = 1200.0  # m above sea level: the origin and the ground
TRUTH = {"vn": 3.0, "ve": -2.0, "sink": 6.0}
RHO = 0.5  # m/s: the radius of D around the truth's (vn, ve)
WINDOW = 60.0  # s compared
LIMIT = RHO * WINDOW**2 / 2.0  # pos_h_abs <= LIMIT  <=>  |v_H - v0_H| <= RHO
MAPPING = {
    "time": "t",
    "time_unit": "s",
    "position": {"north": "n", "east": "e", "down": "d", "unit": "m"},
}


def write_track(path: Path, *, height: float = 1500.0, seconds: float = 62.0) -> None:
    """The truth's noise-free track at 4 Hz, NED relative to the origin."""
    t = np.arange(0.0, seconds + 1e-9, 0.25)
    n, e = TRUTH["vn"] * t, TRUTH["ve"] * t
    d = -height + TRUTH["sink"] * t
    lines = ["t,n,e,d"] + [f"{a:.2f},{b:.6f},{c:.6f},{x:.6f}" for a, b, c, x in zip(t, n, e, d)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def kinematic_spec(
    folder: Path, *, trials: int = 2048, sampler: str = "sobol", limit: float = LIMIT, **study
) -> StudySpec:
    """The study: (vn, ve) in a box of 4ρ x 4ρ holding the disc of radius ρ around the truth
    (off its centre, so that no Sobol point is the truth), ``pos_h_abs <= limit``."""
    folder.mkdir(parents=True, exist_ok=True)
    write_track(folder / "drop1.csv")
    drop = {"name": "drop1", "file": "drop1.csv", "mapping": MAPPING, "window": [0.0, WINDOW],
            "origin_altitude": ORIGIN}  # fmt: skip
    data = {
        "study": {"name": "kinematic", "model": MODEL, "trials": trials, "seed": 1,
                  "sampler": sampler, "executor": "inline", **study},
        "variables": [
            {"name": "vn", "low": TRUTH["vn"] - 1.7 * RHO, "high": TRUTH["vn"] + 2.3 * RHO,
             "unit": "m/s"},
            {"name": "ve", "low": TRUTH["ve"] - 2.3 * RHO, "high": TRUTH["ve"] + 1.7 * RHO,
             "unit": "m/s"},
        ],
        "criteria": [{"name": "pos_h_abs", "limit": limit, "unit": "m·s"}],
        "identification": {"dt": 0.05, "output_dt": 0.5, "parameters": {"sink": TRUTH["sink"]},
                           "noise": {"position": 0.5}, "drops": [drop]},
    }  # fmt: skip
    return StudySpec.from_dict(data, base_dir=folder)


def kinematic_store(folder: Path, **kw: Any) -> Path:
    """Run the kinematic study into ``folder/k.db`` (in-process; a second or so)."""
    store = folder / "k.db"
    with Study.create(kinematic_spec(folder, **kw), store) as st:
        st.run(executor="inline", progress=False)
    return store


def drop_file(path: Path, drops: Sequence[Mapping[str, Any]], model: str | None = None) -> Path:
    """A drop file of ``[[identification.drops]]`` tables."""
    lines = []
    if model is not None:
        lines += ["[identification]", f"model = {toml_value(model)}", ""]
    for d in drops:
        lines.append("[[identification.drops]]")
        lines += [f"{k} = {toml_value(v)}" for k, v in d.items()]
        lines.append("")
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def planned(height: float = 1200.0, duration: float = 240.0, **extra: Any) -> dict[str, Any]:
    """A planned drop of the kinematic model from ``height`` m above the origin (the ground)."""
    return {
        "name": "next",
        "initial": {"altitude": ORIGIN + height},
        "origin_altitude": ORIGIN,
        "duration": duration,
        "channels": {"position": 2.0},
        **extra,
    }
