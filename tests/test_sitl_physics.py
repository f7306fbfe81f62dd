"""auvdock as the physics backend of ArduPilot SITL's JSON interface (auvdock.standins.sitl_physics).

No SITL here: the SITL side is a plain UDP socket in the test that speaks SIM_JSON's protocol
(binary servo frames in, one JSON line between newlines back) on 127.0.0.1.  The server
answers in lockstep with the frames, so what it answers does not depend on timing; receives
wait with generous timeouts and nothing asserts a wall-clock duration.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers.loopback import free_udp_pair
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.config.mission import load_mission
from auvdock.standins.sitl_physics import (
    DESCENT_SPEED_M_S,
    MAGIC_16,
    MAGIC_32,
    SURFACE_S,
    SitlPhysics,
    fdm_reply,
    motor_thrust,
    parse_listen,
    parse_servo_frame,
)
from auvdock.vehicle.ardusub import PWM_PER_UNIT, mix, motor_pwm, t200_pwm_to_force, thrust_from_channels
from auvdock.world.plant import TruthPlant

ROOT = Path(__file__).resolve().parents[1]
MISSIONS = ROOT / "missions"
G = 9.80665
RATE = 400
RECV_TIMEOUT_S = 60.0  # a busy machine: generous, never a timing assertion
KEYS = {"timestamp", "imu", "position", "attitude", "velocity"}
runner = CliRunner()


def frame(
    count: int, pwm: list[float] | np.ndarray | None = None, rate: int = RATE, channels: int = 16
) -> bytes:
    """A servo frame as SITL sends it (motors 1..8 first, unused channels 0)."""
    p = [1500] * 8 if pwm is None else [int(round(v)) for v in pwm]
    p = (p + [0] * channels)[:channels]
    magic = MAGIC_16 if channels == 16 else MAGIC_32
    return struct.pack(f"<HHI{channels}H", magic, rate, count, *p)


class Peer:
    """The SITL side: sends frames, reads the answers."""

    def __init__(self, server: tuple[str, int]) -> None:
        self.server = server
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(RECV_TIMEOUT_S)

    def send(self, data: bytes) -> None:
        self.sock.sendto(data, self.server)

    def recv(self) -> bytes:
        data, sender = self.sock.recvfrom(65536)
        assert sender == self.server
        return data

    def exchange(self, data: bytes) -> dict:
        self.send(data)
        return parse(self.recv())

    def close(self) -> None:
        self.sock.close()


def parse(reply: bytes) -> dict:
    """What SIM_JSON reads: one JSON object between two newlines, compact, with the required keys."""
    assert reply.startswith(b"\n{") and reply.endswith(b"}\n") and reply.count(b"\n") == 2, reply
    assert b" " not in reply, reply  # SIM_JSON reads each value right after '"key":'
    msg = json.loads(reply)
    assert set(msg) == KEYS, msg
    assert set(msg["imu"]) == {"gyro", "accel_body"}
    for v in (
        msg["imu"]["gyro"],
        msg["imu"]["accel_body"],
        msg["position"],
        msg["attitude"],
        msg["velocity"],
    ):
        assert len(v) == 3 and all(np.isfinite(v))
    return msg


@pytest.fixture
def serve():
    """serve(mission, **kw) -> (physics, peer), stopped and closed after the test."""
    made: list[tuple[SitlPhysics, Peer]] = []

    def make(mission: str = "tank_positioned", **kw) -> tuple[SitlPhysics, Peer]:
        physics = SitlPhysics(
            load_mission(MISSIONS / f"{mission}.yaml"), listen=("127.0.0.1", 0), **kw
        ).start()
        peer = Peer(physics.local_address)
        made.append((physics, peer))
        return physics, peer

    yield make
    for physics, peer in made:
        peer.close()
        physics.stop()


def surge_pwm(s: float = 0.5) -> np.ndarray:
    """Motor PWM of ArduSub's mixer for a pure forward input s in [-1, 1] (channel 5)."""
    return motor_pwm(mix(np.array([0.0, 0.0, 0.0, 0.0, s, 0.0])))


# --- the protocol's pieces ----------------------------------------------------------------------


def test_servo_frames_are_parsed_and_everything_else_is_not() -> None:
    f = parse_servo_frame(frame(7, [1100, 1900, 1500, 1500, 0, 1500, 1500, 1600], rate=1200))
    assert f is not None and (f.frame_rate, f.frame_count) == (1200, 7) and f.pwm.shape == (16,)
    assert list(f.pwm[:8]) == [1100, 1900, 1500, 1500, 0, 1500, 1500, 1600]
    f32 = parse_servo_frame(frame(2**32 - 1, channels=32))
    assert f32 is not None and f32.frame_count == 2**32 - 1 and f32.pwm.shape == (32,)
    good = frame(1)
    for bad in (
        b"",
        b"\x1aH",
        good[:-2],  # short
        good + b"\0\0",  # long
        struct.pack("<HHI32H", MAGIC_16, RATE, 1, *[1500] * 32),  # 16-channel magic, 32 channels
        struct.pack("<HHI16H", MAGIC_32, RATE, 1, *[1500] * 16),  # 32-channel magic, 16 channels
        struct.pack("<HHI16H", 12345, RATE, 1, *[1500] * 16),  # unknown magic
        frame(1, rate=0),  # no step
    ):
        assert parse_servo_frame(bad) is None, bad


def test_motor_pwm_to_thrust_is_the_manual_path_after_the_mixer() -> None:
    for channels in ([1500] * 6, [1500, 1500, 1500, 1500, 1700, 1500], [1600, 1450, 1300, 1800, 1250, 1650]):
        c = (np.array(channels, dtype=float) - 1500) / PWM_PER_UNIT
        pwm = motor_pwm(mix(c))
        np.testing.assert_array_equal(motor_thrust(np.r_[pwm, np.zeros(8)]), thrust_from_channels(channels))
    # 0 (no output) is neutral; values outside 1100..1900 are clamped
    np.testing.assert_array_equal(motor_thrust(np.zeros(16)), np.zeros(8))
    out = motor_thrust(np.array([900, 2100, 1000, 2000, 1100, 1900, 1, 65535] + [0] * 8))
    edge = t200_pwm_to_force(np.array([1900, 1100, 1900, 1100, 1900, 1100, 1900, 1100]))
    np.testing.assert_array_equal(out, edge)


def test_reply_is_one_compact_json_line_between_newlines() -> None:
    x = np.array([1.0, -2.0, 3.5, 0.1, -0.2, 3.5, 0.3, 0.0, 0.0, 0.01, 0.02, 0.03])
    reply = fdm_reply(1.25, x, np.array([0.1, 0.2, -9.7]), x[9:12])
    msg = parse(reply)
    assert msg["timestamp"] == 1.25
    assert msg["position"] == [1.0, -2.0, 3.5]
    assert msg["attitude"][:2] == [0.1, -0.2] and msg["attitude"][2] == pytest.approx(3.5 - 2 * np.pi)
    np.testing.assert_allclose(msg["velocity"], TruthPlant.rotation(x) @ x[6:9])
    assert msg["imu"] == {"gyro": [0.01, 0.02, 0.03], "accel_body": [0.1, 0.2, -9.7]}


def test_listen_addresses() -> None:
    assert parse_listen("127.0.0.1:9002") == ("127.0.0.1", 9002)
    assert parse_listen("9003") == ("127.0.0.1", 9003)
    assert parse_listen("0.0.0.0:9002") == ("0.0.0.0", 9002)
    for bad, why in (("foo", "expected HOST:PORT"), ("1.2.3.4:0", "outside"), ("h:70000", "outside")):
        with pytest.raises(ValueError, match=why):
            parse_listen(bad)


# --- (a) neutral frames: held, then free ----------------------------------------------------------


def test_neutral_frames_hold_the_vehicle_at_the_start(serve) -> None:
    physics, peer = serve(boot_at_surface=False)
    x0 = physics.mission.start_state()
    for k in range(400):
        msg = peer.exchange(frame(k))
        assert msg["timestamp"] == pytest.approx((k + 1) / RATE, abs=1e-12)
        assert msg["position"] == list(x0[0:3]) and msg["attitude"] == list(x0[3:6])
        assert msg["velocity"] == [0.0, 0.0, 0.0]
        assert msg["imu"] == {"gyro": [0.0, 0.0, 0.0], "accel_body": [0.0, 0.0, -G]}
    assert physics.hold_phase == "start" and physics.frames == 400 and physics.t == pytest.approx(1.0)
    assert [e.kind for e in physics.events] == ["connected"]
    status = physics.status()
    dock = physics.mission.build_dock()
    assert status.dock_distance_m == pytest.approx(np.linalg.norm(dock.position(1.0) - x0[0:3]))
    distances = [np.linalg.norm(dock.position((k + 1) / RATE) - x0[0:3]) for k in range(400)]
    assert status.closest_m == pytest.approx(min(distances))
    assert status.closest_t == pytest.approx((int(np.argmin(distances)) + 1) / RATE)


def test_distances_are_to_the_true_dock(serve) -> None:
    """A camera mission's rendered dock is displaced (camera.synthetic.dock_offset_m): the true one."""
    physics, peer = serve("sitl_camera", boot_at_surface=False, dock_offset_ned_m=[0.0, 0.2, 0.0])
    peer.exchange(frame(0))
    true_dock = physics.mission.build_dock().position(1 / RATE) + np.array([0.0, 0.2, 0.0])
    x0 = physics.mission.start_state()
    assert physics.status().dock_distance_m == pytest.approx(np.linalg.norm(true_dock - x0[0:3]))


def test_held_vehicle_boots_at_the_surface_and_is_lowered_to_the_start(serve) -> None:
    """ArduSub zeroes its depth sensor at boot: the held vehicle is at the surface first, then
    lowered along a smooth path whose velocity and IMU agree with its positions, then held."""
    physics, peer = serve()  # tank: start 1 m deep
    x0 = physics.mission.start_state()
    end = physics.at_start_s
    assert end == pytest.approx(SURFACE_S + 1.5 * x0[2] / DESCENT_SPEED_M_S)
    n = int(round(end * RATE)) + RATE
    msgs = [peer.exchange(frame(k)) for k in range(n)]
    t = np.array([m["timestamp"] for m in msgs])
    z = np.array([m["position"][2] for m in msgs])
    vz = np.array([m["velocity"][2] for m in msgs])
    fz = np.array([m["imu"]["accel_body"][2] for m in msgs])
    assert all(m["position"][0:2] == list(x0[0:2]) and m["attitude"] == list(x0[3:6]) for m in msgs)
    surface, lowering, start = t <= SURFACE_S, (t > SURFACE_S) & (t < end), t >= end
    assert np.all(z[surface] == 0.0) and np.all(vz[surface] == 0.0) and np.all(fz[surface] == -G)
    assert np.all(np.diff(z[lowering]) > 0) and 0.0 < z[lowering].min() and z[lowering].max() < x0[2]
    assert vz[lowering].max() == pytest.approx(DESCENT_SPEED_M_S, rel=0.01)
    np.testing.assert_allclose(np.diff(z), (vz[1:] + vz[:-1]) / 2 / RATE, atol=1e-7)  # velocity fits
    np.testing.assert_allclose(fz[1:], -G + np.diff(vz) * RATE, atol=1e-9)  # the IMU fits the velocity
    assert np.all(z[start] == x0[2]) and np.all(vz[start] == 0.0)
    assert np.all(fz[start][1:] == -G)  # (the first: the mean of the descent's last step, still slowing)
    assert [e.kind for e in physics.events] == ["connected", "lowering", "at-start"]
    assert physics.events[2].t == pytest.approx(end, abs=1.5 / RATE) and physics.hold_phase == "start"


def test_no_hold_neutral_vehicle_rises_at_its_terminal_velocity(serve) -> None:
    """Still water, neutral motors: level, no horizontal motion, rising only as fast as 2 N of
    buoyancy against the heave damping allow, step for step the model's own trajectory."""
    physics, peer = serve("still", hold_until_thrust=False)
    m = physics.mission
    plant = TruthPlant(m.build_vehicle(), m.build_flow(), m.start_state(), substeps=m.simulation.substeps)
    p = plant.vehicle.params
    net_up = p.buoyancy_N - p.weight_N  # 2 N
    a0 = net_up / plant.vehicle.model.M[2, 2]  # initial upward acceleration, m/s^2
    lin, quad = p.linear_damping[2], p.quadratic_damping[2]
    w_term = (-lin + np.sqrt(lin**2 + 4 * quad * net_up)) / (2 * quad)  # lin w + quad w^2 = B - W
    n = 10 * RATE
    prev_t = 0.0
    for k in range(n):
        msg = peer.exchange(frame(k))
        assert msg["timestamp"] - prev_t == pytest.approx(1 / RATE, abs=1e-12)
        prev_t = msg["timestamp"]
        plant.step(np.zeros(8), k / RATE, 1 / RATE)
        assert msg["position"] == list(plant.x[0:3])  # the model's own step, to the bit
        assert msg["position"][0:2] == [0.0, 0.0] and msg["attitude"] == [0.0, 0.0, 0.0]
        assert msg["velocity"][0:2] == [0.0, 0.0] and msg["imu"]["gyro"] == [0.0, 0.0, 0.0]
        if k == 0:
            assert msg["imu"]["accel_body"][2] == pytest.approx(-G - a0, abs=1e-3)
    assert msg["timestamp"] == pytest.approx(10.0, abs=1e-9)
    assert -msg["velocity"][2] == pytest.approx(w_term, rel=0.01)  # 0.173 m/s
    assert msg["imu"]["accel_body"] == pytest.approx([0.0, 0.0, -G], abs=1e-3)  # ~ at rest in acceleration
    assert 5.0 - 10 * w_term < msg["position"][2] < 5.0 - 8 * w_term
    assert not physics.holding and [e.kind for e in physics.events] == ["connected"]


def test_no_hold_buoyant_vehicle_floats_at_the_surface_at_rest(serve) -> None:
    physics, peer = serve("tank_positioned", hold_until_thrust=False)  # starts 1 m deep
    for k in range(12 * RATE):
        msg = peer.exchange(frame(k))
    assert msg["position"] == [0.0, 0.0, 0.0] and msg["velocity"] == [0.0, 0.0, 0.0]
    assert msg["imu"]["accel_body"] == pytest.approx([0.0, 0.0, -G], abs=1e-9)


# --- (b) repeated frames, (c) SITL restarts ------------------------------------------------------


def test_a_repeated_frame_gets_the_same_answer_and_does_not_step(serve) -> None:
    physics, peer = serve(hold_until_thrust=False)
    for k in range(10):
        peer.exchange(frame(k))
    peer.send(frame(10))
    first = peer.recv()
    for _ in range(3):  # SITL resends a frame it got no (parsable) answer to
        peer.send(frame(10))
        assert peer.recv() == first
    assert (physics.frames, physics.repeats) == (11, 3)
    assert physics.t == pytest.approx(11 / RATE)
    assert parse(first)["timestamp"] == pytest.approx(11 / RATE, abs=1e-12)
    assert peer.exchange(frame(11))["timestamp"] == pytest.approx(12 / RATE, abs=1e-12)


def test_frame_count_going_back_resets_time_and_vehicle(serve) -> None:
    physics, peer = serve(hold_until_thrust=False)
    first = peer.exchange(frame(0))
    for k in range(1, 800):
        msg = peer.exchange(frame(k, surge_pwm(0.6)))
    assert msg["position"][0] > 0.05  # it moved
    again = peer.exchange(frame(0))  # a restarted SITL counts from 0 again
    assert again == first  # time back to 0, one step from the start
    assert again["timestamp"] == pytest.approx(1 / RATE, abs=1e-12)
    assert physics.resets == 1
    kinds = [e.kind for e in physics.events]
    assert kinds == ["connected", "reset"]
    assert "SITL restarted" in physics.events[-1].detail and physics.events[-1].t == 0.0


def test_reset_holds_the_vehicle_again(serve) -> None:
    physics, peer = serve()
    x0 = physics.mission.start_state()
    for k in range(200):
        peer.exchange(frame(k, surge_pwm(0.6)))
    assert not physics.holding
    msg = peer.exchange(frame(3))  # at the surface again, as after a boot
    assert physics.hold_phase == "surface" and msg["velocity"] == [0.0, 0.0, 0.0]
    assert msg["position"] == [x0[0], x0[1], 0.0] and msg["timestamp"] == pytest.approx(1 / RATE)
    assert [e.kind for e in physics.events] == ["connected", "release", "reset"]


# --- (d) 32 channels, garbage --------------------------------------------------------------------


def test_32_channel_frames_work_and_garbage_is_ignored_and_counted(serve) -> None:
    physics, peer = serve(hold_until_thrust=False)
    sixteen = [peer.exchange(frame(k, surge_pwm(0.4))) for k in range(5)]
    physics2, peer2 = serve(hold_until_thrust=False)
    garbage = [b"", b"hello SITL", frame(5)[:-1], frame(5) + b"\0", frame(5, rate=0), b"\xff" * 72]
    replies = []
    for k in range(5):
        for g in garbage:
            peer2.send(g)
        replies.append(peer2.exchange(frame(k, surge_pwm(0.4), channels=32)))  # the next datagram back
    assert replies == sixteen  # same motors, same answers
    assert physics2.ignored == 5 * len(garbage) and physics2.frames == 5
    assert physics.ignored == 0


# --- (e) thrust -----------------------------------------------------------------------------------


def test_forward_pwm_pushes_the_vehicle_along_body_x_with_the_t200_force(serve) -> None:
    physics, peer = serve(boot_at_surface=False)  # held at the start until this first frame with thrust
    v = physics.vehicle
    pwm = surge_pwm(0.5)
    u = motor_thrust(pwm)
    np.testing.assert_array_equal(u, thrust_from_channels([1500, 1500, 1500, 1500, 1700, 1500]))
    np.testing.assert_array_equal(u, t200_pwm_to_force(3000 - pwm))
    tau = v.allocation @ u
    assert tau[0] > 20.0 and np.allclose(tau[[1, 5]], 0.0, atol=1e-9)  # a surge wrench
    # analytic initial acceleration at rest: M nu_dot = B u - g(eta)
    x0 = physics.mission.start_state()
    restoring = -np.asarray(v.state_derivative(x0, np.zeros(8)))[6:12]  # M^-1 g(eta) at rest
    nu_dot0 = np.linalg.solve(v.model.M, tau) - restoring
    np.testing.assert_allclose(nu_dot0, v.state_derivative(x0, u)[6:12], atol=1e-12)
    first = peer.exchange(frame(0, pwm))
    assert [e.kind for e in physics.events] == ["connected", "release"]
    assert first["imu"]["accel_body"][0] == pytest.approx(nu_dot0[0], rel=0.01)  # ~1.6 m/s^2
    assert first["imu"]["accel_body"][1] == pytest.approx(0.0, abs=1e-9)
    for k in range(1, RATE):
        msg = peer.exchange(frame(k, pwm))
    vel, pos = np.array(msg["velocity"]), np.array(msg["position"])
    assert vel[0] > 0.3 and abs(vel[1]) < 1e-6 and pos[0] > 0.1 and abs(pos[1]) < 1e-6
    assert msg["attitude"][2] == pytest.approx(0.0, abs=1e-9)  # no yaw
    status = physics.status()
    assert status.motors_active and not status.holding and status.frames == RATE


# --- (f) the command line -------------------------------------------------------------------------


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_cli_bad_input_is_one_line_and_exit_2(tmp_path: Path) -> None:
    tank = str(MISSIONS / "tank_positioned.yaml")
    missing = tmp_path / "nosuch.yaml"
    six = MISSIONS / "tank_bluerov2.yaml"
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", 0))
        port = busy.getsockname()[1]
        cases = [
            ([str(missing)], f"error: {missing}: file not found"),
            (
                [str(six)],
                f"error: {six}: vehicle: bluerov2 has 6 thrusters; sitl-physics flies ArduSub's "
                "VECTORED_6DOF frame (the BlueROV2 Heavy), 8 thrusters",
            ),
            (
                [tank, "--listen", "foo"],
                "error: --listen foo: expected HOST:PORT (e.g. 127.0.0.1:9002), got 'foo'",
            ),
            (
                [tank, "--listen", "127.0.0.1:99999"],
                "error: --listen 127.0.0.1:99999: port 99999 is outside 1..65535",
            ),
            (
                [tank, "--listen", f"127.0.0.1:{port}"],
                f"error: --listen 127.0.0.1:{port}: port in use (another sitl-physics or physics backend?)",
            ),
            (
                [tank, "--camera", "tcp:5600"],
                "error: --camera tcp:5600: expected udp:HOST:PORT or udp:PORT "
                "(where fly's camera.source listens)",
            ),
            (
                [tank, "--camera", "udp:65535"],
                "error: --camera udp:65535: port 65535 is outside 1..65534 (RTCP uses port + 1)",
            ),
            ([tank, "--duration", "0"], "error: --duration 0: must be a positive time, s"),
        ]
        for args, line in cases:
            res = runner.invoke(app, ["sitl-physics", *args])
            assert res.exit_code == 2, (args, res.output, res.stderr)
            assert res.stderr.strip() == line, args
            assert "Traceback" not in res.output + res.stderr


def _spawn(args: list[str], sigint_ignored: bool = False) -> subprocess.Popen:
    env = {**os.environ, "AUVDOCK_COMPILE": "never", "PYTHONUNBUFFERED": "1"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    cmd = [sys.executable, "-m", "auvdock", "sitl-physics", *args]

    def ignore_sigint() -> None:  # as a background job of a non-interactive shell starts
        signal.signal(signal.SIGINT, signal.SIG_IGN)

    return subprocess.Popen(
        cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=ignore_sigint if sigint_ignored else None,
    )  # fmt: skip


def _first_answer(peer: Peer, proc: subprocess.Popen) -> dict:
    """Send frame 0 until the starting server answers (resends are answered the same)."""
    peer.sock.settimeout(1.0)
    try:
        for _ in range(int(RECV_TIMEOUT_S)):
            assert proc.poll() is None, proc.communicate()
            peer.send(frame(0))
            try:
                return parse(peer.recv())
            except TimeoutError:
                continue
        raise AssertionError("sitl-physics never answered")
    finally:
        peer.sock.settimeout(RECV_TIMEOUT_S)


def test_cli_serves_frames_and_stops_after_duration() -> None:
    port = _free_udp_port()
    proc = _spawn(["tank_positioned", "--listen", f"127.0.0.1:{port}", "--duration", "0.5", "--no-hold"])
    peer = Peer(("127.0.0.1", port))
    try:
        _first_answer(peer, proc)
        for k in range(1, 200):
            msg = peer.exchange(frame(k))
        assert msg["timestamp"] == pytest.approx(0.5)
        out, err = proc.communicate(timeout=RECV_TIMEOUT_S)
    finally:
        peer.close()
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    lines = out.splitlines()
    assert lines[0].startswith(f"sitl-physics: listening on udp 127.0.0.1:{port} for ArduPilot SITL")
    assert "mission tank_positioned, vehicle bluerov2_heavy (8 thrusters)" in lines[0]
    assert "free from the first frame (--no-hold)" in lines[0]
    assert any("connected: servo frames from 127.0.0.1:" in ln for ln in lines)
    assert any("duration: 0.5 s of physics time done" in ln for ln in lines)
    assert lines[-1].startswith("done: physics time 0.500 s, 200 frames, ")
    assert "0 ignored, 0 SITL restarts" in lines[-1]
    assert err == "" and "\x1b" not in out  # plain lines in a pipe


def _interrupted(frames: int, sig: signal.Signals, sigint_ignored: bool = False) -> tuple[int, str, str]:
    """The CLI server fed ``frames`` frames, then sent ``sig``: (exit status, stdout, stderr)."""
    port = _free_udp_port()
    proc = _spawn(["tank_positioned", "--listen", f"127.0.0.1:{port}"], sigint_ignored=sigint_ignored)
    peer = Peer(("127.0.0.1", port))
    try:
        _first_answer(peer, proc)
        for k in range(1, frames):
            peer.exchange(frame(k))
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=RECV_TIMEOUT_S)
    finally:
        peer.close()
        if proc.poll() is None:
            proc.kill()
    return proc.returncode, out, err


def test_cli_ctrl_c_is_one_summary_line_and_exit_130() -> None:
    rc, out, err = _interrupted(40, signal.SIGINT)
    assert rc == 130, (out, err)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted (Ctrl-C): physics time 0.100 s, 40 frames"), (
        err
    )
    assert "Traceback" not in out + err


@pytest.mark.parametrize(
    ("sig", "ignored", "said"),
    [(signal.SIGTERM, False, "SIGTERM"), (signal.SIGINT, True, "Ctrl-C")],
    ids=["sigterm", "sigint-started-ignored"],
)
def test_sigterm_and_a_sigint_started_ignored_end_it_as_ctrl_c_does(sig, ignored, said) -> None:
    """What Docker, BlueOS and systemd send (SIGTERM), and Ctrl-C to a server started from a script
    (SIGINT ignored): the same one summary line and exit 130 as a Ctrl-C."""
    rc, out, err = _interrupted(20, sig, sigint_ignored=ignored)
    assert rc == 130, (out, err)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    first = f"interrupted ({said}): physics time 0.050 s, 20 frames"
    assert len(lines) == 1 and lines[0].startswith(first), err


def test_the_truth_is_written_every_50_ms_of_physics_time_and_readable_when_stopped(serve, tmp_path) -> None:
    """sitl-physics --truth-out: 1 s of frames at 400 Hz (neutral, then the motors pushing forward) gives a
    results file of the truth every 0.05 s of physics time, complete once the server stops, with whether
    the motors push, in the format truth-check reads."""
    from auvdock.results.store import read_run

    truth = tmp_path / "truth.h5"
    physics, peer = serve(hold_until_thrust=False, truth_out=truth)
    for k in range(RATE):
        peer.exchange(frame(k, surge_pwm(0.5) if k >= RATE // 2 else None))
    physics.stop()
    t = read_run(truth)
    assert t.attrs["complete"] and t.attrs["stand_in"] == "sitl-physics"
    assert t.attrs["source"] == "vehicle-sim truth"  # the one truth format truth-check reads
    assert np.allclose(np.diff(t.time_s), 0.05, atol=1.5 / RATE)
    assert t.time_s[-1] >= 0.95 - 1e-9
    armed = t.extras["armed"]
    assert armed[0] == 0.0 and armed[-1] == 1.0
    assert t.state[-1, 6] > t.state[len(armed) // 2 - 1, 6]  # surging once the motors push
    assert np.allclose(t.distance_m, np.linalg.norm(t.state[:, 0:3] - t.dock_position_m, axis=1))


def test_the_truth_measures_to_the_dock_the_camera_sees(serve, tmp_path) -> None:
    """With the camera's dock displaced (camera.synthetic.dock_offset_m) the truth file's dock is the
    displaced one, the dock the vehicle can find: measured to the mission's charted dock, truth-check
    called a docking 0.03 m from the rendered dock wrong, 0.217 m away."""
    from auvdock.results.store import read_run

    truth = tmp_path / "truth.h5"
    offset = [0.0, 0.2, 0.0]
    physics, peer = serve("sitl_camera", hold_until_thrust=False, dock_offset_ned_m=offset, truth_out=truth)
    for k in range(RATE // 4):
        peer.exchange(frame(k))
    physics.stop()
    t = read_run(truth)
    charted = physics.mission.build_dock().position(t.time_s)
    np.testing.assert_allclose(t.dock_position_m, charted + np.array([0.0, 0.2, 0.0]), atol=1e-9)


# --- (g) the camera through the real video path ---------------------------------------------------




def test_camera_streams_the_true_view_over_rtp_and_the_markers_are_found(serve) -> None:
    """sitl_camera's camera (its calibration file, mount, markers, dock offset) rendered from
    the true pose after the vehicle rose for 2 s, with the dock where it heaves then, sent as
    RTP/H.264, received by open_source("udp:PORT") as fly receives it: the dock pose from the
    received frames is the true one."""
    pytest.importorskip("av")
    from auvdock.camera.model import CameraMount, camera_from_dock
    from auvdock.camera.pose import MarkerDetector, estimate_dock_pose
    from auvdock.camera.video_in import open_source
    from auvdock.standins.truth_camera import TruthCameraStream

    physics, peer = serve("sitl_camera", hold_until_thrust=False)
    for k in range(2 * RATE):  # 2 s of floating up, then no more frames: the pose stays put
        peer.exchange(frame(k))
    m = physics.mission
    t, eta = physics.pose()
    assert t == pytest.approx(2.0) and 0.02 < m.start_state()[2] - eta[2] < 0.3
    cam = m.build_camera()
    dock = m.build_dock()
    mount = CameraMount(tuple(m.camera.mount.position_body_m), tuple(m.camera.mount.rpy_deg))
    _, t_cd_true = camera_from_dock(
        eta, dock.position(t) + np.array(m.camera.synthetic.dock_offset_m), dock.heading_rad, mount
    )
    port = free_udp_pair()
    received = []
    with open_source(f"udp:{port}") as source:
        stream = TruthCameraStream.from_mission(m, physics.pose, "127.0.0.1", port).start()
        try:
            for _ in range(200):
                f = source.read(0.5)
                if f is not None:
                    received.append(f.image)
                if len(received) >= 4 or stream.error is not None:
                    break
        finally:
            stream.stop()
    assert stream.error is None and stream.frames_sent >= len(received) >= 4
    detector = MarkerDetector(m.dock.marker_layout(), cam)
    for image in received:
        assert image.shape == (480, 640)
        pose = estimate_dock_pose(detector.detect(image), m.dock.marker_layout(), cam)
        assert pose is not None
        np.testing.assert_allclose(pose.t_cd, t_cd_true, atol=0.03)


def test_truth_stream_frame_is_the_synthetic_camera_view_of_the_pose() -> None:
    from auvdock.standins.truth_camera import TruthCameraStream

    m = load_mission(MISSIONS / "sitl_camera.yaml")
    eta = m.start_state()[0:6] + np.array([0.3, 0.05, 0.0, 0.0, 0.0, 0.1])
    a = TruthCameraStream.from_mission(m, lambda: (0.7, eta), "127.0.0.1", 5600, seed=3)
    b = TruthCameraStream.from_mission(m, lambda: (0.0, np.zeros(6)), "127.0.0.1", 5600, seed=3)
    img = a.frame()  # what pose_fn says now
    np.testing.assert_array_equal(img, b.renderer.render(0.7, eta))  # same seed, same noise
    assert img.shape == (480, 640) and img.dtype == np.uint8 and img.min() < 40 and img.max() > 200
    assert a.rate_hz == m.camera.synthetic.rate_hz and not a.running
