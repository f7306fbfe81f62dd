"""The mission's dock motion on the vehicle's clock, in a flight.

The dock moves on mission time; a flight's readings are stamped on the vehicle's clock
(ArduSub's ``time_boot_ms``).  :class:`DockClock` sets the mission's ``t = 0`` on both at the
loop's first period, and keeps the dock on the link's estimate of the vehicle's clock as it is
refined, so that readings and dock move together (the relative position, which the verdict
judges, does not jump).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from auvdock.fly.events import EventLog
    from auvdock.fly.vehicle_io import VehicleIO
    from auvdock.world.dock import ClockedDock

__all__ = ["DockClock"]


class DockClock:
    """The mission's dock (``dock.offset_s``: the vehicle's time at mission ``t = 0``, s) on the
    vehicle's clock.

    Attributes
    ----------
    zero_s : float or None
        Mission ``t = 0`` on the session's clock (s), once set.
    """

    def __init__(self, dock: ClockedDock, events: EventLog) -> None:
        self.dock = dock
        self.events = events
        self.zero_s: float | None = None

    @property
    def offset_s(self) -> float:
        """The vehicle's time (s) at mission ``t = 0``."""
        return float(self.dock.offset_s)

    def start(self, t: float, io: VehicleIO) -> None:
        """Mission time ``t`` (s) is now (the newest drain): the vehicle's time now is the session's plus
        the clocks' offset measured with TIMESYNC (:class:`auvdock.fly.link_health.LinkHealth`), or
        without an answer the newest ATTITUDE's ``time_boot_ms`` plus that message's age on arrival (its
        delivery delay not counted: over a 250 ms link the dock would be a quarter second out of phase)."""
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
        said = f"mission t = 0 at vehicle time {vehicle_now - t:.3f} s"
        self.events.add(f"dock: its motion on the vehicle's clock ({said})")

    def follow(self, offset_s: float) -> None:
        """Keep the dock on the link's estimate of the vehicle's clock (``offset_s``, s: the vehicle's
        minus the session's, :class:`auvdock.fly.link_health.LinkFigures`)."""
        if self.zero_s is not None and math.isfinite(offset_s):
            self.dock.offset_s = self.zero_s + offset_s
