"""Parafoil model options: other canopies (geometry, mass, inertia, rigging, coefficients),
extra per-trial parameters (payload mass, uniform wind) and the payload-attitude outputs."""

from __future__ import annotations

import numpy as np
import pytest

from vectorid import models
from vectorid.models import InitialState, WindProfile, flap_deflections
from vectorid.models.parafoil_aero import (
    I_CD0,
    I_MP,
    ParafoilGeometry,
    ParafoilOptionError,
    build_properties,
    canopy_aero,
    nominal_gains,
)

#: A small steerable canopy (the ETH Zurich test vehicle's stated data, see docs/models.md).
SMALL = {
    "geometry": {
        "area": 1.5,
        "span": 1.88,
        "thickness_ratio": 0.094,
        "arc_ratio": 0.21,
        "line_length": 1.3,
        "canopy_ahead": 0.2,
        "canopy_mass": 0.2,
        "payload_mass": 1.0,
        "payload_size": [0.245, 0.245, 0.245],
        "payload_cd": 3.2,
        "riser_length": 0.05,
        # a 1-kg payload: the cargo system's joint (2000 N m s/rad) would be absurdly stiff
        "joint_stiffness": [0.0, 0.4],
        "joint_damping": [0.15, 0.06],
    },
    "coefficients": {"CD0": 0.12, "A2": 0.0, "CDalpha2": 1.005e-4, "Rig": 0.0, "Alpha0": 6.43,
                     "CLalpha": 0.03735, "Cm0": 0.1, "Cmalpha": -0.01257, "Cmq": -1.49},
}  # fmt: skip


def test_geometry_from_a_table_and_its_errors():
    geo = ParafoilGeometry.from_options({"area": 1.5, "span": 1.88, "payload_size": [1, 1, 1]})
    assert geo.chord == pytest.approx(0.798, abs=1e-3) and geo.payload_size == (1.0, 1.0, 1.0)
    assert geo.payload_mass == ParafoilGeometry().payload_mass  # others stay the reference's
    cases = [
        ({"aera": 1.5}, "geometry.aera: unknown field; did you mean 'area'"),
        ({"area": "big"}, r"geometry.area: expected a number in m\^2, got 'big'"),
        ({"area": True}, "geometry.area: expected a number"),
        ({"area": -1.0}, "area must be > 0"),
        ({"payload_size": [1, 2]}, "payload_size: expected 3 numbers in m, got 2"),
        ({"joint_stiffness": 5.0}, r"joint_stiffness: expected 2 numbers"),
        ({"payload_inertia": [1.0, 1.0, 5.0]}, "triangle inequality"),
        ({"canopy_mass": float("nan")}, "finite"),
    ]
    for options, message in cases:
        with pytest.raises(ParafoilOptionError, match=message) as info:
            ParafoilGeometry.from_options(options)
        assert "\n" not in str(info.value)  # one line


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            {"coefficients": {"CDO": 0.1}},
            "coefficients.CDO: unknown coefficient; did you mean 'CD0'",
        ),
        ({"coefficients": {"CD0": "x"}}, "coefficients.CD0: expected a number"),
        ({"coefficients": [1, 2]}, "coefficients: expected a table"),
        ({"extra_parameters": ["mass"]}, "unknown parameter 'mass'"),
        ({"extra_parameters": "wind_north"}, "expected a list of names"),
        ({"attitude": "pilot"}, 'expected "canopy" or "payload"'),
        ({"geometry": {"span": 0.0}}, "span must be > 0"),
    ],
)
def test_model_option_errors_are_one_line(options, message):
    with pytest.raises(ParafoilOptionError, match=message) as info:
        models.get("parafoil8dof", **options)
    assert "\n" not in str(info.value)


def test_coefficients_replace_the_reference_set_and_the_gains_scale_them():
    m = models.get("parafoil8dof", **SMALL)
    assert m.coefficients["CD0"] == 0.12 and m.coefficients["Cmalpha"] == -0.01257
    assert m.coefficients["Cnr"] == -0.0936  # not given: Set 0
    meaning = dict(zip(m.parameter_names, (p.meaning for p in m.parameters)))
    assert "CD0 = 0.12 - * c6" in meaning["CD0"]
    assert "no effect" in meaning["Rig"]  # a multiplicative gain on a zero reference
    x = m.nominal.copy()
    x[5] = 1.5
    k = m.constants(np.stack([m.nominal, x]))
    assert k[:, I_CD0] == pytest.approx([0.12, 0.18])


def test_cmalpha_and_cdalpha2_enter_the_canopy_aerodynamics():
    base = build_properties(nominal_gains()[None])[0]
    extra = build_properties(
        nominal_gains()[None], extra_coefficients={"Cmalpha": -0.01, "CDalpha2": 2e-4}
    )[0]
    out0, out1 = np.zeros(9), np.zeros(9)
    # chord angle of attack: alpha (atan2(w, u)) minus Rig = 8 deg
    u, w = 14.0, 14.0 * np.tan(np.radians(18.0))
    canopy_aero(base, 1.2, u, 0.0, w, 0.0, 0.0, 0.0, 0.0, 0.0, out0)
    canopy_aero(extra, 1.2, u, 0.0, w, 0.0, 0.0, 0.0, 0.0, 0.0, out1)
    qs = 0.5 * 1.2 * (u * u + w * w) * 90.0
    c = 90.0 / 16.43
    assert (out1[4] - out0[4]) / (qs * c) == pytest.approx(-0.01 * 10.0, rel=1e-9)  # Cm
    drag_dir = -np.array([u, 0.0, w]) / np.hypot(u, w)
    d_drag = (out1[[0, 1, 2]] - out0[[0, 1, 2]]) @ drag_dir / qs
    assert d_drag == pytest.approx(2e-4 * 10.0**2, rel=1e-9)


def test_a_small_canopy_glides_slowly_and_turns_both_ways():
    m = models.get("parafoil8dof", **SMALL)
    init = InitialState(altitude=500.0)
    turns = flap_deflections([0, 5, 6, 15], [0, 0, 0.4, 0.4], [0, 0, 0, 0])
    mirror = flap_deflections([0, 5, 6, 15], [0, 0, 0, 0], [0, 0, 0.4, 0.4])
    calm = m.simulate(m.nominal[None], t_final=15.0, dt=0.01, output_dt=0.5, initial=init)
    assert calm.status[0] == 0
    v = calm.velocity[0, -1]
    assert 2.0 < np.hypot(v[0], v[1]) < 8.0 and 0.5 < v[2] < 3.0  # small canopy: slow
    left = m.simulate(m.nominal[None], t_final=15.0, dt=0.01, output_dt=0.5, inputs=turns,
                      initial=init)  # fmt: skip
    right = m.simulate(m.nominal[None], t_final=15.0, dt=0.01, output_dt=0.5, inputs=mirror,
                       initial=init)  # fmt: skip
    assert left.euler[0, -1, 2] < -0.3 and right.euler[0, -1, 2] == pytest.approx(
        -left.euler[0, -1, 2], rel=1e-6
    )


def test_wind_parameters_act_like_a_uniform_wind_and_payload_mass_like_the_geometry():
    m = models.get("parafoil8dof", extra_parameters=["wind_north", "wind_east", "payload_mass"])
    assert m.parameter_names[-3:] == ("wind_north", "wind_east", "payload_mass")
    assert [p.unit for p in m.parameters[-3:]] == ["m/s", "m/s", "kg"]
    base = models.get("parafoil8dof")
    init = InitialState(altitude=1000.0, velocity=(12.0, 1.0, 5.0))
    x = m.nominal.copy()
    x[33:36] = [2.0, -1.5, 600.0]
    res = m.simulate(x[None], t_final=20.0, dt=0.05, output_dt=1.0, initial=init)
    heavy = models.get("parafoil8dof", geometry={"payload_mass": 600.0})
    ref = heavy.simulate(heavy.nominal[None], t_final=20.0, dt=0.05, output_dt=1.0, initial=init,
                         wind=WindProfile.constant(north=2.0, east=-1.5))  # fmt: skip
    assert np.allclose(res.outputs, ref.outputs, rtol=1e-12, atol=1e-9)
    assert m.constants(x[None])[0, I_MP] == 600.0
    x[35] = -1.0  # a negative mass is refused before integration
    bad = m.simulate(x[None], t_final=1.0, dt=0.05, initial=init)
    assert bad.status[0] == 4 and base.parameter_names == m.parameter_names[:33]


def test_payload_attitude_option_reports_what_a_payload_imu_reads():
    sched = flap_deflections([0, 2, 3, 10], [0, 0, 0.5, 0.5], [0, 0, 0, 0])
    canopy = models.get("parafoil8dof")
    payload = models.get("parafoil8dof", attitude="payload")
    kw = dict(t_final=10.0, dt=0.05, output_dt=0.5, inputs=sched)
    a = canopy.simulate(canopy.nominal[None], **kw)
    b = payload.simulate(payload.nominal[None], **kw)
    assert np.allclose(b.euler[0, :, 0], a["payload_phi"][0])
    assert np.allclose(b.rates[0, :, 2], a["payload_r"][0])
    assert np.allclose(b["canopy_psi"][0], a.euler[0, :, 2])
    assert np.allclose(b.position, a.position)
    assert "canopy_r" in payload.output_names and "payload_r" not in payload.output_names
    rigid = models.get("parafoil6dof", attitude="payload")  # one body: same as the canopy
    assert (
        rigid.attitude == "canopy" and rigid.output_names == models.get("parafoil6dof").output_names
    )


def test_model_options_from_a_study_file_and_one_line_errors(tmp_path):
    from vectorid.errors import StudyDefinitionError
    from vectorid.identify import Identification

    with pytest.raises(StudyDefinitionError, match=r"model_options: model option geometry.aera"):
        Identification.from_table(
            {"model": "parafoil8dof", "model_options": {"geometry": {"aera": 1.0}},
             "drops": [{"file": "x.csv"}]},
            variables=["CD0"], criteria=["pos_h_abs"], base_dir=tmp_path,
        )  # fmt: skip


def test_vectorid_run_refuses_bad_model_options_in_one_line(tmp_path, capsys):
    from vectorid.cli import main

    study = tmp_path / "s.toml"
    study.write_text(
        '[study]\nname = "s"\nmodel = "parafoil8dof"\ntrials = 4\n\n'
        '[[variables]]\nname = "CD0"\nlow = 0.5\nhigh = 1.5\n\n'
        '[[criteria]]\nname = "pos_h_abs"\n\n'
        "[identification]\n"
        "model_options = { geometry = { area = -1.5 } }\n\n"
        '[[identification.drops]]\nfile = "drop.csv"\n',
        encoding="utf-8",
    )
    assert main(["run", str(study), "--executor", "serial"]) == 2
    err = capsys.readouterr().err.strip()
    last = err.splitlines()[-1]  # after the run's header and progress bar: one error line
    assert "identification.model_options" in last and "area must be > 0" in last
    assert "Traceback" not in err
