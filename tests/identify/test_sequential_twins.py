"""The sequential sampler on parachute twins with all 15 parameters free.

Noise-only twins (the parachute6dof model itself at a random truth, plus the stated sensor
noise; ``limits = "noise"``): the truth must lie inside every parameter's feasible range
(min/max over D's members) in at least 90 % of the twins, each run within 50,000 model
evaluations. The fast test runs one twin; the slow one twenty, and the ten-times-less-noisy
twin within 150,000 evaluations with an effective sample size of at least 200.
"""

from __future__ import annotations

import numpy as np
import pytest

from vectorid import models
from vectorid.identify.twins import twin_drop, write_twin, write_wind_csv
from vectorid.models import InitialState, WindProfile
from vectorid.samplers.sequential import assess
from vectorid.spec import StudySpec
from vectorid.study import Study

PARAMS = [(p.name, float(p.low), float(p.high)) for p in models.get("parachute6dof").parameters]
NOISE = {"position_h": 1.5, "position_v": 3.0, "velocity": 0.15, "euler_deg": 0.5, "rates": 0.01}
ORIGIN = 1200.0
LEVELS = ORIGIN + np.arange(0.0, 1501.0, 100.0)
WIND = WindProfile.from_speed_direction(
    ORIGIN + np.array([0.0, 500.0, 1500.0]), [3.0, 6.0, 9.0], [240.0, 255.0, 270.0]
)
PURE = ("pos_h_abs", "pos_v_abs", "vel_h_abs", "vel_v_abs")
PSEUDO = ("roll_abs", "pitch_abs")


def twin_spec(folder, i, *, noise=NOISE, budget=50_000, population=200, window=30.0):
    """A noise-only twin at a random truth (seeded by ``i``) with every parameter free."""
    rng = np.random.default_rng(9100 + i)
    truth = {n: float(lo + (hi - lo) * rng.uniform(0.1, 0.9)) for n, lo, hi in PARAMS}
    ini = InitialState(
        altitude=ORIGIN + 800.0,
        velocity=(2.0, 1.0, 7.0),
        euler=tuple(rng.normal(0.0, 0.1, 3)),
        rates=tuple(rng.normal(0.0, 0.05, 3)),
    )
    flight = twin_drop(
        models.get("parachute6dof"), truth, initial=ini, duration=window + 4.0, noise=noise,
        seed=i, wind=WIND, origin_altitude=ORIGIN,
    )  # fmt: skip
    folder.mkdir(parents=True, exist_ok=True)
    files = write_twin(flight, folder, "drop")
    write_wind_csv(WindProfile(LEVELS, *WIND(LEVELS).T), folder / "wind.csv", LEVELS)
    ident = {
        "dt": 0.05,
        "output_dt": 0.25,
        "init_span": 1.0,
        "noise": noise,
        "limits": "noise",
        "drops": [
            {
                "name": "drop",
                "files": files,
                "wind": "wind.csv",
                "wind_format": "dropsonde",
                "wind_options": {"altitude": "altitude_m", "u": "u_ms", "v": "v_ms"},
                "window": [2.0, 2.0 + window],
            }
        ],
    }
    data = {
        "study": {
            "name": f"twin{i}",
            "model": "parachute6dof",
            "trials": 1024,
            "seed": 1,
            "sampler": "sequential",
            "budget": budget,
            "population": population,
        },
        "variables": [{"name": n, "low": lo, "high": hi} for n, lo, hi in PARAMS],
        "criteria": [{"name": c} for c in PURE] + [{"name": c, "role": "pseudo"} for c in PSEUDO],
        "identification": ident,
    }
    return StudySpec.from_dict(data, base_dir=folder), truth


def run_twin(folder, i, **kw):
    """Run one twin; (summary, truth inside every feasible range, names outside)."""
    spec, truth = twin_spec(folder, i, **kw)
    with Study.create(spec, folder / "s.db") as study:
        summary = study.run(executor="inline", progress=False)
        state = assess(study.store)
        X = study.store.load(stages=[0]).X[state.members]
    outside = [
        n for j, (n, _, _) in enumerate(PARAMS)
        if not len(X) or not X[:, j].min() <= truth[n] <= X[:, j].max()
    ]  # fmt: skip
    return summary, not outside, outside


def test_a_parachute_twin_with_15_free_parameters(tmp_path):
    s, inside, outside = run_twin(tmp_path / "t0", 0)
    assert s.converged, s.describe()
    assert s.evaluations <= 50_000 and s.ess >= 200
    assert inside, (outside, s.describe())


@pytest.mark.long
@pytest.mark.slow
def test_twenty_parachute_twins_hold_their_truth(tmp_path):
    n, held = 20, 0
    for i in range(n):
        s, inside, _ = run_twin(tmp_path / f"t{i}", 100 + i)
        assert s.converged and s.evaluations <= 50_000, s.describe()
        held += inside
    assert held / n >= 0.9, f"truth inside D's ranges in {held}/{n} twins"


@pytest.mark.long
@pytest.mark.slow
def test_ten_times_less_noisy_twin(tmp_path):
    quiet = {k: v / 10.0 for k, v in NOISE.items()}
    s, inside, outside = run_twin(tmp_path / "q", 7, noise=quiet, budget=150_000)
    assert s.converged and s.evaluations <= 150_000, s.describe()
    assert s.ess >= 200, s.describe()
    assert inside, outside
