"""``fly`` against ``vehicle-sim`` on 127.0.0.1, in simulated time (:class:`auvdock.runtime.clock.SimClock`).

One :class:`Loopback` per test: a SimClock whose first participant is the test's thread,
vehicle simulators started on it (their threads are participants too), and the ``fly``
command run in the test's thread through the CLI with the same clock
(``obj=Runtime(clock)``), so that the vehicle, the link's threads, the camera threads
and the control loop run in lockstep, as fast as the machine computes, deterministically.
MAVLink still goes over real UDP sockets on 127.0.0.1 (the clock counts the datagrams, so a
message sent at simulated time t is read at t).

A test's time figures (stale for 0.3 s, abort at 2 s, failsafe after 3 s) are simulated
seconds: exact, whatever the machine's load.
"""

from __future__ import annotations

import os
import socket
from pathlib import Path
from typing import Any

import yaml
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.cli.app import Runtime
from auvdock.config.mission import load_mission
from auvdock.runtime.clock import SimClock
from auvdock.standins.link_relay import Impairment, LinkRelay
from auvdock.standins.vehicle_sim import VehicleSim

ROOT = Path(__file__).resolve().parents[2]
TANK = ROOT / "missions" / "tank_positioned.yaml"
HOST = "127.0.0.1"
NEUTRAL, RELEASE = (1500,) * 6, (0,) * 6
ARM_DISARM = 400


#: Ports handed out by :func:`free_port`: below the kernel's ephemeral range (32768-60999 on Linux), so that
#: no socket bound to port 0 meanwhile (a vehicle simulator's ``udpout``, another worker's) is given the
#: same number between the test picking it and fly binding it; a block per pytest-xdist worker.
_PORT_BLOCK = 3000
_next_port = [0]


def free_port() -> int:
    """A UDP port on 127.0.0.1 that no other test of this session will be handed (see ``_PORT_BLOCK``)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    index = int(worker[2:]) + 1 if worker.startswith("gw") and worker[2:].isdigit() else 0
    base = 20000 + (index % 4) * _PORT_BLOCK
    for _ in range(_PORT_BLOCK):
        port = base + _next_port[0] % _PORT_BLOCK
        _next_port[0] += 1
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            try:
                s.bind((HOST, port))
            except OSError:
                continue
        return port
    raise RuntimeError(f"no free UDP port in {base}-{base + _PORT_BLOCK - 1}")


def free_udp_pair() -> int:
    """An even UDP port p with p and p + 1 (RTCP) free on this host."""
    for _ in range(100):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as a:
            a.bind(("0.0.0.0", 0))
            p = a.getsockname()[1]
            if p % 2 or p > 65000:
                continue
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as b:
                try:
                    b.bind(("0.0.0.0", p + 1))
                except OSError:
                    continue
            return p
    raise RuntimeError("no free UDP port pair")


def write_mission(path: Path, base: Path = TANK, **sections: Any) -> Path:
    """``base`` with top-level sections replaced or merged (dicts are merged one level deep)."""
    data = yaml.safe_load(base.read_text())
    for key, value in sections.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    path.write_text(yaml.safe_dump(data))
    return path


class Loopback:
    """A simulated clock, vehicle simulators on it, and ``fly`` through the CLI on it."""

    def __init__(self, monkeypatch: Any) -> None:
        self.clock = SimClock()
        self.sims: list[VehicleSim] = []
        self.relays: list[LinkRelay] = []
        self.runner = CliRunner()

    def vehicle(self, mission: Path | Any = TANK, **kwargs: Any) -> tuple[VehicleSim, int]:
        """A started VehicleSim on ``udpout:127.0.0.1:PORT`` (fly listens there) and PORT."""
        port = free_port()
        m = mission if not isinstance(mission, str | Path) else load_mission(mission)
        sim = VehicleSim(m, port=f"udpout:{HOST}:{port}", clock=self.clock, **kwargs).start()
        self.sims.append(sim)
        return sim, port

    def impaired_vehicle(
        self,
        mission: Path | Any = TANK,
        to_vehicle: Impairment | None = None,
        to_fly: Impairment | None = None,
        link_seed: int = 0,
        **kwargs: Any,
    ) -> tuple[VehicleSim, LinkRelay, int]:
        """A started VehicleSim sending to a :class:`LinkRelay` (drawing from ``link_seed``) that relays
        to fly's PORT, impairing each direction: (the simulator, the relay, PORT)."""
        port = free_port()
        relay = LinkRelay(port, to_vehicle, to_fly, seed=link_seed, clock=self.clock).start()
        self.relays.append(relay)
        m = mission if not isinstance(mission, str | Path) else load_mission(mission)
        sim = VehicleSim(m, port=f"udpout:{HOST}:{relay.port}", clock=self.clock, **kwargs).start()
        self.sims.append(sim)
        return sim, relay, port

    def fly(self, port: int, out: Path, *extra: str, mission: Path = TANK, clock_rate: float = 1.0) -> Any:
        """``auvdock [--clock-rate R] fly MISSION --port udpin:127.0.0.1:PORT --out OUT EXTRA...`` (a
        CliRunner result), on the loopback's clock (``clock_rate``: scaled, as ``--clock-rate`` does)."""
        args = ["fly", str(mission), "--port", f"udpin:{HOST}:{port}", "--out", str(out), *extra]
        if clock_rate != 1.0:
            args = ["--clock-rate", f"{clock_rate:g}", *args]
        return self.runner.invoke(app, args, obj=Runtime(self.clock))

    def close(self) -> None:
        try:
            for sim in self.sims:
                sim.stop()
            for relay in self.relays:
                relay.stop()
        finally:
            self.clock.close()


def overrides(sim: VehicleSim) -> list[tuple[float, tuple[int, ...]]]:
    """(clock.time() s, channels 1..6) of every RC_CHANNELS_OVERRIDE the vehicle received."""
    out = []
    for stamp, mtype, _src, d in sim.received:
        if mtype == "RC_CHANNELS_OVERRIDE":
            out.append((stamp, tuple(d[f"chan{i}_raw"] for i in range(1, 7))))
    return out


def arm_commands(sim: VehicleSim) -> list[dict[str, Any]]:
    commands = [d for _, mtype, _, d in sim.received if mtype in ("COMMAND_LONG", "COMMAND_INT")]
    return [d for d in commands if d.get("command") == ARM_DISARM and d.get("param1") == 1]
