"""The simulated ArduSub vehicle (auvdock.standins.vehicle_sim), driven by a pymavlink GCS on loopback.

The vehicle and the GCS (the test's thread) share a :class:`auvdock.runtime.clock.SimClock`: the
vehicle's thread and the test run in lockstep in simulated time, so rates, the 3 s override
lapse and the 3 s failsafe are checked exactly and the tests never wait for the wall clock.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers.loopback import free_port
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auvdock.config.mission import load_mission
from auvdock.runtime.clock import SimClock
from auvdock.standins.vehicle_sim import (
    STREAMS,
    VehicleSim,
    channels_from_manual_control,
    channels_from_override,
    pressure_hpa,
)
from auvdock.vehicle.ardusub import MODES, mix, motor_pwm, thrust_from_channels

ROOT = Path(__file__).resolve().parents[1]
HOST = "127.0.0.1"
M = mavlink2


@pytest.fixture(scope="module")
def mission():
    return load_mission(ROOT / "missions" / "tank_positioned.yaml")


@pytest.fixture
def clock() -> Iterator[SimClock]:
    """The test's simulated clock (the test's thread is its first participant)."""
    with SimClock() as c:
        yield c


def gcs(device: str, clock: SimClock, sysid: int = 255) -> Any:
    """A pymavlink GCS speaking MAVLink 2 from the start, its datagrams counted by ``clock``.

    Set on the connection itself, so that pymavlink's auto-switch (which sets MAVLINK20 in
    os.environ for the whole process) is not needed; test_stock_pymavlink_gcs covers that path.
    """
    conn = mavutil.mavlink_connection(device, source_system=sysid, source_component=190)
    conn.mav = M.MAVLink(conn, srcSystem=sysid, srcComponent=190)
    conn.mav.robust_parsing = True
    conn.WIRE_PROTOCOL_VERSION = "2.0"
    conn.first_byte = False
    clock.attach(conn)
    return conn


@pytest.fixture
def link(mission, clock) -> Iterator[Callable[..., tuple[VehicleSim, Any]]]:
    """Factory: (sim on udpout:PORT, GCS sysid 255 on udpin:PORT), on ``clock``; closed after the test."""
    opened: list[Any] = []

    def make(**kwargs: Any) -> tuple[VehicleSim, Any]:
        port = free_port()
        conn = gcs(f"udpin:{HOST}:{port}", clock)
        sim = VehicleSim(mission, port=f"udpout:{HOST}:{port}", clock=clock, **kwargs)
        opened.extend([sim, conn])
        sim.start()
        assert wait_for(conn, "HEARTBEAT", timeout=2.0) is not None
        return sim, conn

    yield make
    for obj in opened:
        if isinstance(obj, VehicleSim):
            obj.stop()
        else:
            obj.close()


def _clock_of(conn: Any) -> SimClock:
    return conn.port._clock  # the SimClock that counts this connection's datagrams


def recv(conn: Any, timeout: float, mtype: str | None = None) -> Any:
    """The next message (of ``mtype``) within ``timeout`` simulated s, or None."""
    clock = _clock_of(conn)
    end = clock.now() + timeout
    while True:
        m = conn.recv_match(type=mtype, blocking=False)
        if m is not None:
            return m
        left = end - clock.now()
        if left <= 0 or not clock.wait_readable(conn, left):
            return conn.recv_match(type=mtype, blocking=False)


def wait_for(conn: Any, mtype: str, cond: Callable[[Any], bool] = lambda m: True, timeout: float = 2.0):
    clock = _clock_of(conn)
    end = clock.now() + timeout
    while (left := end - clock.now()) >= 0:
        m = recv(conn, left, mtype)
        if m is None:
            return None
        if m.get_srcSystem() == 1 and cond(m):
            return m
    return None


def collect(conn: Any, seconds: float) -> list[Any]:
    """Every message of the next ``seconds`` simulated s."""
    clock = _clock_of(conn)
    out = []
    end = clock.now() + seconds
    while (left := end - clock.now()) > 0:
        m = recv(conn, left)
        if m is not None and m.get_type() != "BAD_DATA":
            out.append(m)
    return out


def command(conn: Any, cmd: int, p1: float = 0.0, p2: float = 0.0, target: int = 1) -> int | None:
    conn.mav.command_long_send(target, 1, cmd, 0, p1, p2, 0, 0, 0, 0, 0)
    ack = wait_for(conn, "COMMAND_ACK", lambda m: m.command == cmd, timeout=2.0)
    return None if ack is None else int(ack.result)


def arm(conn: Any, value: float = 1.0) -> int | None:
    return command(conn, M.MAV_CMD_COMPONENT_ARM_DISARM, value)


def set_interval(conn: Any, name: str, hz: float) -> int | None:
    interval = -1 if hz < 0 else int(1e6 / hz)
    return command(conn, M.MAV_CMD_SET_MESSAGE_INTERVAL, STREAMS[name], interval)


def override(conn: Any, channels: list[int], target: int = 1) -> None:
    conn.mav.rc_channels_override_send(target, 1, *channels, 65535, 65535)


ARMED = M.MAV_MODE_FLAG_SAFETY_ARMED


# --- pure helpers ---------------------------------------------------------------------------
def test_channel_helpers() -> None:
    ch = channels_from_override([0, 65535, 2500, 1000, 1700, 1499])
    assert ch.tolist() == [1500, 1500, 1900, 1100, 1700, 1499]
    # ArduSub joystick: gain 0.5 -> full stick is +-200 us; throttle 0..1000 around 500
    ch = channels_from_manual_control(x=1000, y=-1000, z=1000, r=500, gain=0.5)
    assert ch.tolist() == [1500, 1500, 1700, 1600, 1700, 1300]  # pitch roll throttle yaw forward lateral
    assert channels_from_manual_control(0, 0, 0, 0, 1.0).tolist() == [1500, 1500, 1100, 1500, 1500, 1500]
    assert channels_from_manual_control(32767, 0, 32767, 0, 1.0).tolist() == [1500] * 6
    assert pressure_hpa(0.0) == pytest.approx(1013.25)
    assert pressure_hpa(10.0) == pytest.approx(1013.25 + 1025 * 9.80665 * 10 / 100)


# --- link, heartbeat, arming, modes ----------------------------------------------------------
def test_stock_pymavlink_gcs_heartbeat_and_arming(mission, clock, monkeypatch) -> None:
    """A plain pymavlink GCS (MAVLink 1 until it hears the vehicle) sees a BlueROV2 and arms it."""
    monkeypatch.delenv("MAVLINK20", raising=False)  # pymavlink's auto-switch sets it; undone afterwards
    monkeypatch.setattr(mavutil, "mavlink", mavutil.mavlink)
    monkeypatch.setattr(mavutil, "current_dialect", mavutil.current_dialect)
    port = free_port()
    conn = mavutil.mavlink_connection(f"udpin:{HOST}:{port}", source_system=255, source_component=190)
    clock.attach(conn)
    sim = VehicleSim(mission, port=f"udpout:{HOST}:{port}", speed=2.0, clock=clock)
    try:
        sim.start()
        hb = wait_for(conn, "HEARTBEAT", timeout=2.0)
        assert hb is not None
        assert (hb.get_srcSystem(), hb.get_srcComponent()) == (1, 1)
        assert hb.type == M.MAV_TYPE_SUBMARINE
        assert hb.autopilot == M.MAV_AUTOPILOT_ARDUPILOTMEGA
        assert hb.custom_mode == MODES["MANUAL"] == 19
        assert hb.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        assert hb.base_mode & M.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        assert not hb.base_mode & ARMED
        assert hb.system_status == M.MAV_STATE_STANDBY
        assert conn.WIRE_PROTOCOL_VERSION == "2.0"  # switched on the vehicle's MAVLink 2

        assert arm(conn) == M.MAV_RESULT_ACCEPTED
        assert sim.armed
        hb = wait_for(conn, "HEARTBEAT", lambda m: m.base_mode & ARMED, timeout=1.5)
        assert hb is not None and hb.system_status == M.MAV_STATE_ACTIVE
        assert arm(conn, 0.0) == M.MAV_RESULT_ACCEPTED
        assert not sim.armed
        assert wait_for(conn, "HEARTBEAT", lambda m: not m.base_mode & ARMED, timeout=1.5) is not None
        assert [e.kind for e in sim.events] == ["arm", "disarm"]
        assert any(t == "COMMAND_LONG" and src == 255 for _, t, src, _ in sim.received)
    finally:
        sim.stop()
        conn.close()


def test_refuse_arm_and_unsupported_command(link) -> None:
    sim, conn = link(refuse_arm=True)
    assert arm(conn) == M.MAV_RESULT_FAILED
    assert not sim.armed
    assert command(conn, M.MAV_CMD_REQUEST_MESSAGE, 0) == M.MAV_RESULT_UNSUPPORTED
    assert sim.events == []


def test_mode_changes(link) -> None:
    sim, conn = link(speed=2.0)
    conn.mav.set_mode_send(1, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MODES["ALT_HOLD"])
    ack = wait_for(conn, "COMMAND_ACK", lambda m: m.command == M.MAVLINK_MSG_ID_SET_MODE)
    assert ack is not None and ack.result == M.MAV_RESULT_ACCEPTED
    assert sim.mode == 2 and sim.mode_name == "ALT_HOLD"
    hb = wait_for(conn, "HEARTBEAT", lambda m: m.custom_mode == MODES["ALT_HOLD"], timeout=1.5)
    assert hb is not None

    flag = M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert command(conn, M.MAV_CMD_DO_SET_MODE, flag, MODES["POSHOLD"]) == M.MAV_RESULT_ACCEPTED
    assert sim.mode == 16
    assert command(conn, M.MAV_CMD_DO_SET_MODE, flag, 7) == M.MAV_RESULT_DENIED  # no mode 7 in ArduSub
    assert command(conn, M.MAV_CMD_DO_SET_MODE, 0, MODES["MANUAL"]) == M.MAV_RESULT_DENIED  # no custom flag
    assert command(conn, M.MAV_CMD_DO_SET_MODE, flag, float("nan")) == M.MAV_RESULT_DENIED
    assert sim.mode == 16
    assert wait_for(conn, "HEARTBEAT", lambda m: m.custom_mode == 16, timeout=1.5) is not None
    assert [e.detail for e in sim.events if e.kind == "mode"] == ["MANUAL -> ALT_HOLD", "ALT_HOLD -> POSHOLD"]


# --- telemetry -------------------------------------------------------------------------------
def test_only_heartbeat_until_requested_then_attitude_at_the_requested_rate(link) -> None:
    sim, conn = link()
    assert {m.get_type() for m in collect(conn, 0.5)} <= {"HEARTBEAT"}

    assert set_interval(conn, "ATTITUDE", 20.0) == M.MAV_RESULT_ACCEPTED
    assert sim.stream_intervals == {"ATTITUDE": pytest.approx(0.05)}
    collect(conn, 0.2)  # settle
    att = [m for m in collect(conn, 1.0) if m.get_type() == "ATTITUDE"]
    assert 19 <= len(att) <= 21, len(att)
    steps = np.diff([m.time_boot_ms for m in att])
    assert np.all(steps == 50), steps  # simulated clock: exactly every 50 ms
    assert abs(att[-1].roll) < 0.05 and abs(att[-1].yaw) < 0.05

    assert command(conn, M.MAV_CMD_SET_MESSAGE_INTERVAL, 33, 100000) == M.MAV_RESULT_DENIED  # not a stream
    assert command(conn, M.MAV_CMD_SET_MESSAGE_INTERVAL, STREAMS["ATTITUDE"], -5) == M.MAV_RESULT_DENIED
    assert set_interval(conn, "ATTITUDE", -1) == M.MAV_RESULT_ACCEPTED
    collect(conn, 0.1)
    assert not [m for m in collect(conn, 0.4) if m.get_type() == "ATTITUDE"]
    assert sim.stream_intervals == {}


def test_imu_pressure_and_servos(link) -> None:
    """At rest the IMU reads about -1000 mG on z; SERVO_OUTPUT_RAW follows the mixer once armed.

    The shipped BlueROV2 Heavy is 2 N buoyant (B - W = 114.8 - 112.8 N): it starts rising at
    2 / (13.5 + 14.6) = 0.07 m/s^2 (z acceleration -0.07 m/s^2 in {b}), so the specific force
    on z is -(9.807 + 0.07) m/s^2 = -1007 mG, tending to -1000 mG as drag balances the rise
    (about 0.17 m/s).  Hence the band -1015..-995 mG.
    """
    sim, conn = link()
    for name in ("SCALED_IMU2", "RAW_IMU", "SCALED_PRESSURE2", "SERVO_OUTPUT_RAW"):
        assert set_interval(conn, name, 10.0) == M.MAV_RESULT_ACCEPTED
    msgs = collect(conn, 0.5)
    by_type: dict[str, list[Any]] = {}
    for m in msgs:
        by_type.setdefault(m.get_type(), []).append(m)
    for imu in by_type["SCALED_IMU2"] + by_type["RAW_IMU"]:
        assert -1015 <= imu.zacc <= -995, imu
        assert abs(imu.xacc) <= 3 and abs(imu.yacc) <= 3
        assert abs(imu.xgyro) <= 2 and abs(imu.ygyro) <= 2 and abs(imu.zgyro) <= 2
    depth = sim.state[2]
    assert 0.5 < depth <= 1.0
    for p in by_type["SCALED_PRESSURE2"]:
        assert pressure_hpa(depth) - 0.5 <= p.press_abs <= pressure_hpa(1.0) + 0.01
        assert p.temperature == 1500
    for s in by_type["SERVO_OUTPUT_RAW"]:
        assert [getattr(s, f"servo{i}_raw") for i in range(1, 9)] == [1500] * 8

    assert arm(conn) == M.MAV_RESULT_ACCEPTED
    conn.mav.manual_control_send(1, 1000, 0, 500, 0, 0)  # full forward stick, gain 0.5
    want = np.array([1500, 1500, 1500, 1500, 1700, 1500])
    _clock_of(conn).sleep(0.0)  # the vehicle handles it at once (same simulated instant)
    assert np.array_equal(sim.channels, want)
    assert np.allclose(sim.thrust, thrust_from_channels(want))
    pwm = motor_pwm(mix((want - 1500) / 400)).round().astype(int).tolist()
    s = wait_for(conn, "SERVO_OUTPUT_RAW", lambda m: m.servo1_raw != 1500, timeout=1.0)
    assert s is not None and [getattr(s, f"servo{i}_raw") for i in range(1, 9)] == pwm


# --- pilot input -----------------------------------------------------------------------------
def test_override_accepted_only_from_the_gcs_sysid(link) -> None:
    sim, conn = link()
    host, port = sim.local_address  # the vehicle's socket, for a second sender
    clock = _clock_of(conn)
    other = gcs(f"udpout:{HOST}:{port}", clock, sysid=42)
    try:
        assert arm(conn) == M.MAV_RESULT_ACCEPTED
        assert set_interval(conn, "LOCAL_POSITION_NED", 20.0) == M.MAV_RESULT_ACCEPTED
        forward = [1500, 1500, 1500, 1500, 1700, 1500]
        vx_other = []
        end = clock.now() + 0.8
        while clock.now() < end:
            override(other, forward)
            override(conn, forward, target=2)  # right sender, wrong target
            m = wait_for(conn, "LOCAL_POSITION_NED", timeout=0.2)
            if m is not None:
                vx_other.append(m.vx)
        assert vx_other and max(abs(v) for v in vx_other) < 0.02
        assert np.array_equal(sim.channels, [1500] * 6)
        assert sim.ignored_control >= 8
        assert any(t == "RC_CHANNELS_OVERRIDE" and src == 42 for _, t, src, _ in sim.received)

        vx = 0.0
        end = clock.now() + 2.0
        while clock.now() < end and vx <= 0.1:
            override(conn, forward)
            m = wait_for(conn, "LOCAL_POSITION_NED", timeout=0.2)
            if m is not None:
                vx = m.vx
        assert vx > 0.1
        assert sim.armed and sim.channels[4] == 1700
    finally:
        other.close()


def test_pilot_input_failsafe_disarms_3s_after_last_override(link) -> None:
    sim, conn = link()
    clock = _clock_of(conn)
    assert arm(conn) == M.MAV_RESULT_ACCEPTED
    for _ in range(5):
        override(conn, [1500] * 6)
        clock.sleep(0.1)
    text = wait_for(conn, "STATUSTEXT", lambda m: "Lost manual control" in m.text, timeout=4.0)
    assert text is not None and text.severity == M.MAV_SEVERITY_CRITICAL
    assert not sim.armed
    last = max(w for w, t, src, _ in sim.received if t == "RC_CHANNELS_OVERRIDE")
    kinds = [e.kind for e in sim.events]
    assert kinds == ["arm", "failsafe", "disarm"]
    fs = sim.events[1]
    assert fs.wall_time - last == pytest.approx(3.0, abs=0.011)  # clock.time(): simulated s
    assert sim.events[2].detail == "pilot input failsafe"
    assert wait_for(conn, "HEARTBEAT", lambda m: not m.base_mode & ARMED, timeout=1.5) is not None


def test_override_lapses_3s_after_the_last_message(link) -> None:
    sim, conn = link(speed=4.0)  # 4 simulated s per clock s: the 3 s lapse in 0.75 s of the clock
    clock = _clock_of(conn)
    override(conn, [1500, 1500, 1600, 1500, 1700, 1400])
    clock.sleep(0.0)  # handled at once
    t0 = sim.t
    assert sim.channels.tolist() == [1500, 1500, 1600, 1500, 1700, 1400]
    assert np.all(sim.thrust == 0)  # disarmed
    while sim.t < t0 + 2.9:
        clock.sleep(0.005)
    assert sim.channels[4] == 1700
    assert clock.now() == pytest.approx(sim.t / 4.0, abs=0.01)  # speed 4: 4 vehicle s per clock s
    while sim.t < t0 + 3.05:
        clock.sleep(0.005)
    assert sim.channels.tolist() == [1500] * 6


# --- test hooks and robustness ---------------------------------------------------------------
def test_pause_telemetry_stops_heartbeat(link) -> None:
    sim, conn = link(speed=2.0)  # heartbeat every 0.5 s of the clock
    sim.pause_telemetry(True)
    assert collect(conn, 1.3) == []  # nothing is in flight: messages are read when sent
    sim.pause_telemetry(False)
    assert wait_for(conn, "HEARTBEAT", timeout=1.0) is not None


def test_garbage_is_ignored(link) -> None:
    sim, conn = link()
    _, port = sim.local_address
    raw = mavutil.mavlink_connection(f"udpout:{HOST}:{port}")  # raw datagrams, counted by the clock
    _clock_of(conn).attach(raw)
    try:
        rng = np.random.default_rng(1)
        for n in (1, 7, 64, 280):
            raw.write(rng.integers(0, 256, n, dtype=np.uint8).tobytes())
        raw.write(b"\xfd\x09\x00\x00\x00\xff\xbe\x00\x00")  # truncated MAVLink 2
        raw.write(b"\xfe\xff" + b"\x00" * 20)  # MAVLink 1 magic, nonsense
    finally:
        raw.close()
    _clock_of(conn).sleep(0.1)
    assert sim.running
    assert arm(conn) == M.MAV_RESULT_ACCEPTED
    assert sim.garbage_count >= 1


def test_udpin_vehicle_replies_to_its_client(mission, clock) -> None:
    port = free_port()
    with VehicleSim(mission, port=f"udpin:{HOST}:{port}", clock=clock) as sim:
        conn = gcs(f"udpout:{HOST}:{port}", clock)
        try:
            conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            assert wait_for(conn, "HEARTBEAT", timeout=2.0) is not None
            assert arm(conn) == M.MAV_RESULT_ACCEPTED and sim.armed
        finally:
            conn.close()
    assert not sim.running


def test_run_forever_returns_when_stopped(mission, clock) -> None:
    sim = VehicleSim(mission, port=f"udpout:{HOST}:{free_port()}", clock=clock)

    def stop_later() -> None:
        clock.sleep(0.3)
        sim.stop()

    sim.start()
    clock.start_thread(stop_later, "stopper")
    sim.run_forever()
    assert not sim.running
    assert sim.t == pytest.approx(0.3, abs=0.011)
