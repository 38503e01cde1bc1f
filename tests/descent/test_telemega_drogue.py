"""The figures behind the Prometheus drogue phase's verdict (examples/telemega_drogue.py):
why no constant-drag descent comes within 5 m of it. Skipped when ``../shared/data`` is
absent."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LOG = (
    ROOT.parent
    / "shared"
    / "data"
    / "prometheus-2022"
    / "2022-06-24-serial-6583-flight-0003-TeleMega.csv"
)


def _example():
    spec = importlib.util.spec_from_file_location(
        "telemega_drogue", ROOT / "examples" / "telemega_drogue.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def figures():
    if not LOG.exists():
        pytest.skip(f"shared flight data not found at {LOG}")
    return _example().figures(LOG)


def test_the_barometer_carries_an_error_the_gps_does_not(figures):
    n, fv = figures["baro_noise"], figures["fast_variation_20s"]
    assert n["sigma_m"] > 4.0 and 0.1 < n["correlation_time_s"] < 1.0
    assert fv["baro_m"] > 3.0 * fv["gps_m"] and abs(fv["correlation"]) < 0.2


def test_no_constant_drag_descent_comes_within_5_m_of_the_barometer(figures):
    for b in figures["monotone_rate_bound"]:
        assert b["baro_m"] > 5.0  # the goal is below what any such descent can reach
        assert b["gps_m"] < 2.5  # the GPS heights are a descent that slows down


def test_deployment_transient_day_atmosphere_and_constant_drag_fits(figures):
    areas = [a["drag_area_m2"] for a in figures["gps_drag_area_5s"]]
    later = sorted(areas[3:])[len(areas[3:]) // 2]
    assert max(areas[:2]) < 0.9 * later  # the first 17 s after the drogue event
    lo, hi = figures["initial_rate_2s_lines_ms"]
    assert hi - lo > 8.0  # 2-s lines of the barometer: no initial speed to start from
    at = figures["atmosphere"]
    assert 8.0 < at["lapse_rate_K_per_km"] < 11.0  # steeper than ISA's 6.5
    assert 1.02 < at["T_over_T_ISA_top"] < at["T_over_T_ISA_bottom"] < 1.12
    cf = figures["constant_drag_fits"]
    assert cf["log_atmosphere_vs_baro_m"] < cf["isa_vs_baro_m"]
    assert cf["log_atmosphere_vs_gps_m"] > 5.0  # the motion itself strays from constant drag
    assert max(abs(v) for v in figures["gps_rate_minus_constant_drag_10s_ms"]) > 0.8


def test_cli(tmp_path, capsys):
    if not LOG.exists():
        pytest.skip(f"shared flight data not found at {LOG}")
    mod = _example()
    assert mod.main([str(LOG), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert {"baro_noise", "monotone_rate_bound", "constant_drag_fits"} <= set(d)
    assert mod.main([str(tmp_path / "none.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1
