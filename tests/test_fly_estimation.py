"""The vehicle's telemetry as the sensor interface, the estimation stage on a vehicle, and replay.

* :class:`auvdock.fly.telemetry.TelemetrySensors` maps ArduSub's messages to the same
  readings the simulated suite gives (one definition per measurement, :mod:`auvdock.sensing.measurements`);
* ``vehicle-sim`` in a current the flown mission does not know: the flow-estimating
  controllers learn it on the navigation filter and dock (simulated time, loopback only);
* ``auvdock replay`` reruns a flight's tlog to the same controller outputs.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers.loopback import TANK, Loopback
from pymavlink.dialects.v20 import ardupilotmega as mav2

from auvdock.cli import app
from auvdock.config.mission import load_mission
from auvdock.fly import FlySession
from auvdock.fly.link import MavlinkLink
from auvdock.fly.replay import ReplayError, replay
from auvdock.fly.telemetry import TelemetrySensors, frame_turns
from auvdock.fly.units import MG_M_S2, MRAD_S, pressure_hpa
from auvdock.results.store import read_run
from auvdock.sensing import measurements as ms
from auvdock.vehicle.geometry import Rz, rotation_zyx

#: The issue's current: 0.297 m/s towards the south-east of the tank's frame.
CURRENT = [0.2, -0.22]


def _mission(path: Path, **sections) -> Path:
    data = yaml.safe_load(TANK.read_text())
    data.update(sections)
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


# -- the mapping ---------------------------------------------------------------------------------
def _msgs(x: np.ndarray, f_b: np.ndarray, depth: float) -> list:
    """ArduSub's messages for state ``x`` (in the autopilot's frame) and specific force ``f_b``."""
    v_ned = rotation_zyx(*x[3:6]) @ x[6:9]
    return [
        mav2.MAVLink_attitude_message(0, *x[3:6], *x[9:12]),
        mav2.MAVLink_local_position_ned_message(0, *x[0:3], *v_ned),
        mav2.MAVLink_scaled_imu2_message(
            0, *[round(v / MG_M_S2) for v in f_b], *[round(v / MRAD_S) for v in x[9:12]], 0, 0, 0, 0
        ),
        mav2.MAVLink_scaled_pressure2_message(0, pressure_hpa(depth), 0.0, 1500, 0),
    ]


def test_telemetry_readings_are_the_measurement_definitions_in_the_mission_frame() -> None:
    """Readings from ArduSub's messages equal ``measurements.measure`` of the state mapped into the
    mission frame, to the messages' resolution (mG, mrad/s, float32)."""
    m = load_mission(TANK).with_updates(**{"estimation": "filter", "sensors.dvl.enabled": True})
    vehicle = m.build_vehicle()
    tel = TelemetrySensors(m.sensors, "filter")
    assert tel.missing() == [
        "ATTITUDE",
        "LOCAL_POSITION_NED",
        "SCALED_IMU2 or RAW_IMU",
        "SCALED_PRESSURE2 or VFR_HUD",
    ]
    # the vehicle starts 0.4 rad off the mission's heading, elsewhere, 0.3 m deeper than its pressure zero
    x0_v = np.array([5.0, -2.0, 1.3, 0.0, 0.0, 0.4, 0, 0, 0, 0, 0, 0])
    f0 = ms.measure("accel", vehicle, np.r_[x0_v[:5], 0.0, x0_v[6:]])
    tel.feed([(1000 * i, msg) for i, msg in enumerate(_msgs(x0_v, f0, 1.3))])
    assert tel.missing() == []
    frame = tel.set_frame(m.start_state())
    assert frame.dpsi == pytest.approx(-0.4)
    # later: moved and turned, moving, rotating, with thrust
    x_v = np.array([5.5, -1.6, 1.45, 0.05, -0.03, 0.9, 0.3, -0.1, 0.05, 0.02, -0.01, 0.1])
    u = np.linspace(-5, 5, vehicle.n_thrusters)
    x_m = x_v.copy()  # the same state in the mission frame
    x_m[0:3] = m.start_state()[0:3] + Rz(-0.4) @ (x_v[0:3] - x0_v[0:3])
    x_m[5] = x_v[5] - 0.4
    f_b = ms.measure("accel", vehicle, x_m, u)
    tel.feed([(10_000, msg) for msg in _msgs(x_v, f_b, 1.45)])
    readings = {r.kind: r for r in tel.readings(2.5)}
    assert set(readings) == {"attitude", "gyro", "accel", "depth", "position", "dvl"}
    assert all(r.t == 2.5 for r in readings.values())
    tol = {"attitude": 1e-6, "gyro": MRAD_S / 2 + 1e-9, "accel": MG_M_S2 / 2 + 1e-9, "depth": 2e-5,
           "position": 1e-6, "dvl": 1e-6}  # fmt: skip
    for kind, r in readings.items():
        expected = ms.measure(kind, vehicle, x_m, u)
        np.testing.assert_allclose(r.value, expected, atol=tol[kind], err_msg=kind)
        assert np.all(r.std > 0)
    # the IMU's std includes the rounding to whole mG / mrad/s
    assert readings["accel"].std[0] == pytest.approx(
        math.hypot(m.sensors.imu.accel_noise_m_s2, MG_M_S2 / 12**0.5)
    )
    np.testing.assert_allclose(tel.specific_force, f_b, atol=MG_M_S2 / 2)
    # nothing new: no readings, and the specific force is unknown
    assert tel.readings(2.55) == [] and np.all(np.isnan(tel.specific_force))
    # ages of the required telemetry, at a later stamp
    assert tel.age_s(110_000) == pytest.approx(0.1)


def test_positions_fixed_in_an_outside_frame_are_moved_not_turned_by_the_compass() -> None:
    """fly.frame_heading auto: a DVL's dead-reckoned positions turn with the vehicle's heading (its
    compass error is in them), an outside fix's (acoustic, camera, motion capture: SITL's GPS) do not, so
    the frame only moves them; a compass 0.4 rad off then leaves the positions where the fix put them,
    the heading reads as the compass says, and the frame's heading adds nothing to its covariance."""
    assert frame_turns("auto", "dvl_dead_reckoning") and frame_turns("auto", "none")
    assert not any(frame_turns("auto", s) for s in ("acoustic", "camera", "motion_capture"))
    assert frame_turns("vehicle", "camera") and not frame_turns("source", "dvl_dead_reckoning")
    m = load_mission(TANK)
    vehicle = m.build_vehicle()
    x0_v = np.array([5.0, -2.0, 1.3, 0.0, 0.0, 0.4, 0, 0, 0, 0, 0, 0])
    f0 = ms.measure("accel", vehicle, np.r_[x0_v[:5], 0.0, x0_v[6:]])
    covs = {}
    for turn in (True, False):
        tel = TelemetrySensors(m.sensors, "truth")
        tel.feed([(1000 * i, msg) for i, msg in enumerate(_msgs(x0_v, f0, 1.3))])
        frame = tel.set_frame(m.start_state(), turn=turn)
        assert frame.dpsi == pytest.approx(-0.4 if turn else 0.0)
        x_v = x0_v.copy()
        x_v[0] += 1.0  # 1 m north of the start in the fix's frame
        tel.feed([(10_000, msg) for msg in _msgs(x_v, f0, 1.3)])
        expected = m.start_state()[0:3] + (Rz(-0.4) if turn else np.eye(3)) @ np.array([1.0, 0.0, 0.0])
        np.testing.assert_allclose(tel.state()[0:3], expected, atol=1e-6)
        assert tel.state()[5] == pytest.approx(0.0 if turn else 0.4)
        covs[turn] = tel.frame_cov(m.start_state()[0:3] + np.array([2.0, 0.0, 0.0]))
    assert covs[True][1, 1] > covs[False][1, 1] and covs[False][0, 1] == 0.0


def test_a_stated_sensor_latency_stamps_the_reading_that_much_before_its_message() -> None:
    """A message's time_boot_ms is when ArduSub sent it: a raw sensor's stated latency (sample to message)
    moves its reading earlier by exactly that, as sim stamps its sensors' readings at the sample; the
    position (ArduSub's EKF output, delay-compensated by the EKF) keeps its message's time."""
    latency = {"depth": 0.04, "ahrs": 0.02, "imu": 0.01}
    base = load_mission(TANK).with_updates(**{"estimation": "filter", "sensors.position.source": "acoustic"})
    late = base.with_updates(**{f"sensors.{k}.latency_s": v for k, v in latency.items()})
    x = np.zeros(12)
    x[2] = 1.0
    g = np.array([0.0, 0.0, -9.80665])
    stamps = {}
    for name, m in (("base", base), ("late", late)):
        tel = TelemetrySensors(m.sensors, "filter")
        tel.feed([(0, msg) for msg in _msgs(x, g, 1.0)])
        tel.set_frame(m.start_state())
        msgs = _msgs(x, g, 1.0)
        for msg in msgs:
            msg.time_boot_ms = 9_900  # sent 0.1 s before now on the vehicle's clock (offset 0)
        tel.feed([(9_950_000, msg) for msg in msgs])
        stamps[name] = {r.kind: r.t for r in tel.readings(5.0, now_us=10_000_000, clock_offset_s=0.0)}
    kinds = ("attitude", "gyro", "accel", "depth", "position")
    assert stamps["base"] == {k: pytest.approx(4.9) for k in kinds}
    shift = {k: stamps["base"][k] - stamps["late"][k] for k in stamps["base"]}
    assert shift == {
        "attitude": pytest.approx(0.02),
        "gyro": pytest.approx(0.01),
        "accel": pytest.approx(0.01),
        "depth": pytest.approx(0.04),
        "position": pytest.approx(0.0),
    }


def test_truth_mode_needs_only_the_pose_and_skips_position_without_a_source() -> None:
    m = load_mission(TANK).with_updates(**{"sensors.position.source": "none"})
    tel = TelemetrySensors(m.sensors, "truth")
    assert tel.missing() == ["ATTITUDE", "LOCAL_POSITION_NED"]
    x = np.zeros(12)
    x[2] = 1.0
    tel.feed([(0, msg) for msg in _msgs(x, np.array([0, 0, -9.80665]), 1.0)])
    tel.set_frame(m.start_state())
    tel.feed([(1, msg) for msg in _msgs(x, np.array([0, 0, -9.80665]), 1.0)])
    kinds = {r.kind for r in tel.readings(0.05)}
    assert "position" not in kinds and "dvl" not in kinds  # no position source, no DVL
    np.testing.assert_allclose(tel.state(), m.start_state(), atol=1e-6)


# -- on a vehicle, in a current the mission does not know -------------------------------------
def _fly_in_current(loop: Loopback, tmp_path: Path, controller: str, timeout_s: float, seed: int = 0):
    vehicle_mission = _mission(
        tmp_path / "vehicle.yaml", flow={"type": "constant", "velocity_ned_m_s": CURRENT}
    )
    flown = _mission(tmp_path / "flown.yaml", estimation="filter")  # still water, the tank's flow
    sim, port = loop.vehicle(vehicle_mission, noise=True, seed=seed)
    link = MavlinkLink(f"udpin:127.0.0.1:{port}", clock=loop.clock, tlog=tmp_path / f"{controller}.tlog")
    out = tmp_path / f"{controller}.h5"
    result = FlySession(
        load_mission(flown), link, arm=True, out=out, controller=controller, timeout_s=timeout_s
    ).run()
    return result, read_run(out), flown


@pytest.mark.parametrize("seed", [0, 1])  # (and 2 until 2026-12-07: the suite's 8 minutes)
@pytest.mark.parametrize("controller", ["sequential", "optimized"])
@pytest.mark.slow
def test_flow_estimating_controllers_learn_an_unknown_current_and_dock(
    loop, tmp_path, controller, seed
) -> None:
    """vehicle-sim in a 0.3 m/s current (its sensor errors drawn from ``seed``), the flown mission
    in still water, estimation: filter: the FSE controller docks and the final NED current
    estimate is within 0.05 m/s (in the mission frame, which the session rotated onto the
    vehicle's start heading).  Measured (seeds 0-4): docked in 16.6-24.2 s, errors 0.0004-0.010 m/s."""
    result, r, _ = _fly_in_current(loop, tmp_path, controller, 60.0, seed)
    truth = Rz(float(r.attrs["frame_heading_offset_rad"])) @ np.array([*CURRENT, 0.0])
    flow = r.extras["estimated_flow_ned_m_s"][r.control_rows()][-1]
    print(f"{controller} seed {seed}: {result.message}; final flow {flow[:2]} vs {truth[:2]}")
    assert result.reason == "docked", result.message
    assert np.linalg.norm(flow[:2] - truth[:2]) < 0.05
    # the mission's (still-water) flow model never reached the controller
    assert not r.attrs["reads_true_flow"]
    assert np.all(np.isnan(r.extras["flow_body_true_m_s"]))  # unknown on a vehicle, not the mission's


@pytest.mark.slow
def test_a_flight_replays_to_the_same_controller_outputs(loop, tmp_path) -> None:
    """The tlog of a noisy flight on the navigation filter replays, with the same code, to the
    same thrust at every step (to 1e-9 N), the same estimates and the same ending."""
    result, flight, flown = _fly_in_current(loop, tmp_path, "oracle", 8.0)
    assert result.reason == "timeout"
    again, tag = replay(tmp_path / "oracle.tlog", load_mission(flown), tmp_path / "replay.h5")
    assert tag.controller == "oracle" and tag.dt == 0.05 and tag.timeout_s == 8.0
    assert (again.reason, again.message) == (result.reason, result.message)
    r = read_run(tmp_path / "replay.h5")
    assert len(r.time_s) == len(flight.time_s) == 161
    np.testing.assert_allclose(r.thrust_N, flight.thrust_N, rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.state, flight.state, rtol=0, atol=1e-9)
    est_a, est_b = r.extras["estimated_state"], flight.extras["estimated_state"]
    np.testing.assert_allclose(est_a, est_b, rtol=0, atol=1e-9)
    assert r.attrs["source"] == "fly replay:oracle.tlog"
    # another controller on the same data runs too (what a desk debugger wants), and differs
    # (not naive: with the flown mission's still-water forecast, Oracle's model is Naive's)
    seq, _ = replay(
        tmp_path / "oracle.tlog", load_mission(flown), tmp_path / "seq.h5", controller="sequential"
    )
    other = read_run(tmp_path / "seq.h5")
    n = np.flatnonzero(other.control_rows())
    assert not np.allclose(other.thrust_N[n], flight.thrust_N[n])
    # ... to the flight's end, its navigation moved by the thrust that moved the vehicle (the flight's
    # channels): the same estimates as the flight's, whatever the replayed controller asks for
    assert (seq.reason, seq.message) == (result.reason, result.message)
    np.testing.assert_allclose(other.extras["estimated_state"], est_b, rtol=0, atol=1e-9)
    # the command: one line per error, the comparison with the flight's results beside the tlog
    tlog = str(tmp_path / "oracle.tlog")
    res = loop.runner.invoke(app, ["replay", tlog, str(flown), "--out", str(tmp_path / "cli.h5")])
    assert res.exit_code == 0, res.output + res.stderr
    assert "oracle.h5: 161 rows compared, largest thrust difference 0 N" in res.output
    res = loop.runner.invoke(app, ["replay", tlog, str(flown), "--out", str(tmp_path / "cli.h5")])
    assert (
        res.exit_code == 2
        and res.stderr.strip() == f"error: --out {tmp_path / 'cli.h5'}: exists (--force to overwrite)"
    )
    res = loop.runner.invoke(app, ["replay", str(tmp_path / "nope.tlog"), str(flown)])
    assert res.exit_code == 2 and res.stderr.strip() == f"error: {tmp_path / 'nope.tlog'}: no such file"


def test_replay_refuses_what_it_cannot_replay(tmp_path) -> None:
    not_a_flight = tmp_path / "x.tlog"
    not_a_flight.write_bytes(b"")
    with pytest.raises(ReplayError, match="no auvdock step markers"):
        replay(not_a_flight, load_mission(TANK), tmp_path / "r.h5")
    camera = load_mission(TANK).with_updates(**{"dock.source": "camera"})
    with pytest.raises(ReplayError, match="dock.source camera"):
        replay(not_a_flight, camera, tmp_path / "r.h5")
