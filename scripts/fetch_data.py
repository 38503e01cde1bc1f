"""Fetch the real flight data the examples read, from their public sources, and convert it.

Usage (from the clone)::

    .venv/bin/python scripts/fetch_data.py                    # every data set, into ../shared/data
    .venv/bin/python scripts/fetch_data.py eth-parafoil       # one of them
    .venv/bin/python scripts/fetch_data.py --list             # what each is, where it comes from
    .venv/bin/python scripts/fetch_data.py ssi-parafoil --dest DIR
    .venv/bin/python scripts/fetch_data.py eth-parafoil --from DIR   # files downloaded already

The examples that need real data (``examples/eth_parafoil.py``, ``examples/ssi_parafoil.py``,
``examples/real_descent.py``, ``examples/telemega_drogue.py``, ``examples/descent_gallery.py``)
read it from ``../shared/data/`` beside the clone by default, the folder this script writes.
Every file is downloaded from the source repository at a fixed commit and checked against its
git blob id (the id ``git hash-object`` gives, the one the source repository lists), so a file
that changed upstream or arrived damaged is refused, never used. Then the two parafoil data
sets are converted to the CSV files the examples read: the ETH MATLAB files to
``flightN_states.csv`` and ``flightN_inputs.csv`` (needs scipy, a dependency of vectorid), the
Stanford workbook to ``parafoildata_clean.csv`` (needs pandas: ``.venv/bin/pip install -e
'.[pandas]'``), value for value as the data READMEs describe.

None of these files ships with vectorid: the ETH repository states no licence (all rights stay
with its authors), the Stanford data file comes with none (the avionics code beside it is GPL),
and RocketPy's flights (MIT) are the teams' logs; vectorid's own demos and tests run on data its
seeded scripts generate (``scripts/make_demo_data.py``, ``scripts/make_parafoil_demo_data.py``).
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import re
import sys
import urllib.error
import urllib.request
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Where the examples and the acceptance tests look for the data: ``../shared/data``.
DEFAULT_DEST = ROOT.parent / "shared" / "data"
RAW = "https://raw.githubusercontent.com/{repo}/{commit}/{path}"
ETH = ("yuliangzhong/6dof_parafoil_simulation", "5ae0a764b94b12ae26040170ce50a2435e1443aa")
SSI = ("stanford-ssi/balloons-Parafoil", "7611732d7d8f033664273d28646a891952349365")
ROCKETPY = ("RocketPy-Team/RocketPy", "d41dd11efcae7234846b199d9d9b5cdcad17b933")
ROCKETPY_DEVELOP = ("RocketPy-Team/RocketPy", "5bdc4a5a3f295118a65c1edcd0e8f963edb38f70")


@dataclass(frozen=True)
class Source:
    """One file: its repository and commit, its path there, where it goes, its git blob id."""

    repo: tuple[str, str]
    path: str
    dest: str
    blob: str

    @property
    def url(self) -> str:
        return RAW.format(repo=self.repo[0], commit=self.repo[1], path=self.path)


@dataclass(frozen=True)
class DataSet:
    name: str
    what: str
    source: str
    licence: str
    examples: tuple[str, ...]
    files: tuple[Source, ...]
    made: tuple[str, ...] = field(default_factory=tuple)  # files the conversion writes


def _eth(n: int, kind: str, blob: str) -> Source:
    return Source(ETH, f"experiments/const_ref/{kind}{n}.mat", f"{kind}{n}.mat", blob)


def _rp(path: str, blob: str, repo: tuple[str, str] = ROCKETPY, dest: str = "") -> Source:
    return Source(repo, f"data/rockets/{path}", dest or path, blob)


DATASETS: dict[str, DataSet] = {
    d.name: d
    for d in (
        DataSet(
            "eth-parafoil",
            "four constant-heading flight tests of a 1.2-kg steerable parafoil (ETH Zürich "
            "student project, 2022): GNSS position and course at 2.5 Hz, brake command at 100 Hz",
            "github.com/yuliangzhong/6dof_parafoil_simulation, branch feature/paper, commit "
            "5ae0a764, experiments/const_ref/{states,inputs}1-4.mat",
            "none stated (so vectorid cannot ship it)",
            ("examples/eth_parafoil.py",),
            (
                _eth(1, "states", "01d76c230b7c6a5b1b3fb3b06a3204f49e7ba15e"),
                _eth(2, "states", "78e31f73393d843511e9240d2d6bd83d842838b1"),
                _eth(3, "states", "cc9aaad6b832a1957a5184e4748f0689befc15d2"),
                _eth(4, "states", "e4535c64baba50fdb35c580635573f8aa7525f5f"),
                _eth(1, "inputs", "df111b75ce7d957c1ef6f46375d003211cd225f5"),
                _eth(2, "inputs", "db5d830c23aefe65fc399169324d612eec711e50"),
                _eth(3, "inputs", "2d81405f74fba7a7e000bc65728023b208940f33"),
                _eth(4, "inputs", "fc1d6d876a9c7ee8280a2da2e0fe2af85c355449"),
            ),
            tuple(f"flight{n}_{k}.csv" for n in (1, 2, 3, 4) for k in ("states", "inputs")),
        ),
        DataSet(
            "ssi-parafoil",
            "a parafoil payload's avionics log with two real drops (Stanford Student Space "
            "Initiative, 2018-05-19): barometric altitude at 14 Hz, GPS track",
            "github.com/stanford-ssi/balloons-Parafoil, commit 7611732d, parafoildata.xlsx",
            "none stated for the data (the avionics code is GPL-3), so vectorid cannot ship it",
            ("examples/ssi_parafoil.py",),
            (
                Source(
                    SSI,
                    "parafoildata.xlsx",
                    "parafoildata.xlsx",
                    "8503c70cb9b824d1a2f569d4e716b817f58b74fe",
                ),
            ),
            ("parafoildata_clean.csv",),
        ),
        DataSet(
            "prometheus-2022",
            "the TeleMega log of the Prometheus rocket's flight, Spaceport America, 2022-06-24: "
            "barometric altitude, IMU, GPS, flight states, a two-parachute descent",
            "github.com/RocketPy-Team/RocketPy, commit d41dd11e, data/rockets/prometheus/",
            "MIT (RocketPy); the flight's owner gave permission to use the data",
            (
                "examples/real_descent.py",
                "examples/telemega_drogue.py",
                "examples/descent_gallery.py",
            ),
            (
                _rp(
                    "prometheus/2022-06-24-serial-6583-flight-0003-TeleMega.csv",
                    "c10423dd7351c78b80d7bc6cd777145a09877789",
                    dest="2022-06-24-serial-6583-flight-0003-TeleMega.csv",
                ),
            ),
        ),
        DataSet(
            "rocketpy-descents",
            "logs of nine student and amateur rockets' parachute descents (EuRoC, Spaceport "
            "America Cup, 2020-2025)",
            "github.com/RocketPy-Team/RocketPy, commit d41dd11e (valkyrie: 5bdc4a5a, branch "
            "develop), data/rockets/",
            "MIT (RocketPy); each team's permission is quoted in RocketPy's notebooks",
            ("examples/descent_gallery.py",),
            (
                _rp(
                    "EPFL_Bella_Lui/bella_lui_flight_data_filtered.csv",
                    "1735b7c751720652d9ed2a55a8f62ba4dd29ca9a",
                ),
                _rp(
                    "NDRT_2020/ndrt_2020_flight_data.csv",
                    "724494c350afebb3a2a50b8aff32741aa318eebb",
                ),
                _rp("andromeda/flight_data.csv", "6cea3492dc9e0350b37a832791ff44337d82a698"),
                _rp("camoes/flight_data.csv", "6c9da4cfcbe5b069d2007aa1f382acce65a25c91"),
                _rp("camoes/gnss_flight.csv", "36e56df7512bacd16ed1812c8156532cb9f47f19"),
                _rp("genesis/flight_data_faraday.csv", "2f58a11d4bb92f21632cac638c0eaa394caebc54"),
                _rp("genesis/gnss_faraday.csv", "1dfff4ff5f50bed7da0e3a01b78d338c87c95134"),
                _rp("hedy/cats_tust/baro.csv", "721a3cf66d4fb80149f34c277046640c9b2abd63"),
                _rp(
                    "hedy/cats_tust/filteredDataInfo.csv",
                    "992be3d14cbf2bd358c3ded370dd68b021cfb190",
                ),
                _rp("hedy/cats_tust/flightInfo.csv", "edcb4f48bbe79ad4216a585ab29f042fc69ed150"),
                _rp("hedy/cats_tust/gnssInfo.csv", "447ab61af49e12bfa886f9b9678001e30938b942"),
                _rp("hedy/cats_tust/imu.csv", "ef74347ea0c57f492c007e1b92251b2602d2e21b"),
                _rp("juno3/README.txt", "3d583c08eacf8b7d222c26d2c51a53e804e89cae"),
                _rp("juno3/cots_GNSS.csv", "5294c56cc02662f905bebd9977b3ba95e471f918"),
                _rp("juno3/cots_altimeter.csv", "d2d83a55a5534947f4272594eb2a6e0cc5584c29"),
                _rp("lince/main_data.csv", "428311c44c1623fddd06d45f48e51d3e15932e0d"),
                _rp(
                    "valkyrie/flightInfo_merged.csv",
                    "521103f73c3b9bfae3c612dc66a1a227fdc8ca87",
                    ROCKETPY_DEVELOP,
                ),
                _rp(
                    "valkyrie/VLK.json",
                    "92318f469dad980f7462cd860e43aac641e12c52",
                    ROCKETPY_DEVELOP,
                ),
                _rp(
                    "valkyrie/Dima.json",
                    "048ba3c74f950e86ad5f66906da87366bb06f72e",
                    ROCKETPY_DEVELOP,
                ),
            ),
        ),
    )
}


def git_blob_id(data: bytes) -> str:
    """The git blob id of ``data`` (what ``git hash-object`` prints)."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


class FetchError(Exception):
    """A file could not be fetched, or is not the one the source lists."""


def _download(url: str, timeout: float = 60.0) -> bytes:
    try:
        with urllib.request.urlopen(url, timeout=timeout) as resp:
            return resp.read()
    except (urllib.error.URLError, OSError) as exc:
        raise FetchError(f"cannot download {url}: {exc}") from None


def fetch(ds: DataSet, dest: Path, source: Path | None = None) -> list[Path]:
    """Put every file of ``ds`` into ``dest/<name>/``, checked against its blob id, from the
    network or (``source``) from files downloaded already (``source/<name>/<file>`` or
    ``source/<file>``). Files already in place with the right id are kept."""
    folder = dest / ds.name
    out = []
    for f in ds.files:
        target = folder / f.dest
        if target.is_file() and git_blob_id(target.read_bytes()) == f.blob:
            out.append(target)
            continue
        if source is not None:
            found = [p for p in (source / ds.name / f.dest, source / f.dest) if p.is_file()]
            if not found:
                raise FetchError(f"{f.dest} is not in {source} (nor in {source / ds.name})")
            data = found[0].read_bytes()
            where = str(found[0])
        else:
            data = _download(f.url)
            where = f.url
        got = git_blob_id(data)
        if got != f.blob:
            raise FetchError(
                f"{where} is not the file the source lists (git blob {got}, expected {f.blob}); "
                "nothing was written for it"
            )
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_name(target.name + ".part")
        tmp.write_bytes(data)
        tmp.replace(target)
        out.append(target)
    return out


# -- conversions ----------------------------------------------------------------------------

ETH_STATE_COLS = ["t_s", "x_north_m", "y_east_m", "z_down_m", "heading_deg", "heading_rate_deg_s"]
ETH_INPUT_COLS = ["t_s", "delta_a"]


def _write_csv(path: Path, header: list[str], rows) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for r in rows:
            w.writerow([repr(float(v)) for v in r])


def convert_eth(folder: Path) -> list[Path]:
    """``statesN.mat`` / ``inputsN.mat`` (6 x n and 2 x n matrices) to ``flightN_states.csv``
    (t_s, x_north_m, y_east_m, z_down_m, heading_deg, heading_rate_deg_s) and
    ``flightN_inputs.csv`` (t_s, delta_a), values unchanged (the data README gives the rows'
    meanings and the evidence)."""
    from scipy.io import loadmat

    out = []
    for n in (1, 2, 3, 4):
        s = loadmat(folder / f"states{n}.mat")["states"]
        u = loadmat(folder / f"inputs{n}.mat")["inputs"]
        if s.shape[0] != 6 or u.shape[0] != 2:
            raise FetchError(
                f"flight {n}: states {s.shape}, inputs {u.shape}; expected 6 x n, 2 x n"
            )
        _write_csv(folder / f"flight{n}_states.csv", ETH_STATE_COLS, s.T)
        _write_csv(folder / f"flight{n}_inputs.csv", ETH_INPUT_COLS, u.T)
        out += [folder / f"flight{n}_states.csv", folder / f"flight{n}_inputs.csv"]
    return out


def _sheet_rows(path: Path) -> list[list[object]]:
    """The first worksheet of an .xlsx as rows of 13 cells (A..M): numbers as floats, text as
    str, empty cells None (read straight from the workbook's XML)."""
    local = lambda tag: tag.rsplit("}", 1)[-1]  # noqa: E731
    with zipfile.ZipFile(path) as z:
        strings = []
        if "xl/sharedStrings.xml" in z.namelist():
            for si in ET.fromstring(z.read("xl/sharedStrings.xml")):
                strings.append("".join(t.text or "" for t in si.iter() if local(t.tag) == "t"))
        sheet = sorted(n for n in z.namelist() if n.startswith("xl/worksheets/sheet"))[0]
        root = ET.fromstring(z.read(sheet))
    rows: dict[int, list[object]] = {}
    for el in root.iter():
        if local(el.tag) != "c":
            continue
        col, row = re.match(r"([A-Z]+)(\d+)", el.get("r", "")).groups()
        j = ord(col) - ord("A") if len(col) == 1 else 99
        if j >= 13:
            continue
        v = next((c.text for c in el if local(c.tag) == "v"), None)
        kind = el.get("t")
        if kind == "inlineStr":
            v = "".join(t.text or "" for t in el.iter() if local(t.tag) == "t")
        elif v is not None and kind == "s":
            v = strings[int(v)]
        elif v is not None and kind not in ("str", "e"):
            v = float(v)
        rows.setdefault(int(row), [None] * 13)[j] = v
    return [rows[r] for r in sorted(rows)]


SSI_HEADER = (
    "Time(ms),",
    "Pressure(Pa),",
    "Alt(m),",
    "AscentRate(m/s),",
    "TempIn(C),",
    "OrientationX(deg),",
    "y(deg)",
    ",",
    "z(deg),",
    "GPSLat,",
    "GPSLong,",
    "GPSSats,",
    "RBSigalQuality",
)
#: Data columns A..K named from the firmware that wrote them (the header row does not match
#: the data; the data README gives the evidence).
SSI_NAMES = {
    "A": "time_ms",
    "B": "temp_in_C",
    "C": "alt_m",
    "D": "pressure_Pa",
    "E": "ascent_rate_mps",
    "F": "orient_x_deg",
    "G": "orient_y_deg",
    "H": "orient_z_deg",
    "I": "lat_deg",
    "J": "lon_deg",
    "K": "sats_placeholder",
}
SSI_COLUMNS = [
    "session",
    "xlsx_row",
    "t_s",
    "time_ms",
    "temp_in_C",
    "pressure_Pa",
    "alt_m",
    "ascent_rate_mps",
    "orient_x_deg",
    "orient_y_deg",
    "orient_z_deg",
    "lat_deg",
    "lon_deg",
    "drop",
]


def convert_ssi(folder: Path) -> list[Path]:
    """``parafoildata.xlsx`` to ``parafoildata_clean.csv``: the data columns named from the
    firmware, the 24 power-on sessions numbered, their repeated header rows and the
    barometer-glitch rows (temperature below -40 °C or pressure outside 90-110 kPa) dropped, a
    GPS fix of (0, 0) written empty, and a ``drop`` column (1, 2; 0 outside the drops): a drop
    starts at the peak of the altitude's 15-sample running median in a climb more than 20 m
    above the session's first 30 s, and ends where that median first comes within 1 m of its
    lowest value after the peak."""
    try:
        import numpy as np
        import pandas as pd
    except ImportError:
        raise FetchError(
            "converting ssi-parafoil needs pandas: .venv/bin/pip install -e '.[pandas]'"
        ) from None
    rows = _sheet_rows(folder / "parafoildata.xlsx")
    if tuple(rows[0]) != SSI_HEADER:
        raise FetchError(f"parafoildata.xlsx: row 1 is {rows[0]}, not the header the README quotes")
    df = pd.DataFrame(rows[1:], columns=list("ABCDEFGHIJKLM"))
    df.insert(0, "xlsx_row", np.arange(2, len(df) + 2))
    is_header = df["A"].isna() & (df["L"] == "GPSSats,")
    df["session"] = is_header.cumsum() + 1
    df = df[~is_header].copy()
    if not (df["K"].astype(float) == 255).all():
        raise FetchError("parafoildata.xlsx: column K is not the firmware's placeholder 255")
    df = df.rename(columns=SSI_NAMES).drop(columns=["sats_placeholder", "L", "M"])
    for c in SSI_NAMES.values():
        if c in df:
            df[c] = df[c].astype(float)
    glitch = (df.temp_in_C < -40) | (df.pressure_Pa < 90000) | (df.pressure_Pa > 110000)
    df = df[~glitch].copy()
    nofix = (df.lat_deg == 0) & (df.lon_deg == 0)
    df.loc[nofix, ["lat_deg", "lon_deg"]] = np.nan
    df.insert(2, "t_s", df.time_ms / 1000.0)
    df["session"] = df["session"].rank(method="dense").astype(int)
    df["drop"] = 0
    k = 0
    for _, g in df.groupby("session"):
        t = g.t_s.to_numpy()
        sm = pd.Series(g.alt_m.to_numpy()).rolling(15, center=True, min_periods=1).median()
        sm = sm.to_numpy()
        ground0 = np.median(sm[t <= t[0] + 30])
        high = sm > ground0 + 20
        if not high.any():
            continue
        edges = np.flatnonzero(np.diff(np.r_[0, high.astype(int), 0]))
        for i0, i1 in zip(edges[::2], edges[1::2]):
            if t[i1 - 1] - t[i0] < 5:
                continue
            ipk = i0 + int(np.argmax(sm[i0:i1]))
            ground1 = np.min(sm[ipk:])
            iend = ipk + int(np.argmax(sm[ipk:] <= ground1 + 1.0))
            k += 1
            df.loc[g.index[ipk : iend + 1], "drop"] = k
    out = folder / "parafoildata_clean.csv"
    df[SSI_COLUMNS].to_csv(out, index=False, float_format="%.10g")
    return [out]


CONVERT = {"eth-parafoil": convert_eth, "ssi-parafoil": convert_ssi}


def describe(ds: DataSet) -> str:
    return (
        f"{ds.name}: {ds.what}.\n  source  {ds.source}\n  licence {ds.licence}\n"
        f"  used by {', '.join(ds.examples)}"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "names", nargs="*", metavar="NAME", help=f"data sets (default: all): {', '.join(DATASETS)}"
    )
    ap.add_argument(
        "--dest",
        type=Path,
        default=DEFAULT_DEST,
        help=f"folder to write into (default: {DEFAULT_DEST})",
    )
    ap.add_argument(
        "--from",
        dest="source",
        type=Path,
        help="take the source files from this folder instead of downloading them",
    )
    ap.add_argument("--list", action="store_true", help="say what each data set is, and stop")
    args = ap.parse_args(argv)
    unknown = [n for n in args.names if n not in DATASETS]
    if unknown:
        print(
            f"error: unknown data set {unknown[0]!r}; known: {', '.join(DATASETS)}", file=sys.stderr
        )
        return 2
    chosen = [DATASETS[n] for n in (args.names or DATASETS)]
    if args.list:
        print("\n".join(describe(d) for d in chosen))
        return 0
    for ds in chosen:
        print(describe(ds))
        try:
            files = fetch(ds, args.dest, args.source)
            made = CONVERT[ds.name](args.dest / ds.name) if ds.name in CONVERT else []
        except FetchError as exc:
            print(f"error: {ds.name}: {exc}", file=sys.stderr)
            return 2
        size = sum(f.stat().st_size for f in files) / 1e6
        print(
            f"  wrote {len(files)} files ({size:.1f} MB) into {args.dest / ds.name}"
            + (f", converted to {', '.join(p.name for p in made)}" if made else "")
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
