"""The dock's telemetry on a vehicle's link: the dock's motion unit, as ``sim``'s ``dock_motion`` readings.

With ``sensors.dock_telemetry`` the deployable controllers forecast the dock's motion from the dock's own
record of it (:class:`auvdock.sensing.settings.DockTelemetrySettings`).  On a link the dock is a MAVLink
system of its own (``sensors.dock_telemetry.mavlink_system``) sending ODOMETRY
(:mod:`auvdock.standins.dock_out` says why that message, and its fields): x, y, z its displacement from
its mean (NED m), the position block of ``pose_covariance`` its noise, ``time_usec`` the sample's instant
on the vehicle's clock (the dock and the vehicle share one clock: GPS time on a real dock, the stand-in's
in a rehearsal).  :class:`DockTelemetryIn` keeps the record and hands the estimation stage readings of
kind ``dock_motion`` on the mission's clock: ``t = time_usec - (the vehicle's time at the mission's
t = 0)``.  At the first step it hands over the last ``history_s`` of the record at once, as ``sim`` does;
fly waits before arming until it has that much (:meth:`DockTelemetryIn.missing`).
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.sensing.readings import Reading

if TYPE_CHECKING:
    from auvdock.sensing.settings import DockTelemetrySettings

__all__ = ["DockTelemetryIn", "DOCK_TELEMETRY_SERIES"]

#: Per-step series of a flight with the dock's telemetry (name -> per-row shape).
DOCK_TELEMETRY_SERIES: dict[str, tuple[int, ...]] = {"dock_telemetry_age_s": ()}


class DockTelemetryIn:
    """The dock's ODOMETRY from its system, kept and handed on as ``dock_motion`` readings.

    Parameters
    ----------
    settings : DockTelemetrySettings
        The dock's system id, its rate, noise (where the message has no covariance) and ``history_s``.
    """

    def __init__(self, settings: DockTelemetrySettings) -> None:
        self.settings = settings
        self.system = int(settings.mavlink_system)
        self.history_s = float(settings.history_s)
        self._record: deque[tuple[float, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]] = (
            deque()
        )
        self._new: list[tuple[float, np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]] = []
        self._started = False
        self.last_arrival_us: int | None = None
        self.received = 0

    def feed(self, messages: list[tuple[int, Any]]) -> None:
        """Take the messages received since the last call (``(stamp us, message)``): the dock's ODOMETRY."""
        for stamp, msg in messages:
            if msg.get_type() != "ODOMETRY" or msg.get_srcSystem() != self.system:
                continue
            value = np.array([msg.x, msg.y, msg.z], dtype=float)
            if not np.all(np.isfinite(value)):
                continue
            cov = list(msg.pose_covariance)
            var = np.array([cov[0], cov[6], cov[11]], dtype=float)
            known = np.all(np.isfinite(var)) and np.all(var > 0)
            std = np.sqrt(var) if known else np.full(3, self.settings.std_m)
            # the rate, where the unit measures it (a data sheet's unit: motion_unit mru)
            rate = np.array([msg.vx, msg.vy, msg.vz], dtype=float)
            rate_std = None
            if np.all(np.isfinite(rate)):
                vcov = list(msg.velocity_covariance)
                vvar = np.array([vcov[0], vcov[6], vcov[11]], dtype=float)
                good = np.all(np.isfinite(vvar)) and np.all(vvar > 0)
                rate_std = np.sqrt(vvar) if good else np.full(3, self.settings.rate_noise_m_s)
            item = (float(msg.time_usec) * 1e-6, value, std, rate if rate_std is not None else None, rate_std)
            self._record.append(item)
            if self._started:  # (before the first step, the record is handed over whole)
                self._new.append(item)
            self.last_arrival_us = int(stamp)
            self.received += 1
        keep = self.history_s + 60.0  # the record the first step needs, and some
        while self._record and self._record[-1][0] - self._record[0][0] > keep:
            self._record.popleft()

    @property
    def span_s(self) -> float:
        """How long a record fly has, s (0 before two samples)."""
        if len(self._record) < 2:
            return 0.0
        return self._record[-1][0] - self._record[0][0]

    def missing(self) -> str | None:
        """What fly still waits for before arming (None: the record is long enough)."""
        need = max(self.history_s - 1.5 / float(self.settings.rate_hz), 0.0)
        if self.received and self.span_s >= need:
            return None
        return (
            f"the dock's telemetry (ODOMETRY from system {self.system}): {self.span_s:.0f} of "
            f"{self.history_s:g} s of its record (sensors.dock_telemetry.history_s)"
        )

    def age_s(self, now_us: int) -> float:
        """Since the dock's last message arrived, s (inf before one)."""
        return math.inf if self.last_arrival_us is None else max(0.0, (now_us - self.last_arrival_us) * 1e-6)

    def readings(self, vehicle_time_at_zero_s: float) -> list[Reading]:
        """The new samples as ``dock_motion`` readings (and ``dock_motion_rate`` where the message carries the
        rate) on the mission's clock (s: the sample's instant less ``vehicle_time_at_zero_s``, the vehicle's
        time at the mission's t = 0); at the first call, the last ``history_s`` of the record."""
        if not self._started:
            self._started = True
            newest = self._record[-1][0] if self._record else -math.inf
            items = [r for r in self._record if r[0] >= newest - self.history_s - 1e-9]
        else:
            items = self._new
        self._new = []
        z = float(vehicle_time_at_zero_s)
        out = []
        for t, v, s, rate, rate_std in items:
            out.append(Reading("dock_motion", t - z, v.copy(), s.copy()))
            if rate is not None and rate_std is not None:
                out.append(Reading("dock_motion_rate", t - z, rate.copy(), rate_std.copy()))
        return out
