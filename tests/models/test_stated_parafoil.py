"""A stated parafoil set as parafoil6dof model options: the Lissaman-Brown factors reproduce
the stated geometry's apparent masses, and the options reproduce the stated set."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vectorid import models
from vectorid.models.parafoil_aero import I_MAM
from vectorid.models.stated_parafoil import ETH_PARAFOIL, StatedParafoil, lissaman_brown_factors


def test_factors_turn_the_model_forms_into_the_lissaman_brown_masses():
    b, c, a, t = 1.88, 0.80, 0.4, 0.075
    k = lissaman_brown_factors(b, c, a, t)  # no area: the model's chord is the stated one
    ar, a_s, t_s = b / c, a / b, t / c
    assert k["kA"] * math.pi / 4 * t**2 * b == pytest.approx(
        0.666 * (1 + 8 / 3 * a_s**2) * t**2 * b
    )
    assert k["kC_star"] * math.pi / 48 * t**2 * b**3 == pytest.approx(
        0.0555 * (1 + 8 * a_s**2) * t**2 * b**3
    )
    assert k["kA_star"] * math.pi / 48 * c**2 * b**3 == pytest.approx(
        0.055 * ar / (1 + ar) * b**3 * c**2
    )
    assert set(k) == {"kA", "kB", "kC", "kA_star", "kB_star", "kC_star"}
    assert all(v > 0 for v in k.values()) and t_s < 1


def test_eth_set_reproduces_the_readme_apparent_masses_and_mass():
    opts = ETH_PARAFOIL.model_options()
    m = models.get("parafoil6dof", **opts)
    k = m.constants(m.nominal[None])[0]
    am = k[I_MAM : I_MAM + 36].reshape(6, 6)
    # translational diagonal = the README's diag(Im) = 0.00789, 0.0690, 0.692 m^3 (no rigging)
    assert np.diag(am)[:3] == pytest.approx([0.00789, 0.0690, 0.692], rel=2e-3)
    assert m.coefficients["CLalpha"] == pytest.approx(2.14 / np.degrees(1.0))
    assert m.geometry.canopy_mass + m.geometry.payload_mass == pytest.approx(1.2)
    assert opts["extra_parameters"] == ["wind_north", "wind_east"]
    # the canopy's quarter chord sits where stated above the system's mass centre
    g = opts["geometry"]
    d_p = g["riser_length"] + g["payload_size"][2] / 2
    centre = (g["payload_mass"] * d_p - g["canopy_mass"] * g["line_length"]) / 1.2
    assert g["line_length"] + centre == pytest.approx(ETH_PARAFOIL.canopy_above_cg)


def test_a_stated_inertia_is_judged_by_the_triangle_inequality():
    assert not ETH_PARAFOIL.inertia_is_physical()  # 1.68 > 0.80 + 0.32
    ok = StatedParafoil(1.0, 1.0, 1.0, 1.0, 0.1, 0.1, 1.0, 0.01, 1.0, inertia=(1.0, 0.8, 0.3))
    assert ok.inertia_is_physical()
    assert StatedParafoil(1.0, 1.0, 1.0, 1.0, 0.1, 0.1, 1.0, 0.01, 1.0).inertia_is_physical()
