"""A small parafoil as its authors state it, turned into ``parafoil6dof`` model options.

Published parafoil simulators state a vehicle by its total mass, canopy geometry (area, span,
chord, arc height, thickness), where the canopy sits above the mass centre, payload drag and
aerodynamic coefficients per radian. :class:`StatedParafoil` holds such a set and writes the
model options of :mod:`vectorid.models.parafoil6dof` that reproduce it
(:meth:`StatedParafoil.model_options`: what a study file's ``[identification] model_options``
would hold): the coefficients converted to the model's per-degree forms, the line length that
puts the canopy where stated, and the six apparent-mass factors of the model's Lissaman–Brown
forms that reproduce the stated geometry's apparent masses (:func:`lissaman_brown_factors`).

:data:`ETH_PARAFOIL` is the ETH Zürich student parafoil of 2022 (the authors' ``ParamSetup.m``,
quoted in the README of the ``eth-parafoil`` flight data), which ``examples/eth_parafoil.py``
identifies and ``examples/ssi_parafoil.py`` uses as a stand-in canopy of its class.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = ["ETH_PARAFOIL", "StatedParafoil", "lissaman_brown_factors"]

#: Degrees per radian.
_RAD = 180.0 / math.pi


def lissaman_brown_factors(
    span: float, chord: float, arc: float, thickness: float, area: float | None = None
) -> dict[str, float]:
    """The apparent-mass factors of the model's Lissaman–Brown forms (``kA`` … ``kC_star``,
    dimensionless) that reproduce the apparent masses of a canopy of this geometry.

    The apparent masses are Lissaman & Brown's (1993) formulas for an arched canopy of span b,
    chord c, arc height a and thickness t (the formulas of ``ImIiCompute`` in the ETH
    simulator): with a* = a/b, t* = t/c, AR = b/c,
    m_A = 0.666 (1 + 8/3 a*²) t² b, m_B = 0.267 (t² + 2 a² (1 − t*²)) c,
    m_C = 0.785 √(1 + 2 a*² (1 − t*²)) AR/(1 + AR) b c²,
    I_A = 0.055 AR/(1 + AR) b³ c², I_B = 0.0308 AR/(1 + AR) (1 + π/6 (1 + AR) AR a*² t*²) b c⁴,
    I_C = 0.0555 (1 + 8 a*²) t² b³ (kg/(kg/m³): per unit air density). The model's forms
    (:func:`vectorid.models.parafoil_aero.apparent_mass_matrix`) are A = kA π/4 t² b,
    B = kB π/4 t² c', C = kC π/4 c'² b, IA = kA* π/48 c'² b³, IB = kB* 4/(48π) c'⁴ b,
    IC = kC* π/48 t² b³, with the model's mean chord c' = S/b.

    Parameters
    ----------
    span, chord, arc, thickness : float
        Canopy span, chord, arc height and thickness, m (as stated).
    area : float, optional
        Canopy area S, m², for the model's mean chord S/b (default: span x chord).
    """
    a_s, t_s = arc / span, thickness / chord
    ar = span / chord
    b, c, t = span, chord, thickness
    m_a = 0.666 * (1 + 8 / 3 * a_s**2) * t**2 * b
    m_b = 0.267 * (t**2 + 2 * arc**2 * (1 - t_s**2)) * c
    m_c = 0.785 * math.sqrt(1 + 2 * a_s**2 * (1 - t_s**2)) * ar / (1 + ar) * b * c**2
    i_a = 0.055 * ar / (1 + ar) * b**3 * c**2
    i_b = 0.0308 * ar / (1 + ar) * (1 + math.pi / 6 * (1 + ar) * ar * a_s**2 * t_s**2) * b * c**4
    i_c = 0.0555 * (1 + 8 * a_s**2) * t**2 * b**3
    c = (span * chord if area is None else area) / span  # the model's mean chord S / b
    return {
        "kA": m_a / (math.pi / 4 * t**2 * b),
        "kB": m_b / (math.pi / 4 * t**2 * c),
        "kC": m_c / (math.pi / 4 * c**2 * b),
        "kA_star": i_a / (math.pi / 48 * c**2 * b**3),
        "kB_star": i_b / (4 / (48 * math.pi) * c**4 * b),
        "kC_star": i_c / (math.pi / 48 * t**2 * b**3),
    }


@dataclass(frozen=True)
class StatedParafoil:
    """A parafoil-payload system as its authors state it.

    Attributes
    ----------
    mass : float
        Total system mass, kg.
    area, span, chord : float
        Canopy area (m²), span and chord (m).
    arc, thickness : float
        Canopy arc height and airfoil thickness, m.
    canopy_above_cg : float
        Height of the canopy's quarter chord above the system's mass centre, m.
    payload_area, payload_cd : float
        Payload reference area (m²) and drag coefficient (-).
    coefficients : mapping
        The authors' aerodynamic coefficients, per radian where they depend on an angle:
        ``c_D0``, ``c_Da2``, ``c_Dds``, ``c_Yb``, ``c_L0``, ``c_La``, ``c_Lds``, ``c_lp``,
        ``c_lda``, ``c_m0``, ``c_ma``, ``c_mq``, ``c_nr``, ``c_nda``.
    canopy_mass : float
        Mass of canopy and lines, kg (of ``mass``; the rest is the payload). Rarely stated:
        say whose reading it is.
    riser_length : float
        Joint to the top of the payload, m.
    inertia : tuple of float or None
        The stated inertia diagonal (kg m²), kept to be reported; the model's inertia comes
        from the masses and the geometry (:meth:`inertia_is_physical` says whether the stated
        one could be used at all).
    """

    mass: float
    area: float
    span: float
    chord: float
    arc: float
    thickness: float
    canopy_above_cg: float
    payload_area: float
    payload_cd: float
    coefficients: Mapping[str, float] = field(default_factory=dict)
    canopy_mass: float = 0.0
    riser_length: float = 0.10
    inertia: tuple[float, float, float] | None = None

    @property
    def payload_mass(self) -> float:
        """Payload mass, kg: the total less the canopy's."""
        return self.mass - self.canopy_mass

    def inertia_is_physical(self) -> bool:
        """Whether the stated inertia diagonal satisfies the triangle inequality (each moment
        at most the sum of the other two), which every mass distribution does; True when none
        is stated."""
        if self.inertia is None:
            return True
        a, b, c = self.inertia
        return a <= b + c and b <= a + c and c <= a + b

    def lissaman_brown_factors(self) -> dict[str, float]:
        """:func:`lissaman_brown_factors` of this canopy."""
        return lissaman_brown_factors(self.span, self.chord, self.arc, self.thickness, self.area)

    def model_options(self, extra_parameters: Sequence[str] = ("wind_north", "wind_east")) -> dict:
        """The stated set as ``parafoil6dof`` model options.

        The payload is a cube with the stated reference area; the lines are as long as puts
        the canopy's quarter chord ``canopy_above_cg`` above the system's mass centre:
        L + (m_p d_p − m_c L)/m = h, so L = (h − m_p d_p/m) / (1 − m_c/m) with d_p the
        payload centre's depth below the joint. ``extra_parameters``: model parameters added
        to the gains (``wind_north``, ``wind_east``, ``payload_mass``).
        """
        s = self.coefficients
        side = math.sqrt(self.payload_area)
        d_payload = self.riser_length + side / 2
        line = (self.canopy_above_cg - self.payload_mass * d_payload / self.mass) / (
            1 - self.canopy_mass / self.mass
        )
        coefficients = {
            "CD0": s["c_D0"], "A2": 0.0, "CDalpha2": s["c_Da2"] / _RAD**2, "ADf": s["c_Dds"],
            "CLalpha": s["c_La"] / _RAD, "Alpha0": s["c_L0"] / (s["c_La"] / _RAD),
            "CLDf": s["c_Lds"], "Rig": 0.0,
            "Cm0": s["c_m0"], "Cmalpha": s["c_ma"] / _RAD, "Cmq": s["c_mq"],
            "CYbnom": -s["c_Yb"] / _RAD, "CYbgrad": 0.0, "CYDanom": 0.0, "CYDagrad": 0.0,
            "Clbnom": 0.0, "Clbgrad": 0.0, "ClDanom": s["c_lda"], "ClDagrad": 0.0,
            "Clp": s["c_lp"], "Clr": 0.0,
            "Cnbnom": 0.0, "Cnbgrad": 0.0, "CnDanom": s["c_nda"], "CnDagrad": 0.0,
            "Cnp": 0.0, "Cnr": s["c_nr"],
            **self.lissaman_brown_factors(),
        }  # fmt: skip
        geometry: dict[str, Any] = {
            "area": self.area, "span": self.span,
            "thickness_ratio": self.thickness / (self.area / self.span),
            "arc_ratio": self.arc / self.span,
            "line_length": line, "canopy_ahead": 0.0, "canopy_mass": self.canopy_mass,
            "payload_mass": self.payload_mass, "payload_size": [side, side, side],
            "payload_cd": self.payload_cd, "riser_length": self.riser_length,
        }  # fmt: skip
        return {
            "geometry": geometry,
            "coefficients": coefficients,
            "extra_parameters": list(extra_parameters),
        }


_ETH_COEFFICIENTS = {
    "c_D0": 0.12, "c_Da2": 0.33, "c_Dds": 0.43, "c_Yb": 0.23,
    "c_L0": 0.24, "c_La": 2.14, "c_Lds": 0.2783,
    "c_lp": -0.84, "c_lda": 0.05, "c_m0": 0.1, "c_ma": -0.72, "c_mq": -1.49,
    "c_nr": -0.27, "c_nda": 0.025,
}  # fmt: skip

#: The ETH Zürich student parafoil (2022): the authors' ``ParamSetup.m`` as quoted in the
#: ``eth-parafoil`` data README — 1.2 kg, 1.5 m², 1.88 m span, 0.80 m chord, arc 0.4 m,
#: thickness 0.075 m, canopy point 1.2 m above the mass centre (``B_r_BP``), payload drag 3.2
#: on 0.06 m², their coefficients per radian. Two readings are ours, not stated: the split of
#: the 1.2 kg into canopy 0.2 kg and payload 1.0 kg, and the 0.10-m riser. The stated inertia
#: diagonal (1.68, 0.80, 0.32) kg m² violates the triangle inequality (1.68 > 0.80 + 0.32),
#: which no mass distribution satisfies, so the model's inertia comes from masses and geometry.
ETH_PARAFOIL = StatedParafoil(
    mass=1.2,
    area=1.5,
    span=1.88,
    chord=0.80,
    arc=0.4,
    thickness=0.075,
    canopy_above_cg=1.2,
    payload_area=0.06,
    payload_cd=3.2,
    coefficients=_ETH_COEFFICIENTS,
    canopy_mass=0.2,
    riser_length=0.10,
    inertia=(1.68, 0.80, 0.32),
)
