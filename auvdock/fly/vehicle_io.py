"""What goes to and comes from the vehicle in a session: messages drained into what reads them, and
RC overrides out.

Every decision of a flight is made on drained messages (:meth:`VehicleIO.take`), never on the link's
own state, so that ``auvdock replay`` hands the same code the same messages at the same steps: the
link marks each drain in the tlog.  One drain feeds the telemetry's sensors
(:class:`auvdock.fly.telemetry.TelemetrySensors`), the vehicle's state (parameters, acks, battery, its
texts, another station flying: :class:`auvdock.fly.vehicle_state.VehicleState`), the link's health
(round trip, clocks' offset, loss: :class:`auvdock.fly.link_health.LinkHealth`) and the feeds added
(the dock's telemetry, the camera's frames' source).
"""

from __future__ import annotations

import math
from typing import Any, Protocol

from auvdock.fly.events import EventLog
from auvdock.fly.link import MavlinkLink
from auvdock.fly.link_health import LinkFigures, LinkHealth
from auvdock.fly.telemetry import TelemetrySensors
from auvdock.fly.vehicle_state import VehicleState
from auvdock.vehicle.ardusub import NEUTRAL_CHANNELS

__all__ = ["Feed", "VehicleIO"]


class Feed(Protocol):
    """Anything that reads the drained messages (the dock's telemetry, the camera's SIM_STATE)."""

    def feed(self, messages: list[Any]) -> None: ...


class VehicleIO:
    """The vehicle's link as a session uses it (see the module docstring).

    Parameters
    ----------
    link : MavlinkLink
        The link (connected by the session).
    telemetry : TelemetrySensors
        The telemetry's sensors, fed every drain.
    events : EventLog
        The session's events (the vehicle's texts go there).
    timesync_period_s : float
        A TIMESYNC request goes this often (``fly.timesync_period_s``), s: the round trip and the
        vehicle's clock.

    Attributes
    ----------
    now_us : int
        The newest drain's instant, us (the tlog's clock).
    state : VehicleState
        What the vehicle has said.
    health : LinkHealth
        The link's health.
    """

    def __init__(
        self, link: MavlinkLink, telemetry: TelemetrySensors, events: EventLog, timesync_period_s: float
    ) -> None:
        self.link = link
        self.clock = link.clock
        self.telemetry = telemetry
        self.events = events
        self.timesync_period_s = float(timesync_period_s)
        self.state = VehicleState()
        self.health = LinkHealth()
        self.feeds: list[Feed] = []
        self.now_us = 0
        self._next_timesync = -math.inf
        #: (tlog stamp us, time_boot_ms) of the first and the newest ATTITUDE drained: the vehicle's clock
        #: against ours (:meth:`clock_rate`)
        self._clock_first: tuple[int, int] | None = None
        self._clock_last: tuple[int, int] | None = None

    @property
    def target_system(self) -> int:
        """The vehicle's MAVLink system id."""
        return int(getattr(self.link, "target_system", 1))

    def take(self, marker: str, value: int = 0) -> int:
        """The messages received since the last call, into everything that reads them; returns now (us,
        the tlog's clock, also :attr:`now_us`).  The link marks the moment in the tlog (for replay)."""
        now_us, messages = self.link.drain(marker, value)
        self.now_us = now_us
        self.telemetry.feed(messages)
        for feed in self.feeds:
            feed.feed(messages)
        self.health.feed(messages, self.target_system)
        link = self.health.figures()
        rtt = max(link.rtt_s, link.rtt_latest_s)  # (NaN before a TIMESYNC answer)
        self.state.round_trip_us = int(rtt * 1e6) if math.isfinite(rtt) else 0
        self.state.clock_offset_s = link.offset_s
        if self.clock.now() >= self._next_timesync:  # the round trip and the vehicle's clock
            self._next_timesync = self.clock.now() + self.timesync_period_s
            self.link.send_timesync(LinkHealth.request_ns(now_us * 1e-6))
        for text in self.state.feed(messages, self.target_system):
            self.events.add(text)
        att, stamp = self.telemetry.latest("ATTITUDE")
        if att is not None and stamp is not None:
            pair = (int(stamp), int(att.time_boot_ms))
            if self._clock_first is None:
                self._clock_first = pair
            self._clock_last = pair
        return now_us

    def clock_rate(self) -> tuple[float, float]:
        """(the vehicle's clock's rate against this session's clock, the span it was measured over, s):
        the newest ATTITUDE's ``time_boot_ms`` against its arrival, from the first one drained; the rate
        is NaN over less than 1 s."""
        if self._clock_first is None or self._clock_last is None:
            return math.nan, 0.0
        (s0, b0), (s1, b1) = self._clock_first, self._clock_last
        span = (s1 - s0) * 1e-6
        return ((b1 - b0) * 1e-3 / span if span >= 1.0 else math.nan), span

    def figures(self) -> LinkFigures:
        """The link's health now."""
        return self.health.figures()

    def send_channels(self, channels: Any) -> tuple[int, ...]:
        """RC overrides for channels 1..6; returns the channels that went to the vehicle (a replay's: the
        flight's), remembered (the RC_CHANNELS check compares with them)."""
        went = self.link.send_override(tuple(int(round(c)) for c in channels))
        self.state.sent_channels(int(self.clock.time() * 1e6), went)
        return went

    def send_neutral(self) -> None:
        """Neutral overrides."""
        self.send_channels(NEUTRAL_CHANNELS)

    def age_s(self, stamp_us: int | None) -> float:
        """How old (s) a message received at ``stamp_us`` (us) is at the newest drain (inf: none)."""
        return math.inf if stamp_us is None else (self.now_us - stamp_us) * 1e-6
