"""``auvdock fly`` with ``dock.source: camera``: the synthetic camera + vehicle-sim, on 127.0.0.1 only.

The synthetic camera renders the dock's markers from the vehicle's pose (the mission's ideal
640x480 camera), the tracker detects them in its own thread, and the dock filter re-anchors
the heave model; the rendered dock is 0.2 m east of the mission's, so only a camera that
really tracks it can dock there.
"""

from __future__ import annotations

import dataclasses
import json
import socket
import time
from pathlib import Path

import numpy as np
import yaml
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.fly import CAMERA_STATES
from auvdock.hardware.vehicle_sim import VehicleSim
from auvdock.mission import load_mission
from auvdock.results import read_run

ROOT = Path(__file__).resolve().parents[1]
TANK = ROOT / "missions" / "tank_0p6hz.yaml"
runner = CliRunner()
NEUTRAL = (1500,) * 6
OFFSET_EAST_M = 0.2


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def camera_mission(tmp_path: Path, **camera) -> Path:
    data = yaml.safe_load(TANK.read_text())
    data["dock"]["source"] = "camera"
    data["camera"] = {"source": "synthetic", **camera}
    data["camera"].setdefault("synthetic", {})["dock_offset_m"] = [0.0, OFFSET_EAST_M, 0.0]
    path = tmp_path / "camera.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def fly(port: int, out: Path, mission: Path, *extra: str):
    return runner.invoke(
        app, ["fly", str(mission), "--port", f"udpin:127.0.0.1:{port}", "--out", str(out), "--arm", *extra]
    )


def test_synthetic_camera_docks_in_the_tank_through_a_short_loss(tmp_path) -> None:
    """Docks at the rendered dock; a 0.8 s blackout (hold 0.5 s) is held neutral, then recovered."""
    mission = camera_mission(tmp_path, hold_s=0.5, abort_s=3.0, synthetic={"dropout_s": [[3.0, 3.8]]})
    m = load_mission(mission)
    model = m.build_dock()
    n, e, d = model.position_ned_m
    real = dataclasses.replace(model, position_ned_m=(n, e + OFFSET_EAST_M, d))
    port = free_port()
    with VehicleSim(m, port=f"udpout:127.0.0.1:{port}") as sim:
        res = fly(port, tmp_path, mission, "--timeout", "45")
        assert res.exit_code == 0, res.output + res.stderr
        # the vehicle (its own truth state) is at the rendered dock, not at the mission's
        assert np.linalg.norm(sim.state[0:3] - real.position(sim.t)) < 0.12
        assert np.linalg.norm(sim.state[0:3] - model.position(sim.t)) > 0.12
    r = read_run(next(tmp_path.glob("*_fly_*.h5")))
    assert r.outcome()["docked"]
    events = [text for _, text in json.loads(r.outcome()["events_json"])]
    assert any(e.startswith("camera: dock found") for e in events)
    assert any(e.startswith("camera: dock lost for") and "holding" in e for e in events)
    assert any(e.startswith("camera: dock recovered") for e in events)
    state = r.extras["camera_state"].astype(int)
    holding = state == CAMERA_STATES.index("holding")
    assert holding.any()
    assert np.all(r.thrust_N[holding] == 0.0)  # neutral while the dock is lost
    assert np.all(r.extras["channels_us"][holding] == 1500)
    assert np.nansum(r.extras["camera_fixes"]) > 50  # fixes kept coming (about 15/s)
    latency = r.extras["camera_latency_s"]  # recorded (its size is a benchmark figure, not asserted)
    assert np.isfinite(latency).sum() > 50 and np.all(latency[np.isfinite(latency)] > 0)


def test_markers_lost_longer_than_hold_neutral_then_abort(tmp_path) -> None:
    mission = camera_mission(tmp_path, hold_s=1.0, abort_s=2.5, synthetic={"dropout_s": [[2.0, 100.0]]})
    port = free_port()
    with VehicleSim(load_mission(mission), port=f"udpout:127.0.0.1:{port}") as sim:
        res = fly(port, tmp_path, mission, "--timeout", "30")
        time.sleep(0.2)
        assert not sim.armed  # every ending disarms
    assert res.exit_code == 3, res.output + res.stderr
    assert res.stderr.strip().startswith("aborted: camera: dock lost for ")
    assert res.stderr.strip().endswith("s (limit 2.5 s)")
    r = read_run(next(tmp_path.glob("*_fly_*.h5")))
    events = [text for _, text in json.loads(r.outcome()["events_json"])]
    i_hold = next(i for i, e in enumerate(events) if "holding" in e)
    i_abort = next(i for i, e in enumerate(events) if e.startswith("abort: camera: dock lost"))
    assert i_hold < i_abort
    state = r.extras["camera_state"].astype(int)
    t = r.time_s
    holding = state == CAMERA_STATES.index("holding")
    # tracking until the markers vanish at 2 s, neutral from hold_s after that, abort at abort_s
    assert t[holding].min() >= 2.0 + 1.0 - 0.2
    assert t[-1] <= 2.0 + 2.5 + 0.5
    assert np.all(r.thrust_N[holding] == 0.0)


def test_no_markers_ever_aborts(tmp_path) -> None:
    mission = camera_mission(tmp_path, hold_s=0.5, abort_s=2.0, synthetic={"dropout_s": [[0.0, 100.0]]})
    port = free_port()
    with VehicleSim(load_mission(mission), port=f"udpout:127.0.0.1:{port}"):
        res = fly(port, tmp_path, mission, "--timeout", "30")
    assert res.exit_code == 3
    assert res.stderr.strip() == "aborted: camera: no dock markers seen within 2 s"


def test_real_camera_needs_a_calibration_file(tmp_path) -> None:
    data = yaml.safe_load(TANK.read_text())
    data["dock"]["source"] = "camera"
    path = tmp_path / "cam.yaml"
    path.write_text(yaml.safe_dump(data))
    res = fly(free_port(), tmp_path, path)
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: {path}: camera.calibration: a camera file is required for source 'udp:5600' "
        "(make one with auvdock calibrate)"
    )
