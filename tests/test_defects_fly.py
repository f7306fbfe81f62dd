"""``fly`` / ``replay`` defects: no heartbeat says what to check; the tlog of a flight that ended
before its first control step is said to have nothing to replay (not "not written by auvdock
fly").  In simulated time on 127.0.0.1 (tests/helpers/loopback.py)."""

from __future__ import annotations

import pytest
from helpers.loopback import TANK, Loopback, free_port, write_mission

from auvdock.cli import app
from auvdock.fly.link import no_heartbeat_hint


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


def test_no_heartbeat_says_what_to_check(loop, tmp_path) -> None:
    port = free_port()
    res = loop.fly(port, tmp_path, "--connect-timeout", "1")
    assert res.exit_code == 3
    assert res.stderr == (
        f"aborted: no ArduSub heartbeat on udpin:127.0.0.1:{port} within 1 s: is `auvdock vehicle-sim` "
        "running (it sends to udpout:127.0.0.1:14550 unless its --port says otherwise), or the vehicle's "
        f"BlueOS sending MAVLink to 127.0.0.1's port {port}? (BlueOS: the MAVLink Endpoints page, a UDP "
        f"Client endpoint to the topside's address and port {port}; --port udp:{port} listens on "
        f"0.0.0.0:{port})\n"
    )


def test_no_heartbeat_hints_by_kind_of_port() -> None:
    assert "this computer's port 14550" in no_heartbeat_hint("udp:14550")
    assert "udp:14550 listens on 0.0.0.0:14550" in no_heartbeat_hint("udp:14550")
    assert no_heartbeat_hint("udpout:192.168.2.2:14550") == (
        "is `auvdock vehicle-sim --port udpin:192.168.2.2:14550` running, or a BlueOS MAVLink endpoint "
        "(the MAVLink Endpoints page) serving 192.168.2.2:14550?"
    )
    assert no_heartbeat_hint("/dev/ttyACM0,115200") == (
        "is the autopilot connected on /dev/ttyACM0,115200 (and at that baud rate)?"
    )


def test_replay_of_a_flight_no_vehicle_answered(loop, tmp_path) -> None:
    res = loop.fly(free_port(), tmp_path, "--connect-timeout", "1")
    assert res.exit_code == 3
    tlog = next(tmp_path.glob("*.tlog"))
    res = loop.runner.invoke(app, ["replay", str(tlog), str(TANK)])
    assert res.exit_code == 2, res.output
    assert res.stderr == (
        f"error: {tlog}: the flight ended before its first control step (nothing to replay): no vehicle "
        "ever answered (no ArduSub heartbeat in the tlog)\n"
    )


def test_replay_of_a_flight_refused_before_arming(loop, tmp_path) -> None:
    """The vehicle answered, the telemetry came, the pre-flight check refused to arm (a battery
    floor above the vehicle's voltage): no control step, and replay says where it stopped."""
    mission = write_mission(tmp_path / "floor.yaml", fly={"min_battery_v": 100.0})
    _, port = loop.vehicle()
    res = loop.fly(port, tmp_path, "--arm", mission=mission)
    assert res.exit_code == 3, res.output + res.stderr
    assert res.stderr.startswith("aborted: refusing to arm: battery ")
    tlog = next(tmp_path.glob("*.tlog"))
    res = loop.runner.invoke(app, ["replay", str(tlog), str(mission)])
    assert res.exit_code == 2, res.output
    assert res.stderr == (
        f"error: {tlog}: the flight ended before its first control step (nothing to replay): it stopped "
        "after the telemetry wait, before arming (camera start or pre-flight checks)\n"
    )


def test_a_tlog_not_written_by_fly_is_still_called_so(tmp_path) -> None:
    from auvdock.config.mission import load_mission
    from auvdock.fly.replay import ReplayError, replay

    empty = tmp_path / "x.tlog"
    empty.write_bytes(b"")
    with pytest.raises(ReplayError, match="no auvdock step markers"):
        replay(empty, load_mission(TANK), tmp_path / "r.h5")
