"""Print the fuzz tally (cases per input kind and outcome) at the end of the session."""

from __future__ import annotations

from ._harness import TALLY


def pytest_terminal_summary(terminalreporter) -> None:  # pragma: no cover - reporting
    if not TALLY:
        return
    tr = terminalreporter
    tr.section("fuzz cases per input kind")
    tr.write_line(f"{'kind':<16}{'cases':>7}{'clear':>8}{'tracebacks':>12}{'silent':>8}")
    total = {"cases": 0, "clear": 0, "traceback": 0, "silent": 0}
    for kind in sorted(TALLY):
        c = TALLY[kind]
        n = sum(c.values())
        total["cases"] += n
        for k in ("clear", "traceback", "silent"):
            total[k] += c[k]
        tr.write_line(f"{kind:<16}{n:>7}{c['clear']:>8}{c['traceback']:>12}{c['silent']:>8}")
    tr.write_line(
        f"{'all':<16}{total['cases']:>7}{total['clear']:>8}{total['traceback']:>12}"
        f"{total['silent']:>8}"
    )
