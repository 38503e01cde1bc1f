"""Parafoil-payload aerodynamics, mass properties and kinematics shared by the parafoil models.

This module holds everything the 8-DoF (:mod:`vectorid.models.parafoil8dof`) and the rigid 6-DoF
(:mod:`vectorid.models.parafoil6dof`) parafoil models have in common:

* the 33 gain factors c1..c33 of Figure 12 of Yakimenko & Statnikov (seed 000) with the nominal
  coefficient values of its "Set 0" column (:data:`GAINS`);
* the geometry and mass of the reference cargo parafoil (:class:`ParafoilGeometry`);
* :func:`build_properties`, which turns a batch of gain vectors into a per-trial property row
  (effective coefficients, rigid and apparent mass matrices about the payload joint, payload data),
  computed once per trial in numpy;
* numba-compiled scalar kernels used inside the integrator: rotation matrices, Euler-angle
  kinematics, the canopy aerodynamic force and moment, and the generalised mass matrix and
  right-hand side of the two-body (canopy + payload) system (:func:`system_matrices`).

Frames and conventions (see ``docs/models.md``):

* inertial frame: local north-east-down (NED), z down, altitude ``h = h0 - z``;
* canopy body frame ``c``: origin at the payload joint (confluence point) J, x forward, y right,
  z down along the suspension lines; Euler angles (phi, theta, psi) in the 3-2-1 (yaw-pitch-roll)
  order; yaw positive clockwise seen from above, so a left turn decreases psi;
* canopy aerodynamic frame: the canopy body frame pitched nose-down by the rigging angle ``Rig``;
  the canopy chord angle of attack is ``alpha_c = alpha - Rig``;
* payload frame ``p``: ``R_cp = Rz(psi_r) @ Ry(theta_r)`` maps payload components to canopy
  components (relative yaw about the line axis first, then relative pitch).

All angles are in radians in the state; coefficients whose reference values are per degree
(``CLalpha``, the sideslip derivatives, the ``grad`` parts) are applied to angles in degrees,
exactly as the Set 0 values imply.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numba as nb
import numpy as np

from vectorid.errors import VectoridError, suggest

__all__ = [
    "EXTRA_COEFFICIENTS",
    "GAINS",
    "GAIN_NAMES",
    "NPROP",
    "GainSpec",
    "ParafoilGeometry",
    "ParafoilOptionError",
    "apparent_mass_matrix",
    "build_properties",
    "canopy_aero",
    "dcm_body_to_ned",
    "euler_from_dcm",
    "euler_rates",
    "gains_to_coefficients",
    "nominal_gains",
    "reference_coefficients",
    "system_matrices",
]


class ParafoilOptionError(VectoridError, ValueError):
    """A parafoil model option (geometry, mass, coefficients, ...) is invalid.

    The message is one line: which option, what was expected, what came and how to fix it.
    """


class GainSpec(NamedTuple):
    """One of the 33 gain factors of Figure 12 of seed 000.

    Attributes
    ----------
    index : int
        The paper's number (1 for c1 ... 33 for c33).
    name : str
        Coefficient name as printed in Figure 12 (``CIDanom``/``CIDagrad`` of the scan are
        read as ``ClDanom``/``ClDagrad``, roll due to asymmetric flap; ``kA*`` is ``kA_star``).
    reference : float
        The "Set 0" value: the nominal coefficient the gain multiplies (or is added to).
    coef_unit : str
        Unit of the coefficient itself.
    additive : bool
        ``True`` when the gain is an offset added to the reference (default 0),
        ``False`` when it multiplies the reference (default 1).
    lower, upper : float
        Parameter bounds: ``[0.2, 2]`` for multiplicative gains (the range the paper settled
        on); a symmetric range for the additive ones.
    meaning : str
        Physical reading of the coefficient in this implementation.
    """

    index: int
    name: str
    reference: float
    coef_unit: str
    additive: bool
    lower: float
    upper: float
    meaning: str


def _mul(index: int, name: str, ref: float, unit: str, meaning: str) -> GainSpec:
    return GainSpec(index, name, ref, unit, False, 0.2, 2.0, meaning)


#: The 33 gain factors c1..c33 of seed 000, Figure 12, in the paper's order.
GAINS: tuple[GainSpec, ...] = (
    _mul(1, "delcon", 1.0, "-", "control scale: effective flap deflection = delcon * command"),
    GainSpec(
        2,
        "xcg",
        0.0,
        "m",
        True,
        -1.0,
        1.0,
        "forward shift of the payload joint (and so of the system CG) relative to the canopy "
        "aerodynamic reference point, along canopy x",
    ),
    _mul(3, "Alpha0", 10.0, "deg", "zero-lift angle magnitude: CL = CLalpha*(alpha_c + Alpha0)"),
    _mul(4, "CLalpha", 0.0375, "1/deg", "lift-curve slope per degree of chord angle of attack"),
    _mul(5, "CLDf", 0.2, "-", "lift increment per unit symmetric flap deflection"),
    _mul(6, "CD0", 0.14, "-", "zero-lift drag (canopy and lines)"),
    _mul(7, "A2", 0.25, "-", "induced-drag factor: CD = CD0 + A2*CL**2 + ADf*delta_s"),
    _mul(8, "ADf", 0.2, "-", "drag increment per unit symmetric flap deflection"),
    _mul(9, "Cm0", -0.33, "-", "pitching moment at zero rate about the canopy reference point"),
    _mul(10, "Rig", 8.0, "deg", "rigging angle: canopy chord pitched nose-down from canopy x"),
    _mul(11, "Cmq", -6.39, "-", "pitch damping per unit q*c/(2V)"),
    _mul(12, "CYbnom", -0.005, "1/deg", "side force per degree of sideslip at alpha_c = 0"),
    _mul(13, "CYbgrad", -0.0001, "1/deg^2", "change of CYbeta per degree of alpha_c"),
    _mul(14, "CYDanom", -0.007, "-", "side force per unit asymmetric flap at alpha_c = 0"),
    _mul(15, "CYDagrad", 0.0012, "1/deg", "change of CYdelta_a per degree of alpha_c"),
    _mul(16, "Clbnom", -0.0014, "1/deg", "rolling moment per degree of sideslip at alpha_c = 0"),
    GainSpec(
        17,
        "Clbgrad",
        -0.001,
        "1/deg^2",
        True,
        -0.001,
        0.001,
        "change of Clbeta per degree of alpha_c (additive gain)",
    ),
    _mul(18, "ClDanom", -0.0063, "-", "rolling moment per unit asymmetric flap at alpha_c = 0"),
    GainSpec(
        19,
        "ClDagrad",
        -0.001,
        "1/deg",
        True,
        -0.001,
        0.001,
        "change of Cldelta_a per degree of alpha_c (additive gain)",
    ),
    _mul(20, "Clp", -0.15, "-", "roll damping per unit p*b/(2V)"),
    _mul(21, "Clr", 0.0775, "-", "rolling moment per unit r*b/(2V)"),
    _mul(22, "Cnbnom", 0.007, "1/deg", "yawing moment per degree of sideslip at alpha_c = 0"),
    _mul(23, "Cnbgrad", -0.0003, "1/deg^2", "change of Cnbeta per degree of alpha_c"),
    _mul(24, "CnDanom", 0.03, "-", "yawing moment per unit asymmetric flap at alpha_c = 0"),
    _mul(25, "CnDagrad", -0.001, "1/deg", "change of Cndelta_a per degree of alpha_c"),
    _mul(26, "Cnp", 0.023, "-", "yawing moment per unit p*b/(2V)"),
    _mul(27, "Cnr", -0.0936, "-", "yaw damping per unit r*b/(2V)"),
    _mul(28, "kA", 0.899, "-", "Lissaman-Brown apparent mass factor, axial (chordwise) A"),
    _mul(29, "kB", 0.339, "-", "Lissaman-Brown apparent mass factor, side (spanwise) B"),
    _mul(30, "kC", 0.783, "-", "Lissaman-Brown apparent mass factor, normal C"),
    _mul(31, "kA_star", 0.63, "-", "Lissaman-Brown apparent inertia factor, roll IA"),
    _mul(32, "kB_star", 0.817, "-", "Lissaman-Brown apparent inertia factor, pitch IB"),
    _mul(33, "kC_star", 1.0, "-", "Lissaman-Brown apparent inertia factor, yaw IC"),
)

GAIN_NAMES: tuple[str, ...] = tuple(g.name for g in GAINS)
NGAIN = len(GAINS)
_REF = np.array([g.reference for g in GAINS])
_ADD = np.array([g.additive for g in GAINS])

# Indices of the effective coefficients in a property row (same order as GAINS).
(
    I_DELCON,
    I_XCG,
    I_ALPHA0,
    I_CLA,
    I_CLDF,
    I_CD0,
    I_A2,
    I_ADF,
    I_CM0,
    I_RIG,
    I_CMQ,
    I_CYBN,
    I_CYBG,
    I_CYDAN,
    I_CYDAG,
    I_CLBN,
    I_CLBG,
    I_CLDAN,
    I_CLDAG,
    I_CLP,
    I_CLR,
    I_CNBN,
    I_CNBG,
    I_CNDAN,
    I_CNDAG,
    I_CNP,
    I_CNR,
    I_KA,
    I_KB,
    I_KC,
    I_KAS,
    I_KBS,
    I_KCS,
) = range(33)

# Further entries of a property row.
I_S = 33  # canopy reference area, m^2
I_B = 34  # span, m
I_C = 35  # chord, m
I_MC = 36  # canopy + lines mass, m
I_MP = 37  # payload mass, kg
I_CDSP = 38  # payload drag area CD*S, m^2
I_G = 39  # gravity, m/s^2
I_RA = 40  # 40..42 joint -> canopy aerodynamic/apparent-mass reference point, canopy frame, m
I_RMC = 43  # 43..45 joint -> canopy mass centre, canopy frame, m
I_RP = 46  # 46..48 joint -> payload mass centre, payload frame, m
I_IP = 49  # 49..51 payload principal inertia Ixx, Iyy, Izz (payload frame), kg m^2
I_MRB = 52  # 52..87 canopy rigid-body 6x6 mass matrix about J, canopy frame (row major)
I_MAM = 88  # 88..123 apparent-mass 6x6 matrix about J per unit air density (row major)
I_KTH = 124  # joint pitch stiffness, N m/rad
I_CTH = 125  # joint pitch damping, N m s/rad
I_KPS = 126  # joint yaw (twist) stiffness, N m/rad
I_CPS = 127  # joint yaw (twist) damping, N m s/rad
I_CRIG = 128  # cos(Rig)
I_SRIG = 129  # sin(Rig)
I_AERO = 130  # 1.0: aerodynamic forces and moments on, 0.0: off (energy tests)
I_RAM = 131  # 131..133 joint -> canopy centre (mid-chord; mass and apparent-mass centre), m
I_MUNK = 134  # 1.0: the steady Munk moment is taken as contained in the static Cm, Cn data
I_CMA = 135  # Cmalpha: pitching moment per degree of chord angle of attack, 1/deg (default 0)
I_CDA2 = 136  # CDalpha2: drag per squared degree of chord angle of attack, 1/deg^2 (default 0)
I_WN = 137  # uniform wind added to the environment's, north, m/s (per-trial parameter)
I_WE = 138  # uniform wind added to the environment's, east, m/s (per-trial parameter)
NPROP = 139

#: Coefficients outside the 33 gains that a model option may set (name -> (unit, meaning)).
#: Both default to 0 (the seed's Set 0 has neither); they let a canopy whose data are stated in
#: these forms (e.g. ``CD = CD0 + CDa2 alpha^2``, ``Cm = Cm0 + Cma alpha + Cmq q^``) be entered.
EXTRA_COEFFICIENTS: dict[str, tuple[str, str]] = {
    "Cmalpha": ("1/deg", "pitching moment slope per degree of chord angle of attack alpha_c"),
    "CDalpha2": ("1/deg^2", "drag per squared degree of alpha_c: CD += CDalpha2*alpha_c**2"),
}


#: Units and meanings of the geometry fields, for option errors and documentation.
GEOMETRY_FIELDS: dict[str, tuple[str, str]] = {
    "area": ("m^2", "canopy reference (planform) area S"),
    "span": ("m", "canopy span b"),
    "thickness_ratio": ("-", "airfoil thickness over chord t/c"),
    "arc_ratio": ("-", "canopy arc height over span a/b"),
    "line_length": ("m", "joint J to canopy quarter chord, along canopy z (rigging)"),
    "canopy_ahead": ("m", "canopy quarter chord ahead of the joint J along canopy x (rigging)"),
    "canopy_mass": ("kg", "canopy fabric and suspension-line mass"),
    "payload_mass": ("kg", "payload mass"),
    "payload_size": ("m", "payload box length, width, height [x, y, z]"),
    "payload_cd": ("-", "payload drag coefficient on its frontal area width*height"),
    "riser_length": ("m", "joint J down to the top of the payload"),
    "joint_stiffness": ("N m/rad", "payload joint stiffness [pitch, yaw] (8-DoF)"),
    "joint_damping": ("N m s/rad", "payload joint damping [pitch, yaw] (8-DoF)"),
    "gravity": ("m/s^2", "gravitational acceleration"),
    "canopy_inertia": (
        "kg m^2",
        "principal inertia [Ixx, Iyy, Izz] of canopy and lines about their mass centre, canopy "
        "axes (default: thin plate of the canopy's mass and size)",
    ),
    "payload_inertia": (
        "kg m^2",
        "principal inertia [Ixx, Iyy, Izz] of the payload about its mass centre (default: solid "
        "box of payload_mass and payload_size)",
    ),
}
_TUPLE_LENGTHS = {
    "payload_size": 3,
    "joint_stiffness": 2,
    "joint_damping": 2,
    "canopy_inertia": 3,
    "payload_inertia": 3,
}


def _option_number(where: str, value: Any, unit: str) -> float:
    unit = "(dimensionless)" if unit == "-" else f"in {unit}"
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise ParafoilOptionError(
            f"model option {where}: expected a number {unit}, got {value!r}; "
            "write a plain number (e.g. 1.5)"
        )
    v = float(value)
    if not math.isfinite(v):
        raise ParafoilOptionError(
            f"model option {where}: expected a finite number {unit}, got {value!r}"
        )
    return v


@dataclass(frozen=True)
class ParafoilGeometry:
    """Mass and geometry of a parafoil-payload system (default: the reference cargo system).

    Defaults describe a generic ram-air cargo parafoil of the 2,200-lb (1,000-kg) class (the
    class of the Pegasus system of the seed's reference 5 and of the FireFly family): see
    ``docs/models.md`` for every value and where it comes from. Any other canopy is described
    by changing the fields (in a study file: ``model_options = { geometry = { ... } }``, see
    :meth:`from_options`).

    Attributes
    ----------
    area : float
        Canopy reference (planform) area S, m^2.
    span : float
        Canopy span b, m.
    thickness_ratio : float
        Airfoil thickness over chord t/c, -.
    arc_ratio : float
        Canopy arc height over span a/b (anhedral), -.
    line_length : float
        Distance from the payload joint J (confluence point) to the canopy aerodynamic
        reference point (quarter chord), along the canopy z axis, m.
    canopy_ahead : float
        Distance the canopy quarter chord lies ahead of the joint J along canopy x, m (the
        longitudinal rigging of the confluence point; ``xcg`` (c2) shifts it).
    canopy_mass : float
        Canopy fabric and suspension-line mass m_c, kg.
    payload_mass : float
        Payload (cargo, container, airborne guidance unit) mass m_p, kg.
    payload_size : tuple of float
        Payload box length, width, height (x, y, z), m.
    payload_cd : float
        Payload drag coefficient on its frontal area (width*height), -.
    riser_length : float
        Distance from the joint J down to the top of the payload, m.
    joint_stiffness : tuple of float
        Relative pitch and yaw (twist) stiffness of the payload joint, N m/rad (8-DoF only).
    joint_damping : tuple of float
        Relative pitch and yaw damping of the payload joint, N m s/rad (8-DoF only).
    gravity : float
        Gravitational acceleration, m/s^2.
    canopy_inertia : tuple of float or None
        Principal moments of inertia (Ixx, Iyy, Izz) of canopy and lines about their mass
        centre in canopy axes, kg m^2; ``None``: a thin plate of ``canopy_mass`` with the
        canopy's span, chord and thickness.
    payload_inertia : tuple of float or None
        Principal moments of inertia of the payload about its mass centre, payload axes,
        kg m^2; ``None``: a solid box of ``payload_mass`` and ``payload_size``.
    """

    area: float = 90.0
    span: float = 16.43
    thickness_ratio: float = 0.15
    arc_ratio: float = 0.15
    line_length: float = 11.0
    canopy_ahead: float = 1.8
    canopy_mass: float = 45.0
    payload_mass: float = 900.0
    payload_size: tuple[float, float, float] = (1.2, 1.2, 1.2)
    payload_cd: float = 1.05
    riser_length: float = 0.9
    joint_stiffness: tuple[float, float] = (0.0, 2000.0)
    joint_damping: tuple[float, float] = (2000.0, 700.0)
    gravity: float = 9.80665
    canopy_inertia: tuple[float, float, float] | None = None
    payload_inertia: tuple[float, float, float] | None = None

    @property
    def chord(self) -> float:
        """Mean chord c = S/b, m."""
        return self.area / self.span

    @property
    def aspect_ratio(self) -> float:
        """Aspect ratio b^2/S, -."""
        return self.span**2 / self.area

    @property
    def wing_loading(self) -> float:
        """Weight over canopy area (m_c + m_p) g / S, N/m^2."""
        return (self.canopy_mass + self.payload_mass) * self.gravity / self.area

    @classmethod
    def from_options(
        cls, options: Mapping[str, Any], base: ParafoilGeometry | None = None
    ) -> ParafoilGeometry:
        """A geometry from a mapping of field values (a study file's ``geometry = {...}``).

        Fields not given keep the values of ``base`` (default: the reference cargo system).
        Raises :class:`ParafoilOptionError` with a one-line message for an unknown field, a
        value of the wrong kind or length, or a non-physical value.
        """
        if not isinstance(options, Mapping):
            raise ParafoilOptionError(
                f"model option geometry: expected a table of fields, got {options!r}; write "
                "geometry = { area = 1.5, span = 1.88, ... }"
            )
        values: dict[str, Any] = {}
        for key, value in options.items():
            if key not in GEOMETRY_FIELDS:
                hint = suggest(str(key), GEOMETRY_FIELDS)
                raise ParafoilOptionError(f"model option geometry.{key}: unknown field; {hint}")
            unit = GEOMETRY_FIELDS[key][0]
            length = _TUPLE_LENGTHS.get(key)
            if length is None:
                values[key] = _option_number(f"geometry.{key}", value, unit)
                continue
            if value is None and key in ("canopy_inertia", "payload_inertia"):
                values[key] = None
                continue
            if isinstance(value, str | bytes) or not isinstance(value, Sequence | np.ndarray):
                raise ParafoilOptionError(
                    f"model option geometry.{key}: expected {length} numbers in {unit}, got "
                    f"{value!r}; write {key} = [{', '.join(['1.0'] * length)}]"
                )
            if len(value) != length:
                raise ParafoilOptionError(
                    f"model option geometry.{key}: expected {length} numbers in {unit}, got "
                    f"{len(value)} ({list(value)!r})"
                )
            values[key] = tuple(
                _option_number(f"geometry.{key}[{i}]", v, unit) for i, v in enumerate(value)
            )
        from dataclasses import replace

        geo = replace(base or cls(), **values)
        geo.validate()
        return geo

    def validate(self) -> None:
        """Raise :class:`ParafoilOptionError` naming the field when a value is not physical."""
        for f in fields(self):
            value = getattr(self, f.name)
            if value is None and f.name in ("canopy_inertia", "payload_inertia"):
                continue
            values = value if isinstance(value, tuple) else (value,)
            length = _TUPLE_LENGTHS.get(f.name)
            if length is not None and len(values) != length:
                raise ParafoilOptionError(
                    f"ParafoilGeometry.{f.name} must be {length} numbers, got {value!r}."
                )
            for v in values:
                if not np.isfinite(v):
                    raise ParafoilOptionError(
                        f"ParafoilGeometry.{f.name} must be finite, got {value!r}."
                    )
        positive = (
            "area",
            "span",
            "thickness_ratio",
            "line_length",
            "canopy_mass",
            "payload_mass",
            "payload_cd",
            "gravity",
        )
        for name in positive:
            if getattr(self, name) <= 0.0:
                raise ParafoilOptionError(
                    f"ParafoilGeometry.{name} must be > 0, got {getattr(self, name)!r}; "
                    f"use a positive value in {GEOMETRY_FIELDS[name][0]} "
                    f"({GEOMETRY_FIELDS[name][1]})."
                )
        if min(self.payload_size) <= 0.0:
            raise ParafoilOptionError(
                f"ParafoilGeometry.payload_size must be three positive lengths in m, "
                f"got {self.payload_size!r}."
            )
        if self.arc_ratio < 0.0 or self.riser_length < 0.0:
            raise ParafoilOptionError(
                "ParafoilGeometry.arc_ratio and riser_length must be >= 0, "
                f"got {self.arc_ratio!r} and {self.riser_length!r}."
            )
        if min(self.joint_stiffness) < 0.0 or min(self.joint_damping) < 0.0:
            raise ParafoilOptionError(
                "ParafoilGeometry.joint_stiffness and joint_damping must be >= 0, got "
                f"{self.joint_stiffness!r} and {self.joint_damping!r}."
            )
        for name in ("canopy_inertia", "payload_inertia"):
            inertia = getattr(self, name)
            if inertia is None:
                continue
            a, b, c = sorted(inertia)
            if a <= 0.0 or a + b < c * (1.0 - 1e-9):
                raise ParafoilOptionError(
                    f"ParafoilGeometry.{name} must be three positive principal moments in kg m^2 "
                    f"that satisfy the triangle inequality (each <= the sum of the other two), "
                    f"got {inertia!r}."
                )


def nominal_gains() -> np.ndarray:
    """The nominal gain vector: 1 for multiplicative gains, 0 for additive ones, shape (33,)."""
    return np.where(_ADD, 0.0, 1.0)


def reference_coefficients(overrides: Mapping[str, Any] | None = None) -> np.ndarray:
    """The Set-0 reference coefficients (33,) with some replaced: another canopy's nominal set.

    Parameters
    ----------
    overrides : mapping of str to float, optional
        Coefficient name (:data:`GAIN_NAMES`) -> reference value in the coefficient's unit
        (:attr:`GainSpec.coef_unit`). The gains then multiply (or are added to) these values.

    Raises
    ------
    ParafoilOptionError
        Unknown name or a value that is not a finite number.
    """
    ref = _REF.copy()
    for key, value in dict(overrides or {}).items():
        if key not in GAIN_NAMES:
            raise ParafoilOptionError(
                f"model option coefficients.{key}: unknown coefficient; "
                f"{suggest(str(key), [*GAIN_NAMES, *EXTRA_COEFFICIENTS])}"
            )
        g = GAINS[GAIN_NAMES.index(key)]
        ref[g.index - 1] = _option_number(f"coefficients.{key}", value, g.coef_unit)
    return ref


def gains_to_coefficients(gains: np.ndarray, reference: np.ndarray | None = None) -> np.ndarray:
    """Effective coefficients from gains: ``ref*gain`` (multiplicative) or ``ref+gain`` (additive).

    Parameters
    ----------
    gains : ndarray, shape (n, 33)
        Gain factors c1..c33 in the order of :data:`GAINS`.
    reference : ndarray, shape (33,), optional
        Reference coefficients (default: the seed's Set 0; see :func:`reference_coefficients`).

    Returns
    -------
    ndarray, shape (n, 33)
        Coefficients in the units of :attr:`GainSpec.coef_unit`.
    """
    g = np.asarray(gains, dtype=float)
    if g.ndim != 2 or g.shape[1] != NGAIN:
        raise ValueError(
            f"gains must have shape (n, {NGAIN}) (one row of c1..c{NGAIN} per trial), "
            f"got shape {g.shape}; reshape with gains.reshape(-1, {NGAIN})."
        )
    ref = _REF if reference is None else np.asarray(reference, dtype=float)
    return np.where(_ADD, ref + g, ref * g)


def _skew(r: np.ndarray) -> np.ndarray:
    """Cross-product matrix: ``_skew(r) @ x == np.cross(r, x)``; r has shape (..., 3)."""
    z = np.zeros(r.shape[:-1])
    return np.stack(
        [
            np.stack([z, -r[..., 2], r[..., 1]], -1),
            np.stack([r[..., 2], z, -r[..., 0]], -1),
            np.stack([-r[..., 1], r[..., 0], z], -1),
        ],
        -2,
    )


def _rigid_mass_about(m: float, r: np.ndarray, i_cg: np.ndarray) -> np.ndarray:
    """6x6 rigid-body mass matrix about a reference point, for mass centre at r (batch)."""
    n = r.shape[0]
    s = _skew(r)
    out = np.zeros((n, 6, 6))
    out[:, :3, :3] = m * np.eye(3)
    out[:, :3, 3:] = -m * s
    out[:, 3:, :3] = m * s
    out[:, 3:, 3:] = i_cg - m * s @ s
    return out


def apparent_mass_matrix(
    coefs: np.ndarray, geometry: ParafoilGeometry, rho: float = 1.0
) -> np.ndarray:
    """Apparent-mass 6x6 matrix about the payload joint J in canopy body axes.

    Lissaman & Brown (1993) form, diagonal in the canopy aerodynamic (chord) frame at the canopy
    reference point::

        A  = kA  * rho * pi/4 * t^2 * b        (chordwise)
        B  = kB  * rho * pi/4 * t^2 * c        (spanwise)
        C  = kC  * rho * pi/4 * c^2 * b        (normal)
        IA = kA* * rho * pi/48 * c^2 * b^3     (roll)
        IB = kB* * rho * 4/(48 pi) * c^4 * b   (pitch)
        IC = kC* * rho * pi/48 * t^2 * b^3     (yaw)

    about the canopy centre (mid-chord), rotated by the rigging angle into canopy body axes and
    transferred to J.

    Parameters
    ----------
    coefs : ndarray, shape (n, 33)
        Effective coefficients from :func:`gains_to_coefficients`.
    geometry : ParafoilGeometry
        Canopy geometry.
    rho : float
        Air density, kg/m^3 (1.0 gives the matrix per unit density).

    Returns
    -------
    ndarray, shape (n, 6, 6)
        Symmetric apparent-mass matrix [kg, kg m, kg m^2 blocks].
    """
    coefs = np.atleast_2d(coefs)
    n = coefs.shape[0]
    b, c = geometry.span, geometry.chord
    t = geometry.thickness_ratio * c
    d = np.zeros((n, 6))
    d[:, 0] = coefs[:, I_KA] * math.pi / 4.0 * t**2 * b
    d[:, 1] = coefs[:, I_KB] * math.pi / 4.0 * t**2 * c
    d[:, 2] = coefs[:, I_KC] * math.pi / 4.0 * c**2 * b
    d[:, 3] = coefs[:, I_KAS] * math.pi / 48.0 * c**2 * b**3
    d[:, 4] = coefs[:, I_KBS] * 4.0 / (48.0 * math.pi) * c**4 * b
    d[:, 5] = coefs[:, I_KCS] * math.pi / 48.0 * t**2 * b**3
    rig = np.deg2rad(coefs[:, I_RIG])
    # R maps canopy-body components to aerodynamic-frame components (pitch by -Rig).
    cr, sr = np.cos(-rig), np.sin(-rig)
    rot = np.zeros((n, 3, 3))
    rot[:, 0, 0] = cr
    rot[:, 0, 2] = -sr
    rot[:, 1, 1] = 1.0
    rot[:, 2, 0] = sr
    rot[:, 2, 2] = cr
    m_o = np.zeros((n, 6, 6))
    rt = np.transpose(rot, (0, 2, 1))
    m_o[:, :3, :3] = rt @ (d[:, :3, None] * rot)
    m_o[:, 3:, 3:] = rt @ (d[:, 3:, None] * rot)
    r_a = _joint_to_centre(coefs, geometry)
    tr = np.zeros((n, 6, 6))
    tr[:, :3, :3] = np.eye(3)
    tr[:, 3:, 3:] = np.eye(3)
    tr[:, :3, 3:] = -_skew(r_a)
    out = np.transpose(tr, (0, 2, 1)) @ m_o @ tr
    return rho * 0.5 * (out + np.transpose(out, (0, 2, 1)))


def _joint_to_canopy(coefs: np.ndarray, geometry: ParafoilGeometry) -> np.ndarray:
    """Vector J -> canopy aerodynamic reference point (quarter chord), canopy axes, (n, 3)."""
    n = coefs.shape[0]
    r = np.zeros((n, 3))
    r[:, 0] = geometry.canopy_ahead - coefs[:, I_XCG]
    r[:, 2] = -geometry.line_length
    return r


def _joint_to_centre(coefs: np.ndarray, geometry: ParafoilGeometry) -> np.ndarray:
    """Vector J -> canopy centre (mid-chord), canopy axes, shape (n, 3).

    The chord is pitched nose-down by ``Rig``: its unit vector is ``(cos Rig, 0, sin Rig)``;
    mid-chord lies a quarter chord behind the quarter-chord point.
    """
    rig = np.deg2rad(coefs[:, I_RIG])
    r = _joint_to_canopy(coefs, geometry)
    quarter = 0.25 * geometry.chord
    r[:, 0] -= quarter * np.cos(rig)
    r[:, 2] -= quarter * np.sin(rig)
    return r


def build_properties(
    gains: np.ndarray,
    geometry: ParafoilGeometry | None = None,
    *,
    aero: bool = True,
    munk_in_static_data: bool = True,
    reference: np.ndarray | None = None,
    extra_coefficients: Mapping[str, float] | None = None,
    payload_mass: np.ndarray | None = None,
    wind_offset: np.ndarray | None = None,
) -> np.ndarray:
    """Per-trial property rows for the compiled kernels.

    Parameters
    ----------
    gains : ndarray, shape (n, 33)
        Gain factors c1..c33.
    geometry : ParafoilGeometry, optional
        Mass and geometry; the reference system when omitted.
    aero : bool
        ``False`` switches the aerodynamic forces and moments (canopy and payload) off; the
        apparent masses stay (they are conservative in air of uniform density).
    munk_in_static_data : bool
        ``True`` (default): the steady part of the apparent-mass moment, the Munk moment
        ``v_rel x (M_11 v_rel)``, is taken as already contained in the static moment
        coefficients (they come from steady wind-tunnel and flight data) and is removed from
        the Kirchhoff terms, so that it is not counted twice. Only applies with ``aero=True``.
    reference : ndarray, shape (33,), optional
        Reference coefficients the gains apply to (default: Set 0).
    extra_coefficients : mapping, optional
        Values of :data:`EXTRA_COEFFICIENTS` (``Cmalpha`` 1/deg, ``CDalpha2`` 1/deg^2;
        default 0).
    payload_mass : ndarray, shape (n,), optional
        Per-trial payload mass, kg (default: ``geometry.payload_mass``); a box payload's
        inertia scales with it, a stated ``payload_inertia`` is scaled by the mass ratio.
    wind_offset : ndarray, shape (n, 2), optional
        Per-trial uniform wind (north, east) added to the environment's wind, m/s.

    Returns
    -------
    ndarray, shape (n, NPROP)
        Property rows; indices are the ``I_*`` constants of this module.
    """
    geometry = geometry or ParafoilGeometry()
    geometry.validate()
    coefs = gains_to_coefficients(gains, reference)
    n = coefs.shape[0]
    props = np.zeros((n, NPROP))
    props[:, :NGAIN] = coefs
    b, c = geometry.span, geometry.chord
    props[:, I_S] = geometry.area
    props[:, I_B] = b
    props[:, I_C] = c
    props[:, I_MC] = geometry.canopy_mass
    mp = np.full(n, geometry.payload_mass) if payload_mass is None else np.asarray(payload_mass)
    props[:, I_MP] = mp
    lx, ly, lz = geometry.payload_size
    props[:, I_CDSP] = geometry.payload_cd * ly * lz
    props[:, I_G] = geometry.gravity
    r_a = _joint_to_canopy(coefs, geometry)
    props[:, I_RA : I_RA + 3] = r_a
    # Canopy and line mass centre: at the canopy centre (mid-chord). The arc lifts the fabric's
    # mass centre above that point while the lines' mass lies below it; to first order the two
    # cancel, so the mid-chord point is used.
    r_mid = _joint_to_centre(coefs, geometry)
    props[:, I_RMC : I_RMC + 3] = r_mid
    props[:, I_RAM : I_RAM + 3] = r_mid
    props[:, I_RP + 2] = geometry.riser_length + 0.5 * lz
    if geometry.payload_inertia is None:
        props[:, I_IP] = mp * (ly**2 + lz**2) / 12.0
        props[:, I_IP + 1] = mp * (lx**2 + lz**2) / 12.0
        props[:, I_IP + 2] = mp * (lx**2 + ly**2) / 12.0
    else:
        scale = mp / geometry.payload_mass
        for j in range(3):
            props[:, I_IP + j] = geometry.payload_inertia[j] * scale
    mc = geometry.canopy_mass
    t = geometry.thickness_ratio * c
    if geometry.canopy_inertia is None:
        i_c = np.diag([b**2 + t**2, c**2 + t**2, b**2 + c**2]) * (mc / 12.0)
    else:
        i_c = np.diag(np.asarray(geometry.canopy_inertia, dtype=float))
    props[:, I_MRB : I_MRB + 36] = _rigid_mass_about(mc, r_mid, i_c).reshape(n, 36)
    props[:, I_MAM : I_MAM + 36] = apparent_mass_matrix(coefs, geometry, 1.0).reshape(n, 36)
    props[:, I_KTH], props[:, I_KPS] = geometry.joint_stiffness
    props[:, I_CTH], props[:, I_CPS] = geometry.joint_damping
    rig = np.deg2rad(coefs[:, I_RIG])
    props[:, I_CRIG] = np.cos(rig)
    props[:, I_SRIG] = np.sin(rig)
    props[:, I_AERO] = 1.0 if aero else 0.0
    props[:, I_MUNK] = 1.0 if (aero and munk_in_static_data) else 0.0
    extra = dict(extra_coefficients or {})
    for key in extra:
        if key not in EXTRA_COEFFICIENTS:
            raise ParafoilOptionError(
                f"model option coefficients.{key}: unknown coefficient; "
                f"{suggest(str(key), [*GAIN_NAMES, *EXTRA_COEFFICIENTS])}"
            )
    props[:, I_CMA] = float(extra.get("Cmalpha", 0.0))
    props[:, I_CDA2] = float(extra.get("CDalpha2", 0.0))
    if wind_offset is not None:
        w = np.asarray(wind_offset, dtype=float)
        props[:, I_WN] = w[:, 0]
        props[:, I_WE] = w[:, 1]
    return props


# ---------------------------------------------------------------------------------------------
# Compiled scalar kernels
# ---------------------------------------------------------------------------------------------

_jit = nb.njit(cache=True, fastmath=False, nogil=True, error_model="numpy")
_jit_inline = nb.njit(cache=True, nogil=True, error_model="numpy", inline="always")


@_jit_inline
def dcm_body_to_ned(phi: float, theta: float, psi: float, out: np.ndarray) -> None:
    """Rotation matrix body -> NED for 3-2-1 Euler angles (rad); writes ``out`` (3, 3)."""
    cf, sf = math.cos(phi), math.sin(phi)
    ct, st = math.cos(theta), math.sin(theta)
    cp, sp = math.cos(psi), math.sin(psi)
    out[0, 0] = ct * cp
    out[0, 1] = sf * st * cp - cf * sp
    out[0, 2] = cf * st * cp + sf * sp
    out[1, 0] = ct * sp
    out[1, 1] = sf * st * sp + cf * cp
    out[1, 2] = cf * st * sp - sf * cp
    out[2, 0] = -st
    out[2, 1] = sf * ct
    out[2, 2] = cf * ct


@_jit
def euler_from_dcm(r: np.ndarray) -> tuple[float, float, float]:
    """3-2-1 Euler angles (phi, theta, psi) in rad from a body -> NED rotation matrix."""
    s = -r[2, 0]
    s = min(1.0, max(-1.0, s))
    return math.atan2(r[2, 1], r[2, 2]), math.asin(s), math.atan2(r[1, 0], r[0, 0])


@_jit
def euler_rates(
    phi: float, theta: float, p: float, q: float, r: float
) -> tuple[float, float, float]:
    """Euler-angle rates (rad/s) from body rates (rad/s), eq. (2) of seed 000 (3-2-1 order)."""
    cf, sf = math.cos(phi), math.sin(phi)
    ct = math.cos(theta)
    qr = q * sf + r * cf
    return p + qr * math.tan(theta), q * cf - r * sf, qr / ct


@_jit_inline
def canopy_aero(
    k: np.ndarray,
    rho: float,
    ur: float,
    vr: float,
    wr: float,
    p: float,
    q: float,
    r: float,
    dl: float,
    dr: float,
    out: np.ndarray,
) -> None:
    """Canopy aerodynamic force and moment (about the canopy reference point), canopy axes.

    Parameters
    ----------
    k : ndarray, shape (NPROP,)
        Property row of the trial.
    rho : float
        Air density, kg/m^3.
    ur, vr, wr : float
        Air-relative velocity of the canopy reference point in canopy axes, m/s.
    p, q, r : float
        Canopy angular rates, rad/s.
    dl, dr : float
        Commanded left and right trailing-edge deflections (0 = none, 1 = full), -.
    out : ndarray, shape (>= 9,)
        Receives Fx, Fy, Fz (N), L, M, N (N m), airspeed (m/s), alpha, beta (rad); alpha and
        beta are those of the canopy body axes (the chord angle of attack is alpha - Rig).
    """
    va2 = ur * ur + vr * vr + wr * wr
    va = math.sqrt(va2)
    if va < 1e-6:
        for i in range(9):
            out[i] = 0.0
        return
    alpha = math.atan2(wr, ur)
    inv_va = 1.0 / va  # one division, then products (divisions are slow and serial)
    beta = math.asin(min(1.0, max(-1.0, vr * inv_va)))
    out[6] = va
    out[7] = alpha
    out[8] = beta
    if k[I_AERO] == 0.0:
        for i in range(6):
            out[i] = 0.0
        return
    deg = 180.0 / math.pi
    delcon = k[I_DELCON]
    ds = 0.5 * delcon * (dl + dr)
    da = delcon * (dr - dl)
    ac = alpha * deg - k[I_RIG]  # chord angle of attack, deg
    bd = beta * deg
    cl = k[I_CLA] * (ac + k[I_ALPHA0]) + k[I_CLDF] * ds
    cd = k[I_CD0] + k[I_A2] * cl * cl + k[I_CDA2] * ac * ac + k[I_ADF] * ds
    cy = (k[I_CYBN] + k[I_CYBG] * ac) * bd + (k[I_CYDAN] + k[I_CYDAG] * ac) * da
    b = k[I_B]
    c = k[I_C]
    half_inv_va = 0.5 * inv_va
    ph = p * b * half_inv_va
    qh = q * c * half_inv_va
    rh = r * b * half_inv_va
    cl_roll = (
        (k[I_CLBN] + k[I_CLBG] * ac) * bd
        + (k[I_CLDAN] + k[I_CLDAG] * ac) * da
        + k[I_CLP] * ph
        + k[I_CLR] * rh
    )
    cm = k[I_CM0] + k[I_CMA] * ac + k[I_CMQ] * qh
    cn = (
        (k[I_CNBN] + k[I_CNBG] * ac) * bd
        + (k[I_CNDAN] + k[I_CNDAG] * ac) * da
        + k[I_CNP] * ph
        + k[I_CNR] * rh
    )
    qs = 0.5 * rho * va2 * k[I_S]
    # unit vectors: drag along -V, lift perpendicular to V in the plane normal to canopy y
    ex, ey, ez = ur * inv_va, vr * inv_va, wr * inv_va
    nxz = math.sqrt(ex * ex + ez * ez)
    if nxz < 1e-9:
        lx, lz = 0.0, 0.0
    else:
        inv_nxz = 1.0 / nxz
        lx, lz = ez * inv_nxz, -ex * inv_nxz
    out[0] = qs * (-cd * ex + cl * lx)
    out[1] = qs * (-cd * ey + cy)
    out[2] = qs * (-cd * ez + cl * lz)
    out[3] = qs * b * cl_roll
    out[4] = qs * c * cm
    out[5] = qs * b * cn


@_jit
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@_jit_inline
def system_matrices(
    k: np.ndarray,
    rho: float,
    gx: float,
    gy: float,
    gz: float,
    th_r: float,
    ps_r: float,
    vel: np.ndarray,
    wind_c: np.ndarray,
    dl: float,
    dr: float,
    mass: np.ndarray,
    rhs: np.ndarray,
    aux: np.ndarray,
) -> None:
    """Generalised mass matrix A and right-hand side of the canopy + payload system.

    Generalised speeds (canopy axes) ``u = [u, v, w, p, q, r, theta_r_dot, psi_r_dot]``: the
    inertial velocity of the joint J, the canopy angular velocity and the payload's relative
    pitch and yaw rates. The equations are ``A(q) du/dt = F(q, u) - Sigma(u) A u`` written out by
    Kane's method (canopy: Kirchhoff's equations with apparent mass; payload: Newton-Euler through
    its partial velocities). For the rigid 6-DoF model call with ``th_r = ps_r = 0`` and
    ``vel[6:8] = 0`` and use the leading 6x6 block.

    Parameters
    ----------
    k : ndarray, shape (NPROP,)
        Property row.
    rho : float
        Air density, kg/m^3.
    gx, gy, gz : float
        Gravitational acceleration in canopy axes, m/s^2 (``g * R_ib[2, :]``).
    th_r, ps_r : float
        Payload relative pitch and yaw (rad).
    vel : ndarray, shape (8,)
        Generalised speeds.
    wind_c : ndarray, shape (3,)
        Wind (air velocity over ground) in canopy axes, m/s; assumed uniform and steady in
        the apparent-mass terms.
    dl, dr : float
        Left and right flap commands, -.
    mass : ndarray, shape (8, 8)
        Receives the symmetric mass matrix A.
    rhs : ndarray, shape (8,)
        Receives the generalised forces minus velocity terms.
    aux : ndarray, shape (>= 70,)
        Work array; on return ``aux[6:9]`` = canopy airspeed (m/s), alpha, beta (rad) and
        ``aux[9:12]`` = payload mass-centre offset from J in canopy axes (m).
    """
    u, v, w = vel[0], vel[1], vel[2]
    p, q, r = vel[3], vel[4], vel[5]
    tdot, pdot = vel[6], vel[7]

    # ---- canopy: rigid part + apparent mass (Kirchhoff), about J -------------------------
    # Every entry of ``mass`` and ``rhs`` is assigned below except these (sums start from 0).
    rhs[6] = 0.0
    rhs[7] = 0.0
    mass[2, 7] = 0.0
    wx, wy, wz = wind_c[0], wind_c[1], wind_c[2]
    urel, vrel, wrel = u - wx, v - wy, w - wz
    for i in range(6):
        for j in range(6):
            mass[i, j] = k[I_MRB + 6 * i + j] + rho * k[I_MAM + 6 * i + j]
    # momenta: rigid uses inertial velocity, apparent mass the air-relative one
    pr = aux[64:70]  # rigid-body momenta
    vi = (u, v, w, p, q, r)
    va = (urel, vrel, wrel, p, q, r)
    for i in range(6):
        s_rb = 0.0
        s_am = 0.0
        for j in range(6):
            s_rb += k[I_MRB + 6 * i + j] * vi[j]
            s_am += k[I_MAM + 6 * i + j] * va[j]
        pr[i] = s_rb
        aux[i] = rho * s_am
    # Sigma * A * V (Kirchhoff gyroscopic terms)
    c1 = _cross(p, q, r, pr[0], pr[1], pr[2])
    c2 = _cross(p, q, r, pr[3], pr[4], pr[5])
    c3 = _cross(u, v, w, pr[0], pr[1], pr[2])
    a1 = _cross(p, q, r, aux[0], aux[1], aux[2])
    a2 = _cross(p, q, r, aux[3], aux[4], aux[5])
    a3 = _cross(urel, vrel, wrel, aux[0], aux[1], aux[2])
    if k[I_MUNK] != 0.0:
        # remove the steady Munk moment v_rel x (M11 v_rel): it is in the static coefficients
        m0 = 0.0
        m1 = 0.0
        m2 = 0.0
        for j in range(3):
            m0 += k[I_MAM + j] * va[j]
            m1 += k[I_MAM + 6 + j] * va[j]
            m2 += k[I_MAM + 12 + j] * va[j]
        mk = _cross(urel, vrel, wrel, rho * m0, rho * m1, rho * m2)
        a3 = (a3[0] - mk[0], a3[1] - mk[1], a3[2] - mk[2])
    # steady uniform wind seen from the rotating canopy frame: d(v_rel)/dt = du/dt + omega x w
    ow = _cross(p, q, r, wx, wy, wz)
    for i in range(3):
        extra_t = 0.0
        extra_r = 0.0
        for j in range(3):
            extra_t += rho * k[I_MAM + 6 * i + j] * ow[j]
            extra_r += rho * k[I_MAM + 6 * (i + 3) + j] * ow[j]
        rhs[i] = -(c1[i] + a1[i]) - extra_t
        rhs[3 + i] = -(c2[i] + c3[i] + a2[i] + a3[i]) - extra_r
    # gravity on canopy mass
    mc = k[I_MC]
    rmx, rmy, rmz = k[I_RMC], k[I_RMC + 1], k[I_RMC + 2]
    rhs[0] += mc * gx
    rhs[1] += mc * gy
    rhs[2] += mc * gz
    t1 = _cross(rmx, rmy, rmz, mc * gx, mc * gy, mc * gz)
    rhs[3] += t1[0]
    rhs[4] += t1[1]
    rhs[5] += t1[2]
    # canopy aerodynamics at the canopy reference point
    rax, ray, raz = k[I_RA], k[I_RA + 1], k[I_RA + 2]
    vc = _cross(p, q, r, rax, ray, raz)
    canopy_aero(k, rho, urel + vc[0], vrel + vc[1], wrel + vc[2], p, q, r, dl, dr, aux[6:15])
    fx, fy, fz = aux[6], aux[7], aux[8]
    t2 = _cross(rax, ray, raz, fx, fy, fz)
    rhs[0] += fx
    rhs[1] += fy
    rhs[2] += fz
    rhs[3] += t2[0] + aux[9]
    rhs[4] += t2[1] + aux[10]
    rhs[5] += t2[2] + aux[11]
    airspeed, alpha, beta = aux[12], aux[13], aux[14]

    # ---- payload (Newton-Euler through partial velocities) --------------------------------
    cth, sth = math.cos(th_r), math.sin(th_r)
    cps, sps = math.cos(ps_r), math.sin(ps_r)
    # R_cp = Rz(ps_r) @ Ry(th_r)
    r00, r01, r02 = cps * cth, -sps, cps * sth
    r10, r11, r12 = sps * cth, cps, sps * sth
    r20, r21, r22 = -sth, 0.0, cth
    px, py, pz = k[I_RP], k[I_RP + 1], k[I_RP + 2]
    rx = r00 * px + r01 * py + r02 * pz
    ry = r10 * px + r11 * py + r12 * pz
    rz = r20 * px + r21 * py + r22 * pz
    # partial angular velocities (canopy axes): e_theta, e_psi
    etx, ety, etz = -sps, cps, 0.0
    # payload inertia in canopy axes: I_c = R diag(I) R^T
    i0, i1, i2 = k[I_IP], k[I_IP + 1], k[I_IP + 2]
    ixx = r00 * r00 * i0 + r01 * r01 * i1 + r02 * r02 * i2
    iyy = r10 * r10 * i0 + r11 * r11 * i1 + r12 * r12 * i2
    izz = r20 * r20 * i0 + r21 * r21 * i1 + r22 * r22 * i2
    ixy = r00 * r10 * i0 + r01 * r11 * i1 + r02 * r12 * i2
    ixz = r00 * r20 * i0 + r01 * r21 * i1 + r02 * r22 * i2
    iyz = r10 * r20 * i0 + r11 * r21 * i1 + r12 * r22 * i2
    # Omega = omega + tdot e_theta + pdot e_z
    ox = p + tdot * etx
    oy = q + tdot * ety
    oz = r + tdot * etz + pdot
    # payload velocity and acceleration terms independent of du/dt
    orho = _cross(ox, oy, oz, rx, ry, rz)
    vpx, vpy, vpz = u + orho[0], v + orho[1], w + orho[2]
    # alpha0 = tdot*pdot*(e_z x e_theta) + omega x Omega;  e_z x e_theta = (-cps, -sps, 0)
    woo = _cross(p, q, r, ox, oy, oz)
    al0x = -tdot * pdot * cps + woo[0]
    al0y = -tdot * pdot * sps + woo[1]
    al0z = woo[2]
    t3 = _cross(p, q, r, u, v, w)
    t4 = _cross(al0x, al0y, al0z, rx, ry, rz)
    t5 = _cross(ox, oy, oz, orho[0], orho[1], orho[2])
    mp = k[I_MP]
    # applied force on payload: gravity + drag at its mass centre, minus m*a0
    vprx, vpry, vprz = vpx - wx, vpy - wy, vpz - wz
    vpr = math.sqrt(vprx * vprx + vpry * vpry + vprz * vprz)
    dq = -0.5 * rho * k[I_CDSP] * vpr * k[I_AERO]
    fpx = mp * gx + dq * vprx - mp * (t3[0] + t4[0] + t5[0])
    fpy = mp * gy + dq * vpry - mp * (t3[1] + t4[1] + t5[1])
    fpz = mp * gz + dq * vprz - mp * (t3[2] + t4[2] + t5[2])
    # moment on payload about its mass centre: -(I alpha0 + Omega x I Omega)
    iox = ixx * ox + ixy * oy + ixz * oz
    ioy = ixy * ox + iyy * oy + iyz * oz
    ioz = ixz * ox + iyz * oy + izz * oz
    goo = _cross(ox, oy, oz, iox, ioy, ioz)
    mpx = -(ixx * al0x + ixy * al0y + ixz * al0z) - goo[0]
    mpy = -(ixy * al0x + iyy * al0y + iyz * al0z) - goo[1]
    mpz = -(ixz * al0x + iyz * al0y + izz * al0z) - goo[2]
    # Partial velocities of the payload (Kane), canopy axes. Translational: col j (0..2) = e_j,
    # cols 3..5 = e_j x rho, col 6 = e_theta x rho, col 7 = e_z x rho; angular: cols 0..2 = 0,
    # cols 3..5 = e_j, col 6 = e_theta, col 7 = e_z. Their products are written out below
    # (a generic 8x8 loop over these sparse columns cost ~25 % of the right-hand side):
    #   forces:  Q_0..2 = F, Q_3..5 = T = rho x F + M_p, Q_6 = e_theta . T, Q_7 = T_z;
    #   mass:    m_p (e_j x rho).(e_k x rho) = m_p (|rho|^2 delta_jk - rho_j rho_k), and the
    #            payload's share of column 5 is column 7 (both partial velocities are equal).
    tx = ry * fpz - rz * fpy + mpx
    ty = rz * fpx - rx * fpz + mpy
    tz = rx * fpy - ry * fpx + mpz
    rhs[0] += fpx
    rhs[1] += fpy
    rhs[2] += fpz
    rhs[3] += tx
    rhs[4] += ty
    rhs[5] += tz
    rhs[6] += etx * tx + ety * ty
    rhs[7] += tz
    mrx, mry, mrz = mp * rx, mp * ry, mp * rz
    rr = rx * rx + ry * ry + rz * rz
    ret = rx * etx + ry * ety  # rho . e_theta (e_theta has no z component)
    ex_ = _cross(etx, ety, etz, rx, ry, rz)
    iex = ixx * etx + ixy * ety  # I e_theta
    iey = ixy * etx + iyy * ety
    iez = ixz * etx + iyz * ety
    # translation rows 0..2
    mass[0, 0] += mp
    mass[1, 1] += mp
    mass[2, 2] += mp
    mass[1, 3] -= mrz
    mass[2, 3] += mry
    mass[0, 4] += mrz
    mass[2, 4] -= mrx
    mass[0, 6] = mp * ex_[0]
    mass[1, 6] = mp * ex_[1]
    mass[2, 6] = mp * ex_[2]
    mass[0, 7] = -mry
    mass[1, 7] = mrx
    mass[0, 5] -= mry
    mass[1, 5] += mrx
    # rotation rows 3..5
    izz_p = mp * (rr - rz * rz) + izz
    ixz_p = -mrx * rz + ixz
    iyz_p = -mry * rz + iyz
    mass[3, 3] += mp * (rr - rx * rx) + ixx
    mass[4, 4] += mp * (rr - ry * ry) + iyy
    mass[5, 5] += izz_p
    mass[3, 4] += -mrx * ry + ixy
    mass[3, 5] += ixz_p
    mass[4, 5] += iyz_p
    mass[3, 6] = mp * (rr * etx - rx * ret) + iex
    mass[4, 6] = mp * (rr * ety - ry * ret) + iey
    mass[5, 6] = -mrz * ret + iez
    mass[3, 7] = ixz_p
    mass[4, 7] = iyz_p
    mass[5, 7] = izz_p
    # rows 6 and 7
    mass[6, 6] = mp * (rr - ret * ret) + etx * iex + ety * iey
    mass[6, 7] = mass[5, 6]
    mass[7, 7] = izz_p
    for i in range(8):  # the lower triangle
        for j in range(i + 1, 8):
            mass[j, i] = mass[i, j]
    # joint spring-damper (generalised forces on the relative coordinates)
    rhs[6] += -k[I_KTH] * th_r - k[I_CTH] * tdot
    rhs[7] += -k[I_KPS] * ps_r - k[I_CPS] * pdot
    aux[6] = airspeed
    aux[7] = alpha
    aux[8] = beta
    aux[9] = rx
    aux[10] = ry
    aux[11] = rz
