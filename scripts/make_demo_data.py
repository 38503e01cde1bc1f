"""Generate the embedded data of ``vectorid demo``: an uncontrolled and a controlled G-12 drop.

Run from the repository root (re-runnable; the output is a function of ``SEED`` only)::

    python scripts/make_demo_data.py            # writes src/vectorid/data/demo/

What it does
------------
The "real system" is the ``parachute6dof`` model with the TRUE parameters below, made
deliberately richer than the model the demo identifies, so that the fit is not trivially exact:

- seeded Dryden turbulence (MIL-F-8785C, W20 = 6 m/s; vertical component made zero-mean over
  the record, see ``ZeroMeanUpdraft``) on top of the mean wind: gusts the identified model
  never sees (it gets only the "measured" mean profile);
- a different payload inertia: the container's moments of inertia are 25 % larger than the
  identified model assumes;
- actuator lag: the risers move 0.6 s after the logged command (pneumatic transport delay);
- a measured wind profile that is not the true one: the "dropsonde" file holds the true mean
  profile at 100-m levels plus seeded errors (σ = 0.4 m/s per component).

Sensors (seeded noise): GPS at 4 Hz (position: a Gauss-Markov error of 20-s correlation time,
σ 1.5 m horizontal and 2.5 m vertical, plus 0.2 m white noise; velocity σ 0.15 m/s), IMU at
50 Hz (Euler angles σ 0.3°, body rates σ 0.01 rad/s), controls logged at 10 Hz. The position
is north-east-down relative to the landing-zone origin at 1200 m above mean sea level. Event:
``canopy_deployed`` (the model assumes a fully inflated canopy from here).

Files written (small CSVs, one per sensor and drop, plus the wind files and the truth):
``<drop>_gps.csv``, ``<drop>_imu.csv``, ``<drop>_controls.csv`` (controlled drop only),
``<drop>_wind.csv`` and ``truth.json`` (the event time ``canopy_deployed_s`` is there; the
demo's study files put it in the GPS mapping's ``events``; ``sensor_noise`` states the noise
added here as an ``[identification] noise`` table, which the demo's criteria constraints are
computed from).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from vectorid import models
from vectorid.models import DrydenTurbulence, InitialState, Wind, WindProfile, riser_commands
from vectorid.models.parachute6dof import Parachute6DoF

SEED = 20_240_611
OUT = Path(__file__).resolve().parents[1] / "src" / "vectorid" / "data" / "demo"
ORIGIN_ALTITUDE = 1200.0  # m above mean sea level, landing zone
DT = 0.01  # s, truth integration step (100 Hz)
DURATION = 95.0  # s of record per drop
T_CANOPY = 3.0  # s, canopy fully deployed
INERTIA_FACTOR = 1.25  # truth inertia / model inertia
COMMAND_DELAY = 0.6  # s, actuator transport delay of the truth
W20 = 6.0  # m/s, turbulence intensity reference
GPS_POSITION_SIGMA = (1.5, 1.5, 2.5)  # m, Gauss-Markov position error (north, east, down)
GPS_POSITION_TAU = 20.0  # s, its correlation time
GPS_POSITION_WHITE = 0.2  # m, white position noise on top
GPS_VELOCITY_SIGMA = 0.15  # m/s
IMU_EULER_SIGMA_DEG = 0.3  # deg
IMU_RATES_SIGMA = 0.01  # rad/s

#: The sensor noise added below, as an ``[identification] noise`` table (units of the keys:
#: m, m/s, deg, rad/s): what a study of these data states as its measurement noise.
SENSOR_NOISE = {
    "position_h": {
        "sigma": GPS_POSITION_SIGMA[0],
        "correlation_time": GPS_POSITION_TAU,
        "white": GPS_POSITION_WHITE,
    },
    "position_v": {
        "sigma": GPS_POSITION_SIGMA[2],
        "correlation_time": GPS_POSITION_TAU,
        "white": GPS_POSITION_WHITE,
    },
    "velocity": GPS_VELOCITY_SIGMA,
    "euler_deg": IMU_EULER_SIGMA_DEG,
    "rates": IMU_RATES_SIGMA,
}

#: The TRUE parameter values (the demo identifies x6, x8, x11, x14 and then x13, x15).
TRUTH = {
    "x1": 1.03,
    "x2": 0.98,
    "x3": 1.31,
    "x4": 0.22,
    "x5": 0.0,
    "x6": 0.52,
    "x7": 1.0,
    "x8": 1.1,
    "x9": 0.21,
    "x10": 0.05,
    "x11": 0.09,
    "x12": 0.25,
    "x13": 0.55,
    "x14": 2.4,
    "x15": 1.3,
}

#: Riser commands of the controlled drop: (time s, [l1, l2, l3, l4]), 1 = not actuated.
COMMANDS = [
    (0.0, [1, 1, 1, 1]),
    (12.0, [0, 1, 1, 1]),
    (30.0, [1, 1, 1, 1]),
    (40.0, [1, 0, 0, 1]),
    (58.0, [1, 1, 1, 1]),
    (66.0, [1, 1, 1, 0]),
    (82.0, [1, 1, 1, 1]),
]


class ZeroMeanUpdraft(DrydenTurbulence):
    """Dryden gusts whose vertical component has zero mean over the record.

    With a scale length of 1750 ft the vertical gust is correlated over about a minute, so one
    80-s realisation carries a mean up- or downdraft of several tenths of m/s that no sensor of
    the drop sees and that would bias the drag coefficient by some 10 %; the demo wants gusts
    (oscillations the model cannot reproduce), not a hidden steady vertical wind.
    """

    def series(self, t_final, h0, profile=None):
        t, gust = super().series(t_final, h0, profile)
        gust = gust.copy()
        gust[:, 2] -= gust[:, 2].mean()
        return t, gust


class TruthParachute(Parachute6DoF):
    """The "real" parachute: the identified model with a heavier-inertia payload."""

    def rigid_body(self) -> dict[str, float]:
        rb = dict(super().rigid_body())
        rb["Ixx"] *= INERTIA_FACTOR
        rb["Izz"] *= INERTIA_FACTOR
        return rb


def true_wind(kind: str) -> WindProfile:
    """Mean wind of each drop's day (speed and FROM-direction vs altitude)."""
    h = ORIGIN_ALTITUDE + np.array([0.0, 200, 400, 700, 1000, 1500, 2500])
    if kind == "uncontrolled":
        speed = np.array([3.0, 5.0, 6.5, 8.0, 9.0, 10.0, 11.0])
        direction = np.array([240.0, 248, 255, 262, 268, 272, 275])
    else:
        speed = np.array([2.5, 4.0, 5.5, 6.5, 7.0, 8.0, 9.0])
        direction = np.array([300.0, 305, 312, 318, 322, 326, 330])
    return WindProfile.from_speed_direction(h, speed, direction)


def simulate_truth(kind: str, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Simulate one drop of the truth at 100 Hz; returns time and channels."""
    m = TruthParachute()
    x = np.array([TRUTH[p] for p in m.parameter_names])
    profile = true_wind(kind)
    h0 = ORIGIN_ALTITUDE + 1000.0
    w0 = profile(h0)
    turb = ZeroMeanUpdraft(w20=W20, seed=rng, v_ref=9.0, dt=0.05, ground_altitude=ORIGIN_ALTITUDE)
    initial = InitialState(
        altitude=h0,
        velocity=(float(w0[0]) + 1.5, float(w0[1]) - 1.0, 13.0),
        euler=(0.12, -0.08, 0.4 if kind == "uncontrolled" else -0.6),
        rates=(0.08, -0.05, 0.03),
    )
    inputs = None
    if kind == "controlled":
        t = [c[0] for c in COMMANDS]
        v = [c[1] for c in COMMANDS]
        shifted = [ti + COMMAND_DELAY if ti > 0 else 0.0 for ti in t]
        inputs = riser_commands(shifted, v)
    res = m.simulate(
        x[None, :],
        t_final=DURATION,
        dt=DT,
        inputs=inputs,
        wind=Wind(profile, turb),
        output_dt=DT,
        initial=initial,
    )
    if res.status[0] != 0:
        raise RuntimeError(f"truth simulation failed: {res.messages[0]}")
    pos = np.array(res.position[0])
    pos[:, 2] += ORIGIN_ALTITUDE  # NED relative to the origin
    return {
        "t": res.t,
        "position": pos,
        "velocity": np.array(res.velocity[0]),
        "euler": np.array(res.euler[0]),
        "rates": np.array(res.rates[0]),
    }


def _gauss_markov(
    rng: np.random.Generator, n: int, dt: float, tau: float, sigma: list[float]
) -> np.ndarray:
    """First-order Gauss-Markov errors (n, 3): correlation time ``tau`` s, std ``sigma``."""
    a = np.exp(-dt / tau)
    s = np.asarray(sigma, dtype=float)
    out = np.empty((n, 3))
    out[0] = rng.normal(0.0, s)
    for k in range(1, n):
        out[k] = a * out[k - 1] + np.sqrt(1.0 - a * a) * rng.normal(0.0, s)
    return out


def _every(t: np.ndarray, rate_hz: float) -> np.ndarray:
    step = round(1.0 / (rate_hz * DT))
    return np.arange(0, t.size, step)


def _fmt(a: np.ndarray, digits: int) -> list[str]:
    return [f"{v:.{digits}f}" for v in a]


def _write_csv(path: Path, header: list[str], cols: list[list[str]]) -> None:
    lines = [",".join(header)]
    lines += [",".join(row) for row in zip(*cols)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def write_drop(kind: str, truth: dict[str, np.ndarray], rng: np.random.Generator) -> None:
    t = truth["t"]
    g = _every(t, 4.0)
    pos = truth["position"][g] + _gauss_markov(
        rng, g.size, 0.25, GPS_POSITION_TAU, list(GPS_POSITION_SIGMA)
    )
    pos += rng.normal(0.0, GPS_POSITION_WHITE, (g.size, 3))
    vel = truth["velocity"][g] + rng.normal(0.0, GPS_VELOCITY_SIGMA, (g.size, 3))
    _write_csv(
        OUT / f"{kind}_gps.csv",
        ["time_s", "north_m", "east_m", "down_m", "v_north_ms", "v_east_ms", "v_down_ms"],
        [_fmt(t[g], 2)]
        + [_fmt(pos[:, j], 2) for j in range(3)]
        + [_fmt(vel[:, j], 3) for j in range(3)],
    )
    i = _every(t, 50.0)
    eul = np.rad2deg(
        truth["euler"][i] + rng.normal(0.0, np.deg2rad(IMU_EULER_SIGMA_DEG), (i.size, 3))
    )
    eul[:, 2] = np.mod(eul[:, 2], 360.0)  # the IMU logs heading in [0, 360)
    rat = truth["rates"][i] + rng.normal(0.0, IMU_RATES_SIGMA, (i.size, 3))
    _write_csv(
        OUT / f"{kind}_imu.csv",
        ["time_s", "roll_deg", "pitch_deg", "yaw_deg", "p_rads", "q_rads", "r_rads"],
        [_fmt(t[i], 2)]
        + [_fmt(eul[:, j], 3) for j in range(3)]
        + [_fmt(rat[:, j], 4) for j in range(3)],
    )
    if kind == "controlled":
        c = _every(t, 10.0)
        times = np.array([x[0] for x in COMMANDS])
        vals = np.array([x[1] for x in COMMANDS], dtype=float)
        k = np.searchsorted(times, t[c], side="right") - 1
        _write_csv(
            OUT / f"{kind}_controls.csv",
            ["time_s", "riser1", "riser2", "riser3", "riser4"],
            [_fmt(t[c], 2)] + [_fmt(vals[k, j], 0) for j in range(4)],
        )
    prof = true_wind(kind)
    levels = ORIGIN_ALTITUDE + np.arange(0.0, 1501.0, 100.0)
    ne = prof(levels) + rng.normal(0.0, 0.4, (levels.size, 2))
    _write_csv(
        OUT / f"{kind}_wind.csv",
        ["altitude_m", "u_ms", "v_ms"],
        [_fmt(levels, 1), _fmt(ne[:, 1], 2), _fmt(ne[:, 0], 2)],  # u east, v north
    )


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    for kind in ("uncontrolled", "controlled"):
        truth = simulate_truth(kind, rng)
        write_drop(kind, truth, rng)
    m = models.get("parachute6dof")
    (OUT / "truth.json").write_text(
        json.dumps(
            {
                "seed": SEED,
                "parameters": TRUTH,
                "model_nominal": dict(zip(m.parameter_names, m.nominal.tolist())),
                "inertia_factor": INERTIA_FACTOR,
                "command_delay_s": COMMAND_DELAY,
                "w20_ms": W20,
                "origin_altitude_m": ORIGIN_ALTITUDE,
                "canopy_deployed_s": T_CANOPY,
                "sensor_noise": SENSOR_NOISE,
            },
            indent=1,
        )
        + "\n",
        encoding="utf-8",
    )
    print(f"wrote {sorted(p.name for p in OUT.iterdir())} into {OUT}")


if __name__ == "__main__":
    main()
