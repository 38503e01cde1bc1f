"""The worth of a planned drop against flying it (issue 34, item 3): ``scripts/design_twins.py``
on 10 parachute6dof twins, three plans for a second drop (GPS alone, IMU without the GPS
position, 20 s of every sensor), each flown with the truth and identified again with both
drops. Where flying tells two plans apart, the estimate must order them as flying did in at
least 80 % of those twins (and of the pairs of sound plans it tells apart), and flying must
tell some apart; a plan the estimate says would reject the truth must empty D when flown more
often than not, and no plan it calls sound may."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "design_twins.py"


def _script():
    spec = importlib.util.spec_from_file_location("design_twins", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.long
@pytest.mark.slow
def test_the_estimate_ranks_plans_as_flying_them_does(tmp_path):
    """About 5 minutes on 2 cores (ten twins, four studies of 2,048 trials each)."""
    mod = _script()
    lines = []
    s = mod.summary(mod.run(10, tmp_path, out=lines.append))
    text = "\n".join(lines)
    assert s["apart"] >= 3, text
    assert s["agree"] >= 0.8 * s["apart"], text
    # the ranking among sound plans (both keep the truth), not only against a broken one
    assert s["sound_pairs_apart"] >= 2, text
    assert s["sound_pairs_agree"] >= 0.8 * s["sound_pairs_apart"], text
    # a plan said to reject the truth empties D when flown more often than not; a sound one never
    if s["rejects"]:
        assert s["rejects_emptied"] >= 0.5 * s["rejects"], text
    assert s["sound_emptied"] == 0, text
