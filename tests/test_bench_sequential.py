"""benchmarks/sequential.py --quick: Sobol, the sequential sampler and (if installed) pyABC on
the three-parameter parachute twin, each until D at the stated limits holds 50 members."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import sequential  # noqa: E402  (benchmarks/ is not a package)


def test_quick_run_reaches_d_and_prints_the_cpu_first(tmp_path, capsys):
    code = sequential.main(["--quick", "--methods", "sobol,sequential,pyabc",
                            "--pyabc-budget", "400", "--keep", str(tmp_path)])  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0
    assert out.splitlines()[0].startswith("CPU: ")
    rows = {
        line.split("|")[2].strip(): [c.strip() for c in line.split("|")[1:-1]]
        for line in out.splitlines()
        if line.startswith("| parachute3 |")
    }
    assert set(rows) == {"sobol", "sequential", "pyabc"}
    for method in ("sobol", "sequential"):
        _, _, evals, first, wall, cpu, members, ess, inside = rows[method]
        assert "not reached" not in evals, out
        # D first held the population's distinct members no later than the run stopped
        assert int(first.replace(",", "")) <= int(evals.replace(",", "")), out
        assert int(members) >= 50 and float(ess) >= 45
        assert inside == "yes", out  # the truth meets the limits: inside every range of D
    if importlib.util.find_spec("pyabc") is None:
        assert "skipped: pyABC not installed" in out
    else:
        assert int(rows["pyabc"][2].split()[0].replace(",", "")) > 0
    assert sequential.main(["--methods", "nope"]) == 2
