"""``auvdock fly`` with ``dock.source: camera``: the synthetic camera + vehicle-sim, on 127.0.0.1 only.

The synthetic camera renders the dock's markers from the vehicle's pose, the tracker detects
them in its own thread, and the dock filter re-anchors the heave model; the rendered dock is
east of the mission's, so only a camera that really tracks it can dock there.

Everything runs in simulated time (tests/helpers/loopback.py): the camera's frame pacing,
the frame grabber and the detection thread share the session's SimClock, so rendering and
detection take no simulated time and the runs are deterministic.  To keep them short the
docking test renders a 320x240 camera at 5 frames/s (the mission default is 640x480 at
15 Hz; the docs' camera figures are wall-clock rehearsals).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from helpers.loopback import Loopback, free_port, write_mission

from auvdock.camera.model import CameraModel, save_camera
from auvdock.config.mission import load_mission
from auvdock.fly import CAMERA_STATES
from auvdock.results.store import read_run


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


def camera_mission(tmp_path: Path, *, offset_east_m: float = 0.2, docking=None, start=None, **camera) -> Path:
    synthetic = {"dock_offset_m": [0.0, offset_east_m, 0.0], **camera.pop("synthetic", {})}
    sections = {
        "dock": {"source": "camera"},
        "camera": {"source": "synthetic", **camera, "synthetic": synthetic},
    }
    if docking is not None:
        sections["docking"] = docking
    if start is not None:
        sections["start"] = start
    return write_mission(tmp_path / "camera.yaml", **sections)


@pytest.mark.slow
def test_synthetic_camera_docks_in_the_tank_through_a_short_loss(loop, tmp_path) -> None:
    """Docks at the rendered dock (0.3 m east); a 0.8 s blackout (hold 0.5 s) is held (depth and
    attitude), recovered."""
    save_camera(CameraModel.ideal(320, 240), tmp_path / "cam320.yaml")
    mission = camera_mission(
        tmp_path,
        offset_east_m=0.3,
        calibration="cam320.yaml",
        hold_s=0.5,
        abort_s=3.0,
        synthetic={"rate_hz": 5.0, "dropout_s": [[3.0, 3.8]]},
        docking={"tolerance_m": 0.08},
        start={"state": [1.0, 0.0, 1.0, 0, 0, 0, 0, 0, 0, 0, 0, 0]},
    )
    m = load_mission(mission)
    model = m.build_dock()
    n, e, d = model.position_ned_m
    real = dataclasses.replace(model, position_ned_m=(n, e + 0.3, d))
    sim, port = loop.vehicle(m)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "30", mission=mission)
    assert res.exit_code == 0, res.output + res.stderr
    # the vehicle (its own truth state; horizontally: it floats up after the ending) is at the
    # rendered dock, not at the mission's
    assert np.linalg.norm(sim.state[0:2] - np.array(real.position_ned_m[0:2])) < 0.12
    assert np.linalg.norm(sim.state[0:2] - np.array(model.position_ned_m[0:2])) > 0.18
    r = read_run(next(tmp_path.glob("*_fly_*.h5")))
    assert r.outcome()["docked"]
    events = [text for _, text in json.loads(r.outcome()["events_json"])]
    assert any(e.startswith("camera: dock found") for e in events)
    assert any(e.startswith("camera: dock lost for") and "holding" in e for e in events)
    assert any(e.startswith("camera: dock recovered") for e in events)
    state = r.extras["camera_state"].astype(int)
    t = r.time_s
    holding = state == CAMERA_STATES.index("holding")
    assert holding.any()
    assert t[holding].min() >= 3.0 + 0.5 - 0.25  # the last frame before the blackout is at most 0.2 s old
    assert t[holding].max() <= 3.8 + 0.25  # the first frame after it brings the dock back
    status = r.solver_status[holding]
    assert np.all(status == 6)  # "hold": no controller step, the hold's thrust
    assert np.any(r.extras["channels_us"][holding] != 1500)  # not neutral: the buoyant vehicle would rise
    fixes = np.nansum(r.extras["camera_fixes"])
    assert fixes >= 0.9 * 5.0 * (t[-1] - 0.8)  # every frame outside the blackout gives a fix
    # capture to fix: no simulated time (wall-clock figure in the docs)
    latency = r.extras["camera_latency_s"]
    assert np.all(latency[np.isfinite(latency)] == 0.0)


@pytest.mark.slow
def test_markers_lost_longer_than_hold_neutral_then_abort(loop, tmp_path) -> None:
    mission = camera_mission(tmp_path, hold_s=1.0, abort_s=2.5, synthetic={"dropout_s": [[2.0, 100.0]]})
    sim, port = loop.vehicle(mission)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "30", mission=mission)
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
    # tracking until the markers vanish at 2 s, hold from hold_s after that, abort at abort_s
    assert t[holding].min() == pytest.approx(2.0 + 1.0, abs=0.1)
    assert t[-1] == pytest.approx(2.0 + 2.5, abs=0.1)
    # the hold keeps depth and attitude (neutral thrust: the 2 N buoyant vehicle rises about
    # 0.17 m/s, 0.25 m over these 1.5 s); it starts while the vehicle follows the dock's heave (up to
    # 0.24 m/s), and stops it within 7 cm (with the dock's phase on the vehicle's clock)
    z = r.state[holding, 2]
    assert np.ptp(z) < 0.1, z
    assert abs(z[-1] - z[-5]) < 0.01, z  # at rest
    # the hold's pitch while it stops the heave depends on the heave's phase when the hold starts (the
    # markers' last fix, on the camera's frame grid): 4.9 deg with the hold from 3.00 s, 5.7 deg from 2.90 s
    assert np.max(np.abs(r.state[holding, 3:5])) < np.radians(8.0)
    assert np.all(state[t < 2.0] == CAMERA_STATES.index("tracking"))


def test_no_markers_ever_aborts(loop, tmp_path) -> None:
    mission = camera_mission(tmp_path, hold_s=0.5, abort_s=2.0, synthetic={"dropout_s": [[0.0, 100.0]]})
    sim, port = loop.vehicle(mission)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "30", mission=mission)
    assert res.exit_code == 3
    assert res.stderr.strip() == "aborted: camera: no dock markers seen within 2 s"
    assert not sim.armed


def test_real_camera_needs_a_calibration_file(loop, tmp_path) -> None:
    path = write_mission(tmp_path / "cam.yaml", dock={"source": "camera"})
    res = loop.fly(free_port(), tmp_path, mission=path)
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: {path}: camera.calibration: a camera file is required for source 'udp:5600' "
        "(make one with auvdock calibrate)"
    )
