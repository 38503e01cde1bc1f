"""External models: a command-line program, or an FMU (FMI 2.0 / 3.0) run through FMPy.

Both are chosen with the study's ``model`` key and evaluated one trial at a time (wrapped by
:func:`~vectorid.problem.as_batch`), so a trial whose program fails, hangs or answers
nonsense is stored as a failed trial with the reason, and the study goes on.

Command-line models
-------------------
::

    [study]
    model = "cmd:python sim.py {input} {output}"   # split like a shell would (shlex)
    timeout = 60                                    # seconds per trial (optional)
    # or, to avoid quoting: model = "cmd" and command = ["python", "sim.py", "{input}"]

For each trial the program is started in the study file's folder with the template's
placeholders replaced:

``{input}``
    path of a JSON file holding the trial's parameters, ``{"x1": 0.25, "x2": 3.0, ...}``
    (the study's variable names). Without ``{input}`` in the template the same JSON is
    written to the program's standard input.
``{output}``
    path where the program writes its answer. Without ``{output}`` the answer is read from
    the program's standard output.
``{workdir}``
    a fresh empty folder for this trial (removed afterwards).

The answer is one JSON object with a number for every criterion and functional constraint
of the study, by name: ``{"f1": 0.12, "f2": 3.4, "g1": 0.9}`` (extra keys are ignored;
``null`` means "not computed" and fails the trial as non-finite). A non-zero exit status, a
run longer than ``timeout`` (the program and its children are killed), or an answer that is
not such an object fails the trial; the reason holds the last lines of the program's
standard error.

FMU models
----------
::

    [study]
    model = "fmu:decay.fmu"        # path relative to the study file
    timeout = 30                   # seconds per simulation (optional)

    [study.fmu]
    interface = "cs"               # "cs" (co-simulation) or "me" (model exchange); default:
                                   # co-simulation when the FMU offers it
    start_time = 0.0               # default: the FMU's default experiment, else 0
    stop_time = 10.0               # default: the FMU's default experiment, else 1
    output_interval = 0.01         # sampling of the outputs (and the co-simulation step)
    solver = "CVode"               # model exchange: "CVode" (default) or "Euler"
    # step_size = 1e-3             # model exchange with "Euler"
    # relative_tolerance = 1e-6

    [study.fmu.parameters]         # design variable -> FMU variable; default: same name
    x1 = "k"

    [study.fmu.start_values]       # FMU variables fixed for every trial
    x0 = 2.0

    [study.fmu.outputs]            # criterion or constraint -> reduction of an FMU variable
    f1 = "final(y)"                # final, initial, max, min, mean, integral, abs_integral, rms
    f2 = "integral(y)"
    g1 = { variable = "y", reduce = "mypkg.reductions:overshoot" }   # f(t, y) -> float

A criterion or constraint that has no entry under ``outputs`` takes the final value of the
FMU variable of the same name. FMI 2.0 and 3.0 FMUs, co-simulation and model exchange, are
simulated by :func:`fmpy.simulate_fmu` (the ``fmu`` extra: ``pip install 'vectorid[fmu]'``);
the FMU is unpacked once per worker process.
"""

from __future__ import annotations

import atexit
import contextlib
import importlib
import json
import math
import os
import shlex
import shutil
import signal
import subprocess
import tempfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .errors import StudyDefinitionError, VectoridError, suggest
from .problem import BatchModel, Problem, as_batch, checked_output

__all__ = [
    "REDUCTIONS",
    "CommandModel",
    "ExternalModelError",
    "FmuModel",
    "build_external_problem",
    "external_model",
]


class ExternalModelError(RuntimeError):
    """An external model failed on one trial (the trial is stored as failed)."""


def build_external_problem(spec: Any) -> Any:
    """The Problem of a ``cmd:`` or ``fmu:`` study (the builder of those kinds in
    :mod:`vectorid.builders`)."""

    return Problem(external_model(spec), spec.criteria, spec.constraints)


def external_model(spec: Any) -> BatchModel:
    """The batch model for a study whose ``model`` is ``"cmd:..."``, ``"cmd"`` or
    ``"fmu:PATH"``."""
    kind, _, rest = str(spec.model).partition(":")
    base = Path(spec.base_dir) if spec.base_dir else Path.cwd()
    names_in = list(spec.space.names)
    names_out = list(spec.criterion_names) + list(spec.constraint_names)
    if kind == "cmd":
        if rest.strip():
            if spec.command is not None:
                raise StudyDefinitionError(
                    "study.command",
                    "the command is given twice (in model = 'cmd:...' and in command = [...])",
                    'keep one: model = "cmd" with command = [...], or model = "cmd:..." alone',
                )
            try:
                template = shlex.split(rest)
            except ValueError as exc:
                raise StudyDefinitionError(
                    "study.model", f"cannot split the command {rest!r}: {exc}", "fix the quoting"
                ) from None
        elif spec.command is not None:
            template = list(spec.command)
        else:
            raise StudyDefinitionError(
                "study.model",
                "model = 'cmd' needs a command, got none",
                'write model = "cmd:python sim.py {input} {output}", or add command = [...]',
            )
        model = CommandModel(template, names_in, names_out, base, spec.timeout)
        model.n_criteria = len(spec.criterion_names)
        return as_batch(model)
    if kind == "fmu":
        if not rest.strip():
            raise StudyDefinitionError(
                "study.model", "model = 'fmu:' needs a path", 'write model = "fmu:model.fmu"'
            )
        path = Path(rest.strip())
        if not path.is_absolute():
            path = base / path
        model = FmuModel(path, names_in, names_out, spec.fmu or {}, spec.timeout)
        model.n_criteria = len(spec.criterion_names)
        return as_batch(model)
    raise StudyDefinitionError(
        "study.model", f"unknown external model {spec.model!r}", "use 'cmd:...' or 'fmu:PATH'"
    )


# -- command-line models -------------------------------------------------------------------


def _tail(data: bytes | str | None, limit: int = 400) -> str:
    if not data:
        return "(nothing on stderr)"
    text = data.decode(errors="replace") if isinstance(data, bytes) else data
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    out = " | ".join(lines[-5:])
    return out if len(out) <= limit else "…" + out[-limit:]


class CommandModel:
    """One trial = one run of a command-line program (see the module docstring).

    Parameters
    ----------
    template : sequence of str
        Program and arguments, with ``{input}``, ``{output}`` and ``{workdir}`` placeholders.
    inputs : sequence of str
        Variable names, in the order of the parameter vector.
    outputs : sequence of str
        Criterion names then constraint names: the keys expected in the answer.
    cwd : path
        Folder the program runs in (the study file's folder).
    timeout : float, optional
        Most seconds one run may take.
    """

    def __init__(
        self,
        template: Sequence[str],
        inputs: Sequence[str],
        outputs: Sequence[str],
        cwd: str | Path,
        timeout: float | None = None,
    ) -> None:
        if not template:
            raise StudyDefinitionError("study.command", "empty command", "name a program")
        self.template = list(template)
        self.inputs = list(inputs)
        self.outputs = list(outputs)
        self.cwd = Path(cwd)
        self.timeout = timeout
        self.n_criteria = len(outputs)

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        params = {name: float(v) for name, v in zip(self.inputs, x)}
        with tempfile.TemporaryDirectory(prefix="vectorid-trial-") as work:
            paths = {
                "{input}": os.path.join(work, "input.json"),
                "{output}": os.path.join(work, "output.json"),
                "{workdir}": work,
            }
            uses = {p: any(p in arg for arg in self.template) for p in paths}
            argv = []
            for arg in self.template:
                for placeholder, value in paths.items():
                    arg = arg.replace(placeholder, value)
                argv.append(arg)
            payload = json.dumps(params)
            if uses["{input}"]:
                Path(paths["{input}"]).write_text(payload, encoding="utf-8")
            stdout, stderr = self._run(argv, None if uses["{input}"] else payload)
            if uses["{output}"]:
                try:
                    text = Path(paths["{output}"]).read_text(encoding="utf-8")
                except FileNotFoundError:
                    raise ExternalModelError(
                        f"the program wrote no output file {{output}}; stderr: {_tail(stderr)}"
                    ) from None
            else:
                text = stdout.decode(errors="replace")
        return self._parse(text, stderr)

    def _run(self, argv: list[str], stdin: str | None) -> tuple[bytes, bytes]:
        try:
            proc = subprocess.Popen(
                argv,
                cwd=self.cwd,
                stdin=subprocess.PIPE if stdin is not None else subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                start_new_session=True,  # its own process group: a timeout kills children too
            )
        except OSError as exc:
            raise ExternalModelError(f"cannot start {argv[0]!r}: {exc}") from None
        try:
            out, err = proc.communicate(
                None if stdin is None else stdin.encode(), timeout=self.timeout
            )
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()
            raise ExternalModelError(
                f"timed out after {self.timeout:g} s (program killed); stderr: {_tail(err)}"
            ) from None
        except BaseException:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            raise
        if proc.returncode != 0:
            raise ExternalModelError(
                f"the program exited with status {proc.returncode}; stderr: {_tail(err)}"
            )
        return out, err

    def _parse(self, text: str, stderr: bytes) -> tuple[np.ndarray, np.ndarray]:
        try:
            answer = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ExternalModelError(
                f"malformed output: not JSON ({exc.msg} at character {exc.pos}; "
                f"got {text[:80]!r}); stderr: {_tail(stderr)}"
            ) from None
        if not isinstance(answer, dict):
            raise ExternalModelError(
                f"malformed output: expected a JSON object with keys {', '.join(self.outputs)}, "
                f"got {type(answer).__name__}"
            )
        missing = [n for n in self.outputs if n not in answer]
        if missing:
            raise ExternalModelError(
                f"malformed output: missing {', '.join(missing)} (expected keys "
                f"{', '.join(self.outputs)}, got {', '.join(map(str, answer)) or 'none'})"
            )
        values = []
        for n in self.outputs:
            v = answer[n]
            if v is None:
                values.append(math.nan)
            elif isinstance(v, int | float) and not isinstance(v, bool):
                values.append(float(v))
            else:
                raise ExternalModelError(f"malformed output: {n} = {v!r} is not a number")
        k = self.n_criteria
        return np.array(values[:k]), np.array(values[k:])


# -- FMU models ----------------------------------------------------------------------------

FMU_HINT = "pip install 'vectorid[fmu]'"


def _integral(t: np.ndarray, y: np.ndarray) -> float:
    """Trapezoidal rule (written out: ``np.trapezoid`` needs numpy 2)."""
    return float(np.sum((y[1:] + y[:-1]) * np.diff(t)) / 2.0) if len(t) > 1 else 0.0


#: Built-in reductions of an output's time series ``(t, y) -> float``.
REDUCTIONS: dict[str, Callable[[np.ndarray, np.ndarray], float]] = {
    "final": lambda t, y: float(y[-1]),
    "initial": lambda t, y: float(y[0]),
    "max": lambda t, y: float(np.max(y)),
    "min": lambda t, y: float(np.min(y)),
    "mean": lambda t, y: (
        _integral(t, y) / float(t[-1] - t[0]) if t[-1] > t[0] else float(np.mean(y))
    ),
    "integral": _integral,
    "abs_integral": lambda t, y: _integral(t, np.abs(y)),
    "rms": lambda t, y: (
        math.sqrt(_integral(t, y * y) / float(t[-1] - t[0]))
        if t[-1] > t[0]
        else float(np.sqrt(np.mean(y * y)))
    ),
}

_FMU_KEYS = {
    "interface": "'cs' (co-simulation) or 'me' (model exchange)",
    "start_time": "start of the simulation, s",
    "stop_time": "end of the simulation, s",
    "output_interval": "sampling interval of the outputs (and co-simulation step), s",
    "step_size": "fixed step of the 'Euler' solver (model exchange), s",
    "solver": "'CVode' or 'Euler' (model exchange)",
    "relative_tolerance": "relative tolerance of the solver",
    "parameters": "table: design variable -> FMU variable",
    "start_values": "table: FMU variable -> fixed value",
    "outputs": "table: criterion/constraint -> 'reduce(variable)' or {variable, reduce}",
}


def _import_fmpy() -> Any:
    try:
        import fmpy
    except ImportError as exc:
        raise VectoridError(
            f"FMU models need FMPy, which cannot be imported ({exc}); install it with {FMU_HINT}"
        ) from None
    return fmpy


def _resolve_reduction(where: str, name: str) -> Callable[[np.ndarray, np.ndarray], float]:
    if name in REDUCTIONS:
        return REDUCTIONS[name]
    if ":" in name:
        module, _, func = name.partition(":")
        try:
            return getattr(importlib.import_module(module), func)
        except (ImportError, AttributeError) as exc:
            raise StudyDefinitionError(
                where, f"cannot load reduction {name!r} ({exc})", "check 'module:function'"
            ) from None
    raise StudyDefinitionError(
        where,
        f"unknown reduction {name!r}",
        suggest(name, REDUCTIONS) + " — or give your own as 'module:function' taking (t, y)",
    )


class FmuModel:
    """One trial = one simulation of an FMU (see the module docstring).

    Parameters
    ----------
    path : path
        The ``.fmu`` file.
    inputs : sequence of str
        Design variable names, in the order of the parameter vector.
    outputs : sequence of str
        Criterion names then constraint names.
    options : mapping
        The ``[study.fmu]`` table.
    timeout : float, optional
        Most seconds one simulation may take.
    """

    def __init__(
        self,
        path: str | Path,
        inputs: Sequence[str],
        outputs: Sequence[str],
        options: Mapping[str, Any],
        timeout: float | None = None,
    ) -> None:
        fmpy = _import_fmpy()
        from fmpy.model_description import read_model_description

        for key in options:
            if key not in _FMU_KEYS:
                raise StudyDefinitionError(
                    f"study.fmu.{key}", f"unknown key {key!r}", suggest(key, _FMU_KEYS)
                )
        self.path = Path(path)
        if not self.path.is_file():
            raise StudyDefinitionError(
                "study.model",
                f"FMU file {self.path} not found",
                "give its path relative to the study file, e.g. model = 'fmu:models/plant.fmu'",
            )
        try:
            md = read_model_description(str(self.path))
        except Exception as exc:
            raise StudyDefinitionError(
                "study.model", f"{self.path} is not a readable FMU ({exc})", "check the file"
            ) from None
        self.md = md
        self.timeout = timeout
        variables = {v.name: v for v in md.modelVariables}
        interface = options.get("interface")
        offers = {"cs": md.coSimulation is not None, "me": md.modelExchange is not None}
        if interface is None:
            interface = "cs" if offers["cs"] else "me"
        if interface not in offers:
            raise StudyDefinitionError(
                "study.fmu.interface",
                f"expected 'cs' or 'me', got {interface!r}",
                'write interface = "cs" or interface = "me"',
            )
        if not offers[interface]:
            other = [k for k, v in offers.items() if v]
            raise StudyDefinitionError(
                "study.fmu.interface",
                f"{self.path.name} does not offer {interface!r} (it offers {other})",
                f"write interface = {other[0]!r}" if other else "use another FMU",
            )
        self.fmi_type = "CoSimulation" if interface == "cs" else "ModelExchange"
        exp = md.defaultExperiment
        self.start_time = float(
            options.get("start_time", exp.startTime if exp and exp.startTime else 0.0)
        )
        self.stop_time = float(
            options.get("stop_time", exp.stopTime if exp and exp.stopTime else 1.0)
        )
        if not self.stop_time > self.start_time:
            raise StudyDefinitionError(
                "study.fmu.stop_time",
                f"expected stop_time > start_time, got {self.stop_time} <= {self.start_time}",
                "set stop_time after start_time",
            )
        self.sim_options: dict[str, Any] = {}
        for key in ("output_interval", "step_size", "relative_tolerance"):
            if key in options:
                self.sim_options[key] = float(options[key])
        if "solver" in options:
            if options["solver"] not in ("CVode", "Euler"):
                raise StudyDefinitionError(
                    "study.fmu.solver",
                    f"expected 'CVode' or 'Euler', got {options['solver']!r}",
                    'write solver = "CVode"',
                )
            self.sim_options["solver"] = options["solver"]

        def known(where: str, name: str) -> str:
            if name not in variables:
                raise StudyDefinitionError(
                    where,
                    f"{self.path.name} has no variable {name!r}",
                    suggest(name, variables),
                )
            return name

        params = dict(options.get("parameters", {}))
        for name in params:
            if name not in inputs:
                raise StudyDefinitionError(
                    f"study.fmu.parameters.{name}",
                    f"{name!r} is not a design variable",
                    suggest(name, inputs),
                )
        self.param_map = [known(f"study.fmu.parameters.{n}", params.get(n, n)) for n in inputs]
        self.start_values = {
            known(f"study.fmu.start_values.{n}", n): v
            for n, v in dict(options.get("start_values", {})).items()
        }
        outs = dict(options.get("outputs", {}))
        for name in outs:
            if name not in outputs:
                raise StudyDefinitionError(
                    f"study.fmu.outputs.{name}",
                    f"{name!r} is not a criterion or constraint",
                    suggest(name, outputs),
                )
        self.reductions: list[tuple[str, Callable]] = []
        self.labels: list[str] = []
        for name in outputs:
            where = f"study.fmu.outputs.{name}"
            entry = outs.get(name, name if name in variables else None)
            if entry is None:
                raise StudyDefinitionError(
                    where,
                    f"no FMU output is mapped to {name!r}",
                    f'add {name} = "final(VARIABLE)" under [study.fmu.outputs]; the FMU has '
                    + ", ".join(sorted(variables)[:20]),
                )
            if isinstance(entry, Mapping):
                var, red = entry.get("variable"), entry.get("reduce", "final")
                if not isinstance(var, str):
                    raise StudyDefinitionError(
                        where, f"expected variable = 'NAME', got {entry!r}", "add variable = ..."
                    )
            elif isinstance(entry, str):
                red, sep, rest = entry.partition("(")
                if sep:
                    if not rest.endswith(")"):
                        raise StudyDefinitionError(
                            where, f"cannot read {entry!r}", "write e.g. 'max(y)'"
                        )
                    var = rest[:-1].strip()
                else:
                    var, red = entry, "final"
                red = red.strip()
            else:
                raise StudyDefinitionError(
                    where, f"expected 'reduce(variable)' or a table, got {entry!r}"
                )
            self.reductions.append((known(where, var), _resolve_reduction(where, red)))
            self.labels.append(f"reduction {red}({var}) of {name}")
        self.record = sorted({v for v, _ in self.reductions})
        self._unzipdir = fmpy.extract(str(self.path))
        atexit.register(shutil.rmtree, self._unzipdir, ignore_errors=True)
        self._simulate = fmpy.simulate_fmu
        self.n_criteria = len(outputs)

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        start = dict(self.start_values)
        for name, v in zip(self.param_map, x):
            start[name] = float(v)
        try:
            res = self._simulate(
                self._unzipdir,
                model_description=self.md,
                fmi_type=self.fmi_type,
                start_time=self.start_time,
                stop_time=self.stop_time,
                start_values=start,
                output=self.record,
                timeout=self.timeout,
                **self.sim_options,
            )
        except Exception as exc:
            text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
            raise ExternalModelError(
                f"FMU simulation failed: {type(exc).__name__}: {text}"
            ) from None
        t = np.asarray(res["time"], dtype=float)
        if (
            self.timeout is not None
            and len(t)
            and t[-1] < self.stop_time - 1e-9 * max(1.0, abs(self.stop_time))
        ):
            raise ExternalModelError(
                f"timed out after {self.timeout:g} s at simulation time {t[-1]:g} s of "
                f"{self.stop_time:g} s"
            )
        values = [
            float(checked_output(label, red(t, np.asarray(res[var], dtype=float)), (), "a number"))
            for (var, red), label in zip(self.reductions, self.labels)
        ]
        k = self.n_criteria
        return np.array(values[:k]), np.array(values[k:])
