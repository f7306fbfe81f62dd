"""``dock.source: mavlink``: the dock re-anchored from the vehicle's LANDING_TARGET messages.

:class:`LandingTargetSource` reads the latest LANDING_TARGET with ``position_valid`` (frames
MAV_FRAME_BODY_FRD: x, y, z from the vehicle in {b}; MAV_FRAME_LOCAL_NED: the autopilot's NED
frame, mapped to the mission frame), re-anchors the :class:`~auvdock.world.dock.TrackedDock`
on each new one, and says when the dock is lost (none within ``limit_s`` of the start, or none
for ``limit_s``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pymavlink import mavutil

from auvdock.vehicle.geometry import rotation_of
from auvdock.vehicle.state import ATT, POS

if TYPE_CHECKING:
    from auvdock.fly.telemetry import MissionFrame, TelemetrySensors
    from auvdock.world.dock import TrackedDock

__all__ = ["LandingTargetSource"]


class LandingTargetSource:
    """The dock from LANDING_TARGET (see the module docstring)."""

    def __init__(self, dock: TrackedDock, telemetry: TelemetrySensors, limit_s: float) -> None:
        self.dock = dock
        self.telemetry = telemetry
        self.limit_s = float(limit_s)
        self._last: int | None = None

    def update(self, t: float, x: np.ndarray, now_us: int, frame: MissionFrame) -> float:
        """Re-anchor the dock from the latest LANDING_TARGET at mission time ``t`` (s), the vehicle
        at ``x`` (12,); returns the message's age (s; inf without one)."""
        lt, stamp = self.telemetry.latest("LANDING_TARGET")
        if lt is None or stamp is None or not getattr(lt, "position_valid", 0):
            return float("inf")
        age = (now_us - stamp) * 1e-6
        if id(lt) == self._last:
            return age
        self._last = id(lt)
        rel = np.array([lt.x, lt.y, lt.z])
        if lt.frame == mavutil.mavlink.MAV_FRAME_BODY_FRD:
            p = x[POS] + rotation_of(x[ATT]) @ rel
        elif lt.frame == mavutil.mavlink.MAV_FRAME_LOCAL_NED:
            p = frame.position(rel)
        else:
            return float("inf")
        self.dock.update(t, p)
        return age

    def lost(self, t: float, x: np.ndarray, now_us: int, frame: MissionFrame) -> str | None:
        """Update, then why the dock is lost (None while it is not)."""
        age = self.update(t, x, now_us, frame)
        if self.dock.measurements == 0 and t > self.limit_s:
            return f"no LANDING_TARGET with a position within {self.limit_s:g} s"
        if self.dock.measurements and age > self.limit_s:
            return f"dock lost: no LANDING_TARGET for {age:.1f} s"
        return None
