"""Acceptance test: drag coefficients of a real rocket descent (shared TeleMega log)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data" / "prometheus-2022"
LOG = DATA / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"


def _example():
    spec = importlib.util.spec_from_file_location(
        "real_descent", ROOT / "examples" / "real_descent.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.skipif(not LOG.exists(), reason=f"shared flight data not found at {LOG}")
def test_real_descent_drag_coefficients(tmp_path):
    r = _example().identify(LOG, tmp_path / "descent.db", trials=512)
    assert r["n"] == 512 and r["n_pareto"] >= 1
    k = r["baro_scale"]
    assert 1.02 < k < 1.12  # hot day: GPS heights exceed pressure-altitude heights
    cd_d = r["chosen"]["cd_drogue"] / k
    cd_m = r["chosen"]["cd_main"] / k
    # stated tolerances: within 25 % of the nominal Cd 1.6 (drogue; body drag lumped in) and
    # between 2.0 and 3.3 for the main (nominal 2.2; the drogue's share is counted separately)
    assert abs(cd_d - 1.6) < 0.25 * 1.6
    assert 2.0 < cd_m < 3.3
    for name in ("cd_drogue", "cd_main"):
        assert r["pareto_min"][name] <= r["chosen"][name] <= r["pareto_max"][name]
    # altitude residuals: RMS under 40 m over each phase (2-3 min of descent, 3.6 km)
    for phase in ("drogue", "main"):
        assert r["residuals"][phase]["rms"] < 40.0
