"""Shared fixtures: small study files with a user model written next to them."""

from __future__ import annotations

import signal
import textwrap
from pathlib import Path

import pytest

# A test run started in the background by a non-interactive shell (``cmd &``) inherits SIGINT
# ignored, and so would every process the tests start: the Ctrl-C tests (exit 130, resume) would
# see their SIGINT ignored and the run go on. An ignored signal stays ignored across exec, a
# handled one is reset to the default, so handling it here gives each child Python's own
# Ctrl-C behaviour, as in a terminal.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist (``-n``), the controller compiles the shipped models' numba kernels
    that the on-disk cache lacks (a fresh clone) once, one model per core, before the workers
    start; otherwise every worker would compile the same kernel at once on first use (a
    kernel's compile is tens of CPU-seconds). Nothing to do on a second run."""
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    from vectorid.models import available, compile_models

    compile_models(available())


# A user model in the contract's form: batch X (n, 3) -> (criteria (n, 2), functionals (n, 1)).
# Trials with x1 > 0.9 raise (the batch is bisected), trials with x2 < 0.05 return NaN,
# and VECTORID_TEST_SLEEP seconds are slept per batch so a run can be killed mid-way.
USER_MODEL = """
import os
import time

import numpy as np


def evaluate(X):
    time.sleep(float(os.environ.get("VECTORID_TEST_SLEEP", "0")))
    if np.any(X[:, 0] > 0.9):
        raise RuntimeError("x1 above 0.9 makes the model diverge")
    f1 = X[:, 0] ** 2 + X[:, 1]
    f2 = (1.0 - X[:, 0]) ** 2 + X[:, 2]
    f2 = np.where(X[:, 1] < 0.05, np.nan, f2)
    return np.column_stack([f1, f2]), (X[:, 0] + X[:, 1])[:, None]


def one(x):
    f, g = evaluate(x[None, :])
    return f[0], g[0]
"""

STUDY = """
[study]
name = "user"
model = "usermodel:{func}"
trials = {trials}
seed = 1
batch = {batch}

[[variables]]
name = "x1"
low = 0.0
high = 1.0

[[variables]]
name = "x2"
low = 0.0
high = 1.0

[[variables]]
name = "x3"
low = 0.0
high = 0.5

[[criteria]]
name = "f1"
sense = "min"

[[criteria]]
name = "f2"
sense = "min"
limit = 1.0

[[constraints]]
name = "g"
high = 1.5
"""


def write_user_study(folder: Path, trials: int = 256, batch: bool = True) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "usermodel.py").write_text(textwrap.dedent(USER_MODEL), encoding="utf-8")
    path = folder / "user.toml"
    path.write_text(
        STUDY.format(
            trials=trials, func="evaluate" if batch else "one", batch="true" if batch else "false"
        ),
        encoding="utf-8",
    )
    return path


@pytest.fixture
def user_study(tmp_path: Path) -> Path:
    """Path of a study file with a user model beside it (256 trials)."""
    return write_user_study(tmp_path / "study")
