"""Model base class: compiling announces itself, once, only when numba's cache is cold."""

import os
import re
import subprocess
import sys
import textwrap

import pytest

TINY = """
import numpy as np
from numba import njit

from vectorid.models.base import Model, Parameter


@njit(cache=True)
def _kernel(y):
    y[:] = 1.0


class Tiny(Model):
    name = "tiny"
    parameters = (Parameter("a", 1.0, 0.0, 2.0),)
    compile_seconds = 3.0

    def _simulate(self, X, status, t_fail, *, dt, n_steps, stride, controls, env, initial):
        y = np.zeros((X.shape[0], n_steps // stride + 1, len(self.outputs)))
        _kernel(y[:, 0, 0])
        return y
"""

RUN = """
import sys
from tinymodel import Tiny
m = Tiny()
print("cached", m.kernel_cached())
if sys.argv[1] == "compile":
    print("compiled", m.compile())
m.simulate(m.nominal, t_final=1.0, dt=0.5)
m.simulate(m.nominal, t_final=1.0, dt=0.5)
"""


def _run(tmp_path, env, how):
    return subprocess.run(
        [sys.executable, "-c", RUN, how], cwd=tmp_path, env=env, capture_output=True, text=True
    )


def test_first_compile_is_announced_once_and_never_from_the_cache(tmp_path):
    (tmp_path / "tinymodel.py").write_text(textwrap.dedent(TINY), encoding="utf-8")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(tmp_path))
    cold = _run(tmp_path, env, "simulate")
    assert cold.returncode == 0, cold.stderr
    assert "cached False" in cold.stdout
    # what is compiled, and (a log, not a terminal) how long it took at the end
    msg = (
        "compiling the tiny model's kernel (tinymodel._kernel) (numba, first use only, cached "
        "on disk afterwards; about 3 s on 2 quiet cores) ..."
    )
    assert cold.stderr.count(msg) == 1, cold.stderr  # two simulations, one message
    done = r"compiling the tiny model's kernel \(tinymodel\._kernel\): done after \d+\.\d s"
    assert len(re.findall(done, cold.stderr)) == 1, cold.stderr
    warm = _run(tmp_path, env, "simulate")
    assert "cached True" in warm.stdout and "compiling" not in warm.stderr
    # compile() compiles (with the message) only when the cache is cold
    (tmp_path / "cache2").mkdir()
    env2 = dict(env, NUMBA_CACHE_DIR=str(tmp_path / "cache2"))
    first = _run(tmp_path, env2, "compile")
    assert "compiled True" in first.stdout and first.stderr.count(msg) == 1
    assert re.search(done, first.stderr)
    again = _run(tmp_path, env2, "compile")
    assert "compiled False" in again.stdout and "compiling" not in again.stderr
    # a changed source makes the cache stale: compiled again, announced again
    (tmp_path / "tinymodel.py").write_text(
        textwrap.dedent(TINY).replace("y[:] = 1.0", "y[:] = 2.0"), encoding="utf-8"
    )
    changed = _run(tmp_path, env2, "simulate")
    assert "cached False" in changed.stdout and changed.stderr.count(msg) == 1
    # --quiet (VECTORID_QUIET) silences it, with the compile still done
    (tmp_path / "tinymodel.py").write_text(
        textwrap.dedent(TINY).replace("y[:] = 1.0", "y[:] = 3.0"), encoding="utf-8"
    )
    hushed = _run(tmp_path, dict(env2, VECTORID_QUIET="1"), "simulate")
    assert "cached False" in hushed.stdout and "compiling" not in hushed.stderr


def test_models_without_a_compiled_kernel_say_nothing():
    from vectorid.models.base import Model

    class Plain(Model):
        name = "plain"

        def _simulate(self, *a, **k):  # pragma: no cover - not called
            raise AssertionError

    assert Plain().kernel_cached() is None


@pytest.mark.parametrize("name", ["parachute6dof", "parafoil8dof", "parafoil6dof"])
def test_shipped_kernels_can_be_cached(name):
    """numba refuses to cache a kernel that uses dynamic globals (e.g. a thread-count call in
    a parallel loop), silently but for a warning: every new process would compile again."""
    from vectorid import models

    m = models.get(name)
    m.simulate(m.nominal, t_final=0.1, dt=0.05)
    kernels = m._kernels()
    assert kernels
    for kernel in kernels:
        for compiled in kernel.overloads.values():
            assert not compiled.library.has_dynamic_globals


def test_compile_models_compiles_several_kernels_in_parallel_processes_once(tmp_path):
    """Two models' first compiles run in two child processes at once (one notice says which
    and for how long); a second call finds both cached and does nothing (issue 37)."""
    for i in (1, 2):
        body = textwrap.dedent(TINY).replace("y[:] = 1.0", f"y[:] = {i}.0")
        (tmp_path / f"tiny{i}.py").write_text(body.replace('"tiny"', f'"tiny{i}"'), "utf-8")
    script = textwrap.dedent(
        """
        from vectorid import models
        models.register("one", "tiny1:Tiny")
        print("compiled", models.compile_models(["one", "tiny2:Tiny"], workers=2))
        print("again", models.compile_models(["one", "tiny2:Tiny"], workers=2))
        print("cached", models.get("one").kernel_cached(), models.get("tiny2:Tiny").kernel_cached())
        """
    )
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(tmp_path))
    env.pop("VECTORID_QUIET", None)
    r = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=env,
                       capture_output=True, text=True)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "compiled ['one', 'tiny2:Tiny']" in r.stdout and "again []" in r.stdout
    assert "cached True True" in r.stdout
    head = "compiling the kernels of one, tiny2:Tiny in 2 processes"
    lines = r.stderr.splitlines()
    assert lines[0] == f"{head} (numba, first use only, cached on disk afterwards) ...", r.stderr
    assert re.fullmatch(re.escape(head) + r": done after \d+\.\d s", lines[-1]), r.stderr
