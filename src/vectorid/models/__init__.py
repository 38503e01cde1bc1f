"""Flight-dynamics models that simulate whole batches of parameter vectors in compiled code.

>>> from vectorid import models
>>> models.available()
('parachute6dof', 'parafoil6dof', 'parafoil8dof')
>>> m = models.get("parachute6dof")
>>> res = m.simulate(m.nominal[None, :], t_final=10.0, dt=0.02, output_dt=1.0)  # doctest: +SKIP

Models are registered by name and imported on first use, so importing this package is cheap and
a missing optional model only fails when it is asked for.
"""

# ruff: noqa: E402  (the imports below come after _simd.configure(), on purpose)
from __future__ import annotations

import importlib
from typing import Any

from vectorid._simd import configure as _configure_simd

_configure_simd()  # before numba compiles: full-width vectors on AVX-512 CPUs (see _simd)

from vectorid.models.base import (
    BASE_CHANNELS,
    Channel,
    InitialState,
    Model,
    Parameter,
    SimulationResult,
)
from vectorid.models.controls import ControlSchedule, flap_deflections, riser_commands
from vectorid.models.integrate import STATUS_MESSAGES
from vectorid.models.steps import StepChoice, choose_step
from vectorid.models.wind import DrydenTurbulence, Wind, WindProfile

__all__ = [
    "BASE_CHANNELS",
    "STATUS_MESSAGES",
    "Channel",
    "ControlSchedule",
    "DrydenTurbulence",
    "InitialState",
    "Model",
    "Parameter",
    "SimulationResult",
    "StepChoice",
    "Wind",
    "WindProfile",
    "available",
    "choose_step",
    "flap_deflections",
    "get",
    "register",
    "riser_commands",
]

_REGISTRY: dict[str, str] = {
    "parachute6dof": "vectorid.models.parachute6dof:Parachute6DoF",
    "parafoil8dof": "vectorid.models.parafoil8dof:Parafoil8DoF",
    "parafoil6dof": "vectorid.models.parafoil6dof:Parafoil6DoF",
    "rocket-descent": "vectorid.descent.model:RocketDescent",
    "rocket-descent-cds": "vectorid.descent.model:RocketDescentCdS",
}


def register(name: str, target: str) -> None:
    """Register a model class under ``name``; ``target`` is ``"package.module:ClassName"``."""
    if ":" not in target:
        raise ValueError(f"target must look like 'package.module:ClassName', got {target!r}")
    _REGISTRY[name] = target


def available() -> tuple[str, ...]:
    """Registered model names (whether or not their module can be imported)."""
    return tuple(sorted(_REGISTRY))


def get(name: str, **options: Any) -> Model:
    """A new model instance by registry name.

    Parameters
    ----------
    name : str
        Registry name, one of :func:`available`.
    **options
        Configuration passed to the model's constructor (e.g. ``aerodynamics=False``).

    Raises
    ------
    KeyError
        Unknown name (the message lists the known ones).
    ImportError
        The model's module or class cannot be imported (not written yet, or broken).
    """
    try:
        target = _REGISTRY[name]
    except KeyError:
        raise KeyError(
            f"unknown model {name!r}; available models: {', '.join(available())}"
        ) from None
    module_name, _, class_name = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as exc:
        if exc.name == module_name:
            raise ImportError(
                f"model {name!r} is registered as {target} but module {module_name} does not "
                f"exist (not implemented yet, or vectorid is installed without it)"
            ) from exc
        raise
    try:
        cls = getattr(module, class_name)
    except AttributeError:
        raise ImportError(
            f"model {name!r}: module {module_name} has no class {class_name}"
        ) from None
    return cls(**options)
