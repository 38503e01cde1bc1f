"""Small FMUs built by the tests themselves (nothing downloaded).

All model the same exponential decay ``dx/dt = -k x, x(0) = x0`` with output ``x``, so the
criteria have closed forms: final value ``x0 exp(-k T)``, integral ``x0 (1 - exp(-k T)) / k``
and maximum ``x0``.

* :func:`build_fmi2_c`: FMI 2.0, model exchange and co-simulation, written in C and compiled
  with the system C compiler against FMPy's FMI 2.0 headers (source in ``fmu_src/``);
* :func:`build_fmi2_pythonfmu`: FMI 2.0 co-simulation with ``pythonfmu`` (its ``do_step``
  raises for ``k > 4.5``, to test a failing simulation);
* :func:`build_fmi3_pythonfmu3`: FMI 3.0, model exchange and co-simulation, with ``pythonfmu3``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

SOURCES = Path(__file__).parent / "fmu_src"

PYTHONFMU2 = """
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class Decay(Fmi2Slave):
    author = "vectorid tests"
    description = "dx/dt = -k x, x(0) = x0"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.k = 1.0
        self.x0 = 1.0
        self.x = 1.0
        tunable = Fmi2Variability.tunable
        self.register_variable(Real("k", causality=Fmi2Causality.parameter, variability=tunable))
        self.register_variable(Real("x0", causality=Fmi2Causality.parameter, variability=tunable))
        self.register_variable(Real("x", causality=Fmi2Causality.output))

    def setup_experiment(self, start_time, stop_time=None, tolerance=None):
        pass

    def enter_initialization_mode(self):
        pass

    def exit_initialization_mode(self):
        self.x = self.x0

    def do_step(self, current_time, step_size):
        if self.k > 4.5:
            raise RuntimeError("k above 4.5 is not supported")
        for _ in range(100):
            self.x -= self.k * self.x * step_size / 100
        return True
"""

PYTHONFMU3 = """
from pythonfmu3 import (
    CoSimulation, Fmi3Causality, Fmi3Initial, Fmi3SlaveBase, Fmi3Variability, Float64,
    ModelExchange,
)


class Decay3(Fmi3SlaveBase, ModelExchange, CoSimulation):
    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.author = "vectorid tests"
        self.description = "dx/dt = -k x"
        self.time = 0.0
        self.k = 1.0
        self.x = 1.0
        self.derx = 0.0
        cont = Fmi3Variability.continuous
        self.register_variable(
            Float64("time", causality=Fmi3Causality.independent, variability=cont)
        )
        self.register_variable(
            Float64("x", causality=Fmi3Causality.output, start=1.0, variability=cont,
                    initial=Fmi3Initial.exact)
        )
        self.register_variable(
            Float64("derx", causality=Fmi3Causality.local, variability=cont, derivative=1)
        )
        self.register_variable(
            Float64("k", causality=Fmi3Causality.parameter, variability=Fmi3Variability.fixed)
        )

    def get_continuous_state_derivatives(self):
        self.derx = -self.k * self.x
        return [self.derx]

    def do_step(self, current_time, step_size):
        for _ in range(100):
            self.x -= self.k * self.x * step_size / 100
        self.time = current_time + step_size
        return True
"""


def _zip(folder: Path, out: Path) -> Path:
    with zipfile.ZipFile(out, "w") as z:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                z.write(path, path.relative_to(folder).as_posix())
    return out


def build_fmi2_c(dest: Path) -> Path:
    """FMI 2.0 model exchange + co-simulation FMU compiled from C (needs a C compiler)."""
    import fmpy

    cc = shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")
    if cc is None:
        raise FileNotFoundError("no C compiler (cc/gcc) on PATH")
    headers = Path(fmpy.__file__).parent / "c-code"
    work = dest / "decay2-build"
    binaries = work / "binaries" / "linux64"
    binaries.mkdir(parents=True, exist_ok=True)
    shutil.copy(SOURCES / "decay2-modelDescription.xml", work / "modelDescription.xml")
    subprocess.run(
        [
            cc,
            "-shared",
            "-fPIC",
            "-O1",
            f"-I{headers}",
            str(SOURCES / "decay2.c"),
            "-o",
            str(binaries / "decay2.so"),
        ],
        check=True,
        capture_output=True,
    )
    return _zip(work, dest / "decay2.fmu")


def _pythonfmu(tool: str, source: str, name: str, dest: Path) -> Path:
    script = dest / f"{name}.py"
    script.write_text(source, encoding="utf-8")
    subprocess.run(
        [sys.executable, "-m", tool, "build", "-f", str(script), "-d", str(dest)],
        check=True,
        capture_output=True,
        cwd=dest,
    )
    return dest / f"{name}.fmu"


def build_fmi2_pythonfmu(dest: Path) -> Path:
    """FMI 2.0 co-simulation FMU made with pythonfmu."""
    return _pythonfmu("pythonfmu", PYTHONFMU2, "Decay", dest)


def build_fmi3_pythonfmu3(dest: Path) -> Path:
    """FMI 3.0 model exchange + co-simulation FMU made with pythonfmu3."""
    return _pythonfmu("pythonfmu3", PYTHONFMU3, "Decay3", dest)
