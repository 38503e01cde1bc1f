"""Study file parsing and every validation error path."""

import textwrap

import pytest

from vectorid import StudyDefinitionError, StudySpec, load_study

CONTRACT = """
[study]
name = "example"
model = "mypkg.mymodel:evaluate"   # or a built-in name such as "binh-korn"
trials = 2048
seed = 1

[[variables]]
name = "x1"
low = 0.0
high = 5.0

[[criteria]]
name = "f1"
sense = "min"                      # "min" | "max"
role = "pure"                      # "pure" | "pseudo"; pure by default
limit = 40.0                       # optional criteria constraint Φ**

[[constraints]]
name = "g1"
low = 0.0                          # either bound optional
high = 25.0
"""


def write(tmp_path, text, name="study.toml"):
    p = tmp_path / name
    p.write_text(textwrap.dedent(text), encoding="utf-8")
    return p


def test_contract_file_accepted_as_written(tmp_path):
    spec = load_study(write(tmp_path, CONTRACT))
    assert spec.name == "example"
    assert spec.trials == 2048 and spec.seed == 1
    assert spec.space.names == ["x1"]
    (c,) = spec.criteria
    assert (c.name, c.sense, c.role, c.limit) == ("f1", "min", "pure", 40.0)
    (g,) = spec.constraints
    assert (g.low, g.high) == (0.0, 25.0)
    assert spec.base_dir == str(tmp_path.resolve())


def test_round_trip_through_dict(tmp_path):
    spec = load_study(write(tmp_path, CONTRACT))
    again = StudySpec.from_dict(spec.to_dict(), base_dir=spec.base_dir)
    assert again == spec


def test_all_variable_kinds(tmp_path):
    spec = load_study(
        write(
            tmp_path,
            """
        [study]
        name = "kinds"
        model = "binh-korn"
        [[variables]]
        name = "a"
        low = 0
        high = 1
        nominal = 0.5
        unit = "m"
        [[variables]]
        name = "n"
        type = "integer"
        low = 1
        high = 6
        [[variables]]
        name = "c"
        values = [1.0, 2.0, 4.0]
        [[criteria]]
        name = "f"
        sense = "max"
        role = "pseudo"
    """,
        )
    )
    kinds = [v.kind for v in spec.space]
    assert kinds == ["continuous", "integer", "choice"]
    assert spec.criteria[0].sense == "max" and spec.criteria[0].role == "pseudo"


BASE = {
    "study": {"name": "s", "model": "binh-korn"},
    "variables": [{"name": "x1", "low": 0.0, "high": 5.0}, {"name": "x2", "low": 0.0, "high": 3.0}],
    "criteria": [{"name": "f1"}, {"name": "f2"}],
}


def mutate(path, value):
    import copy

    data = copy.deepcopy(BASE)
    target = data
    for key in path[:-1]:
        target = target[key]
    if value is KeyError:
        del target[path[-1]]
    else:
        target[path[-1]] = value
    return data


@pytest.mark.parametrize(
    ("path", "value", "field", "match"),
    [
        (("variables", 0, "low"), 9.0, "variables.x1", "low must be smaller"),
        (("variables", 0, "high"), 0.0, "variables.x1", "equal bounds"),
        (("variables", 1, "name"), "x1", "variables.x1", "duplicate"),
        (("variables", 0, "hihg"), 1.0, "variables[0].hihg", "did you mean 'high'"),
        (("study", "trails"), 10, "study.trails", "did you mean 'trials'"),
        (("criteria",), [], "criteria", "at least one"),
        (("criteria", 0, "sense"), "minimise", "criteria.f1.sense", "'min' or 'max'"),
        (("criteria", 0, "role"), "main", "criteria.f1.role", "'pure' or 'pseudo'"),
        (("criteria", 0, "limit"), float("nan"), "criteria.f1.limit", "finite"),
        (("criteria", 1, "name"), "f1", "f1", "more than once"),
        (("variables", 0, "low"), float("inf"), "variables.x1.low", "finite"),
        (
            ("variables", 0),
            {"name": "c", "type": "choice", "values": []},
            "variables.c.values",
            "at least one value",
        ),
        (("variables", 0), {"name": "c", "type": "choice"}, "variables.c.values", "needs values"),
        (("limits",), {"f9": 3.0}, "limits.f9", "unknown criterion"),
        (("study", "trials"), 0, "study.trials", ">= 1"),
        (("study", "trials"), 2.5, "study.trials", "integer"),
        (("study", "model"), KeyError, "study.model", "missing required"),
        (("study", "sampler"), "sobel", "study.sampler", "did you mean 'sobol'"),
        (("study", "batch"), "yes", "study.batch", "true or false"),
        (("variables", 0, "type"), "real", "variables[0].type", "unknown variable type"),
        (("constraints",), [{"name": "g", "low": 3.0, "high": 1.0}], "constraints.g", "swap"),
        (("constraints",), [{"name": "g"}], "constraints.g", "neither"),
        (("critera",), [], "critera", "did you mean 'criteria'"),
    ],
)
def test_validation_errors_name_field_and_fix(path, value, field, match):
    with pytest.raises(StudyDefinitionError, match=match) as err:
        StudySpec.from_dict(mutate(path, value))
    assert err.value.field == field
    assert "—" in str(err.value) or err.value.fix == ""  # a fix is offered where one exists


def test_missing_file_and_bad_toml(tmp_path):
    with pytest.raises(StudyDefinitionError, match="not found"):
        load_study(tmp_path / "nope.toml")
    with pytest.raises(StudyDefinitionError, match="not valid TOML"):
        load_study(write(tmp_path, "[study\nname='x'"))


def test_with_limits_replaces_and_rejects_unknown():
    spec = StudySpec.from_dict(BASE)
    s2 = spec.with_limits({"f1": 3.0})
    assert s2.criteria[0].limit == 3.0 and spec.criteria[0].limit is None
    with pytest.raises(StudyDefinitionError, match="did you mean 'f1'"):
        spec.with_limits({"f11": 1.0})


def test_unknown_builtin_model_suggests(tmp_path):
    spec = StudySpec.from_dict(mutate(("study", "model"), "binh-kron"))
    with pytest.raises(StudyDefinitionError, match="binh-korn"):
        spec.problem()


def test_module_function_model_is_imported_from_study_folder(tmp_path):
    (tmp_path / "mymodel_xyz.py").write_text(
        "import numpy as np\ndef evaluate(X):\n    return X.sum(axis=1, keepdims=True), X[:, :1]\n"
    )
    p = write(tmp_path, CONTRACT.replace("mypkg.mymodel:evaluate", "mymodel_xyz:evaluate"))
    spec = load_study(p)
    res = spec.problem().evaluate([[1.0], [2.0]])
    assert res.criteria[:, 0].tolist() == [1.0, 2.0]
    assert res.functionals[:, 0].tolist() == [1.0, 2.0]


def test_module_missing_function_suggests(tmp_path):
    (tmp_path / "mymodel_abc.py").write_text("def evaluate(X):\n    return X\n")
    p = write(tmp_path, CONTRACT.replace("mypkg.mymodel:evaluate", "mymodel_abc:evalute"))
    with pytest.raises(StudyDefinitionError, match="did you mean 'evaluate'"):
        load_study(p).problem()


def test_limit_noise_without_a_noise_statement_is_refused(tmp_path):
    """A plain study cannot compute a noise floor: `limit = "noise"` there is an error that
    says what to add, never a silent "no limit"."""
    path = tmp_path / "s.toml"
    path.write_text(
        textwrap.dedent(
            """
            [study]
            name = "plain"
            model = "binh-korn"

            [[variables]]
            name = "x1"
            low = 0.0
            high = 5.0

            [[variables]]
            name = "x2"
            low = 0.0
            high = 3.0

            [[criteria]]
            name = "f1"
            limit = "noise"

            [[criteria]]
            name = "f2"
            """
        ),
        encoding="utf-8",
    )
    with pytest.raises(
        StudyDefinitionError,
        match=r"criteria\[0\]\.limit.*states no noise.*add an \[identification\] table",
    ):
        load_study(path)
