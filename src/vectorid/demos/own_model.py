"""``vectorid init own-model``: a working starting point for identifying a model of your own.

It writes, into a new folder: a small package ``msd`` with a forced mass-spring-damper in
plain numpy (``msd/dynamics.py``) and the same model with a numba kernel (``msd/fast.py``),
a record ``run1.csv`` of displacement (mm) and acceleration (m/s²) with stated noise, and the
study file ``study.toml`` that identifies m, c and k from it with noise-grounded limits.
The record is synthetic: the numpy model at :data:`TRUTH`, sampled at 50 Hz, plus seeded
white noise of :data:`NOISE`, so that you can check that the identified ranges hold the
truth before you put your own model and data in its place (``docs/own-model.md``).
"""

from __future__ import annotations

import shutil
import sys
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import StudyDefinitionError

__all__ = ["NOISE", "TRUTH", "write_own_model"]

#: The parameters the record was made with (m kg, c N·s/m, k N/m).
TRUTH = {"m": 1.2, "c": 0.8, "k": 42.0}
#: σ of the white noise added to the record: x in m, a in m/s².
NOISE = {"x": 0.002, "a": 0.2}
_SEED = 2024
_FILES = ("msd/__init__.py", "msd/dynamics.py", "msd/fast.py", "study.toml")


def write_own_model(out: str | Path) -> list[Path]:
    """Write the starting point into the folder ``out`` (created; must not exist or be
    empty). Returns the files written."""
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise StudyDefinitionError(
            "--out", f"{out} exists and is not an empty folder", "choose another --out"
        )
    src = resources.files("vectorid") / "data" / "own_model"
    written = []
    for name in _FILES:
        dest = out / name
        dest.parent.mkdir(parents=True, exist_ok=True)
        with resources.as_file(src / name) as f:
            shutil.copyfile(f, dest)
        written.append(dest)
    written.append(_write_record(out))
    return written


def _write_record(out: Path) -> Path:
    sys.path.insert(0, str(out.resolve()))
    try:
        from msd.dynamics import MassSpringDamper  # the model just written
    finally:
        sys.path.remove(str(out.resolve()))
        sys.modules.pop("msd.dynamics", None)
        sys.modules.pop("msd", None)
    model = MassSpringDamper(force_amplitude=2.0, force_frequency=1.5)
    p = [[TRUTH[n] for n in model.parameter_names]]
    res = model.simulate(p, t_final=6.0, dt=0.001, output_dt=0.1, initial={"x": 0.02})
    rng = np.random.default_rng(_SEED)
    x = res["x"][0] + rng.normal(0.0, NOISE["x"], res.t.size)
    a = res["a"][0] + rng.normal(0.0, NOISE["a"], res.t.size)
    path = out / "run1.csv"
    truth = ", ".join(f"{k} = {v:g}" for k, v in TRUTH.items())
    lines = [
        f"# synthetic record: msd.dynamics.MassSpringDamper at {truth} (kg, N*s/m, N/m),",
        f"# released from x = 20 mm at rest; white noise x {NOISE['x'] * 1e3:g} mm, "
        f"a {NOISE['a']:g} m/s^2 (seed {_SEED})",
        "t,x_mm,a",
    ]
    lines += [f"{t:.3f},{xi * 1e3:.4f},{ai:.5f}" for t, xi, ai in zip(res.t, x, a)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
