"""What the vehicle has said, folded from its MAVLink messages: :class:`VehicleState`.

A pure fold: :meth:`VehicleState.feed` takes the messages drained from the link at one moment
and updates what a session decides on -- the parameters read, the COMMAND_ACKs, the battery
voltage (low-passed), the vehicle's texts (STATUSTEXT chunks joined), and signs of another
station flying (its pilot input on our link; RC_CHANNELS showing channels fly did not send) --
and returns the events to show.  No link, no clock: the same messages give the same state,
which is what lets ``auvdock replay`` reproduce a flight's decisions, and what the tests feed.
"""

from __future__ import annotations

import collections
import math
from typing import Any

from auvdock.fly.link import PILOT_INPUT_TYPES

__all__ = [
    "BATTERY_FILTER_S",
    "FOREIGN_CHANNELS_IN_A_ROW",
    "SENT_WINDOW_US",
    "StatustextJoiner",
    "VehicleState",
]

#: Time constant of the battery voltage's low-pass (thrust makes the voltage sag briefly), s.
BATTERY_FILTER_S = 1.0
#: RC_CHANNELS showing channels fly did not send in this many messages in a row: another station.
FOREIGN_CHANNELS_IN_A_ROW = 2
#: Overrides sent within this window (us) before an RC_CHANNELS message may be what it shows.
SENT_WINDOW_US = 1_000_000


class StatustextJoiner:
    """The vehicle's texts, whole: ArduPilot sends a text longer than 50 bytes in chunks that share
    an ``id``, the last one shorter than 50 (at most 8 chunks)."""

    def __init__(self) -> None:
        self._chunks: dict[int, list[str]] = {}

    def join(self, msg: Any) -> str | None:
        """The whole text of a STATUSTEXT message; None until its last chunk has come."""
        text = msg.text if isinstance(msg.text, str) else msg.text.decode(errors="replace")
        text_id = int(getattr(msg, "id", 0) or 0)
        if text_id == 0:
            return text.strip()
        parts = self._chunks.setdefault(text_id, [])
        parts.append(text)
        if len(text.encode()) >= 50 and len(parts) < 8:
            return None
        del self._chunks[text_id]
        return "".join(parts).strip()


class VehicleState:
    """The fold (see the module docstring).

    Attributes
    ----------
    params : dict
        Parameter name -> value, from PARAM_VALUE.
    acks : list of (int, int)
        (command, MAV_RESULT) of every COMMAND_ACK, in order.
    battery_v : float or None
        Low-passed battery voltage, V (SYS_STATUS voltage_battery, else BATTERY_STATUS cell sum).
    battery_reported : bool
        A SYS_STATUS came (with or without a voltage).
    foreign : list of str
        Another station's pilot input, described (a takeover).
    last_arm_text : str
        The vehicle's latest ``Arm:`` / ``PreArm:`` text.
    sent : deque of (int, tuple)
        The overrides fly sent (us on the tlog's clock, channels 1..6): :meth:`sent_channels`
        adds to it; the RC_CHANNELS check compares with it.
    """

    def __init__(self) -> None:
        self.params: dict[str, float] = {}
        self.acks: list[tuple[int, int]] = []
        self.battery_v: float | None = None
        self._battery_stamp: int | None = None
        self.battery_reported = False
        self._battery_from_sys_status = False
        self.foreign: list[str] = []
        self._foreign_rc = 0
        self.last_arm_text = ""
        self.sent: collections.deque[tuple[int, tuple[int, ...]]] = collections.deque()
        #: The link's measured round trip (us; :class:`auvdock.fly.link_health.LinkHealth`): RC_CHANNELS
        #: shows what was sent this much earlier and more, so the window reaches back further by twice it.
        self.round_trip_us = 0
        #: The vehicle's clock minus the tlog's (s, NaN: unknown): an RC_CHANNELS message is then judged
        #: from when the vehicle sampled it (its time_boot_ms), not from when it arrived.
        self.clock_offset_s = math.nan
        self._texts = StatustextJoiner()

    def sent_channels(self, now_us: int, channels: tuple[int, ...]) -> None:
        """Remember an override sent at ``now_us`` (us); forget those older than two windows."""
        self.sent.append((now_us, channels))
        while len(self.sent) > 1 and self.sent[1][0] < now_us - 2 * self._window_us():
            self.sent.popleft()

    def feed(self, messages: list[tuple[int, Any]], vehicle_sysid: int) -> list[str]:
        """Fold messages ``(stamp_us, msg)`` from the vehicle ``vehicle_sysid``; the events to show."""
        events: list[str] = []
        for stamp, msg in messages:
            mtype = msg.get_type()
            if mtype in PILOT_INPUT_TYPES and msg.get_srcSystem() != vehicle_sysid:
                self.foreign.append(f"pilot input from system {msg.get_srcSystem()} ({mtype})")
            elif mtype == "STATUSTEXT":
                text = self._texts.join(msg)
                if text is None:
                    continue
                events.append(f"vehicle: {text}")
                if text.startswith(("Arm:", "PreArm:")):
                    self.last_arm_text = text
            elif mtype == "PARAM_VALUE":
                name = msg.param_id.decode() if isinstance(msg.param_id, bytes) else str(msg.param_id)
                self.params[name.rstrip("\x00")] = float(msg.param_value)
            elif mtype == "COMMAND_ACK":
                self.acks.append((int(msg.command), int(msg.result)))
            elif mtype in ("SYS_STATUS", "BATTERY_STATUS"):
                self._battery(stamp, msg)
            elif mtype == "RC_CHANNELS":
                self._rc_channels(stamp, msg)
        return events

    def _battery(self, stamp: int, msg: Any) -> None:
        """Low-pass the battery voltage (SYS_STATUS voltage_battery, else BATTERY_STATUS cell sum)."""
        if msg.get_type() == "SYS_STATUS":
            self.battery_reported = True
            if msg.voltage_battery in (0, 65535):  # no battery monitor (ArduPilot's BATT_MONITOR 0)
                return
            v = msg.voltage_battery / 1000.0
            self._battery_from_sys_status = True
        else:
            if self._battery_from_sys_status:
                return  # SYS_STATUS first
            cells = [c for c in msg.voltages if c not in (0, 65535)]
            if not cells:
                return
            v = sum(cells) / 1000.0
        if self.battery_v is None or self._battery_stamp is None:
            self.battery_v = v
        else:
            a = min(1.0, max(0.0, (stamp - self._battery_stamp) * 1e-6 / BATTERY_FILTER_S))
            self.battery_v += a * (v - self.battery_v)
        self._battery_stamp = stamp

    def _window_us(self) -> int:
        return SENT_WINDOW_US + 2 * max(0, int(self.round_trip_us))

    def _rc_channels(self, stamp: int, msg: Any) -> None:
        """Count RC_CHANNELS whose channels 1..6 fly did not send within SENT_WINDOW_US (plus twice the
        link's round trip): another station (e.g. a joystick in QGroundControl or Cockpit with our system
        id) flying too."""
        window = self._window_us()
        since = stamp - window
        boot_ms = getattr(msg, "time_boot_ms", None)
        if boot_ms is not None and math.isfinite(self.clock_offset_s):  # from when the vehicle showed them
            since = min(since, int(round((boot_ms * 1e-3 - self.clock_offset_s) * 1e6)) - window)
        if not self.sent or stamp - self.sent[0][0] < window // 2:
            return  # too early to tell
        shown = tuple(int(getattr(msg, f"chan{i}_raw")) for i in range(1, 7))
        recent = [ch for t, ch in self.sent if since <= t <= stamp]  # (only ever wider than on arrival)
        if not recent:
            recent = [self.sent[-1][1]]
        if shown in recent:
            self._foreign_rc = 0
            return
        self._foreign_rc += 1
        if self._foreign_rc >= FOREIGN_CHANNELS_IN_A_ROW:
            ours = recent[-1]
            diff = max(range(6), key=lambda i: abs(shown[i] - ours[i]))  # the channel most unlike ours
            self.foreign.append(
                f"the vehicle uses channel {diff + 1} = {shown[diff]} us where fly sends {ours[diff]} us "
                "(RC_CHANNELS): another ground station with our system id is flying"
            )
