"""The thrust-response gain (auvdock.fly.response) recovers a plant's known thruster gain from a
flight's own measurements (fly against vehicle-sim on loopback, simulated time)."""

from __future__ import annotations

import pytest
from helpers.loopback import TANK, Loopback, write_mission

from auvdock.fly.response import main, thrust_response


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


@pytest.mark.parametrize("gain", [1.0, 1.5])
def test_recovers_the_plants_thruster_gain(loop, tmp_path, gain, capsys) -> None:
    """A plant whose thrusters push ``gain`` times the command: surge and heave read ``gain``."""
    plant = write_mission(tmp_path / "plant.yaml", vehicle={"overrides": {"thruster_gain": gain}})
    sim, port = loop.vehicle(plant)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "10", mission=TANK)
    assert res.exit_code in (0, 1), res.output
    h5 = next(tmp_path.glob("*_fly_*.h5"))
    axes = {a.axis: a for a in thrust_response(h5)}
    for name in ("surge", "heave"):
        assert axes[name].gain == pytest.approx(gain, rel=0.02), axes[name]
        assert axes[name].r2 > 0.99
        assert axes[name].steps >= 150
    main([str(h5)])
    out = capsys.readouterr().out
    assert out.splitlines()[1].split() == ["axis", "gain", "R^2", "steps", "model", "rms", "m/s^2"]
