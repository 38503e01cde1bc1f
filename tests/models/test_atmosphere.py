"""ISA and gravity against the U.S. Standard Atmosphere 1976 tables."""

import numpy as np
import pytest

from vectorid.models import atmosphere as atm


@pytest.mark.parametrize(
    ("H", "T", "p", "rho"),
    [
        # geopotential altitude (m), T (K), p (Pa), rho (kg/m³) — US Standard Atmosphere 1976
        (0.0, 288.15, 101_325.0, 1.2250),
        (5_000.0, 255.65, 54_019.9, 0.73612),
        (11_000.0, 216.65, 22_632.1, 0.36392),
        (15_000.0, 216.65, 12_044.6, 0.19367),
        (20_000.0, 216.65, 5_474.89, 0.088035),
        (32_000.0, 228.65, 868.019, 0.013225),
    ],
)
def test_isa_matches_standard_tables(H, T, p, rho):
    assert atm.temperature(H, geopotential=True) == pytest.approx(T, abs=1e-6)
    assert atm.pressure(H, geopotential=True) == pytest.approx(p, rel=2e-5)
    assert atm.density(H, geopotential=True) == pytest.approx(rho, rel=2e-4)


def test_geometric_altitude_is_converted_to_geopotential():
    h = np.array([0.0, 1_000.0, 11_019.0, 30_000.0])
    H = atm.geopotential_altitude(h)
    assert H[1] == pytest.approx(999.843, abs=1e-3)
    np.testing.assert_allclose(atm.geometric_altitude(H), h, rtol=1e-12)
    # geometric 1000 m is geopotential 999.84 m: slightly lower, so the air is denser
    assert atm.density(1_000.0) > atm.density(1_000.0, geopotential=True)
    # US Standard Atmosphere 1976, geometric 5000 m: 54 048 Pa
    assert atm.pressure(5_000.0) == pytest.approx(54_048.3, rel=2e-5)
    assert atm.density(1_000.0) == pytest.approx(1.1116, rel=1e-4)


def test_density_is_continuous_and_decreasing_across_layers():
    h = np.linspace(-4_000.0, 50_000.0, 20_001)
    rho = atm.density(h, geopotential=True)
    assert np.all(np.diff(rho) < 0)
    # continuity at the tropopause: no jump larger than the local slope allows
    i = np.searchsorted(h, 11_000.0)
    assert abs(rho[i] - rho[i - 1]) < 2 * abs(rho[i - 1] - rho[i - 2])


def test_gravity_inverse_square():
    assert atm.gravity(0.0) == pytest.approx(atm.G0)
    r = atm.R_EARTH
    assert atm.gravity(r) == pytest.approx(atm.G0 / 4)


def test_out_of_range_altitude_says_the_range():
    with pytest.raises(ValueError, match=r"expected geopotential altitude in \[-5000, 71000\]"):
        atm.density(100_000.0)


def test_isa_temperature_offset_and_uniform_atmosphere():
    hot = atm.ISA(temperature_offset=15.0)
    assert hot.density(0.0) == pytest.approx(101_325.0 / (atm.R_AIR * 303.15))
    u = atm.UniformAtmosphere(rho=1.0, g=9.0)
    np.testing.assert_array_equal(u.density(np.array([0.0, 5e3])), [1.0, 1.0])
    np.testing.assert_array_equal(u.gravity(np.array([0.0, 5e3])), [9.0, 9.0])
    with pytest.raises(ValueError, match="rho must be a finite density"):
        atm.UniformAtmosphere(rho=-1.0)
