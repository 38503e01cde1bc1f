"""Generate the embedded data of ``vectorid demo parafoil``: one guided drop of a cargo parafoil.

Run from the repository root (re-runnable; the output is a function of ``SEED`` only)::

    python scripts/make_parafoil_demo_data.py      # writes src/vectorid/data/demo_parafoil/

What it does
------------
The "real system" is the ``parafoil8dof`` model (the reference 2,200-lb-class system of
``docs/models.md``) with the TRUE gains below, made deliberately richer than the model the demo
identifies, so that no parameter vector fits exactly:

- seeded Dryden turbulence (MIL-F-8785C, W20 = 2 m/s, vertical component zero-mean over the
  record as in the G-12 demo) on top of the mean wind: gusts the identified model never sees;
- flap actuator lag: the trailing edges follow the logged commands through a first-order lag
  of 0.8 s (servo and line stretch) that the model does not have;
- a payload joint the model does not have: a pitch stiffness of 1500 N m/rad (the model's
  joint pitches freely) and less damping (600 and 250 N m s/rad in pitch and yaw, the
  model's 2000 and 700), so the payload's pendulum and twist modes ring longer;
- a measured wind profile that is not the true one: the "dropsonde" file holds the true mean
  profile at 100-m levels plus seeded errors (σ = 0.25 m/s per component).

The flight: released at 1000 m above the landing zone, a straight glide, a left turn
(left flap 50 % for 20 s), a straight glide, a right turn (right flap 50 %), a glide, a
symmetric brake (both flaps 60 % for 15 s) and a last glide: 150 s of data after the canopy is
flying (event ``glide_start``, 5 s after the start of the record).

Sensors (seeded noise), all on the payload: GPS at 4 Hz (position: a Gauss-Markov error of 20-s
correlation time, σ 1.5 m horizontal and 2.5 m vertical, plus 0.2 m white noise; velocity σ
0.15 m/s), IMU at 50 Hz (Euler angles σ 0.2°, body rates σ 0.004 rad/s), flap commands logged at
10 Hz. Position is north-east-down relative to the landing-zone origin at 1200 m above mean sea
level.

Files written: ``gps.csv``, ``imu.csv``, ``controls.csv``, ``wind.csv`` and ``truth.json`` (the
true gains, the model's nominal gains, the richer-truth settings, the event time, and
``sensor_noise``: the noise added here as an ``[identification] noise`` table, from which the
demo computes its criteria constraints).

Twins: ``generate(seed, out)`` writes the same drop with other seeds (other gusts, sonde errors
and sensor noise; the same truth, flight program and sensors) into another folder.
``scripts/parafoil_discrepancy.py`` reads the demo's model-discrepancy allowance from such
twins, never from the embedded drop itself.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from vectorid import models
from vectorid.models import DrydenTurbulence, InitialState, Wind, WindProfile, flap_deflections

SEED = 20_240_612
OUT = Path(__file__).resolve().parents[1] / "src" / "vectorid" / "data" / "demo_parafoil"
ORIGIN_ALTITUDE = 1200.0  # m above mean sea level, landing zone
RELEASE_HEIGHT = 1000.0  # m above the landing zone
DT = 0.01  # s, truth integration step (100 Hz)
DURATION = 160.0  # s of record
T_GLIDE = 5.0  # s, the canopy is flying from here (event glide_start)
W20 = 2.0  # m/s, turbulence intensity reference
ACTUATOR_LAG = 0.8  # s, first-order lag of the truth's trailing edges behind the commands
JOINT_STIFFNESS = (1500.0, 2000.0)  # N m/rad, pitch and yaw of the truth's payload joint
JOINT_DAMPING = (600.0, 250.0)  # N m s/rad
SONDE_SIGMA = 0.25  # m/s, error of the dropsonde's wind per component and level
GPS_POSITION_SIGMA = (1.5, 1.5, 2.5)  # m, Gauss-Markov position error (north, east, down)
GPS_POSITION_TAU = 20.0  # s, its correlation time
GPS_POSITION_WHITE = 0.2  # m, white position noise on top
GPS_VELOCITY_SIGMA = 0.15  # m/s
IMU_EULER_SIGMA_DEG = 0.2  # deg
IMU_RATES_SIGMA = 0.004  # rad/s

#: The sensor noise added below, as an ``[identification] noise`` table (units of the keys:
#: m, m/s, deg, rad/s): what a study of these data states as its measurement noise. The
#: dropsonde's wind errors are not sensor noise of a compared channel: the model flies in that
#: wind, so they are part of what the demo grants as model discrepancy.
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

#: The TRUE gains that differ from 1 (multiplicative) or 0 (additive); the others are nominal.
TRUTH_GAINS = {
    "delcon": 0.7,  # the trailing edges deflect less than commanded
    "CLalpha": 0.95,
    "CD0": 1.15,
    "Rig": 0.9,
    "Clp": 1.3,
    "CnDanom": 1.2,
    "Cnr": 1.1,
}

#: Flap commands (time s, left, right), held between knots with 1-s ramps.
PROGRAM = [
    (0.0, 0.0, 0.0),
    (30.0, 0.5, 0.0),  # left turn
    (50.0, 0.0, 0.0),
    (70.0, 0.0, 0.5),  # right turn
    (90.0, 0.0, 0.0),
    (110.0, 0.6, 0.6),  # symmetric brake
    (125.0, 0.0, 0.0),
]


def commands() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Commanded flap deflections on the truth's 100-Hz grid: t, left, right (1-s ramps)."""
    t = np.arange(0.0, DURATION + DT / 2, DT)
    kt, kl, kr = [0.0], [PROGRAM[0][1]], [PROGRAM[0][2]]
    for t0, left, right in PROGRAM[1:]:
        kt += [t0, t0 + 1.0]
        kl += [kl[-1], left]
        kr += [kr[-1], right]
    return t, np.interp(t, kt, kl), np.interp(t, kt, kr)


def lagged(t: np.ndarray, u: np.ndarray, tau: float) -> np.ndarray:
    """First-order lag ``tau dy/dt = u - y`` (exact for a linear input between samples)."""
    y = np.empty_like(u)
    y[0] = u[0]
    a = np.exp(-np.diff(t) / tau)
    for k in range(1, u.size):
        h = t[k] - t[k - 1]
        slope = (u[k] - u[k - 1]) / h
        y[k] = u[k] - tau * slope + a[k - 1] * (y[k - 1] - u[k - 1] + tau * slope)
    return y


class ZeroMeanUpdraft(DrydenTurbulence):
    """Dryden gusts whose vertical component has zero mean over the record (a hidden steady
    up- or downdraft would bias the drag identification; the demo wants gusts, not that)."""

    def series(self, t_final, h0, profile=None):
        t, gust = super().series(t_final, h0, profile)
        gust = gust.copy()
        gust[:, 2] -= gust[:, 2].mean()
        return t, gust


def true_wind() -> WindProfile:
    """Mean wind of the day (speed and FROM-direction vs altitude)."""
    h = ORIGIN_ALTITUDE + np.array([0.0, 200, 400, 700, 1000, 1500, 2500])
    speed = np.array([3.0, 4.5, 6.0, 7.0, 8.0, 9.0, 10.0])
    direction = np.array([250.0, 256, 262, 268, 274, 278, 282])
    return WindProfile.from_speed_direction(h, speed, direction)


def truth_model():
    """The truth: the 8-DoF model with the richer joint, IMU on the payload."""
    return models.get(
        "parafoil8dof",
        attitude="payload",
        joint_stiffness=JOINT_STIFFNESS,
        joint_damping=JOINT_DAMPING,
    )


def truth_vector(model) -> np.ndarray:
    x = model.nominal.copy()
    for name, value in TRUTH_GAINS.items():
        x[model.parameter_names.index(name)] = value
    return x


def simulate_truth(rng: np.random.Generator) -> dict[str, np.ndarray]:
    """Simulate the truth at 100 Hz; returns time, channels and the commands."""
    m = truth_model()
    t, left, right = commands()
    inputs = flap_deflections(t, lagged(t, left, ACTUATOR_LAG), lagged(t, right, ACTUATOR_LAG))
    turb = ZeroMeanUpdraft(w20=W20, seed=rng, v_ref=15.0, dt=0.05, ground_altitude=ORIGIN_ALTITUDE)
    initial = InitialState(
        altitude=ORIGIN_ALTITUDE + RELEASE_HEIGHT,
        euler=(0.05, 0.0, np.radians(40.0)),
        rates=(0.02, -0.03, 0.01),
    )
    res = m.simulate(
        truth_vector(m)[None, :],
        t_final=DURATION,
        dt=DT,
        inputs=inputs,
        wind=Wind(true_wind(), turb),
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
        "left": left,
        "right": right,
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


def write_files(
    truth: dict[str, np.ndarray], rng: np.random.Generator, out: Path | None = None
) -> None:
    out = OUT if out is None else out
    t = truth["t"]
    g = _every(t, 4.0)
    pos = truth["position"][g] + _gauss_markov(
        rng, g.size, 0.25, GPS_POSITION_TAU, list(GPS_POSITION_SIGMA)
    )
    pos += rng.normal(0.0, GPS_POSITION_WHITE, (g.size, 3))
    vel = truth["velocity"][g] + rng.normal(0.0, GPS_VELOCITY_SIGMA, (g.size, 3))
    _write_csv(
        out / "gps.csv",
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
        out / "imu.csv",
        ["time_s", "roll_deg", "pitch_deg", "yaw_deg", "p_rads", "q_rads", "r_rads"],
        [_fmt(t[i], 2)]
        + [_fmt(eul[:, j], 3) for j in range(3)]
        + [_fmt(rat[:, j], 4) for j in range(3)],
    )
    c = _every(t, 10.0)
    _write_csv(
        out / "controls.csv",
        ["time_s", "flap_left", "flap_right"],
        [_fmt(t[c], 2), _fmt(truth["left"][c], 3), _fmt(truth["right"][c], 3)],
    )
    levels = ORIGIN_ALTITUDE + np.arange(0.0, 1501.0, 100.0)
    ne = true_wind()(levels) + rng.normal(0.0, SONDE_SIGMA, (levels.size, 2))
    _write_csv(
        out / "wind.csv",
        ["altitude_m", "u_ms", "v_ms"],
        [_fmt(levels, 1), _fmt(ne[:, 1], 2), _fmt(ne[:, 0], 2)],  # u east, v north
    )


def generate(seed: int = SEED, out: Path | None = None) -> Path:
    """Fly the truth with ``seed`` (gusts, sensor noise, sonde errors) and write the drop's
    files into ``out`` (default :data:`OUT`, the embedded data); returns the folder."""
    out = OUT if out is None else Path(out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    truth = simulate_truth(rng)
    write_files(truth, rng, out)
    m = truth_model()
    (out / "truth.json").write_text(
        json.dumps(
            {
                "seed": seed,
                "parameters": dict(zip(m.parameter_names, truth_vector(m).tolist())),
                "model_nominal": dict(zip(m.parameter_names, m.nominal.tolist())),
                "actuator_lag_s": ACTUATOR_LAG,
                "joint_stiffness_Nm_rad": list(JOINT_STIFFNESS),
                "joint_damping_Nms_rad": list(JOINT_DAMPING),
                "w20_ms": W20,
                "origin_altitude_m": ORIGIN_ALTITUDE,
                "glide_start_s": T_GLIDE,
                "program": PROGRAM,
                "sonde_sigma_ms": SONDE_SIGMA,
                "sensor_noise": SENSOR_NOISE,
            },
            indent=1,
        )
        + "\n",
        encoding="utf-8",
    )
    return out


def main() -> None:
    out = generate()
    print(f"wrote {sorted(p.name for p in out.iterdir())} into {out}")


if __name__ == "__main__":
    main()
