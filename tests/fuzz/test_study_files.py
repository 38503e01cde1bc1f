"""Fuzz table: study files. Each row is a damaged, mistyped or malformed study file run with
``vectorid run``; the answer must be one ``error:`` line naming the field, what came and the
fix, with exit status 2, and no store left holding a trial."""

from __future__ import annotations

import textwrap

import pytest

from ..conftest import USER_MODEL
from ._harness import cli, expect, expect_error, write

KIND = "study files"

BASE = """\
[study]
name = "user"
model = "usermodel:evaluate"
trials = 16
seed = 1

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


def edit(*pairs: tuple[str, str], add: str = "") -> str:
    text = BASE
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text + add


# (id, file text (str) or bytes, regex the error must match)
CASES = [
    # -- encodings and file kinds
    ("binary", b"\x00\x01SQLite format 3\x00" + bytes(range(256)), "binary file"),
    ("latin-1", edit(('name = "user"', 'name = "caf\xe9"')).encode("latin-1"), "not UTF-8"),
    ("utf-16", BASE.encode("utf-16"), "binary file|not UTF-8"),
    ("empty", "", r"missing \[study\]"),
    ("only comment", "# nothing\n", r"missing \[study\]"),
    ("not toml", "this is not toml\n", "not valid TOML"),
    ("unclosed table", "[study\nname = 'x'\n", "not valid TOML"),
    ("unclosed string", edit(('name = "user"', 'name = "user')), "not valid TOML"),
    ("duplicate key", edit(("seed = 1", "seed = 1\nseed = 2")), "not valid TOML"),
    ("inline table split", BASE + "x-a = { b = 1,\n c = 2 }\n", "not valid TOML"),
    ("json", '{"study": {"name": "x"}}', "not valid TOML"),
    # -- [study]
    ("study not a table", "study = 5\n", "expected a table"),
    ("no name", edit(('name = "user"\n', "")), "study.name.*missing"),
    ("no model", edit(('model = "usermodel:evaluate"\n', "")), "study.model.*missing"),
    ("empty name", edit(('name = "user"', 'name = ""')), "study.name"),
    ("name number", edit(('name = "user"', "name = 5")), "study.name"),
    ("model colon", edit(('model = "usermodel:evaluate"', 'model = ":"')), "study.model"),
    ("model spaces", edit(('model = "usermodel:evaluate"', 'model = "a b:c"')), "study.model"),
    ("model number", edit(('model = "usermodel:evaluate"', "model = 5")), "study.model"),
    ("model empty", edit(('model = "usermodel:evaluate"', 'model = ""')), "study.model"),
    ("model list", edit(('model = "usermodel:evaluate"', "model = []")), "study.model"),
    ("model unknown builtin", edit(('"usermodel:evaluate"', '"binh-kron"')), "binh-korn"),
    ("model no module", edit(('"usermodel:evaluate"', '"nosuchmod:f"')), "cannot import"),
    ("model no function", edit(('"usermodel:evaluate"', '"usermodel:evaluat"')), "evaluate"),
    ("model not callable", edit(('"usermodel:evaluate"', '"usermodel:np"')), "not callable"),
    ("model trailing colon", edit(('"usermodel:evaluate"', '"usermodel:"')), "study.model"),
    ("store number", edit(("seed = 1", "seed = 1\nstore = 5")), "study.store.*expected text"),
    ("store list", edit(("seed = 1", "seed = 1\nstore = []")), "study.store"),
    ("trials string", edit(("trials = 16", 'trials = "16"')), "study.trials.*integer"),
    ("trials bool", edit(("trials = 16", "trials = true")), "study.trials"),
    ("trials float", edit(("trials = 16", "trials = 1.5")), "study.trials"),
    ("trials zero", edit(("trials = 16", "trials = 0")), "study.trials.*>= 1"),
    ("trials negative", edit(("trials = 16", "trials = -5")), "study.trials"),
    ("trials inf", edit(("trials = 16", "trials = inf")), "study.trials"),
    ("seed negative", edit(("seed = 1", "seed = -1")), "study.seed"),
    ("seed string", edit(("seed = 1", 'seed = "1"')), "study.seed"),
    ("batch string", edit(("seed = 1", 'seed = 1\nbatch = "yes"')), "study.batch"),
    ("batch number", edit(("seed = 1", "seed = 1\nbatch = 1")), "study.batch"),
    ("batch_size zero", edit(("seed = 1", "seed = 1\nbatch_size = 0")), "study.batch_size"),
    ("sampler unknown", edit(("seed = 1", 'seed = 1\nsampler = "halton"')), "study.sampler"),
    ("sampler number", edit(("seed = 1", "seed = 1\nsampler = 3")), "study.sampler"),
    ("scramble number", edit(("seed = 1", "seed = 1\nscramble = 1")), "study.scramble"),
    ("executor unknown", edit(("seed = 1", 'seed = 1\nexecutor = "threads"')), "executor"),
    ("executor number", edit(("seed = 1", "seed = 1\nexecutor = 1")), "study.executor"),
    ("workers zero", edit(("seed = 1", "seed = 1\nworkers = 0")), "study.workers"),
    ("workers string", edit(("seed = 1", 'seed = 1\nworkers = "2"')), "study.workers"),
    ("timeout zero", edit(("seed = 1", "seed = 1\ntimeout = 0")), "study.timeout"),
    ("timeout string", edit(("seed = 1", 'seed = 1\ntimeout = "5"')), "study.timeout"),
    ("timeout bool", edit(("seed = 1", "seed = 1\ntimeout = true")), "study.timeout"),
    ("timeout nan", edit(("seed = 1", "seed = 1\ntimeout = nan")), "study.timeout"),
    ("scheduler number", edit(("seed = 1", "seed = 1\nscheduler = 5")), "study.scheduler"),
    ("scheduler malformed", edit(("seed = 1", 'seed = 1\nscheduler = "tcp//h"')), "HOST:PORT"),
    ("scheduler no port", edit(("seed = 1", 'seed = 1\nscheduler = "tcp://h"')), "HOST:PORT"),
    (
        "scheduler serial",
        edit(("seed = 1", 'seed = 1\nscheduler = "tcp://h:1"\nexecutor = "serial"')),
        "applies to executor 'dask'",
    ),
    ("study typo key", edit(("seed = 1", "seed = 1\ntrails = 5")), "did you mean 'trials'"),
    ("description number", edit(("seed = 1", "seed = 1\ndescription = 3")), "description"),
    ("cmd without command", edit(('"usermodel:evaluate"', '"cmd"')), "needs a command"),
    ("fmu without path", edit(('"usermodel:evaluate"', '"fmu:"')), "needs a path"),
    ("command not list", edit(("seed = 1", 'seed = 1\ncommand = "python x"')), "study.command"),
    (
        "command with a python model",
        edit(("seed = 1", 'seed = 1\ncommand = ["python", "x.py"]')),
        "study.command.*applies to a 'cmd' model only",
    ),
    (
        "fmu with a python model",
        edit(("seed = 1", "seed = 1\nfmu = { stop_time = 1.0 }")),
        "study.fmu.*applies to a 'fmu' model only",
    ),
    # -- [[variables]]
    ("no variables", BASE.split("[[variables]]")[0] + "[[criteria]]\nname='f1'\n", "variables"),
    ("variables not array", edit(add="variables = 3\n"), "not valid TOML|variables"),
    ("high bool", edit(("high = 1.0", "high = true")), r"variables.x1.high.*true"),
    ("low string", edit(("low = 0.0", 'low = "0"')), r'variables.x1.low.*"0"'),
    ("low list", edit(("low = 0.0", "low = [0]")), r"variables.x1.low"),
    ("low above high", edit(("low = 0.0", "low = 2.0")), "smaller than high"),
    ("low equal high", edit(("low = 0.0", "low = 1.0")), "equal bounds"),
    ("low nan", edit(("low = 0.0", "low = nan")), "finite"),
    ("high inf", edit(("high = 1.0", "high = inf")), "finite"),
    ("no low", edit(("low = 0.0\n", "")), "variables.x1.low.*missing"),
    ("nominal outside", edit(("high = 1.0", "high = 1.0\nnominal = 3.0")), "outside"),
    ("nominal string", edit(("high = 1.0", 'high = 1.0\nnominal = "1"')), "nominal"),
    ("type unknown", edit(("high = 1.0", 'high = 1.0\ntype = "float"')), "unknown variable type"),
    ("type number", edit(("high = 1.0", "high = 1.0\ntype = 3")), "variables.*type.*text"),
    ("integer half", edit(("high = 1.0", 'high = 1.5\ntype = "integer"')), "whole-number"),
    ("choice no values", edit(("low = 0.0\nhigh = 1.0", 'type = "choice"')), "needs values"),
    ("choice string values", edit(("low = 0.0\nhigh = 1.0", 'values = "abc"')), "array"),
    ("choice bool values", edit(("low = 0.0\nhigh = 1.0", "values = [true, false]")), "number"),
    ("choice text values", edit(("low = 0.0\nhigh = 1.0", 'values = ["a", "b"]')), "number"),
    ("choice with bounds", edit(("high = 1.0", "high = 1.0\nvalues = [1.0]")), "values"),
    ("unit number", edit(("high = 1.0", "high = 1.0\nunit = 5")), "unit.*expected text"),
    ("variable name number", edit(('name = "x1"', "name = 1")), "name"),
    ("variable unknown key", edit(("high = 1.0", "high = 1.0\nhgih = 2")), "unknown key"),
    ("duplicate variable", edit(('name = "x2"', 'name = "x1"')), "duplicate|more than once"),
    ("variable named like criterion", edit(('name = "x2"', 'name = "f1"')), "more than once"),
    # -- [[criteria]]
    ("no criteria", BASE.split("[[criteria]]")[0], "criteria"),
    ("sense word", edit(('sense = "min"', 'sense = "minimize"')), "'min' or 'max'"),
    ("sense number", edit(('sense = "min"', "sense = 1")), "criteria.*sense"),
    ("role unknown", edit(('sense = "min"', 'sense = "min"\nrole = "primary"')), "pure"),
    ("limit string", edit(("limit = 1.0", 'limit = "40"')), r'limit.*"40"'),
    ("limit bool", edit(("limit = 1.0", "limit = true")), r"limit.*true"),
    ("limit nan", edit(("limit = 1.0", "limit = nan")), "limit.*finite"),
    (
        "limit noise without noise",
        edit(("limit = 1.0", 'limit = "noise"')),
        r'criteria\[1\]\.limit.*limit = "noise", but this study states no noise',
    ),
    ("limits noise", edit(add='[limits]\nf1 = "noise"\n'), r"f1\.limit.*expected a number"),
    ("criterion no name", edit(('name = "f1"\n', "")), "criteria.*name"),
    ("criterion name number", edit(('name = "f1"', "name = 7")), "name"),
    ("criterion unknown key", edit(("limit = 1.0", "limit = 1.0\nweight = 2")), "unknown key"),
    # -- [[constraints]]
    ("constraint no bound", edit(("high = 1.5\n", "")), "neither"),
    ("constraint low string", edit(("high = 1.5", 'high = 1.5\nlow = "0"')), "low"),
    ("constraint inverted", edit(("high = 1.5", "high = 1.5\nlow = 2.0")), "exceed"),
    ("constraint high bool", edit(("high = 1.5", "high = true")), "high"),
    # -- [limits] and other tables
    ("limits unknown", edit(add="[limits]\nf9 = 1.0\n"), "unknown criterion"),
    ("limits string", edit(add='[limits]\nf1 = "1"\n'), r'limit.*"1"'),
    ("limits not table", edit(add="limits = 3\n"), "not valid TOML|limits"),
    ("unknown table", edit(add="[studdy]\nx = 1\n"), "unknown top-level table"),
    ("identification not table", edit(add="identification = 3\n"), "identification|TOML"),
]


@pytest.mark.parametrize(("case", "text", "match"), CASES, ids=[c[0] for c in CASES])
def test_bad_study_file_is_one_clear_line(tmp_path, case, text, match):
    write(tmp_path / "usermodel.py", textwrap.dedent(USER_MODEL))
    path = write(tmp_path / "study.toml", text)
    r = cli("run", path, "--store", tmp_path / "s.db", "--executor", "serial", "--quiet")
    expect_error(KIND, r, match)
    # nothing computed was left behind
    if (tmp_path / "s.db").exists():
        from vectorid.store import Store

        with Store.open(tmp_path / "s.db") as st:
            assert st.count() == 0


def test_model_module_with_a_syntax_error(tmp_path):
    write(tmp_path / "broken.py", "def evaluate(X):\n    return X[:, :2\n")
    path = write(tmp_path / "s.toml", edit(('"usermodel:evaluate"', '"broken:evaluate"')))
    r = cli("run", path, "--store", tmp_path / "s.db", "--executor", "serial", "--quiet")
    expect_error(KIND, r, r"syntax error.*broken\.py, line 2")


def test_model_module_raising_on_import(tmp_path):
    write(tmp_path / "boom.py", "raise RuntimeError('no licence server')\n")
    path = write(tmp_path / "s.toml", edit(('"usermodel:evaluate"', '"boom:evaluate"')))
    r = cli("run", path, "--store", tmp_path / "s.db", "--executor", "serial", "--quiet")
    expect_error(KIND, r, "no licence server")


def test_model_module_missing_dependency(tmp_path):
    write(tmp_path / "needs.py", "import nosuchpackage_xyz\n\ndef evaluate(X):\n    return X\n")
    path = write(tmp_path / "s.toml", edit(('"usermodel:evaluate"', '"needs:evaluate"')))
    r = cli("run", path, "--store", tmp_path / "s.db", "--executor", "serial", "--quiet")
    expect_error(KIND, r, "nosuchpackage_xyz.*install")


def test_study_asking_for_more_workers_than_the_machine_holds(tmp_path):
    write(tmp_path / "usermodel.py", textwrap.dedent(USER_MODEL))
    path = write(tmp_path / "s.toml", edit(("seed = 1", "seed = 1\nworkers = 100000")))
    r = cli("run", path, "--store", tmp_path / "s.db", "--quiet")
    expect_error(KIND, r, r"100000 worker processes are more than this machine can hold: at most")


def test_study_path_is_a_folder(tmp_path):
    r = cli("run", tmp_path, "--executor", "serial", "--quiet")
    expect_error(KIND, r, "is a folder")


def test_missing_study_file(tmp_path):
    r = cli("run", tmp_path / "nope.toml", "--quiet")
    expect_error(KIND, r, "not found")


def test_byte_order_mark_is_accepted(tmp_path):
    write(tmp_path / "usermodel.py", textwrap.dedent(USER_MODEL))
    path = write(tmp_path / "s.toml", b"\xef\xbb\xbf" + BASE.encode())
    r = cli("run", path, "--store", tmp_path / "s.db", "--executor", "serial", "--quiet")
    expect(KIND, r.code == 0 and "16 trials computed" in r.out, r.err, r)


def test_x_tables_are_kept(tmp_path):
    write(tmp_path / "usermodel.py", textwrap.dedent(USER_MODEL))
    path = write(tmp_path / "s.toml", edit(add='[x-notes]\nwho = "me"\n'))
    r = cli("run", path, "--store", tmp_path / "s.db", "--executor", "serial", "--quiet")
    from vectorid.store import Store

    with Store.open(tmp_path / "s.db") as st:
        kept = st.spec.extra.get("x-notes") == {"who": "me"}
    expect(KIND, r.code == 0 and kept, r.err, r)


def test_new_store_in_a_read_only_folder(tmp_path):
    import os

    write(tmp_path / "usermodel.py", textwrap.dedent(USER_MODEL))
    path = write(tmp_path / "s.toml", BASE)
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("running as a user that ignores permissions")
        r = cli("run", path, "--store", ro / "s.db", "--executor", "serial", "--quiet")
        expect_error(KIND, r, "cannot create store.*writable folder")
    finally:
        ro.chmod(0o755)


def test_new_store_under_a_file(tmp_path):
    write(tmp_path / "usermodel.py", textwrap.dedent(USER_MODEL))
    path = write(tmp_path / "s.toml", BASE)
    r = cli("run", path, "--store", path / "s.db", "--executor", "serial", "--quiet")
    expect_error(KIND, r, "cannot create store")
