"""A link impairment stand-in: a UDP relay between ``fly`` and a vehicle that delays, drops, reorders
and duplicates datagrams, and goes silent in outages.

A BlueROV2 is flown over its tether, often with a Wi-Fi hop to the topside: datagrams arrive late,
with jitter, and some never.  :class:`LinkRelay` sits between ``fly`` (``udpin:HOST:FLY_PORT``) and a
vehicle that sends to the relay (``vehicle-sim --port udpout:HOST:RELAY_PORT``, or SITL's
``--out``): every datagram from the vehicle goes to fly, every one from fly to the vehicle, each
through its direction's :class:`Impairment`:

* lost with probability ``loss`` (independently), or in an outage (every datagram of the interval);
* delayed by ``delay_s`` plus a normal jitter of std ``jitter_s`` (truncated at zero delay), so that
  datagrams overtake each other when the jitter exceeds their spacing;
* held back a further ``reorder_s`` with probability ``reorder`` (reordering beyond the jitter);
* sent twice with probability ``duplicate`` (the copy ``duplicate_gap_s`` later).

It runs on a :class:`~auvdock.runtime.clock.Clock`: on a SimClock it is one of the participants and
its draws come from one seeded generator in the order the datagrams arrive, so an impaired session
is reproducible to the bit from its seed, at any machine load; on the wall clock it is a real relay
for a real ``fly`` and vehicle (no test depends on that).

Statistics per direction (:attr:`LinkRelay.stats`): datagrams in, lost, duplicated, delivered.
"""

from __future__ import annotations

import heapq
import itertools
import math
import socket
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from auvdock.runtime.clock import Clock, SimClock, wall_clock
from auvdock.runtime.sim_udp import CountingSocket

__all__ = ["Impairment", "LinkRelay", "DirectionStats"]

#: The relay looks at its stop flag at least this often, s (of its clock).
IDLE_POLL_S = 0.1


@dataclass(frozen=True)
class Impairment:
    """What one direction of the link does to datagrams (times in s, probabilities in [0, 1]).

    ``outages``: (start, end) intervals of the relay's clock (s since it started) in which every
    datagram is lost.
    """

    delay_s: float = 0.0
    jitter_s: float = 0.0
    loss: float = 0.0
    reorder: float = 0.0
    reorder_s: float = 0.05
    duplicate: float = 0.0
    duplicate_gap_s: float = 0.001
    outages: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        for name in ("delay_s", "jitter_s", "reorder_s", "duplicate_gap_s"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"link impairment: {name} must be >= 0 s, got {getattr(self, name)}")
        for name in ("loss", "reorder", "duplicate"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(
                    f"link impairment: {name} must be a probability in [0, 1], got {getattr(self, name)}"
                )
        for start, end in self.outages:
            if not end > start:
                raise ValueError(f"link impairment: an outage must end after it starts, got ({start}, {end})")

    def describe(self) -> str:
        """One line: ``"100 ms +- 30 ms, 5 % lost"``."""
        parts = [f"{1e3 * self.delay_s:g} ms" + (f" +- {1e3 * self.jitter_s:g} ms" if self.jitter_s else "")]
        if self.loss:
            parts.append(f"{100 * self.loss:g} % lost")
        if self.reorder:
            parts.append(f"{100 * self.reorder:g} % held {1e3 * self.reorder_s:g} ms")
        if self.duplicate:
            parts.append(f"{100 * self.duplicate:g} % duplicated")
        for start, end in self.outages:
            parts.append(f"outage {start:g}-{end:g} s")
        return ", ".join(parts)


@dataclass
class DirectionStats:
    """Datagrams of one direction: received by the relay, lost, duplicated, delivered."""

    received: int = 0
    lost: int = 0
    duplicated: int = 0
    delivered: int = 0
    delays_s: list[float] = field(default_factory=list)


class LinkRelay:
    """The relay (see the module docstring).

    Parameters
    ----------
    fly_port : int
        The UDP port ``fly`` listens on (``udpin:HOST:fly_port``).
    to_vehicle, to_fly : Impairment
        What the link does to fly's datagrams (commands) and to the vehicle's (telemetry).
    seed : int
        The generator of every draw.
    clock : Clock
        What it waits on (a SimClock: it is a participant, started by :meth:`start`).
    host : str
        The loopback address both ends use.

    Attributes
    ----------
    port : int
        The relay's own UDP port: the vehicle sends here.
    stats : dict
        ``{"to_vehicle": DirectionStats, "to_fly": DirectionStats}``.
    """

    def __init__(
        self,
        fly_port: int,
        to_vehicle: Impairment | None = None,
        to_fly: Impairment | None = None,
        seed: int = 0,
        clock: Clock = wall_clock,
        host: str = "127.0.0.1",
    ) -> None:
        self.fly_address = (host, int(fly_port))
        self.impairments = {"to_vehicle": to_vehicle or Impairment(), "to_fly": to_fly or Impairment()}
        self.rng = np.random.default_rng(seed)
        self.clock = clock
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        raw.bind((host, 0))
        raw.setblocking(False)
        self._sock: Any = CountingSocket(raw, clock) if isinstance(clock, SimClock) else raw
        self.port = int(raw.getsockname()[1])
        self.vehicle_address: tuple[str, int] | None = None
        self.stats = {name: DirectionStats() for name in self.impairments}
        self._queue: list[tuple[float, int, bytes, str]] = []
        self._seq = itertools.count()
        self._stop = False
        self._thread: Any = None
        self._t0 = 0.0

    def start(self) -> LinkRelay:
        """Start relaying (a thread on the relay's clock)."""
        self._t0 = self.clock.now()
        self._thread = self.clock.start_thread(self._run, name="link-relay")
        return self

    def stop(self) -> None:
        """Stop relaying (datagrams still queued are lost) and close the socket."""
        self._stop = True
        if self._thread is not None:
            self.clock.join(self._thread, timeout=2 * IDLE_POLL_S)
        self._sock.close()

    def __enter__(self) -> LinkRelay:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- the relay -------------------------------------------------------------------------
    def _run(self) -> None:
        while not self._stop:
            now = self.clock.now()
            due = self._queue[0][0] if self._queue else now + IDLE_POLL_S
            if self.clock.wait_readable(self._sock, max(0.0, min(due, now + IDLE_POLL_S) - now)):
                self._receive()
            self._deliver()

    def _receive(self) -> None:
        while True:
            try:
                data, address = self._sock.recvfrom(65535)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return
            if tuple(address[:2]) == self.fly_address:
                direction = "to_vehicle"
            else:
                direction = "to_fly"
                self.vehicle_address = (str(address[0]), int(address[1]))
            self._schedule(direction, data)

    def _schedule(self, direction: str, data: bytes) -> None:
        imp = self.impairments[direction]
        st = self.stats[direction]
        st.received += 1
        now = self.clock.now()
        since = now - self._t0
        # every draw is made for every datagram, in one order: a setting changes only what it governs
        lost = self.rng.random() < imp.loss
        jitter = self.rng.standard_normal() * imp.jitter_s
        held = self.rng.random() < imp.reorder
        twice = self.rng.random() < imp.duplicate
        if lost or any(start <= since < end for start, end in imp.outages):
            st.lost += 1
            return
        delay = max(0.0, imp.delay_s + jitter) + (imp.reorder_s if held else 0.0)
        heapq.heappush(self._queue, (now + delay, next(self._seq), data, direction))
        st.delays_s.append(delay)
        if twice:
            st.duplicated += 1
            heapq.heappush(self._queue, (now + delay + imp.duplicate_gap_s, next(self._seq), data, direction))

    def _deliver(self) -> None:
        now = self.clock.now()
        while self._queue and self._queue[0][0] <= now + 1e-12:
            _, _, data, direction = heapq.heappop(self._queue)
            target = self.fly_address if direction == "to_fly" else self.vehicle_address
            if target is None:  # nothing from the vehicle yet: nowhere to send fly's datagram
                self.stats[direction].lost += 1
                continue
            try:
                self._sock.sendto(data, target)
            except OSError:
                self.stats[direction].lost += 1
                continue
            self.stats[direction].delivered += 1

    def summary(self) -> str:
        """One line per direction: what was done to its datagrams."""
        lines = []
        for name, st in self.stats.items():
            d = np.asarray(st.delays_s) if st.delays_s else np.array([math.nan])
            lines.append(
                f"{name.replace('_', ' ')}: {self.impairments[name].describe()}: {st.received} in, "
                f"{st.lost} lost, {st.duplicated} duplicated, {st.delivered} delivered, "
                f"delay median {1e3 * np.median(d):.0f} ms"
            )
        return "\n".join(lines)
