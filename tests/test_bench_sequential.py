"""benchmarks/sequential.py --quick: Sobol, the sequential sampler and the anchors (UltraNest,
subset simulation; dynesty and pyABC in the slow test) on the three-parameter parachute twin,
each until D at the stated limits holds 50 members, with the KS check against a plain-Sobol
reference sample of D."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import sequential  # noqa: E402  (benchmarks/ is not a package)

PACKAGES = {
    "pyabc": ("pyabc", "pyABC"),
    "dynesty": ("dynesty", "dynesty"),
    "ultranest": ("ultranest", "UltraNest"),
    "subset": ("openturns", "OpenTURNS"),
}


def _rows(out: str) -> dict[str, list[str]]:
    return {
        line.split("|")[2].strip(): [c.strip() for c in line.split("|")[1:-1]]
        for line in out.splitlines()
        if line.startswith("| parachute3 |")
    }


def _check_optional(rows: dict[str, list[str]], out: str, method: str) -> None:
    """An anchor either ran (evaluations, and a KS verdict where it reached D) or is named as
    not installed."""
    module, words = PACKAGES[method]
    if importlib.util.find_spec(module) is None:
        assert f"skipped: {words} not installed" in out, out
        return
    _, _, evals, _, _, _, members, _, ks, _, _ = rows[method]
    assert int(evals.split()[0].replace(",", "")) > 0, out
    if int(members) > 0:
        assert ks.startswith(("passes", "fails")), out


def test_quick_run_reaches_d_and_checks_faithfulness(tmp_path, capsys):
    methods = "sobol,sequential,ultranest,subset"
    code = sequential.main(["--quick", "--methods", methods, "--keep", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    assert out.splitlines()[0].startswith("CPU: ")
    rows = _rows(out)
    assert set(rows) == set(methods.split(","))
    for method in ("sobol", "sequential"):
        _, _, evals, first, wall, cpu, members, ess, ks, faithful, inside = rows[method]
        assert "not reached" not in evals, out
        # D first held the population's distinct members no later than the run stopped
        assert int(first.replace(",", "")) <= int(evals.replace(",", "")), out
        assert int(members) >= 50 and float(ess) >= 45
        assert inside == "yes", out  # the truth meets the limits: inside every range of D
        # Sobol points are uniform on D by construction; the sequential sampler's weighted
        # members must be too
        assert ks.startswith("passes"), out
        assert faithful == evals, out
    for method in ("ultranest", "subset"):
        _check_optional(rows, out, method)

    # the KS check can fail: half of D (below the reference's median of x6) is not D
    ref = np.load(tmp_path / "parachute3" / "reference.npz")["X"]
    assert len(ref) >= 500
    names = ["x6", "x8", "x11"]
    half = ref[ref[:, 0] < np.median(ref[:, 0])][:200]
    o = sequential.Outcome("half", len(half), 0.0, len(half), float(len(half)), None, True,
                           X=half)  # fmt: skip
    sequential.ks_check(o, sequential.Reference(ref, 0, "the whole box"), names)
    assert "x6" in o.ks_fails
    sequential.faithful_at(o, 50, checked=True)
    assert o.faithful_at is None and o.why.startswith("KS fails: x6")
    assert sequential.main(["--methods", "nope"]) == 2
    assert sequential.main(["--first", "0"]) == 2


@pytest.mark.slow
def test_quick_run_one_vector_at_a_time_samplers(tmp_path, capsys):
    """pyABC and dynesty call the model one vector at a time (seconds even on parachute3)."""
    code = sequential.main(["--quick", "--methods", "pyabc,dynesty", "--pyabc-budget", "400",
                            "--keep", str(tmp_path)])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0
    rows = _rows(out)
    assert set(rows) == {"pyabc", "dynesty"}
    for method in rows:
        _check_optional(rows, out, method)
