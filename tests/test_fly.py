"""``auvdock fly`` against ``VehicleSim`` (auvdock's ArduSub-like MAVLink vehicle), on 127.0.0.1 only.

The vehicle simulator runs in this process (a thread) on ``udpout:127.0.0.1:PORT``; ``fly``
listens on ``udpin:127.0.0.1:PORT``, in this process through the CLI or in a subprocess
for Ctrl-C.  Everything runs in real time.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.hardware.link import connection_string
from auvdock.hardware.vehicle_sim import VehicleSim
from auvdock.mission import load_mission
from auvdock.results import read_run

ROOT = Path(__file__).resolve().parents[1]
TANK = ROOT / "missions" / "tank_0p6hz.yaml"
runner = CliRunner()
ARM_DISARM = 400
NEUTRAL, RELEASE = (1500,) * 6, (0,) * 6


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def fly_args(port: int, out: Path, *extra: str, mission: Path = TANK) -> list[str]:
    return ["fly", str(mission), "--port", f"udpin:127.0.0.1:{port}", "--out", str(out), *extra]


def overrides(sim: VehicleSim) -> list[tuple[float, tuple[int, ...]]]:
    out = []
    for wall, mtype, _src, d in list(sim.received):
        if mtype == "RC_CHANNELS_OVERRIDE":
            out.append((wall, tuple(d[f"chan{i}_raw"] for i in range(1, 7))))
    return out


def arm_commands(sim: VehicleSim) -> list:
    return [
        d
        for _, mtype, _, d in list(sim.received)
        if mtype in ("COMMAND_LONG", "COMMAND_INT")
        and d.get("command") == ARM_DISARM
        and d.get("param1") == 1
    ]


def test_connection_strings() -> None:
    assert connection_string("udp:14550") == "udpin:0.0.0.0:14550"
    assert connection_string("udpout:192.168.2.1:14550") == "udpout:192.168.2.1:14550"
    assert connection_string("/dev/ttyACM0,115200") == "/dev/ttyACM0,115200"
    with pytest.raises(ValueError, match="outside 1..65535"):
        connection_string("udp:70000")


def test_fly_arm_docks_in_the_tank(tmp_path) -> None:
    """vehicle-sim + fly --arm with Oracle MPC docks in still water (tank mission, 0.6 Hz heave)."""
    port = free_port()
    with VehicleSim(load_mission(TANK), port=f"udpout:127.0.0.1:{port}") as sim:
        res = runner.invoke(app, fly_args(port, tmp_path, "--arm", "--timeout", "40"))
        assert res.exit_code == 0, res.output + res.stderr
        assert "docked at t =" in res.output
        time.sleep(0.3)
        kinds = [e.kind for e in sim.events]
        assert kinds[0] == "arm" and "disarm" in kinds
        assert not sim.armed
    h5 = next(tmp_path.glob("tank_0p6hz_oracle_fly_*.h5"))
    tlog = h5.with_suffix(".tlog")
    assert tlog.stat().st_size > 1000
    r = read_run(h5)
    assert r.attrs["complete"]
    assert r.outcome()["docked"]
    assert r.outcome()["closest_approach_m"] <= 0.05
    assert r.extras["channels_us"].shape[1] == 6
    assert np.all(r.extras["telemetry_age_s"] < 0.3)
    # the tlog replays with pymavlink: our overrides and the vehicle's heartbeats are both in it
    from pymavlink import mavutil

    log = mavutil.mavlink_connection(str(tlog))
    types = set()
    while (m := log.recv_match()) is not None:
        types.add(m.get_type())
    assert {"HEARTBEAT", "RC_CHANNELS_OVERRIDE", "ATTITUDE", "COMMAND_ACK"} <= types


def test_dry_run_never_arms(tmp_path) -> None:
    port = free_port()
    with VehicleSim(load_mission(TANK), port=f"udpout:127.0.0.1:{port}") as sim:
        res = runner.invoke(app, fly_args(port, tmp_path, "--timeout", "2"))
        assert res.exit_code == 1, res.output  # not docked in 2 s
        time.sleep(0.2)
        assert arm_commands(sim) == []
        assert not any(e.kind == "arm" for e in sim.events)
        ov = overrides(sim)
        assert len(ov) > 20  # streamed at the control rate
        # neutral all along, then the channels released to the RC radio (0) at the end
        assert all(ch == NEUTRAL for _, ch in ov[:-1])
        assert ov[-1][1] == RELEASE
    assert "dry run" in res.output


def test_lost_telemetry_neutral_then_abort(tmp_path) -> None:
    port = free_port()
    with VehicleSim(load_mission(TANK), port=f"udpout:127.0.0.1:{port}") as sim:
        t_pause: list[float] = []

        def pause_later():
            time.sleep(4.0)
            t_pause.append(time.time())
            sim.pause_telemetry(True)

        import threading

        th = threading.Thread(target=pause_later, daemon=True)
        th.start()
        t0 = time.time()
        res = runner.invoke(app, fly_args(port, tmp_path, "--arm", "--timeout", "30"))
        elapsed = time.time() - t0
        th.join()
        assert res.exit_code == 3, res.output
        assert "aborted: telemetry lost: no ATTITUDE or position for" in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1
        # neutral within 0.5 s of the last telemetry, and the session ended about 2 s later
        late = [ch for wall, ch in overrides(sim) if wall > t_pause[0] + 0.5]
        assert late and all(ch in (NEUTRAL, RELEASE) for ch in late)
        assert elapsed > 4.0
    h5 = next(tmp_path.glob("*.h5"))
    with h5py.File(h5, "r") as f:
        assert f.attrs["reason"] == "aborted"
        events = json.loads(f.attrs["events_json"])
    t_stale = next(t for t, text in events if text.startswith("telemetry stale"))
    t_abort = next(t for t, text in events if text.startswith("abort: telemetry lost"))
    assert 1.4 < t_abort - t_stale < 2.6  # stale at 0.3 s, abort at 2 s


def test_geofence_aborts_and_disarms(tmp_path) -> None:
    data = yaml.safe_load(TANK.read_text())
    data["fly"] = {"geofence": {"max_distance_m": 0.3}}
    mission = tmp_path / "fence.yaml"
    mission.write_text(yaml.safe_dump(data))
    port = free_port()
    with VehicleSim(load_mission(mission), port=f"udpout:127.0.0.1:{port}") as sim:
        res = runner.invoke(app, fly_args(port, tmp_path, "--arm", "--timeout", "30", mission=mission))
        assert res.exit_code == 3, res.output
        assert res.stderr.strip().startswith("aborted: geofence: ")
        assert "(limit 0.3 m)" in res.stderr
        time.sleep(0.3)
        assert not sim.armed
        assert [e.kind for e in sim.events][-1] == "disarm"


def test_ctrl_c_disarms_and_keeps_results(tmp_path) -> None:
    port = free_port()
    with VehicleSim(load_mission(TANK), port=f"udpout:127.0.0.1:{port}") as sim:
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        proc = subprocess.Popen(
            [sys.executable, "-m", "auvdock.cli", *fly_args(port, tmp_path, "--arm", "--timeout", "60")],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            env=env,
            text=True,
        )
        deadline = time.time() + 30
        while not sim.armed and time.time() < deadline:
            time.sleep(0.1)
        assert sim.armed
        time.sleep(2.0)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=20)
        assert proc.returncode == 130, out + err
        assert "interrupted" in err
        time.sleep(0.2)
        assert not sim.armed
    h5 = next(tmp_path.glob("*.h5"))
    r = read_run(h5)
    assert len(r.time_s) > 10
    with h5py.File(h5, "r") as f:
        assert f.attrs["reason"] == "interrupted"


def test_no_vehicle_clear_error(tmp_path) -> None:
    port = free_port()
    res = runner.invoke(app, fly_args(port, tmp_path, "--connect-timeout", "1"))
    assert res.exit_code == 3
    assert res.stderr.strip() == f"aborted: no ArduSub heartbeat on udpin:127.0.0.1:{port} within 1 s"


def test_dock_from_landing_target(tmp_path) -> None:
    """dock.source: mavlink -- the real dock is 0.3 m east of the model's; LANDING_TARGET leads there."""
    from auvdock.dock import HeaveDock

    data = yaml.safe_load(TANK.read_text())
    data["dock"]["source"] = "mavlink"
    mission = tmp_path / "target.yaml"
    mission.write_text(yaml.safe_dump(data))
    m = load_mission(mission)
    model = m.build_dock()
    real = HeaveDock(
        (model.position_ned_m[0], model.position_ned_m[1] + 0.3, model.position_ned_m[2]),
        model.heading_rad,
        model.amplitude_m,
        model.angular_frequency_rad_s,
        model.phase_rad,
    )
    port = free_port()
    with VehicleSim(m, port=f"udpout:127.0.0.1:{port}") as sim:
        sim.set_landing_target(real, rate_hz=10.0)
        res = runner.invoke(app, fly_args(port, tmp_path, "--arm", "--timeout", "40", mission=mission))
        assert res.exit_code == 0, res.output + res.stderr
        # the vehicle is at the real dock (its own truth state, not what fly believed)
        assert np.linalg.norm(sim.state[0:3] - real.position(sim.t)) < 0.15
        assert np.linalg.norm(sim.state[0:3] - model.position(sim.t)) > 0.15


def test_no_landing_target_aborts(tmp_path) -> None:
    data = yaml.safe_load(TANK.read_text())
    data["dock"]["source"] = "mavlink"
    mission = tmp_path / "target.yaml"
    mission.write_text(yaml.safe_dump(data))
    port = free_port()
    with VehicleSim(load_mission(mission), port=f"udpout:127.0.0.1:{port}"):
        res = runner.invoke(app, fly_args(port, tmp_path, "--arm", "--timeout", "30", mission=mission))
    assert res.exit_code == 3
    assert res.stderr.strip() == "aborted: no LANDING_TARGET with a position within 2 s"
