"""``fly`` flies the dock camera as ``sim`` does: a sensor of the navigation filter (``sensors.dock_camera``).

The tank trial as shipped (``missions/tank_0p6hz.yaml``: no positioning, the dock found by its markers,
judged by capture against the dock's body), with the frames rendered from the simulator's truth
(``camera.source: synthetic``: vehicle-sim's SIM_STATE and the mission's true dock for its seed), run by
``sim`` and by ``vehicle-sim`` + ``fly`` on 127.0.0.1 in simulated time (tests/helpers/loopback.py).
Everything here is decided by outcomes: captured or not by the truth, the time to capture, the verdict
scored by ``truth-check``; and the rules by exact messages.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers.loopback import ROOT, Loopback, free_port, write_mission

from auvdock.config.mission import MissionError, load_mission
from auvdock.estimation.dock_knowledge import TelemetryDock
from auvdock.estimation.estimate import Estimate
from auvdock.fly.link import MavlinkLink
from auvdock.fly.replay import replay
from auvdock.fly.session import FlySession, check_flyable
from auvdock.loop.simulation import run_simulation
from auvdock.loop.verdict import BOUND_95_3D, CaptureVerdict, MarginVerdict
from auvdock.results.store import read_run
from auvdock.standins.truth_check import check_flight

TANK_0P6 = ROOT / "missions" / "tank_0p6hz.yaml"


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


#: The tests' camera: 5 frames a second (rendering and detecting 640 x 480 frames is most of a flight's
#: time; the shipped 15 Hz flies in benchmarks/soak.py), for sim and fly alike.
CAMERA_RATE_HZ = 5.0


def synthetic_tank(tmp_path: Path, **sections) -> Path:
    camera = {"source": "synthetic", "calibration": None}  # the ideal camera, rendered from the truth
    sensors = {"dock_camera": {"enabled": True, "visibility_m": 6.0, "rate_hz": CAMERA_RATE_HZ}}
    sensors.update(sections.pop("sensors", {}))
    return write_mission(tmp_path / "tank.yaml", base=TANK_0P6, camera=camera, sensors=sensors, **sections)


@pytest.mark.slow
def test_fly_captures_on_the_camera_alone_as_sim_does(loop, tmp_path) -> None:
    """Parity: the same mission and seed, captured by both, fly within 10 control periods of sim.

    The differences that remain, each by design: sim's camera is the fast model of the pipeline's fixes
    (``sensors.dock_camera.model: fast``) with a 0.1 s capture-to-fix latency, fly's the real pipeline on
    rendered frames, which takes no simulated time; fly's telemetry comes at 25 Hz over MAVLink (IMU,
    attitude, pressure) where sim's sensors keep their own rates; sim stops at the truth's first captured
    instant, fly at its own verdict on its estimate (captured with a 95 % margin)."""
    mission = synthetic_tank(tmp_path)
    m = load_mission(mission)
    s = run_simulation(m)
    assert s.outcome["captured"], s.outcome
    sim, port = loop.vehicle(m, truth_out=tmp_path / "truth.h5", hold_start=True, noise=True)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "40", mission=mission)
    assert res.exit_code == 0, res.output + res.stderr
    sim.stop()
    flight = next(tmp_path.glob("tank_0p6hz_oracle_fly_*.h5"))
    r = read_run(flight)
    out = r.outcome()
    assert out["docked"] and "captured with a 95 % margin" in out["reason"] + res.output
    dt = float(r.attrs["dt_s"])
    assert abs(out["time_to_dock_s"] - s.outcome["time_to_dock_s"]) <= 10 * dt
    # the camera fed the filter: every frame was decoded (the dock is in view from the start)
    fixes = np.nansum(r.extras["camera_fixes"])
    assert fixes >= 0.9 * CAMERA_RATE_HZ * out["time_to_dock_s"]
    events = [text for _, text in json.loads(out["events_json"])]
    assert any("a sensor of the navigation filter" in e for e in events)
    # the truth agrees: captured at the verdict, never collided
    check = check_flight(flight, tmp_path / "truth.h5")
    assert check.verdict_right and check.truth_contact_at_verdict == "captured", check.lines()
    truth = read_run(tmp_path / "truth.h5").outcome()
    assert math.isnan(truth["first_collided_armed_t_s"])
    # and the flight replays to the same thrust at every step: the fixes it handed the filter are in its
    # tlog (the frames are not), handed over at the same steps
    again, _ = replay(flight.with_suffix(".tlog"), m, tmp_path / "replay.h5")
    assert again.reason == "docked" and again.message in res.output  # the same verdict, said the same
    rr = read_run(tmp_path / "replay.h5")
    assert len(rr.time_s) == len(r.time_s)
    np.testing.assert_allclose(rr.thrust_N, r.thrust_N, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(rr.extras["camera_fixes"], r.extras["camera_fixes"])


def test_a_camera_fix_is_stamped_its_stated_latency_before_the_frame_was_decoded(tmp_path) -> None:
    """A vehicle's camera frame shows the scene ``sensors.dock_camera.latency_s`` before this process
    decoded it (exposure, encoding, the network, FFmpeg's one-frame parser delay): its fix is stamped at
    the scene's instant, as sim stamps its fixes."""
    import cv2

    from auvdock.camera.model import CameraModel, CameraMount, camera_from_dock
    from auvdock.camera.render import render_view
    from auvdock.camera.video_in import Frame
    from auvdock.fly.camera_sensor import CameraSensor
    from auvdock.runtime.clock import WallClock

    m0 = load_mission(TANK_0P6)
    eta = np.array([1.0, 0.0, 1.0, 0.0, 0.0, 0.0])  # 1 m in front of the dock, on its axis
    dock = m0.build_dock(truth=False)
    R_cd, t_cd = camera_from_dock(eta, dock.position(0.0), dock.heading_rad, CameraMount())
    image = render_view(CameraModel.ideal(), m0.dock.marker_layout(), R_cd, t_cd)
    frames = tmp_path / "frames"
    frames.mkdir()
    cv2.imwrite(str(frames / "0.png"), image)
    stamps = {}
    ideal_camera = ROOT / "missions" / "cameras" / "ideal_640x480_80deg.yaml"
    for latency in (0.0, 0.07):
        path = write_mission(
            tmp_path / f"m{latency}.yaml",
            base=TANK_0P6,
            camera={"source": str(frames), "calibration": str(ideal_camera)},
            sensors={"dock_camera": {"enabled": True, "latency_s": latency}},
        )
        sensor = CameraSensor(load_mission(path), WallClock(), None, lambda: (None, None), lambda _: None)  # type: ignore[arg-type]
        sensor.zero_s = 100.0  # the mission's t = 0 on the clock
        fix = sensor.process(Frame(image, t_capture=102.5, index=0, pts_s=None))
        assert fix is not None
        stamps[latency] = fix.t
    assert stamps == {0.0: pytest.approx(2.5), 0.07: pytest.approx(2.43)}


def test_synthetic_camera_without_sim_state_says_what_is_missing(loop, tmp_path) -> None:
    """A vehicle sends no SIM_STATE: fly waits for it and names it; nothing is armed."""
    mission = synthetic_tank(tmp_path, fly={"telemetry_timeout_s": 3.0})
    sim, port = loop.vehicle(mission)
    sim._send_sim_state = lambda: None  # a real vehicle
    res = loop.fly(port, tmp_path, "--arm", mission=mission)
    assert res.exit_code == 3, res.output + res.stderr
    assert res.stderr.strip() == (
        "aborted: no SIM_STATE (camera.source: synthetic renders the view from a simulator's true pose; a "
        "vehicle sends none: set camera.source to its camera's stream, e.g. udp:5600) "
        f"from udpin:127.0.0.1:{port} within 3 s (fly.telemetry_timeout_s)"
    )
    assert not sim.armed


def test_dock_camera_and_a_tracked_dock_are_one_too_many(tmp_path) -> None:
    path = write_mission(tmp_path / "m.yaml", base=TANK_0P6, dock={"source": "camera"})
    with pytest.raises(MissionError) as e:
        check_flyable(load_mission(path))
    assert str(e.value) == (
        f"{path}: sensors.dock_camera: the dock camera is a sensor of the navigation filter, and "
        "dock.source: camera tracks the dock apart from it; choose one "
        "(dock.source: model with sensors.dock_camera)"
    )


# -- the capture rule on an estimate (no link) ------------------------------------------------------
def _estimate(m, nose_past_entrance_m: float, std_m: float, east_m: float = 0.0) -> Estimate:
    """An estimate with the vehicle on the cradle's axis, its nose ``nose_past_entrance_m`` past the
    entrance (tank dock: heading 0, the axis is north), relative covariance ``std_m^2 I``."""
    contact = m.build_contact(m.build_dock())
    body, hull, limits = contact
    dock = np.asarray(m.dock.position_ned_m, dtype=float)
    x = np.zeros(12)
    # the nose is hull._nose_t ahead of the body origin; the entrance at x_d = body.cradle_entrance_x_m
    x[0] = dock[0] + body.cradle_entrance_x_m + nose_past_entrance_m - hull._nose_t[0]
    x[1] = dock[1] + east_m
    x[2] = dock[2]
    return Estimate(
        t=0.0, state=x, relative_cov=np.eye(3) * std_m**2, dock_fix_t=0.0, dock_offset_ned=np.zeros(3)
    )


def _capture_verdict(m) -> CaptureVerdict:
    return CaptureVerdict(MarginVerdict(0.05, m.build_dock(), 0.01), m.build_contact(m.build_dock()))


def test_capture_verdict_needs_the_nose_inside_by_the_95_percent_radius() -> None:
    m = load_mission(TANK_0P6)
    body, hull, limits = m.build_contact(m.build_dock())
    need = limits.nose_inside_depth_m
    v = _capture_verdict(m)
    std = 0.01
    r95 = BOUND_95_3D * std
    assert v.judge(_estimate(m, need + r95 + 0.005, std)).docked
    assert not v.judge(_estimate(m, need + r95 - 0.005, std)).docked  # captured, but not with the margin
    assert not v.judge(_estimate(m, need + 0.005, 0.05)).docked  # too uncertain
    said = v.judge(_estimate(m, need + r95 + 0.005, std)).describe()
    assert said.startswith("on the navigation filter's estimate: captured with a 95 % margin of 0.028 m")


def test_capture_is_judged_against_the_dock_the_estimate_is_relative_to() -> None:
    """The estimate places the dock 6 mm further in than the chart plus its anchor offset does (the
    dock's motion forecast from its telemetry moves it so): the nose is 4 mm past what the margin needs
    against the chart, 2 mm short of it against the estimate's dock, and the verdict is the second."""
    m = load_mission(TANK_0P6)
    need = m.build_contact(m.build_dock())[2].nose_inside_depth_m
    std = 0.002
    est = _estimate(m, need + BOUND_95_3D * std + 0.004, std)
    v = _capture_verdict(m)
    assert v.judge(est).docked  # no dock of its own: the chart moved by the offset
    est.dock_position_ned = np.asarray(m.dock.position_ned_m, dtype=float) + np.array([0.006, 0.0, 0.0])
    judged = v.judge(est)
    assert not judged.docked and judged.distance_m == pytest.approx(
        float(np.linalg.norm(est.state[0:3] - est.dock_position_ned))
    )


def test_fly_judges_on_the_dock_its_estimate_knows(tmp_path) -> None:
    """basin_regular with the dock's telemetry: the deployable controllers' estimate is relative to the
    dock forecast from that telemetry, and fly's verdict judges against that dock (the velocity and
    heading of the capture rule), not against the chart's motion (Oracle: the chart is what it knows)."""
    m = load_mission(BASIN)
    for controller, told in (("sequential", False), ("oracle", True)):
        link = MavlinkLink(f"udpin:127.0.0.1:{free_port()}")
        try:
            session = FlySession(m, link, arm=False, out=tmp_path / f"{controller}.h5", controller=controller)
            verdict = session._verdict()
        finally:
            link.close()
        assert isinstance(verdict, CaptureVerdict)
        assert verdict.margin.dock is session.autopilot.dock
        assert isinstance(session.autopilot.dock, TelemetryDock) is not told


# -- the dock's telemetry over MAVLink ----------------------------------------------------------------
BASIN = ROOT / "missions" / "basin_regular.yaml"


def _received(msg, src: int):
    """``msg`` as fly receives it from system ``src`` (packed and parsed)."""
    from pymavlink.dialects.v20 import ardupilotmega as m2

    mav = m2.MAVLink(None, srcSystem=src, srcComponent=191)
    return m2.MAVLink(None).parse_char(msg.pack(mav))


def test_dock_odometry_becomes_dock_motion_readings_on_the_mission_clock() -> None:
    """ODOMETRY from the dock's system: its x, y, z and covariance as sim's dock_motion readings, at
    time_usec less the vehicle's time at the mission's t = 0; the first step gets the last history_s of the
    record, later steps the new samples; another system's ODOMETRY is not the dock's."""
    from auvdock.fly.dock_telemetry import DockTelemetryIn
    from auvdock.standins.dock_out import odometry

    settings = load_mission(BASIN).sensors.dock_telemetry.model_copy(update={"history_s": 1.0})
    dock = DockTelemetryIn(settings)
    assert dock.missing() == (
        "the dock's telemetry (ODOMETRY from system 2): 0 of 1 s of its record "
        "(sensors.dock_telemetry.history_s)"
    )
    record = [(_received(odometry(0.1 * k, np.array([0.0, 0.0, 0.01 * k]), 0.05), 2), k) for k in range(20)]
    other = _received(odometry(0.55, np.array([9.0, 9.0, 9.0]), 0.05), 7)
    dock.feed([(1000 * k, msg) for msg, k in record[:15]] + [(15_000, other)])
    assert dock.missing() is None  # 1.4 s of record
    first = dock.readings(vehicle_time_at_zero_s=1.0)
    assert [r.kind for r in first] == ["dock_motion"] * 11  # 0.4 .. 1.4 s: the last second
    assert first[0].t == pytest.approx(0.4 - 1.0) and first[-1].t == pytest.approx(1.4 - 1.0)
    assert first[-1].value == pytest.approx([0.0, 0.0, 0.14])
    assert first[-1].std == pytest.approx([0.05, 0.05, 0.05])
    dock.feed([(1000 * k, msg) for msg, k in record[15:]])
    later = dock.readings(vehicle_time_at_zero_s=1.0)
    assert [round(r.t, 6) for r in later] == pytest.approx([0.5, 0.6, 0.7, 0.8, 0.9])
    assert dock.age_s(19_000 + 250_000) == pytest.approx(0.25)


def test_dock_odometry_with_its_rate_becomes_rate_readings_too() -> None:
    """A data sheet's unit (motion_unit: mru) sends the heave rate in ODOMETRY's vx, vy, vz with its
    velocity covariance: fly hands it on as sim's dock_motion_rate readings beside the displacement."""
    from auvdock.fly.dock_telemetry import DockTelemetryIn
    from auvdock.standins.dock_out import odometry

    settings = load_mission(BASIN).sensors.dock_telemetry.model_copy(update={"history_s": 0.0})
    dock = DockTelemetryIn(settings)
    msg = _received(odometry(0.3, np.array([0.0, 0.0, 0.02]), 0.01, np.array([0.0, 0.0, -0.4]), 0.01), 2)
    dock.feed([(1000, msg)])
    out = dock.readings(vehicle_time_at_zero_s=0.0)
    assert [r.kind for r in out] == ["dock_motion", "dock_motion_rate"]
    assert out[1].t == pytest.approx(0.3) and out[1].value == pytest.approx([0.0, 0.0, -0.4])
    assert out[1].std == pytest.approx([0.01, 0.01, 0.01])
    assert out[0].std == pytest.approx([0.01, 0.01, 0.01])


@pytest.mark.slow
def test_fly_forecasts_the_dock_from_its_telemetry_over_mavlink(loop, tmp_path) -> None:
    """basin_regular (waves, the dock's telemetry, the camera alone) with Sequential, which forecasts
    the dock's motion from the telemetry vehicle-sim sends as the dock's own system: fly waits for the
    record, flies on the forecast and captures, right by the truth.  Not compared with sim's time: the
    rehearsal's sea is the one at the vehicle's time when the loop starts (after the record's wait),
    sim's the one at 0."""
    camera = {"source": "synthetic", "calibration": None}
    sensors = {
        "dock_telemetry": {"enabled": True, "history_s": 5.0},
        "dock_camera": {"enabled": True, "visibility_m": 6.0, "rate_hz": CAMERA_RATE_HZ},
    }
    mission = write_mission(tmp_path / "basin.yaml", base=BASIN, camera=camera, sensors=sensors)
    m = load_mission(mission)
    sim, port = loop.vehicle(m, truth_out=tmp_path / "truth.h5", hold_start=True, noise=True)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "40", "-c", "sequential", mission=mission)
    assert res.exit_code == 0, res.output + res.stderr
    sim.stop()
    flight = next(tmp_path.glob("basin_regular_sequential_fly_*.h5"))
    r = read_run(flight)
    assert np.nanmax(r.extras["dock_telemetry_age_s"]) < 0.5  # 10 Hz, 0.25 s late
    assert np.mean(np.isfinite(r.extras["dock_forecast_m"])) > 0.95  # the forecast flew
    check = check_flight(flight, tmp_path / "truth.h5")
    assert check.verdict_right and check.truth_contact_at_verdict == "captured", check.lines()


PACWAVE = ROOT / "missions" / "pacwave_common_10m.yaml"


@pytest.mark.slow
def test_fly_flies_the_wec_dock_at_pacwave_on_its_telemetry(loop, tmp_path) -> None:
    """PacWave's WEC dock heaves with the sea, which a vehicle knows from the dock's telemetry alone:
    vehicle-sim simulates the buoy in the realised sea and sends its motion as the dock's MAVLink system;
    fly with CE waits for the record, arms and flies on the forecast (a short flight: flown, not docked);
    the truth file has the buoy's heave and the contact columns.  Oracle, told the true motion by its
    definition, is refused in one line, as is the mission without the dock's telemetry."""
    camera = {"source": "synthetic", "calibration": None}
    sensors = {
        "dock_telemetry": {"enabled": True, "history_s": 5.0},
        "dock_camera": {"enabled": True, "visibility_m": 4.0, "rate_hz": CAMERA_RATE_HZ},
    }
    mission = write_mission(tmp_path / "pacwave.yaml", base=PACWAVE, camera=camera, sensors=sensors)
    m = load_mission(mission)
    with pytest.raises(MissionError, match=r"dock\.wec: oracle is told the dock's true motion"):
        check_flyable(m)
    with pytest.raises(MissionError, match=r"dock\.wec: a WEC dock moves with the sea, which a vehicle"):
        check_flyable(m.with_updates(sensors__dock_telemetry__enabled=False), "ce")
    sim, port = loop.vehicle(m, truth_out=tmp_path / "truth.h5", hold_start=True)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "2", "-c", "ce", mission=mission)
    assert res.exit_code == 1, res.output + res.stderr  # flown to its timeout
    assert "not docked within 2 s" in res.output
    sim.stop()
    r = read_run(next(tmp_path.glob("pacwave_common_10m_ce_fly_*.h5")))
    assert r.n_steps == 41 and np.all(r.extras["armed"] == 1.0)
    assert np.nanmax(r.extras["dock_telemetry_age_s"]) < 0.5  # the record keeps coming, 10 Hz
    assert np.mean(np.isfinite(r.extras["dock_forecast_m"])) > 0.9  # CE flew on the forecast
    truth = read_run(tmp_path / "truth.h5")
    heave = truth.dock_position_m[:, 2]
    assert np.ptp(heave) > 0.1  # the buoy heaves with the sea (0.46 m std at PacWave's most common sea)
    assert {"contact_status", "nose_dock_m"} <= set(truth.extras)
