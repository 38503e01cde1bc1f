"""Figures of predictions: bands named for what they are, the landing scatter with its circles
and labelled ellipses, the page and the report section."""

from __future__ import annotations

import pytest

from tests.workflows.predict_helpers import drop_file, kinematic_store, planned
from vectorid.store import Store
from vectorid.views.predict import band_figure, landing_figure, write_prediction
from vectorid.views.report import build_report
from vectorid.workflows.predict import predict


@pytest.fixture(scope="module")
def prediction(tmp_path_factory):
    folder = tmp_path_factory.mktemp("kin")
    store = kinematic_store(folder, trials=512)
    f = drop_file(folder / "p.toml", [planned(noise={"position_h": 5.0})])
    return store, predict(store, f, members=80, seed=2)


def test_band_figure_names_the_credible_band_and_the_with_noise_band(prediction):
    _, p = prediction
    d = p.drops[0]
    fig = band_figure(d, d.channel("position"))
    names = {tr.name for tr in fig.data if tr.name}
    assert "credible band 5-95 % (D's spread)" in names
    assert "with-noise band 5-95 % (a measured sample)" in names
    assert "median of the members" in names
    assert all("prediction interval" not in n for n in names)
    assert "[m]" in fig.layout.title.text


def test_landing_figure_circles_and_ellipses_say_what_they_hold(prediction):
    _, p = prediction
    d = p.drops[0]
    fig = landing_figure(d)
    names = [tr.name for tr in fig.data]
    for key, share in (("R50", 50), ("R90", 90), ("R95", 95)):
        assert any(n.startswith(key) and f"holds {share} % of the points" in n for n in names)
    ell = [n for n in names if "ellipse" in n]
    assert len(ell) == 3 and all("holds" in n and "a normal's" in n for n in ell)
    assert fig.layout.xaxis.title.text == "east of the origin [m]"


def test_page_and_report_section(prediction, tmp_path):
    store, p = prediction
    files = write_prediction(p, tmp_path / "out")
    assert [f.name for f in files] == ["prediction.json", "prediction.html"]
    with Store.open(store) as st:
        doc, page = build_report(st, prediction=p, max_points=200)
    assert "Predictions" in doc and "not a prediction interval" in doc
    assert any("landing dispersion" in t for t in page.figures)
