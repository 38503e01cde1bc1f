"""Leave-one-out over the ETH parafoil's flights: the table of docs/identification.md.

For each flight K asked, runs ``examples/eth_parafoil.py DATA --predict K --json`` (identify
from the other three flights, then predict flight K with ``vectorid predict``; its wind is not
known in advance, so each member flies its own fitted wind of one of the other flights, drawn at
random), keeps the JSON document and the log in ``--out``, and prints one Markdown table row per
flight: the set the members come from (D, or the stated limits relaxed where the sampler did not
reach D: named so), the share of the measured positions inside the credible and the with-noise
90 % bands, the median's RMS error, the end-of-window miss against the with-noise R95, and the
verdict. Run from the repository root (the defaults take minutes a flight on 2 cores)::

    .venv/bin/python scripts/eth_loo.py ../shared/data/eth-parafoil --trials 4096 --budget 50000

``--table-only`` rebuilds the table from the JSON documents already in ``--out``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "eth_parafoil.py"


def run_one(data: Path, k: int, args: argparse.Namespace) -> tuple[dict, float]:
    """Run the example's ``--predict K``; returns its JSON document and the wall time, s."""
    out = Path(args.out)
    cmd = [
        sys.executable, str(EXAMPLE), str(data), "--predict", str(k), "--json",
        "--trials", str(args.trials), "--budget", str(args.budget),
        "--members", str(args.members), "--out", str(out),
    ]  # fmt: skip
    t0 = time.perf_counter()
    with open(out / f"flight{k}.log", "w", encoding="utf-8") as log:
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=log, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(
            f"error: flight {k}: the example exited {proc.returncode}; see {out}/flight{k}.log"
        )
    (out / f"flight{k}.json").write_text(proc.stdout, encoding="utf-8")
    return json.loads(proc.stdout), wall


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.0f} %"


def row(k: int, doc: dict) -> str:
    """One Markdown table row of flight ``k``'s prediction."""
    d = doc["drops"][0]
    s = doc["set"]
    pos = next(c for c in d["channels"] if c["name"] == "position")
    rms = "-" if pos["median_rms"] is None else f"{pos['median_rms']:.1f} {pos['unit']}"
    what = "D" if s["is_d"] else s["set"].split(" (")[0].replace("the set under the ", "")
    land = d["landing"]
    if land is None or land["measured_ne_m"] is None:
        miss = "-"
    else:
        dn = land["measured_ne_m"][0] - land["centre_ne_m"][0]
        de = land["measured_ne_m"][1] - land["centre_ne_m"][1]
        r95 = land["r95_with_noise_m"] if land["r95_with_noise_m"] is not None else land["r95_m"]
        inside = "inside" if land["measured_inside_r95"] else "**outside**"
        miss = f"{(dn**2 + de**2) ** 0.5:.1f} m vs {r95:.1f} m: {inside}"
    verdict = {True: "within", False: "**not within**", None: "not judged"}[d["within"]]
    return (
        f"| flight{k} ({d['duration_s']:.1f} s) | {s['flown']} of {s['of']} ({what}) | "
        f"{_pct(pos['coverage_credible'])} | "
        f"{_pct(pos['coverage_with_noise'])} | {rms} | {miss} | {verdict} |"
    )


HEAD = (
    "| held out | distinct members flown (of the set's) | position values in the credible band | "
    "in the with-noise band | median's RMS error | end point from the centre vs with-noise R95 "
    "| verdict |\n"
    "|---|---|---|---|---|---|---|"
)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", help="the eth-parafoil folder")
    ap.add_argument("--flights", type=int, nargs="+", default=[1, 2, 3, 4], choices=(1, 2, 3, 4))
    ap.add_argument("--trials", type=int, default=4096, help="the example's --trials (4096)")
    ap.add_argument("--budget", type=int, default=50_000, help="the example's --budget (50000)")
    ap.add_argument("--members", type=int, default=400, help="members flown (400)")
    ap.add_argument("--out", default="eth-loo", help="folder of the stores, JSON and logs")
    ap.add_argument(
        "--table-only", action="store_true", help="rebuild the table from the JSON in --out"
    )
    args = ap.parse_args()
    data = Path(args.data)
    if not args.table_only and not (data / "flight1_states.csv").exists():
        print(
            f"error: {data} holds no flight1_states.csv; fetch the ETH flights with "
            "`python scripts/fetch_data.py eth-parafoil`, or pass the folder that holds them",
            file=sys.stderr,
        )
        return 2
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for k in args.flights:
        if args.table_only:
            path = out / f"flight{k}.json"
            if not path.exists():
                print(f"error: --table-only: {path} does not exist; run without --table-only",
                      file=sys.stderr)  # fmt: skip
                return 2
            doc = json.loads(path.read_text(encoding="utf-8"))
        else:
            doc, wall = run_one(data, k, args)
            print(f"flight {k}: {wall:.0f} s", file=sys.stderr, flush=True)
        rows.append(row(k, doc))
    print(HEAD)
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
