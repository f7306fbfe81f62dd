"""The mission's clock in a flight: the vehicle's clock, less its value at the mission's t = 0.

The dock moves on mission time; a flight's readings are stamped on the vehicle's clock (ArduSub's
``time_boot_ms``).  :class:`MissionClock` sets the mission's ``t = 0`` on the vehicle's clock at the loop's
first period (``dock.offset_s``, kept for the flight), so that readings, the dock and the verdict's
instant are on one clock, and follows where that instant is on the session's clock (the camera's frames
and the loop's pacing are on it) as the link measures the vehicle's clock
(:class:`auvdock.fly.link_health.LinkHealth`): in the field both clocks run together; in a rehearsal
slower than its rate the simulator's clock falls behind, and the loop waits for it rather than running
ahead of the vehicle.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from auvdock.fly.events import EventLog
    from auvdock.fly.vehicle_io import VehicleIO
    from auvdock.world.dock import ClockedDock

__all__ = ["MissionClock"]


class MissionClock:
    """The mission's clock: the vehicle's (``dock.offset_s``: the vehicle's time at mission ``t = 0``, s).

    Attributes
    ----------
    zero_s : float or None
        Mission ``t = 0`` on the session's clock (s), once set: the vehicle's time at it less the vehicle's
        clock minus the session's, followed every period (:meth:`follow`).
    """

    def __init__(self, dock: ClockedDock, events: EventLog) -> None:
        self.dock = dock
        self.events = events
        self.zero_s: float | None = None
        self._on_vehicle = False  # the mission's t = 0 set on the vehicle's clock

    @property
    def offset_s(self) -> float:
        """The vehicle's time (s) at mission ``t = 0``."""
        return float(self.dock.offset_s)

    def start(self, t: float, io: VehicleIO) -> None:
        """Mission time ``t`` (s) is now (the newest drain): the vehicle's time now is the session's plus the
        clocks' offset measured with TIMESYNC (:class:`auvdock.fly.link_health.LinkHealth`), or without an
        answer the newest ATTITUDE's ``time_boot_ms`` plus that message's age on arrival (its delivery delay
        not counted: over a 250 ms link the dock would be a quarter second out of phase)."""
        now_s = io.now_us * 1e-6
        self.zero_s = now_s - t
        att, stamp = io.telemetry.latest("ATTITUDE")
        offset = io.figures().offset_s
        if math.isfinite(offset):  # the vehicle's clock now, from TIMESYNC (not the newest ATTITUDE's)
            vehicle_now = now_s + offset
        elif att is not None and stamp is not None:
            vehicle_now = float(att.time_boot_ms) * 1e-3 + max(0, io.now_us - stamp) * 1e-6
        else:
            return
        self.dock.offset_s = vehicle_now - t
        self._on_vehicle = True
        said = f"mission t = 0 at vehicle time {vehicle_now - t:.3f} s"
        self.events.add(f"dock: its motion on the vehicle's clock ({said})")

    def follow(self, offset_s: float) -> None:
        """Mission ``t = 0`` on the session's clock as the vehicle's clock is now measured (``offset_s``, s:
        the vehicle's minus the session's, :class:`auvdock.fly.link_health.LinkFigures`)."""
        if self._on_vehicle and math.isfinite(offset_s):
            self.zero_s = self.offset_s - offset_s

    def reading_offset_s(self, t: float, now_s: float) -> float:
        """The clocks' offset (vehicle minus session, s) that dates a reading stamped on the vehicle's clock
        at its mission time (``time_boot - offset_s``: :func:`auvdock.fly.telemetry.age_s`) for a step at
        mission time ``t`` taken at session time ``now_s`` (s); NaN before the mission's t = 0 is on the
        vehicle's clock (the readings then dated by their arrival)."""
        return self.offset_s + t - now_s if self._on_vehicle else math.nan
