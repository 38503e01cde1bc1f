"""Identification of a model of your own (vectorid.identify.system) from the starting point
``vectorid init own-model`` writes: records, criteria, noise floors, refusals, executors."""

from __future__ import annotations

import importlib.util
import re
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from vectorid import Study, StudyDefinitionError, load_study
from vectorid.builders import prepare_spec
from vectorid.demos.own_model import NOISE, TRUTH, write_own_model


@pytest.fixture
def own(tmp_path: Path):
    write_own_model(tmp_path / "own")
    yield tmp_path / "own"
    for name in ("msd", "msd.dynamics", "msd.fast"):
        sys.modules.pop(name, None)


def _edit(folder: Path, old: str, new: str) -> Path:
    path = folder / "study.toml"
    text = path.read_text(encoding="utf-8")
    assert re.search(old, text, flags=re.M), old
    path.write_text(re.sub(old, new, text, count=1, flags=re.M), encoding="utf-8")
    return path


def test_noise_floor_limits_and_the_truth_meets_them(own):
    spec = prepare_spec(load_study(own / "study.toml"))
    lim = {c.name: c for c in spec.criteria}
    assert lim["x_rms"].limit_source == "noise" and lim["x_rms"].unit == "m"
    assert lim["a_rms"].unit == "m/s^2" and "0.2 m/s^2" in lim["a_rms"].limit_note
    # the record is sampled on the comparison grid: the floor of an RMS residual is the RMS
    # of 61 noise samples at its joint-95 % quantile, a little above σ
    assert NOISE["x"] < lim["x_rms"].limit < 1.4 * NOISE["x"]
    assert NOISE["a"] < lim["a_rms"].limit < 1.4 * NOISE["a"]
    prob = spec.problem()
    truth = np.array([[TRUTH[v] for v in spec.space.names]])
    far = truth * [1.1, 1.5, 0.9]
    F = prob.evaluate(np.vstack([truth, far])).criteria
    limits = np.array([lim["x_rms"].limit, lim["a_rms"].limit])
    assert (F[0] <= limits).all(), F[0]
    assert (F[1] > limits).all(), F[1]


def test_own_criteria_definitions_and_functions(own):
    (own / "mycrit.py").write_text(
        "import numpy as np\n"
        "def peak(sim, meas, t):\n"
        "    return np.abs(sim.max(axis=(1, 2)) - meas.max())\n",
        encoding="utf-8",
    )
    path = _edit(own, r'^name = "a_rms".*$', 'name = "a_peak"')
    text = path.read_text(encoding="utf-8") + (
        '\n[identification.criteria.a_peak]\nchannel = "a"\nuse = "mycrit:peak"\n'
    )
    path.write_text(text, encoding="utf-8")
    sys.path.insert(0, str(own))
    try:
        spec = prepare_spec(load_study(path))
    finally:
        sys.path.remove(str(own))
    c = {c.name: c for c in spec.criteria}["a_peak"]
    assert c.limit_source == "noise" and c.limit > 0  # a Monte Carlo of the user's function
    F = spec.problem().evaluate(np.array([[TRUTH[v] for v in spec.space.names]])).criteria
    assert F.shape == (1, 2) and np.isfinite(F).all()


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        (r"^units = .*$", "", r"data\[0\]\.units.*must be stated"),
        (r"^time_unit = .*$", "", r"data\[0\]\.time_unit.*time column 't' is not stated.*s, ms"),
        (r"^time_unit = .*$", 'time_unit = "sec"', r"data\[0\]\.time_unit.*unknown time unit"),
        (r"^columns = .*$", 'columns = { x = "x_cm", a = "a" }', r"no column 'x_cm'"),
        (r"^units = .*$", 'units = { x = "inch", a = "m/s^2" }', r"'inch'.*no conversion"),
        (r'^name = "x_rms".*$', 'name = "x_mean"', r"neither <channel>_<kind>"),
        (r"^dt = 0.01 .*$", "dt = 0.01\nwind_realisations = 4", r"does not apply to model"),
        (r"^noise = .*$", "noise = { x = 0.002 }", r"no noise is stated for its channel 'a'"),
        (r"^noise = .*$", "noise = { y = 0.002 }", r"'y' is not an output channel"),
        (r"^initial = .*$", "initial = { x = 0.02, w = 1.0 }", r"initial\.w.*unknown key"),
        (r"^window = .*$", "window = [0.0, 60.0]", r"not inside the record's time span"),
        (r"^output_dt = 0.1 .*$", "output_dt = 0.015", r"whole multiple of dt"),
        (r"^limits = .*$", "noise_draws = 500", r"noise_draws shapes noise-floor limits.*no"),
        (r"^limits = .*$", 'limits = "floor"', r'limits.*expected "noise"'),
    ],
)
def test_bad_study_fields_are_refused_with_the_fix(own, old, new, message):
    path = _edit(own, old, new)
    with pytest.raises(StudyDefinitionError, match=message):
        prepare_spec(load_study(path)).problem()


def test_bad_record_rows_are_refused(own):
    lines = (own / "run1.csv").read_text(encoding="utf-8").splitlines()
    bad = [*lines[:10], lines[10].replace(lines[10].split(",")[1], "nan"), *lines[11:]]
    (own / "run1.csv").write_text("\n".join(bad) + "\n", encoding="utf-8")
    with pytest.raises(StudyDefinitionError, match=r"line \d+, column 'x_mm'.*finite number"):
        load_study(own / "study.toml").problem()
    back = [*lines[:10], lines[12], lines[11], *lines[13:]]
    (own / "run1.csv").write_text("\n".join(back) + "\n", encoding="utf-8")
    with pytest.raises(StudyDefinitionError, match="does not increase"):
        load_study(own / "study.toml").problem()


def test_numba_kernel_matches_the_numpy_model(own):
    sys.path.insert(0, str(own))
    try:
        from msd.dynamics import MassSpringDamper
        from msd.fast import MassSpringDamperNumba
    finally:
        sys.path.remove(str(own))
    P = np.array([[1.2, 0.8, 42.0], [0.9, 1.5, 35.0], [1.5, 0.2, 50.0]])
    kw = dict(t_final=6.0, dt=0.01, output_dt=0.1, initial={"x": 0.02})
    a = MassSpringDamper().simulate(P, **kw)
    b = MassSpringDamperNumba().simulate(P, **kw)
    np.testing.assert_allclose(b.outputs, a.outputs, rtol=1e-9, atol=1e-12)


@pytest.mark.skipif(importlib.util.find_spec("distributed") is None, reason="needs dask")
@pytest.mark.parametrize("executor", ["processes", "dask"])
def test_every_executor_imports_the_model_by_path(own, tmp_path, executor):
    path = _edit(own, r"^trials = .*$", "trials = 64")
    spec = load_study(path)
    with Study.create(spec, tmp_path / f"{executor}.db") as s:
        s.run(executor=executor, workers=2, batch_size=16)
        t = s.trials()
    ref = spec.problem().evaluate(spec.space.scale(spec.point_sequence().points(0, 64)))
    assert (t.status == 0).all() and len(t.F) == 64
    np.testing.assert_array_equal(t.F, ref.criteria)


def test_verbs_on_an_own_model_store_report_and_thin_verdicts(own, tmp_path, capsys):
    from vectorid.cli import main

    path = _edit(own, r"^trials = .*$", "trials = 256")
    store = tmp_path / "s.db"
    assert main(["run", str(path), "--store", str(store), "--executor", "serial", "--quiet"]) == 0
    capsys.readouterr()
    # 256 trials leave D nearly empty: the verdicts say it rather than call anything identified
    assert main(["identifiability", str(store), "--json"]) == 0
    import json

    doc = json.loads(capsys.readouterr().out)
    assert all(p["verdict"] != "identified" for p in doc["parameters"])
    assert all(p["thin"] or p["feasible"] is None for p in doc["parameters"])
    out = tmp_path / "r.html"
    assert main(["report", str(store), "--out", str(out)]) == 0
    html = out.read_text(encoding="utf-8")
    assert "Record run1: measured and simulated" in html and "mass-spring-damper" in html


def test_library_criteria_apply_to_an_output_of_their_channel(tmp_path):
    (tmp_path / "fall.py").write_text(
        "import numpy as np\n"
        "from vectorid.models import Channel, Parameter, SystemModel\n\n"
        "class Fall(SystemModel):\n"
        '    parameters = (Parameter("rate", 5.0, 1.0, 9.0, "m/s", "descent rate"),)\n'
        '    states = (Channel("altitude", "m", "height", default=100.0),)\n\n'
        "    def rhs(self, t, x, p):\n"
        "        return -p[:, :1] * np.ones_like(x)\n",
        encoding="utf-8",
    )
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 10.01, 0.1)
    h = 100.0 - 5.0 * t + rng.normal(0.0, 0.5, t.size)
    np.savetxt(
        tmp_path / "h.csv", np.column_stack([t, h]), delimiter=",", header="t,h", comments=""
    )
    (tmp_path / "fall.toml").write_text(
        textwrap.dedent(
            """
            [study]
            name = "fall"
            model = "fall:Fall"
            trials = 64

            [[variables]]
            name = "rate"
            low = 1.0
            high = 9.0

            [[criteria]]
            name = "alt_abs"
            [[criteria]]
            name = "rate_fit"

            [identification]
            dt = 0.1
            output_dt = 0.2
            noise = { altitude = 0.5 }
            limits = "noise"

            [identification.criteria.rate_fit]
            use = "vz_abs"

            [[identification.data]]
            file = "h.csv"
            time_unit = "s"
            columns = { altitude = "h" }
            units = { altitude = "m" }
            """
        ),
        encoding="utf-8",
    )
    try:
        spec = prepare_spec(load_study(tmp_path / "fall.toml"))
        crit = {c.name: c for c in spec.criteria}
        assert crit["alt_abs"].unit == "m·s" and crit["rate_fit"].unit == "m"
        F = spec.problem().evaluate(np.array([[5.0], [6.0]])).criteria
        lim = np.array([crit["alt_abs"].limit, crit["rate_fit"].limit])
        assert (F[0] <= lim).all() and (F[1] > lim).any()
    finally:
        sys.modules.pop("fall", None)


def test_an_edited_record_is_caught_before_a_trial_is_added(own, tmp_path, capsys):
    from vectorid.cli import main

    path = _edit(own, r"^trials = .*$", "trials = 32")
    args = ["run", str(path), "--store", str(tmp_path / "s.db"), "--executor", "serial"]
    assert main([*args, "--quiet"]) == 0
    rec = own / "run1.csv"
    rec.write_text(rec.read_text(encoding="utf-8").replace("\n0.100,", "\n0.100,1"), "utf-8")
    capsys.readouterr()
    assert main([*args, "--trials", "64", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "identification.data[0].file" in err and "content differs" in err


def test_estimated_noise_is_close_to_the_stated_one(own):
    path = _edit(own, r"^noise = .*$", 'noise = "estimate"')
    spec = prepare_spec(load_study(path))
    c = {c.name: c for c in spec.criteria}
    assert "x estimated σ" in c["x_rms"].limit_note and "a estimated σ" in c["a_rms"].limit_note
    stated = prepare_spec(
        load_study(_edit(own, r'^noise = "estimate"', "noise = { x = 0.002, a = 0.2 }"))
    )
    s = {c.name: c.limit for c in stated.criteria}
    # 10 Hz samples of a 1 Hz oscillation: the third differences hold some of the signal
    # (A ω³ Δt³), so the estimate is high, never low: wider limits, a larger D (the
    # tutorial says to sample well above the motion's frequencies for "estimate")
    assert s["x_rms"] <= c["x_rms"].limit < 3 * s["x_rms"]
    assert s["a_rms"] * 0.7 <= c["a_rms"].limit < 3 * s["a_rms"]


def test_a_time_column_in_ms_stated_as_ms_gives_the_numbers_of_the_one_in_s(own):
    spec = prepare_spec(load_study(own / "study.toml"))
    x = np.array([[TRUTH[v] for v in spec.space.names], [1.5 * TRUTH[v] for v in spec.space.names]])
    f_s = spec.problem().evaluate(x).criteria
    rec = own / "run1.csv"
    lines = rec.read_text(encoding="utf-8").splitlines()
    head = next(i for i, ln in enumerate(lines) if ln.startswith("t,"))
    for i in range(head + 1, len(lines)):
        t, rest = lines[i].split(",", 1)
        lines[i] = f"{float(t) * 1000:.3f},{rest}"
    rec.write_text("\n".join(lines) + "\n", encoding="utf-8")
    _edit(own, r'^time_unit = "s".*$', 'time_unit = "ms"')
    spec_ms = prepare_spec(load_study(own / "study.toml"))
    np.testing.assert_allclose(spec_ms.problem().evaluate(x).criteria, f_s, rtol=1e-12)


# -- what the model's functions return is checked before it is used ------------------------

from vectorid.models import Channel, Parameter, SystemModel  # noqa: E402
from vectorid.problem import ModelOutputError  # noqa: E402


class _Osc(SystemModel):
    """Two states, two outputs; ``bad`` says how rhs or output goes wrong."""

    parameters = (Parameter("k", 4.0, 1.0, 9.0, "1/s^2", "stiffness per mass"),)
    states = (Channel("x", "m", "position", default=1.0), Channel("v", "m/s", "velocity"))
    outputs = (Channel("x", "m", "position"), Channel("e", "J/kg", "energy per mass"))

    def __init__(self, bad: str = ""):
        self.bad = bad

    def rhs(self, t, x, p):
        good = np.column_stack([x[:, 1], -p[:, 0] * x[:, 0]])
        return {
            "rhs (n, 1)": good[:, :1],
            "rhs scalar": 0.5,
            "rhs (n, 3)": np.column_stack([good, good[:, :1]]),
            "rhs transposed": good.T,
            "rhs list": [good[:, 0], good[:, 1]],
            "rhs complex": good + 0j,
            "rhs text": good.astype(str),
        }.get(self.bad, good)

    def output(self, t, x, p):
        good = np.column_stack([x[:, 0], 0.5 * x[:, 1] ** 2 + 0.5 * p[:, 0] * x[:, 0] ** 2])
        return {"output (n, 1)": good[:, :1], "output transposed": good.T}.get(self.bad, good)


SHAPE_CASES = [
    ("rhs (n, 1)", r"_Osc\.rhs returned shape \(N, 1\), expected shape \(N, 2\)"),
    ("rhs scalar", r"_Osc\.rhs returned a scalar 0\.5 \(shape \(\)\), expected shape \(N, 2\)"),
    ("rhs (n, 3)", r"_Osc\.rhs returned shape \(N, 3\), expected shape \(N, 2\)"),
    ("rhs transposed", r"_Osc\.rhs returned shape \(2, N\), expected shape \(N, 2\).*transposed"),
    ("rhs list", r"_Osc\.rhs returned a list of 2 items.*expected shape \(N, 2\).*column_stack"),
    ("rhs complex", r"_Osc\.rhs returned complex numbers, expected real numbers of shape"),
    ("rhs text", r"_Osc\.rhs returned text, expected real numbers of shape"),
    ("output (n, 1)", r"_Osc\.output returned shape \(N, 1\), expected shape \(N, 2\)"),
    ("output transposed", r"_Osc\.output returned shape \(2, N\), expected shape \(N, 2\)"),
]


@pytest.mark.parametrize("n", [1, 2, 5])  # 2 trials for 2 states: a transposed result fits
@pytest.mark.parametrize(("bad", "said"), SHAPE_CASES, ids=[c[0] for c in SHAPE_CASES])
def test_wrong_shapes_from_rhs_and_output_are_one_line_naming_the_function(bad, said, n):
    model = _Osc(bad)
    P = np.linspace(2.0, 6.0, n)[:, None]
    if bad == "rhs transposed" and n == 1:
        said = said.replace("transposed", "")
    with pytest.raises(ModelOutputError, match=said.replace("N", str(n if n != 2 else "[12]"))):
        model.simulate(P, t_final=1.0, dt=0.01, output_dt=0.1)
    good = _Osc().simulate(P, t_final=1.0, dt=0.01, output_dt=0.1)
    assert good.outputs.shape == (n, 11, 2) and good.ok.all()


class _Kernel(_Osc):
    def _simulate(self, X, x0, status, t_fail, *, dt, n_steps, stride):
        return np.zeros((X.shape[0], n_steps // stride + 1, 1))  # one output, not two


def test_a_kernel_of_the_wrong_shape_is_named():
    with pytest.raises(ModelOutputError, match=r"_Kernel\._simulate returned shape \(3, 11, 1\)"):
        _Kernel().simulate(np.full((3, 1), 4.0), t_final=1.0, dt=0.01, output_dt=0.1)


def _with_rhs(own: Path, body: str) -> None:
    f = own / "msd" / "dynamics.py"
    text = f.read_text(encoding="utf-8")
    good = "return np.column_stack([x[:, 1], self.acceleration(t, x, p)])"
    assert good in text
    f.write_text(text.replace(good, body), encoding="utf-8")


@pytest.mark.parametrize("limits", ["noise", "numbers"])
def test_a_wrong_shape_stops_the_study_before_any_trial(own, tmp_path, capsys, limits):
    """Through the noise floor (computed when the store is created) or through the first
    batch: exit 2, one line naming the function and both shapes, nothing stored."""
    from vectorid.cli import main

    _with_rhs(own, "return np.column_stack([x[:, 1]])")
    if limits == "numbers":
        _edit(own, r'^limits = "noise".*$', "")
        _edit(own, r'^name = "x_rms".*$', 'name = "x_rms"\nlimit = 0.01')
        _edit(own, r'^name = "a_rms".*$', 'name = "a_rms"\nlimit = 1.0')
    db = tmp_path / "s.db"
    code = main(["run", str(own / "study.toml"), "--store", str(db), "--trials", "64",
                 "--quiet", "--executor", "serial"])  # fmt: skip
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:")]
    assert code == 2 and len(lines) == 1, err
    assert re.search(
        r"msd\.dynamics\.MassSpringDamper\.rhs returned shape \(\d+, 1\), expected shape "
        r"\(\d+, 2\) \(one row per trial, one column per state: x, v\)",
        lines[0],
    ), lines[0]
    assert "Traceback" not in err
    if db.exists():
        with Study.open(db) as st:
            assert st.store.count() == 0


def test_only_the_trials_that_misbehave_fail_with_the_reason(own, tmp_path):
    """rhs returns a column for heavy masses only: those trials fail with the shape named,
    the others are stored as computed."""
    _with_rhs(
        own,
        "out = np.column_stack([x[:, 1], self.acceleration(t, x, p)])\n"
        "        return out[:, :1] if np.any(p[:, 0] > 1.4) else out",
    )
    spec = load_study(own / "study.toml")
    with Study.create(spec, tmp_path / "s.db") as st:
        st.run(trials=64, executor="serial", batch_size=16)
        t = st.store.load()
    heavy = t.X[:, 0] > 1.4
    assert heavy.any() and (~heavy).any()
    assert np.array_equal(t.status == 1, heavy)
    msgs = {t.message(i) for i in np.flatnonzero(heavy)}
    assert msgs == {
        "ModelOutputError: msd.dynamics.MassSpringDamper.rhs returned shape (1, 1), expected "
        "shape (1, 2) (one row per trial, one column per state: x, v)"
    }
    assert np.isfinite(t.F[~heavy]).all()


def test_a_criterion_function_of_the_wrong_shape_is_named(own):
    (own / "shapecrit.py").write_text(
        "import numpy as np\n"
        "def peak(sim, meas, t):\n"
        "    return np.abs(sim.max(axis=(1, 2)) - meas.max())[:, None]\n",
        encoding="utf-8",
    )
    path = _edit(own, r'^name = "a_rms".*$', 'name = "a_peak"')
    path.write_text(
        path.read_text(encoding="utf-8")
        + '\n[identification.criteria.a_peak]\nchannel = "a"\nuse = "shapecrit:peak"\n',
        encoding="utf-8",
    )
    sys.path.insert(0, str(own))
    try:
        said = r"criterion a_peak \(shapecrit:peak\) returned shape \(1, 1\), expected shape \(1,\)"
        with pytest.raises(ModelOutputError, match=said + r" \(one value per trial"):
            prepare_spec(load_study(path))
    finally:
        sys.path.remove(str(own))
        sys.modules.pop("shapecrit", None)


def test_a_model_whose_output_is_nan_everywhere_is_said_to_be_so(own, capsys):
    from vectorid.cli import main

    f = own / "msd" / "dynamics.py"
    text = f.read_text(encoding="utf-8")
    old = "return np.column_stack([x[:, 0], self.acceleration(t, x, p)])"
    f.write_text(text.replace(old, "return np.full((len(x), 2), np.nan)"), encoding="utf-8")
    assert main(["run", str(own / "study.toml"), "--trials", "64", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "limit: expected a finite number" not in err
    assert re.search(
        r"error: identification\.noise: the model's output 'x' is not a finite number at the "
        r"reference vector \{'m': 1\.2, 'c': 0\.9, 'k': 42\.5\} \(NaN or inf at 601 of 601 "
        r"times, first at t = 0 s of record 'run1'\), so the noise floor of x_rms cannot be "
        r"computed — check MassSpringDamper\.output\(t, x, p\)",
        err,
    ), err
