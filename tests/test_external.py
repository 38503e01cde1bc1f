"""External models: command-line programs and FMUs, run through real studies."""

from __future__ import annotations

import importlib.util
import math
import shlex
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from vectorid import Study, StudyDefinitionError, load_study
from vectorid.problem import FAILED, OK

from . import _fmus

# -- command-line models -------------------------------------------------------------------

# A simulator in another process. Its behaviour depends on the parameters so one study shows
# every outcome: x1 > 0.9 exits with status 3, x2 < 0.1 hangs, x1 < 0.07 prints garbage,
# 0.43 < x2 < 0.45 forgets a key; the rest answers f1, f2 and g.
SIM = r"""
import json, sys, time

mode = sys.argv[1]
args = sys.argv[2:]
p = json.load(open(args[0])) if mode == "files" else json.load(sys.stdin)
x1, x2 = p["x1"], p["x2"]
print("simulating", x1, x2, file=sys.stderr)
if x1 > 0.9:
    print("solver diverged at t=1.5", file=sys.stderr)
    sys.exit(3)
if x2 < 0.1:
    time.sleep(60)
if x1 < 0.07:
    print("this is not JSON", file=open(args[1], "w") if mode == "files" else sys.stdout)
    sys.exit(0)
out = {"f1": x1 ** 2 + x2, "f2": (1 - x1) ** 2, "g": x1 + x2, "extra": 1}
if 0.43 < x2 < 0.45:
    del out["f2"]
if mode == "files":
    json.dump(out, open(args[1], "w"))
else:
    print(json.dumps(out))
"""

CMD_STUDY = """
[study]
name = "cmd"
{model}
trials = {trials}
timeout = {timeout}

[[variables]]
name = "x1"
low = 0.0
high = 1.0

[[variables]]
name = "x2"
low = 0.0
high = 1.0

[[criteria]]
name = "f1"

[[criteria]]
name = "f2"

[[constraints]]
name = "g"
high = 1.5
"""


def write_cmd_study(folder: Path, mode: str, trials: int = 24, timeout: float = 0.6) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "sim.py").write_text(textwrap.dedent(SIM), encoding="utf-8")
    py = shlex.quote(sys.executable)
    if mode == "files":
        model = f'model = "cmd:{py} sim.py files {{input}} {{output}}"'
    else:  # stdin/stdout, the command as a list
        model = f'model = "cmd"\ncommand = ["{sys.executable}", "sim.py", "stdio"]'
    path = folder / "cmd.toml"
    path.write_text(CMD_STUDY.format(model=model, trials=trials, timeout=timeout), encoding="utf-8")
    return path


@pytest.mark.parametrize("mode", ["files", "stdio"])
def test_command_model_outcomes(tmp_path, mode):
    spec = load_study(write_cmd_study(tmp_path / mode, mode))
    with Study.create(spec, tmp_path / f"{mode}.db") as study:
        summary = study.run(executor="serial")
        t = study.trials()
    assert summary.stored == 24
    x1, x2 = t.X[:, 0], t.X[:, 1]
    crash = x1 > 0.9
    hang = ~crash & (x2 < 0.1)
    garbage = ~crash & ~hang & (x1 < 0.07)
    missing = ~crash & ~hang & ~garbage & (x2 > 0.43) & (x2 < 0.45)
    good = ~(crash | hang | garbage | missing)
    # the sample holds every outcome, so each branch below is exercised
    assert crash.any() and hang.any() and garbage.any() and missing.any() and good.sum() > 10
    np.testing.assert_array_equal(t.status == OK, good)
    np.testing.assert_allclose(t.F[good, 0], x1[good] ** 2 + x2[good])
    np.testing.assert_allclose(t.F[good, 1], (1 - x1[good]) ** 2)
    np.testing.assert_allclose(t.G[good, 0], x1[good] + x2[good])
    for i in np.flatnonzero(crash):
        msg = t.message(i)
        assert "exited with status 3" in msg and "solver diverged at t=1.5" in msg
    for i in np.flatnonzero(hang):
        assert "timed out after 0.6 s" in t.message(i) and "simulating" in t.message(i)
    for i in np.flatnonzero(garbage):
        assert "malformed output: not JSON" in t.message(i)
    for i in np.flatnonzero(missing):
        assert "malformed output: missing f2" in t.message(i)


def test_command_model_in_worker_processes(tmp_path):
    spec = load_study(write_cmd_study(tmp_path / "p", "files", trials=16))
    with Study.create(spec, tmp_path / "p.db") as study:
        study.run(executor="processes", workers=2, batch_size=4)
        t = study.trials()
    with Study.create(spec, tmp_path / "s.db") as study:
        study.run(executor="serial")
        ref = study.trials()
    np.testing.assert_array_equal(t.status, ref.status)
    np.testing.assert_array_equal(np.nan_to_num(t.F, nan=-1), np.nan_to_num(ref.F, nan=-1))
    assert t.messages.keys() == ref.messages.keys()


def test_command_definition_errors(tmp_path):
    path = write_cmd_study(tmp_path / "e", "files")
    text = path.read_text()
    path.write_text(text.replace('model = "cmd:', 'command = ["x"]\nmodel = "cmd:'))
    with pytest.raises(StudyDefinitionError, match="given twice"):
        load_study(path).problem()
    path.write_text(text.replace("timeout = 0.6", "timeout = -1"))
    with pytest.raises(StudyDefinitionError, match="positive number of seconds"):
        load_study(path)
    bare = text.replace(text[text.index("model") : text.index("trials")], 'model = "cmd"\n')
    path.write_text(bare)
    with pytest.raises(StudyDefinitionError, match="needs a command"):
        load_study(path).problem()


def test_command_that_does_not_exist_fails_trials_with_reason(tmp_path):
    path = write_cmd_study(tmp_path / "n", "files", trials=4)
    text = path.read_text()
    path.write_text(text.replace(shlex.quote(sys.executable), "/nonexistent/simulator"))
    spec = load_study(path)
    res = spec.problem().evaluate(np.full((2, 2), 0.5))
    assert (res.status == FAILED).all()
    assert "cannot start '/nonexistent/simulator'" in res.messages[0]


# -- FMU models ----------------------------------------------------------------------------

needs_fmpy = pytest.mark.skipif(
    importlib.util.find_spec("fmpy") is None, reason="FMPy not installed (pip install fmpy)"
)

FMU_STUDY = """
[study]
name = "fmu"
model = "fmu:{fmu}"
trials = {trials}

[study.fmu]
interface = "{interface}"
stop_time = 1.0
output_interval = 0.01

[study.fmu.parameters]
rate = "k"

[study.fmu.outputs]
final = "final(x)"
area = "integral(x)"
peak = {{ variable = "x", reduce = "max" }}

[[variables]]
name = "rate"
low = 0.5
high = 5.0

{x0_var}

[[criteria]]
name = "final"

[[criteria]]
name = "area"
sense = "max"

[[constraints]]
name = "peak"
high = 2.5
"""

X0_VAR = """[[variables]]
name = "x0"
low = 1.0
high = 3.0
"""


def _build(kind: str, dest: Path) -> Path:
    dest.mkdir(parents=True, exist_ok=True)
    try:
        if kind == "fmi2-c":
            return _fmus.build_fmi2_c(dest)
        if kind == "fmi2-pythonfmu":
            if importlib.util.find_spec("pythonfmu") is None:
                pytest.skip("pythonfmu not installed (pip install pythonfmu)")
            return _fmus.build_fmi2_pythonfmu(dest)
        if importlib.util.find_spec("pythonfmu3") is None:
            pytest.skip("pythonfmu3 not installed (pip install pythonfmu3)")
        return _fmus.build_fmi3_pythonfmu3(dest)
    except FileNotFoundError as exc:
        pytest.skip(f"cannot build {kind}: {exc}")


def write_fmu_study(folder: Path, fmu: Path, interface: str, trials: int, x0: bool = True) -> Path:
    path = folder / "fmu.toml"
    path.write_text(
        FMU_STUDY.format(
            fmu=fmu.name,
            trials=trials,
            interface=interface,
            x0_var=X0_VAR if x0 else "",
        ),
        encoding="utf-8",
    )
    return path


@needs_fmpy
@pytest.mark.parametrize(
    "kind, interface",
    [
        ("fmi2-c", "me"),
        ("fmi2-c", "cs"),
        ("fmi2-pythonfmu", "cs"),
        ("fmi3-pythonfmu3", "me"),
        ("fmi3-pythonfmu3", "cs"),
    ],
)
def test_fmu_study_matches_closed_form(tmp_path, kind, interface):
    fmu = _build(kind, tmp_path)
    # pythonfmu3's FMU sets the state x directly; the others take the parameter x0
    has_x0 = kind != "fmi3-pythonfmu3"
    path = write_fmu_study(tmp_path, fmu, interface, trials=12, x0=True)
    if not has_x0:
        text = path.read_text().replace(
            "[study.fmu.parameters]", "[study.fmu.parameters]\nx0 = 'x'"
        )
        path.write_text(text)
    spec = load_study(path)
    with Study.create(spec, tmp_path / "fmu.db") as study:
        study.run(executor="serial")
        t = study.trials()
    k, x0 = t.X[:, 0], t.X[:, 1]
    final = x0 * np.exp(-k)
    area = x0 * (1 - np.exp(-k)) / k
    ok = t.status == OK
    if kind == "fmi2-pythonfmu":  # its do_step raises for k > 4.5: those trials fail
        assert ((k > 4.5) == ~ok).all() and (~ok).any()
        for i in np.flatnonzero(~ok):
            assert "FMU simulation failed" in t.message(i)
    else:
        assert ok.all(), t.messages
    # Euler sub-steps (co-simulation) and CVode (model exchange) agree with the closed form
    # to well under 1 %; the trapezoidal integral of 100 samples to about 1e-3.
    np.testing.assert_allclose(t.F[ok, 0], final[ok], rtol=1e-2)
    np.testing.assert_allclose(t.F[ok, 1], area[ok], rtol=1e-2)
    np.testing.assert_allclose(t.G[ok, 0], x0[ok], rtol=1e-9)


@needs_fmpy
def test_fmu_in_worker_processes_equals_serial(tmp_path):
    fmu = _build("fmi2-c", tmp_path)
    spec = load_study(write_fmu_study(tmp_path, fmu, "cs", trials=16, x0=True))
    with Study.create(spec, tmp_path / "a.db") as a:
        a.run(executor="processes", workers=2, batch_size=4)
        ta = a.trials()
    ref = spec.problem().evaluate(spec.space.scale(spec.point_sequence().points(0, 16)))
    np.testing.assert_array_equal(ta.F, ref.criteria)
    np.testing.assert_array_equal(ta.G, ref.functionals)


@needs_fmpy
def test_fmu_mapping_errors_name_the_fix(tmp_path):
    fmu = _build("fmi2-c", tmp_path)
    path = write_fmu_study(tmp_path, fmu, "cs", trials=4, x0=True)
    text = path.read_text()

    def problem_with(old: str, new: str):
        path.write_text(text.replace(old, new))
        return load_study(path).problem()

    with pytest.raises(StudyDefinitionError, match=r"no variable 'kk'.*did you mean 'k'"):
        problem_with('rate = "k"', 'rate = "kk"')
    with pytest.raises(StudyDefinitionError, match="no FMU output is mapped to 'area'"):
        problem_with('area = "integral(x)"', "")
    with pytest.raises(StudyDefinitionError, match="unknown reduction 'integrl'"):
        problem_with('"integral(x)"', '"integrl(x)"')
    with pytest.raises(StudyDefinitionError, match="not a design variable"):
        problem_with('rate = "k"', 'rate = "k"\nspeed = "k"')
    with pytest.raises(StudyDefinitionError, match="FMU file .* not found"):
        problem_with("fmu:decay2.fmu", "fmu:missing.fmu")
    with pytest.raises(StudyDefinitionError, match="unknown key 'stoptime'"):
        problem_with("stop_time = 1.0", "stoptime = 1.0")
    # a user-given reduction 'module:function' of (t, y)
    (tmp_path / "myreduce.py").write_text(
        "import numpy as np\n\n\ndef half_time(t, y):\n"
        "    return float(t[np.argmax(y <= y[0] / 2)])\n"
    )
    sys.path.insert(0, str(tmp_path))
    try:
        model = problem_with('"integral(x)"', '{ variable = "x", reduce = "myreduce:half_time" }')
        res = model.evaluate(np.array([[2.0, 1.0]]))
    finally:
        sys.path.remove(str(tmp_path))
    assert res.status[0] == OK
    assert res.criteria[0, 1] == pytest.approx(math.log(2) / 2, abs=0.011)
