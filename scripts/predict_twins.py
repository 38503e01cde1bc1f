"""Predictive checks over many twins: the figures of docs/predict.md ("Twins").

Run from the repository root (a few minutes; about 7 s a twin on a 2-core machine)::

    .venv/bin/python scripts/predict_twins.py --twins 50

Each twin is the slow test's (``tests/workflows/test_predict_twins.py``): the parachute6dof
model at a random truth with its generated noise, identified on one drop (3 parameters free on
a plain Sobol table, or all 15 on the sequential sampler), then its second drop (another
altitude, heading and wind) predicted with ``vectorid.workflows.predict.predict``. Printed per
kind: how many twins' with-noise 90 % band holds at least 85 % of the second drop's measured
positions, and the quantiles of that share and of the credible band's.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the twins are the test suite's

from tests.workflows.test_predict_twins import ALL, THREE, twin  # noqa: E402

from vectorid.study import Study  # noqa: E402
from vectorid.workflows.predict import EmptySetError, predict  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--twins", type=int, default=50, help="twins of each kind (50)")
    ap.add_argument("--first", type=int, default=100, help="seed index of the first twin (100)")
    args = ap.parse_args()
    for label, variables in (("3 free", THREE), ("15 free", ALL)):
        t0 = time.perf_counter()
        noisy, cred, members, empty = [], [], [], 0
        with tempfile.TemporaryDirectory() as tmp:
            for i in range(args.first, args.first + args.twins):
                folder = Path(tmp) / f"t{i}"
                spec, _, second = twin(folder, i, variables)
                with Study.create(spec, folder / "s.db") as st:
                    st.run(executor="inline", progress=False)
                try:
                    p = predict(folder / "s.db", second, members=400, seed=i)
                except EmptySetError:
                    empty += 1
                    continue
                pos = p.drops[0].channel("position")
                noisy.append(pos.coverage_with_noise)
                cred.append(pos.coverage_credible)
                members.append(p.members.n_set)
        noisy_a, cred_a = np.array(noisy), np.array(cred)
        q = [0.05, 0.5, 0.95]
        print(
            f"{label}: {args.twins} twins ({time.perf_counter() - t0:.0f} s; D empty in {empty}); "
            "with-noise band "
            f">= 85 % of the positions in {int(np.sum(noisy_a >= 0.85))}; its share of the "
            f"positions 5/50/95 %: {np.round(np.quantile(noisy_a, q), 3).tolist()}; the credible "
            f"band's: {np.round(np.quantile(cred_a, q), 3).tolist()}; members of D "
            f"{int(np.min(members))}-{int(np.max(members))}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
