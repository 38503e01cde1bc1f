"""Wind profiles: Wyoming soundings, dropsonde CSV, seeded wind uncertainty."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from vectorid.identify import FlightDataError, WindUncertainty, load_dropsonde_csv, load_wyoming
from vectorid.models import WindProfile

DATA = Path(__file__).parents[2] / ".." / "shared" / "data"
SOUNDING = DATA / "soundings" / "may4_sounding.txt"
KN = 1852 / 3600


@pytest.mark.skipif(not SOUNDING.exists(), reason=f"real sounding not found at {SOUNDING}")
def test_real_wyoming_sounding():
    w = load_wyoming(SOUNDING)
    # "959.0 345 ... DRCT 160 SKNT 18": the 1000 hPa level (-7 m) has no wind and is skipped
    assert w.altitude[0] == 345.0
    speed, direction = w.speed_direction(np.array([345.0, 1397.0, 10049.0]))
    assert speed == pytest.approx([18 * KN, 38 * KN, 73 * KN])
    assert direction == pytest.approx([160.0, 195.0, 245.0])
    # FROM 160 deg: the air moves towards north-north-west
    assert w.north[0] == pytest.approx(-18 * KN * math.cos(math.radians(160)))
    assert w.east[0] == pytest.approx(-18 * KN * math.sin(math.radians(160)))
    assert w.north[0] > 0 and w.east[0] < 0
    # the repeated levels at the end of the file are merged; heights strictly increase
    assert w.altitude.size == 30 and w.altitude[-1] == 10058.0
    assert np.all(np.diff(w.altitude) > 0)


def test_wyoming_html_and_station_info(tmp_path):
    text = """<HTML><PRE>
-----------------------------------------------------------------------------
   PRES   HGHT   TEMP   DWPT   RELH   MIXR   DRCT   SKNT   THTA   THTE   THTV
    hPa     m      C      C      %    g/kg    deg   knot     K      K      K
-----------------------------------------------------------------------------
 1000.0    100   20.0   10.0     50   7.00    270     10  293.0  313.0  294.0
  900.0   1000   15.0    5.0     50   6.00           20  298.0  315.0  299.0
  850.0   1500   12.0    2.0     50   5.00     90     20  300.0  316.0  301.0
</PRE><H3>Station information and sounding indices</H3><PRE>
                         Station number: 72357
</PRE>"""
    path = tmp_path / "s.html"
    path.write_text(text)
    w = load_wyoming(path)
    assert w.altitude == pytest.approx([100.0, 1500.0])  # level without direction skipped
    assert w.east == pytest.approx([10 * KN, -20 * KN])  # from 270: towards east
    bad = tmp_path / "bad.txt"
    bad.write_text("altitude,speed\n1,2\n")
    with pytest.raises(FlightDataError, match="not a University of Wyoming sounding"):
        load_wyoming(bad)


def test_dropsonde_speed_direction_and_uv(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("alt_ft,spd,dir\n0,10,0\n1000,20,90\n2000,NaN,90\n")
    w = load_dropsonde_csv(
        p,
        altitude="alt_ft",
        speed="spd",
        direction="dir",
        altitude_unit="ft",
        speed_unit="knot",
        altitude_offset=1200.0,
    )
    assert w.altitude == pytest.approx([1200.0, 1200.0 + 304.8])
    assert w.north == pytest.approx([-10 * KN, 0.0], abs=1e-12)
    assert w.east == pytest.approx([0.0, -20 * KN], abs=1e-12)
    q = tmp_path / "uv.csv"
    q.write_text("z;u;v\n500;3;-4\n100;1;2\n")
    w = load_dropsonde_csv(q, altitude="z", u="u", v="v")
    assert w.altitude == pytest.approx([100.0, 500.0])  # sorted
    assert w.east == pytest.approx([1.0, 3.0]) and w.north == pytest.approx([2.0, -4.0])


def test_dropsonde_bad_input(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("altitude,speed,direction\n0,250,10\n1000,260,20\n")
    with pytest.raises(FlightDataError, match="implausible.*knots"):
        load_dropsonde_csv(p)
    p.write_text("altitude,speed,direction\n" + "".join(
        f"{100 * k},{5 + k},{0.5 * k}\n" for k in range(8)))  # fmt: skip
    with pytest.raises(FlightDataError, match="radians given as degrees"):
        load_dropsonde_csv(p)
    assert load_dropsonde_csv(p, direction_unit="rad").altitude.size == 8
    p.write_text("altitude,speed,direction\n0,5,400\n")
    with pytest.raises(FlightDataError, match=r"\[0, 360\]"):
        load_dropsonde_csv(p)
    p.write_text("height,speed,direction\n0,5,40\n")
    with pytest.raises(FlightDataError, match="column 'altitude'.*height"):
        load_dropsonde_csv(p)
    with pytest.raises(FlightDataError, match="both u"):
        load_dropsonde_csv(p, altitude="height", u="speed")


def test_uncertainty_reproducible_from_seed():
    prof = WindProfile.from_speed_direction([0.0, 3000.0], [5.0, 15.0], [270.0, 300.0])
    wu = WindUncertainty(1.5, 10.0, 300.0, seed=7)
    a = wu.realisations(prof, 5)
    b = WindUncertainty(1.5, 10.0, 300.0, seed=7).realisations(prof, 3)
    c = WindUncertainty(1.5, 10.0, 300.0, seed=8).realisations(prof, 1)
    assert len(a) == 5 and all(isinstance(r, WindProfile) for r in a)
    for r, s in zip(a[:3], b):  # the first k do not depend on m
        assert np.array_equal(r.north, s.north) and np.array_equal(r.east, s.east)
    assert not np.allclose(a[0].north, c[0].north)
    assert not np.allclose(a[0].north, a[1].north)
    # spacing L/4 over the profile's range, plus its levels
    assert a[0].altitude[0] == 0.0 and a[0].altitude[-1] == 3000.0
    assert np.max(np.diff(a[0].altitude)) <= 75.0 + 1e-9


def test_uncertainty_statistics():
    prof = WindProfile.constant(north=0.0, east=10.0)  # 10 m/s from 270 deg at every altitude
    L = 200.0
    wu = WindUncertainty(2.0, 8.0, L, seed=3, altitude_range=(0.0, 4000.0))
    rs = wu.realisations(prof, 300)
    h = rs[0].altitude
    step = h[1] - h[0]
    assert step == pytest.approx(L / 4)
    sd = np.array([r.speed_direction(h) for r in rs])  # (M, 2, K)
    ds = sd[:, 0] - 10.0
    dd = (sd[:, 1] - 270.0 + 180.0) % 360.0 - 180.0
    assert abs(ds.mean()) < 0.1 and ds.std() == pytest.approx(2.0, rel=0.05)
    assert abs(dd.mean()) < 0.5 and dd.std() == pytest.approx(8.0, rel=0.05)
    lag = round(L / step)
    corr = np.mean(ds[:, :-lag] * ds[:, lag:]) / ds.var()
    assert corr == pytest.approx(math.exp(-1), abs=0.06)
    corr_sd = np.mean(ds * dd) / (ds.std() * dd.std())
    assert abs(corr_sd) < 0.05  # speed and direction independent


def test_uncertainty_bad_parameters():
    with pytest.raises(FlightDataError, match="correlation_length_m"):
        WindUncertainty(1.0, 5.0, 0.0, seed=1)
    with pytest.raises(FlightDataError, match="sigma_speed"):
        WindUncertainty(-1.0, 5.0, 100.0, seed=1)
    with pytest.raises(FlightDataError, match="seed"):
        WindUncertainty(1.0, 5.0, 100.0, seed=None)  # type: ignore[arg-type]
    with pytest.raises(FlightDataError, match="m must be"):
        WindUncertainty(1.0, 5.0, 100.0, seed=1).realisations(WindProfile.constant(), 0)
