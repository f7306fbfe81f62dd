"""Does the vehicle respond to thrust as the model says?  Gains from a flight's own measurements.

A flight's results file (``fly``, ``replay``) holds, per step, the state the autopilot
reported, the channels sent and the accelerometer's specific force.  For each body axis this
compares what the accelerometer measured with what the one model (the mission's vehicle,
still water) predicts for the same state, split into the part the thrust causes and the rest:

    f_meas - f_model(x, 0)  ~  gain * (f_model(x, u) - f_model(x, 0))

with ``u`` the thrust ArduSub produces from the channels sent at the step before (what the
accelerometer read at a step has felt: the channels of the step itself are sent after it)
(:func:`auvdock.vehicle.ardusub.thrust_from_channels`) and ``f_model = nu_1_dot + nu_2 x
nu_1 - R^T g`` the specific force the model's accelerations give (paper eqs. 1-2).  ``gain`` is
the least-squares slope over the armed steps (1: the vehicle pushes as modelled; 2: twice as
hard), with the share of the measured variation it explains (R^2).  A flight on a plant the
model does not describe (ArduPilot SITL's built-in submarine, a vehicle with other thrusters or
ballast) shows here, from its own data, before anyone tunes a filter.

    python -m auvdock.fly.response RESULTS.h5 [--mission MISSION.yaml]
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from auvdock.config.mission import Mission, parse_mission
from auvdock.results.store import read_run
from auvdock.sensing.measurements import GRAVITY
from auvdock.vehicle.ardusub import thrust_from_channels
from auvdock.vehicle.geometry import rotation_of

__all__ = ["AxisResponse", "thrust_response", "main"]

AXES = ("surge", "sway", "heave")


@dataclass(frozen=True)
class AxisResponse:
    """One body axis: measured against modelled thrust-driven specific force."""

    axis: str
    gain: float  # least-squares slope, measured / modelled
    r2: float  # share of the measured thrust-driven variation the fit explains
    steps: int
    model_rms_m_s2: float  # RMS of the modelled thrust-driven part


def thrust_response(path: str | Path, mission: Mission | None = None) -> list[AxisResponse]:
    """Per body axis (surge, sway, heave), the gain of the vehicle's measured response to thrust
    over the model's, from a ``fly`` results file (the mission stored in it unless given)."""
    run = read_run(path)
    m = mission if mission is not None else parse_mission_text(run.mission_yaml)
    vehicle = m.build_vehicle()
    f_imu = np.asarray(run.extras["imu_specific_force_m_s2"], dtype=float)
    channels = np.asarray(run.extras["channels_us"], dtype=float)
    armed = np.asarray(run.extras["armed"], dtype=float) > 0.5
    ok = armed & np.all(np.isfinite(f_imu), axis=1) & np.all(np.isfinite(run.state), axis=1)
    ok[1:] &= armed[:-1]
    ok[0] = False  # the first step has no command before it
    rows = np.flatnonzero(ok)
    meas, model = [], []
    g_n = np.array([0.0, 0.0, GRAVITY])
    zero = np.zeros(vehicle.n_thrusters)

    def specific_force(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        R = rotation_of(x[3:6])
        xd = vehicle.state_derivative(x, u)
        return xd[6:9] + np.cross(x[9:12], x[6:9]) - R.T @ g_n

    for i in rows:
        x = run.state[i]
        f0 = specific_force(x, zero)
        meas.append(f_imu[i] - f0)
        model.append(specific_force(x, thrust_from_channels(channels[i - 1], vehicle.thruster_curve)) - f0)
    meas_a, model_a = np.array(meas).reshape(-1, 3), np.array(model).reshape(-1, 3)
    out = []
    for k, name in enumerate(AXES):
        y, p = meas_a[:, k], model_a[:, k]
        den = float(p @ p)
        gain = float(p @ y) / den if den > 0 else float("nan")
        resid = y - gain * p
        ss = float(((y - y.mean()) ** 2).sum()) if len(y) else 0.0
        r2 = 1.0 - float(resid @ resid) / ss if ss > 0 else float("nan")
        rms = float(np.sqrt(den / len(p))) if len(p) else float("nan")
        out.append(AxisResponse(name, gain, r2, len(p), rms))
    return out


def parse_mission_text(text: str) -> Mission:
    import yaml

    return parse_mission(yaml.safe_load(text), "<results file>")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description="The vehicle's measured response to thrust over the model's.")
    ap.add_argument("results", type=Path, help="a fly or replay results file (HDF5)")
    ap.add_argument("--mission", type=Path, default=None, help="the model's mission (default: stored)")
    args = ap.parse_args(argv)
    mission = None
    if args.mission is not None:
        from auvdock.config.mission import load_mission

        mission = load_mission(args.mission)
    print(f"{args.results.name}: measured / modelled thrust-driven specific force, armed steps")
    print(f"{'axis':6s} {'gain':>6s} {'R^2':>6s} {'steps':>6s} {'model rms m/s^2':>16s}")
    for a in thrust_response(args.results, mission):
        print(f"{a.axis:6s} {a.gain:6.2f} {a.r2:6.2f} {a.steps:6d} {a.model_rms_m_s2:16.3f}")


if __name__ == "__main__":
    main()
