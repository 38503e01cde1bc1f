"""Gain table, aerodynamics, apparent masses and kinematics of ``parafoil_aero``."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import qmc

from vectorid.models import parafoil_aero as pa

# Figure 12 of seed 000, "Set 0" column (the specification the gains multiply).
SET0 = {
    "delcon": 1, "xcg": 0, "Alpha0": 10, "CLalpha": 0.0375, "CLDf": 0.2, "CD0": 0.14,
    "A2": 0.25, "ADf": 0.2, "Cm0": -0.33, "Rig": 8, "Cmq": -6.39, "CYbnom": -0.005,
    "CYbgrad": -0.0001, "CYDanom": -0.007, "CYDagrad": 0.0012, "Clbnom": -0.0014,
    "Clbgrad": -0.001, "ClDanom": -0.0063, "ClDagrad": -0.001, "Clp": -0.15, "Clr": 0.0775,
    "Cnbnom": 0.007, "Cnbgrad": -0.0003, "CnDanom": 0.03, "CnDagrad": -0.001, "Cnp": 0.023,
    "Cnr": -0.0936, "kA": 0.899, "kB": 0.339, "kC": 0.783, "kA_star": 0.63, "kB_star": 0.817,
    "kC_star": 1.0,
}  # fmt: skip


def box_samples(n_sobol: int = 128, n_corners: int = 128, seed: int = 0) -> np.ndarray:
    """Gain vectors spanning the whole parameter box: random corners plus a Sobol sample."""
    lo = np.array([g.lower for g in pa.GAINS])
    hi = np.array([g.upper for g in pa.GAINS])
    rng = np.random.default_rng(seed)
    corners = np.where(rng.integers(0, 2, (n_corners, lo.size)) == 1, hi, lo)
    sobol = qmc.scale(qmc.Sobol(lo.size, seed=seed).random(n_sobol), lo, hi)
    return np.vstack([corners, lo, hi, sobol])


def test_gain_table_follows_figure_12():
    assert [g.index for g in pa.GAINS] == list(range(1, 34))
    assert pa.GAIN_NAMES == tuple(SET0)
    for g in pa.GAINS:
        assert g.reference == pytest.approx(SET0[g.name])
    additive = {g.name for g in pa.GAINS if g.additive}
    assert additive == {"xcg", "Clbgrad", "ClDagrad"}
    for g in pa.GAINS:
        if not g.additive:
            assert (g.lower, g.upper) == (0.2, 2.0)
        else:
            assert g.lower < 0.0 < g.upper
    nom = pa.nominal_gains()
    assert np.array_equal(nom, np.where([g.additive for g in pa.GAINS], 0.0, 1.0))
    coefs = pa.gains_to_coefficients(nom[None])[0]
    assert np.allclose(coefs, [SET0[n] for n in pa.GAIN_NAMES])


def test_gains_multiply_or_add():
    g = pa.nominal_gains()[None].repeat(2, 0)
    g[1] = 0.5
    c = pa.gains_to_coefficients(g)
    i_cla = pa.GAIN_NAMES.index("CLalpha")
    i_xcg = pa.GAIN_NAMES.index("xcg")
    i_clbg = pa.GAIN_NAMES.index("Clbgrad")
    assert c[1, i_cla] == pytest.approx(0.5 * 0.0375)
    assert c[1, i_xcg] == pytest.approx(0.5)
    assert c[1, i_clbg] == pytest.approx(-0.001 + 0.5)


def test_gains_shape_error_names_the_fix():
    with pytest.raises(ValueError, match=r"shape \(n, 33\).*reshape"):
        pa.gains_to_coefficients(np.ones(33))


@pytest.mark.parametrize(
    ("field", "value"),
    [("area", -1.0), ("payload_mass", 0.0), ("payload_size", (1.0, 0.0, 1.0)), ("span", np.nan)],
)
def test_geometry_validation(field, value):
    from dataclasses import replace

    geo = replace(pa.ParafoilGeometry(), **{field: value})
    with pytest.raises(ValueError, match=field):
        geo.validate()


def test_geometry_is_consistent():
    geo = pa.ParafoilGeometry()
    assert geo.chord * geo.span == pytest.approx(geo.area)
    assert 2.0 <= geo.aspect_ratio <= 3.6  # cargo ram-air canopies; kC = AR/(1+AR) gives 3.6
    # wing loading of 2,200-lb-class cargo parafoils: about 1.5-3 lb/ft^2 = 72-144 N/m^2
    load = (geo.payload_mass + geo.canopy_mass) * geo.gravity / geo.area
    assert 72.0 <= load <= 144.0


def test_apparent_mass_is_lissaman_brown_and_spd_over_box():
    geo = pa.ParafoilGeometry()
    gains = box_samples()
    coefs = pa.gains_to_coefficients(gains)
    rho = 1.225
    m = pa.apparent_mass_matrix(coefs, geo, rho)
    assert np.allclose(m, np.transpose(m, (0, 2, 1)), atol=1e-9)
    assert np.all(np.linalg.eigvalsh(m)[:, 0] > 0.0)
    # translation and rotation keep the spectrum of the translational block: A, B, C
    b, c = geo.span, geo.chord
    t = geo.thickness_ratio * c
    expect = np.sort(
        np.stack(
            [
                coefs[:, pa.I_KA] * rho * math.pi / 4 * t**2 * b,
                coefs[:, pa.I_KB] * rho * math.pi / 4 * t**2 * c,
                coefs[:, pa.I_KC] * rho * math.pi / 4 * c**2 * b,
            ],
            1,
        ),
        1,
    )
    assert np.allclose(np.linalg.eigvalsh(m[:, :3, :3]), expect, rtol=1e-10)
    # about the canopy centre (no transfer), the rotational block has IA, IB, IC as spectrum
    ia = coefs[:, pa.I_KAS] * rho * math.pi / 48 * c**2 * b**3
    ib = coefs[:, pa.I_KBS] * rho * 4 / (48 * math.pi) * c**4 * b
    ic = coefs[:, pa.I_KCS] * rho * math.pi / 48 * t**2 * b**3
    r = pa._joint_to_centre(coefs, geo)
    s = pa._skew(r)
    tr = np.zeros_like(m)
    tr[:, :3, :3] = np.eye(3)
    tr[:, 3:, 3:] = np.eye(3)
    tr[:, :3, 3:] = s  # inverse of the transfer T = [[I, -S(r)], [0, I]]
    m_centre = np.transpose(tr, (0, 2, 1)) @ m @ tr
    assert np.allclose(
        np.linalg.eigvalsh(m_centre[:, 3:, 3:]), np.sort(np.stack([ia, ib, ic], 1), 1), rtol=1e-9
    )
    assert np.allclose(m_centre[:, :3, 3:], 0.0, atol=1e-8)


def test_rigid_and_total_mass_matrices_spd_over_box():
    from vectorid.models import get

    gains = box_samples(64, 64, seed=1)
    for name in ("parafoil8dof", "parafoil6dof"):
        model = get(name)
        for rho, th_r, ps_r in ((1.225, 0.0, 0.0), (0.9, 0.4, -1.0), (1.5, -0.6, 2.5)):
            a = model.mass_matrix(gains, rho, th_r, ps_r)
            assert np.allclose(a, np.transpose(a, (0, 2, 1)), rtol=1e-12, atol=1e-9)
            assert np.all(np.linalg.eigvalsh(a)[:, 0] > 0.0)


def _aero(gains: np.ndarray, u: float, v: float, w: float, p=0.0, q=0.0, r=0.0, dl=0.0, dr=0.0):
    k = pa.build_properties(gains[None])[0]
    out = np.zeros(9)
    pa.canopy_aero(k, 1.2, u, v, w, p, q, r, dl, dr, out)
    return k, out


def test_canopy_aero_lift_drag_and_symmetry():
    nom = pa.nominal_gains()
    alpha = math.radians(15.0)
    va = 14.0
    k, out = _aero(nom, va * math.cos(alpha), 0.0, va * math.sin(alpha))
    assert out[6] == pytest.approx(va)
    assert out[7] == pytest.approx(alpha)
    assert out[8] == 0.0
    assert out[1] == 0.0 and out[3] == 0.0 and out[5] == 0.0  # no lateral force/moment
    qs = 0.5 * 1.2 * va**2 * k[pa.I_S]
    cl = 0.0375 * (15.0 - 8.0 + 10.0)
    cd = 0.14 + 0.25 * cl**2
    lift = out[0] * math.sin(alpha) - out[2] * math.cos(alpha)
    drag = -(out[0] * math.cos(alpha) + out[2] * math.sin(alpha))
    assert lift == pytest.approx(qs * cl)
    assert drag == pytest.approx(qs * cd)
    assert out[4] == pytest.approx(qs * k[pa.I_C] * -0.33)
    # symmetric flaps: more lift and drag, still no lateral terms
    _, both = _aero(nom, va * math.cos(alpha), 0.0, va * math.sin(alpha), dl=0.5, dr=0.5)
    assert both[1] == 0.0 and both[5] == 0.0
    assert -both[2] > -out[2]


def test_flap_and_rate_signs():
    nom = pa.nominal_gains()
    u, w = 14.0, 3.5
    _, left = _aero(nom, u, 0.0, w, dl=0.5)
    _, right = _aero(nom, u, 0.0, w, dr=0.5)
    assert left[5] < 0.0 < right[5]  # left flap yaws left (psi decreases), right flap right
    assert left[5] == pytest.approx(-right[5])
    _, yawing = _aero(nom, u, 0.0, w, r=0.3)
    _, rolling = _aero(nom, u, 0.0, w, p=0.3)
    _, pitching = _aero(nom, u, 0.0, w, q=0.3)
    _, still = _aero(nom, u, 0.0, w)
    assert yawing[5] < still[5]  # Cnr < 0 damps yaw
    assert rolling[3] < still[3]  # Clp < 0 damps roll
    assert pitching[4] < still[4]  # Cmq < 0 damps pitch
    _, slip = _aero(nom, u, 2.0, w)
    assert slip[5] > 0.0  # Cnbeta > 0 at this alpha: weathercock stability
    _, off = _aero(nom, u, 0.0, w, dl=0.5, dr=0.2)
    g = nom.copy()
    g[pa.GAIN_NAMES.index("delcon")] = 0.2
    _, scaled = _aero(g, u, 0.0, w, dl=2.5, dr=1.0)
    assert np.allclose(off[:6], scaled[:6])  # delcon scales the commands


def test_dcm_and_euler_roundtrip():
    rng = np.random.default_rng(3)
    r = np.zeros((3, 3))
    for _ in range(50):
        phi, th, psi = rng.uniform(-3, 3), rng.uniform(-1.5, 1.5), rng.uniform(-3, 3)
        pa.dcm_body_to_ned(phi, th, psi, r)
        assert np.allclose(r @ r.T, np.eye(3))
        assert np.linalg.det(r) == pytest.approx(1.0)
        assert np.allclose(pa.euler_from_dcm(r), (phi, th, psi))
    # Euler rates: pure yaw rate with level attitude is psi_dot = r
    assert pa.euler_rates(0.0, 0.0, 0.0, 0.0, 0.2) == pytest.approx((0.0, 0.0, 0.2))
    # numerical check of the kinematics against the rotation-matrix derivative
    phi, th = 0.3, -0.2
    rates = np.array([0.1, -0.2, 0.3])
    d = np.array(pa.euler_rates(phi, th, *rates))
    h = 1e-6
    r0 = np.zeros((3, 3))
    r1 = np.zeros((3, 3))
    pa.dcm_body_to_ned(phi, th, 0.4, r0)
    pa.dcm_body_to_ned(phi + h * d[0], th + h * d[1], 0.4 + h * d[2], r1)
    omega = r0.T @ (r1 - r0) / h
    assert np.allclose([omega[2, 1], omega[0, 2], omega[1, 0]], rates, atol=1e-5)
