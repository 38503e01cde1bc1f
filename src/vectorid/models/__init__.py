"""Flight-dynamics models that simulate whole batches of parameter vectors in compiled code.

>>> from vectorid import models
>>> models.available()
('parachute6dof', 'parafoil6dof', 'parafoil8dof', 'rocket-descent', 'rocket-descent-cds')
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
import os
from collections.abc import Sequence
from typing import Any

from vectorid._hints import QUIET_ENV, waiting
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
    "compile_models",
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

    Examples
    --------
    >>> from vectorid import models
    >>> models.available()
    ('parachute6dof', 'parafoil6dof', 'parafoil8dof', 'rocket-descent', 'rocket-descent-cds')
    >>> m = models.get("parachute6dof")
    >>> len(m.parameters), m.parameter_names[:3]
    (15, ('x1', 'x2', 'x3'))
    >>> p = m.parameters[0]
    >>> p.name, p.nominal, (p.low, p.high), p.meaning
    ('x1', 1.03, (0.0, 1.5), 'α11 = x1 m_a, apparent mass along x and y (eq. 9)')

    ``m.simulate(m.nominal[None, :], t_final=60.0, dt=0.02)`` flies it (the first call
    compiles its kernel, once per machine; the README's tour shows the result).
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


def compile_models(names: Sequence[str], workers: int | None = None) -> list[str]:
    """Compile, in parallel, the kernels of the models ``names`` that numba's on-disk cache
    lacks, so that their first use loads them instead of compiling one after the other.

    A kernel's first compile (numba, tens of seconds each) runs on one core; several models'
    compiles are independent, so they run in child interpreters, one per core (at most
    ``workers``), while a waiting notice says which and for how long. One kernel to compile
    is compiled here. Nothing is done for kernels cached already (a second run). A child that
    fails leaves its model to compile here, on first use, where its error shows.

    Parameters
    ----------
    names : sequence of str
        Registry names (:func:`available`).
    workers : int, optional
        Most processes (default: the cores this process may use).

    Returns
    -------
    list of str
        The models whose kernel is compiled now (empty when every one was cached).
    """
    import subprocess
    import sys
    import time

    todo = [n for n in dict.fromkeys(names) if get(n).kernel_cached() is False]
    if not todo:
        return []
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    n = max(1, min(len(todo), workers or cores))
    if n == 1:
        for name in todo:
            get(name).compile()
        return todo
    code = "import sys; from vectorid.models import get; get(sys.argv[1]).compile()"
    env = dict(os.environ, **{QUIET_ENV: "1"})  # the notice below speaks for them
    what = f"compiling the kernels of {', '.join(todo)} in {n} processes"
    with waiting(what, note="numba, first use only, cached on disk afterwards"):
        queue, running = list(todo), []
        while queue or running:
            while queue and len(running) < n:
                name = queue.pop(0)  # a child knows the import path, not names registered here
                target = _REGISTRY.get(name) or _entry_points().get(name) or name
                args = [sys.executable, "-c", code, target]
                quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
                running.append(subprocess.Popen(args, env=env, **quiet))
            time.sleep(0.1)
            running = [p for p in running if p.poll() is None]
    return [name for name in todo if get(name).kernel_cached() is not False]
