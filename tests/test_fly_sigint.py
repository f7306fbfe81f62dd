"""Ctrl-C (SIGINT) at every moment of ``auvdock fly`` (a real process on the wall clock).

``auvdock fly --arm`` runs in its own process against an in-process ``VehicleSim`` on
127.0.0.1 (wall clock), and gets a real SIGINT at a chosen point of its life
(tests/helpers/ctrl_c.py): while the controller is built, just connected, about to arm,
just armed, after control steps drawn once from a fixed seed, and during the ending (a
SIGINT during the ending in simulated time is in tests/test_fly.py).  The point is in the
program, not in time, so every moment is exercised at any machine load and none can come
after the run has ended.  Each run must exit with status 130, print no traceback and one
"interrupted" line that names only files that are there, leave the vehicle disarmed (never
armed, before the arm command) and leave a readable, complete results file once it flew.
Only exit codes, output, files and the vehicle's state are checked, never durations.
"""

from __future__ import annotations

import os
import random
import re
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
from helpers.loopback import HOST, TANK, arm_commands, free_port

from auvdock.config.mission import load_mission
from auvdock.results.store import read_run
from auvdock.standins.vehicle_sim import VehicleSim

CTRL_C = Path(__file__).resolve().parent / "helpers" / "ctrl_c.py"
STEPS = sorted(random.Random(1234).sample(range(1, 40), 2))  # [8, 29]

#: moment, whether fly armed the vehicle (sent the arm command) by then, whether it flew (results file)
MOMENTS = [
    pytest.param("call:auvdock.fly.session:build_autopilot", False, False, id="building-the-controller"),
    pytest.param("fly-event:connected", False, False, id="just-connected"),
    pytest.param("fly-event:arming", False, False, id="about-to-arm"),
    pytest.param("fly-event:armed", True, False, id="just-armed"),
    *[pytest.param(f"fly-step:{k}", True, True, id=f"after-step-{k}") for k in STEPS],
    pytest.param("fly-event:disarmed", True, True, id="while-ending"),
]


@pytest.mark.parametrize(("moment", "armed", "flew"), MOMENTS)
def test_sigint_at_every_moment_exits_130_cleanly(moment: str, armed: bool, flew: bool, tmp_path) -> None:
    _interrupt_at(moment, armed, flew, tmp_path, "SIGINT")


def test_sigterm_in_flight_ends_as_ctrl_c_does(tmp_path) -> None:
    """What Docker, BlueOS and systemd send to stop a service: the same clean ending, said as SIGTERM."""
    _interrupt_at(f"fly-step:{STEPS[0]}", True, True, tmp_path, "SIGTERM")


def _interrupt_at(moment: str, armed: bool, flew: bool, tmp_path: Path, sig: str) -> None:
    port = free_port()
    # wall clock; held at the start while disarmed, as vehicle-sim does
    sim = VehicleSim(load_mission(TANK), port=f"udpout:{HOST}:{port}", hold_start=True).start()
    timeout = "1" if moment == "fly-event:disarmed" else "30"  # the ending comes by timeout; else cut first
    args = ["fly", str(TANK), "--port", f"udpin:{HOST}:{port}", "--out", str(tmp_path), "--arm"]
    args += ["--timeout", timeout]
    try:
        res = subprocess.run(
            [sys.executable, str(CTRL_C), moment, *args],
            env=dict(os.environ, PYTHONUNBUFFERED="1", CTRL_C_SIGNAL=sig),
            capture_output=True,
            text=True,
            timeout=300,
        )
    finally:
        sim.stop()
    what = f"{moment}:\nstdout:\n{res.stdout}\nstderr:\n{res.stderr}"
    assert res.returncode == 130, what
    assert "Traceback" not in res.stderr + res.stdout, what
    last = [ln for ln in res.stderr.splitlines() if ln.strip()][-1]
    assert last.startswith("interrupted"), what
    if flew:
        assert last.startswith("interrupted (SIGTERM)" if sig == "SIGTERM" else "interrupted (Ctrl-C)"), what
    for named in re.findall(r"\S+\.(?:h5|tlog)\b", res.stdout + last):  # only files that are there
        assert Path(named).is_file(), what
    if not armed:
        assert arm_commands(sim) == [], what  # never armed
    assert not sim.armed, what  # every ending disarms
    files = sorted(tmp_path.glob("*.h5"))
    assert len(files) == (1 if flew else 0), what
    for h5 in files:  # the results file reads back whole, its outcome written
        run = read_run(h5)
        with h5py.File(h5, "r") as f:
            assert bool(f.attrs["complete"]) and f.attrs["reason"] == "interrupted", what
        assert f"results in {h5}" in last and len(run.time_s) > 0, what
    if moment.startswith("call:"):
        assert last == "interrupted: before connecting to the vehicle; nothing was sent", what
        assert sim.received == [], what
