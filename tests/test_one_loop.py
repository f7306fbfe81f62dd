"""One closed loop serves every command (issue 25): sim, fly on a vehicle, the vehicle-sim stand-in it
flies against, sitl-physics under ArduPilot SITL, and replay of a flight all run
auvdock.loop.closed_loop.run_closed_loop, and nothing else in the package takes a control step."""

from __future__ import annotations

import re
import socket
import struct
from pathlib import Path

import pytest
from helpers.loopback import TANK, Loopback
from typer.testing import CliRunner

import auvdock
from auvdock.cli import app
from auvdock.config.mission import load_mission
from auvdock.fly.plant import MavlinkPlant
from auvdock.fly.replay import replay
from auvdock.loop import closed_loop
from auvdock.loop.simulated_plant import SimulatedPlant
from auvdock.standins.sitl_physics import MAGIC_16, SitlPhysics, _SitlPlant
from auvdock.standins.vehicle_sim import _StandinPlant

PACKAGE = Path(auvdock.__file__).parent


@pytest.fixture
def plants(monkeypatch):
    """The plant of every run_closed_loop call, in order."""
    seen: list[object] = []
    real = closed_loop.run_closed_loop

    def spy(stages, **kwargs):
        seen.append(stages.plant)
        return real(stages, **kwargs)

    monkeypatch.setattr(closed_loop, "run_closed_loop", spy)
    return seen


def test_sim_fly_and_replay_run_the_one_loop(plants, monkeypatch, tmp_path) -> None:
    res = CliRunner().invoke(
        app, ["sim", "still", "--timeout", "0.5", "--no-plots", "--out", str(tmp_path / "s")]
    )
    assert res.exit_code == 1, res.output  # not docked in 0.5 s: exit 1, but it ran
    assert len(plants) == 1 and isinstance(plants[0], SimulatedPlant)
    r = auvdock.simulate("still", docking__timeout_s=0.5)
    assert len(plants) == 2 and isinstance(plants[1], SimulatedPlant) and r.n_steps == 11

    loop = Loopback(monkeypatch)
    try:
        _, port = loop.vehicle(TANK)
        res = loop.fly(port, tmp_path / "flight", "--arm", "--timeout", "1")
        assert res.exit_code == 1, res.output + res.stderr  # timed out (not docked), flown
    finally:
        loop.close()
    # the stand-in vehicle's loop and fly's, side by side on the one clock
    assert len(plants) == 4
    assert sorted(type(p).__name__ for p in plants[2:]) == ["MavlinkPlant", "_StandinPlant"]
    assert any(isinstance(p, _StandinPlant) for p in plants[2:])
    (tlog,) = (tmp_path / "flight").glob("*.tlog")
    result, _ = replay(tlog, load_mission(TANK), tmp_path / "replay.h5")
    assert result.reason == "timeout"
    assert len(plants) == 5 and isinstance(plants[4], MavlinkPlant)


def test_sitl_physics_runs_the_one_loop(plants) -> None:
    """Each new servo frame from SITL is one step of the loop: answered with the stepped truth."""
    neutral = [1500] * 8 + [0] * 8
    with SitlPhysics(load_mission(TANK), listen=("127.0.0.1", 0)) as physics:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as peer:
            peer.settimeout(10.0)
            for count in (1, 2, 3):
                peer.sendto(
                    struct.pack("<HHI16H", MAGIC_16, 400, count, *neutral),
                    physics.local_address,
                )
                assert peer.recv(65536).startswith(b"\n{")
        assert physics.frames == 3
    assert len(plants) == 1 and isinstance(plants[0], _SitlPlant)


def test_nothing_else_takes_a_control_step() -> None:
    """The autopilot's step (estimation + control) is called in the loop and nowhere else."""
    callers = []
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text()
        if re.search(r"\b(autopilot|ap|self\.autopilot)\.step\(", text):
            callers.append(path.relative_to(PACKAGE).as_posix())
    assert callers == ["loop/closed_loop.py"]
