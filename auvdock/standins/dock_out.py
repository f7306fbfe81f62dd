"""The dock as its own MAVLink system in a rehearsal: its motion unit's telemetry, as ODOMETRY.

A WEC dock's motion reference unit reports the docking point's displacement from its mean (heave, and
surge and sway where it moves so); ``sim`` simulates it as readings of kind ``dock_motion``
(:class:`auvdock.sensing.settings.DockTelemetrySettings`).  On a link the dock is a MAVLink system of its
own (``sensors.dock_telemetry.mavlink_system``, component ``MAV_COMP_ID_ONBOARD_COMPUTER``: the dock's
computer relaying its motion unit) sending **ODOMETRY**, MAVLink's standard message for a pose with its
covariance and its own time stamp from an outside estimator:

==================  =====================================================================================
field               value
==================  =====================================================================================
time_usec           the sample's instant on the stand-in's clock (its ``time_boot``, us): the dock and the
                    vehicle on one clock (on a real dock: GPS time on both; fly places it on the mission's
                    clock with the vehicle's, :mod:`auvdock.fly.dock_telemetry`)
frame_id            MAV_FRAME_LOCAL_NED; child_frame_id MAV_FRAME_LOCAL_NED
x, y, z             the displacement from the dock's mean, NED m, with the motion unit's errors (the same
                    :class:`auvdock.sensing.motion_unit.MotionUnit` as ``sim``'s)
q                   (1, 0, 0, 0)
vx, vy, vz          the displacement's rate, NED m/s, where the unit measures it (``motion_unit: mru``);
                    else NaN; angular rates NaN (not measured)
pose_covariance     the white noise's variance on the position's diagonal (the upper triangle's entries 0,
                    6, 11), NaN for the attitude (not measured); velocity_covariance likewise for the
                    rate, or NaN (first entry) without one
estimator_type      MAV_ESTIMATOR_TYPE_NAIVE; quality 100
==================  =====================================================================================

Each sample is sent ``latency_s`` after it is taken, a share ``dropout`` is lost, at ``rate_hz``: the
mission's stated errors, drawn from the streams ``sim`` draws them from (:class:`DockTelemetryOut`).
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING, Any

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auvdock.sensing.motion_unit import MotionUnit
from auvdock.standins.telemetry_out import time_usec

if TYPE_CHECKING:
    from auvdock.sensing.settings import DockTelemetrySettings

__all__ = ["DockTelemetryOut", "DOCK_COMPONENT", "odometry"]

M = mavlink2

#: The dock's component id: its computer, relaying the motion unit.
DOCK_COMPONENT = M.MAV_COMP_ID_ONBOARD_COMPUTER

_NAN = float("nan")


def odometry(
    t: float,
    displacement_ned_m: np.ndarray,
    std_m: float,
    rate_ned_m_s: np.ndarray | None = None,
    rate_std_m_s: float = 0.0,
) -> mavlink2.MAVLink_message:
    """ODOMETRY of the dock's displacement from its mean (3,, NED m) sampled at ``t`` (s, the stand-in's
    clock), with the per-axis noise ``std_m`` (m) as its covariance, and its rate (3,, NED m/s; None: not
    measured) with ``rate_std_m_s`` (see the module docstring)."""
    x, y, z = (float(v) for v in displacement_ned_m)
    cov = [_NAN] * 21
    var = float(std_m) ** 2
    cov[0] = cov[6] = cov[11] = var  # x, y, z on the upper triangle's diagonal
    cov[1] = cov[2] = cov[7] = 0.0
    if rate_ned_m_s is None:
        vx = vy = vz = _NAN
        vcov = [_NAN] + [0.0] * 20
    else:
        vx, vy, vz = (float(v) for v in rate_ned_m_s)
        vcov = [_NAN] * 21
        vcov[0] = vcov[6] = vcov[11] = float(rate_std_m_s) ** 2
        vcov[1] = vcov[2] = vcov[7] = 0.0
    return M.MAVLink_odometry_message(
        time_usec(t), M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_LOCAL_NED, x, y, z, [1.0, 0.0, 0.0, 0.0],
        vx, vy, vz, _NAN, _NAN, _NAN, cov, vcov, 0, M.MAV_ESTIMATOR_TYPE_NAIVE, 100,
    )  # fmt: skip


class DockTelemetryOut:
    """The dock's telemetry sent on a stand-in's connection (see the module docstring).

    Parameters
    ----------
    settings : DockTelemetrySettings
        Rate, latency, noise, dropout and the dock's system id.
    dock : object
        The true dock (``position(t)``, ``position_ned_m``: its mean).
    seed : int
        The mission's seed (the errors' own stream, as ``sim`` draws them).
    """

    def __init__(self, settings: DockTelemetrySettings, dock: Any, seed: int) -> None:
        self.settings = settings
        self.dock = dock
        self.anchor = np.asarray(dock.position_ned_m, dtype=float)
        self.period = 1.0 / float(settings.rate_hz)
        self.rng = np.random.default_rng([int(seed), 16])
        self.unit = MotionUnit(
            settings, np.random.default_rng([int(seed), 17])
        )  # sim's streams, sim's errors
        self._next = 0.0
        self._pending: deque[tuple[float, mavlink2.MAVLink_message]] = deque()
        self._mav: mavlink2.MAVLink | None = None
        self.sent = 0

    def attach(self, conn: Any) -> None:
        """Send on ``conn`` (a pymavlink connection) as system ``mavlink_system``, MAVLink 2."""
        self._mav = M.MAVLink(conn, srcSystem=int(self.settings.mavlink_system), srcComponent=DOCK_COMPONENT)

    def step(self, t: float, paused: bool = False) -> None:
        """At the stand-in's time ``t`` (s): sample where due, send what is ``latency_s`` old."""
        s = self.settings
        while t + 1e-9 >= self._next:
            ts = self._next
            lost = self.rng.random() < s.dropout
            value = np.asarray(self.dock.position(ts), dtype=float) - self.anchor
            sample = self.unit.sample(ts, value, np.asarray(self.dock.velocity(ts), dtype=float))
            if not lost:
                pos = sample[0]
                rate = sample[1] if len(sample) > 1 else None
                msg = odometry(
                    ts,
                    pos.value,
                    float(np.asarray(pos.std)[2]),
                    None if rate is None else rate.value,
                    0.0 if rate is None else float(np.asarray(rate.std)[2]),
                )
                self._pending.append((ts + s.latency_s, msg))
            self._next = ts + self.period
        while self._pending and self._pending[0][0] <= t + 1e-9:
            _, msg = self._pending.popleft()
            if self._mav is not None and not paused:
                try:
                    self._mav.send(msg)
                    self.sent += 1
                except (OSError, ValueError, OverflowError):
                    pass
