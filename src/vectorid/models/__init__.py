"""Flight-dynamics models that simulate whole batches of parameter vectors in compiled code.

>>> from vectorid import models
>>> models.available()
('parachute6dof', 'parafoil6dof', 'parafoil8dof')
>>> m = models.get("parachute6dof")
>>> res = m.simulate(m.nominal[None, :], t_final=10.0, dt=0.02, output_dt=1.0)  # doctest: +SKIP

Models are registered by name and imported on first use, so importing this package is cheap and
a missing optional model only fails when it is asked for.

Your own model (a :class:`SystemModel`, see :mod:`vectorid.models.system` and
``docs/own-model.md``) is found by :func:`get` in three ways: by import path
(``"mypkg.dynamics:Oscillator"``), by a name given to :func:`register`, or by a name an
installed package declares in the ``vectorid.models`` entry-point group::

    # pyproject.toml of your package
    [project.entry-points."vectorid.models"]
    oscillator = "mypkg.dynamics:Oscillator"
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
from vectorid.models.system import SystemModel, SystemResult
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
    "SystemModel",
    "SystemResult",
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


#: Entry-point group in which installed packages declare their models.
ENTRY_POINT_GROUP = "vectorid.models"


def register(name: str, target: str) -> None:
    """Register a model class under ``name``.

    Parameters
    ----------
    name : str
        The name a study file then uses (``model = "oscillator"``).
    target : str
        ``"package.module:ClassName"`` of a :class:`Model` or :class:`SystemModel` subclass;
        imported on first use. Process and Dask workers import it again by that path, so
        register in a module the workers import too, or prefer an entry point (see the
        module docstring), which every process sees.
    """
    if not isinstance(target, str) or not _is_import_path(target):
        raise ValueError(f"target must look like 'package.module:ClassName', got {target!r}")
    _REGISTRY[name] = target


def _is_import_path(text: str) -> bool:
    module, sep, name = text.partition(":")
    return (
        bool(sep)
        and all(p.isidentifier() for p in module.split("."))
        and all(p.isidentifier() for p in name.split("."))
    )


def _entry_points() -> dict[str, str]:
    from importlib.metadata import entry_points

    try:
        return {ep.name: ep.value for ep in entry_points(group=ENTRY_POINT_GROUP)}
    except Exception:  # a broken installed distribution must not hide the built-in models
        return {}


def available() -> tuple[str, ...]:
    """Registered model names, entry points included (whether or not their module can be
    imported)."""
    return tuple(sorted({*_REGISTRY, *_entry_points()}))


def get(name: str, **options: Any) -> Model:
    """A new model instance by registry name.

    Parameters
    ----------
    name : str
        Registry name (one of :func:`available`: registered or declared in the
        ``vectorid.models`` entry-point group), or an import path
        ``"package.module:ClassName"`` (the module must be importable: installed, or on
        ``sys.path``; a study file's folder is put there for it).
    **options
        Configuration passed to the model's constructor (e.g. ``aerodynamics=False``).

    Raises
    ------
    KeyError
        Unknown name (the message lists the known ones).
    ImportError
        The model's module or class cannot be imported (not written yet, or broken).
    """
    if name in _REGISTRY:
        target = _REGISTRY[name]
    elif _is_import_path(name):
        target = name
    else:
        target = _entry_points().get(name)
        if target is None:
            raise KeyError(
                f"unknown model {name!r}; available models: {', '.join(available())}, or an "
                "import path 'package.module:ClassName' of your own model"
            )
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
    cls: Any = module
    try:
        for part in class_name.split("."):
            cls = getattr(cls, part)
    except AttributeError:
        raise ImportError(
            f"model {name!r}: module {module_name} has no class {class_name}"
        ) from None
    if not (isinstance(cls, type) and issubclass(cls, Model | SystemModel)):
        raise TypeError(
            f"model {name!r}: {target} is not a model class (expected a subclass of "
            "vectorid.models.SystemModel or vectorid.models.Model)"
        )
    return cls(**options)
