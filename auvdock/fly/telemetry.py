"""Telemetry to the mission frame: the vehicle's pose mapped onto the mission's start, and the sensors.

The mission is written in its own NED frame, in which the vehicle starts at ``start.state``.
The vehicle's telemetry (LOCAL_POSITION_NED, ATTITUDE) is in the autopilot's frame; at the
start of a session :class:`MissionFrame` maps the vehicle's pose onto the mission's start
pose (a translation and a rotation about down), and every later reading through the same
map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry import Rz, rotation_zyx, wrap_angle
from ..vehicle.state import ANG, ATT, ETA, LIN

__all__ = ["G", "TELEMETRY_MESSAGES", "MissionFrame", "sensors_from_telemetry", "geofence_violation"]

G = 9.80665
#: The streams a session requests (MAV_CMD_SET_MESSAGE_INTERVAL) at ``fly.telemetry_rate_hz``.
TELEMETRY_MESSAGES = ("ATTITUDE", "LOCAL_POSITION_NED", "SCALED_IMU2", "SCALED_PRESSURE2", "SERVO_OUTPUT_RAW")


def _rotation(angles: np.ndarray) -> np.ndarray:
    return rotation_zyx(float(angles[0]), float(angles[1]), float(angles[2]))


@dataclass(frozen=True)
class MissionFrame:
    """The map from the autopilot's NED frame to the mission's.

    Attributes
    ----------
    dpsi : float
        Heading added to the vehicle's (rad): mission heading = vehicle heading + dpsi.
    p_vehicle0, p_mission0 : ndarray (3,)
        The vehicle's start position in the autopilot's frame and in the mission's (m).
    """

    dpsi: float
    p_vehicle0: np.ndarray
    p_mission0: np.ndarray

    @classmethod
    def at_start(cls, p_vehicle: np.ndarray, psi_vehicle: float, x0: np.ndarray) -> MissionFrame:
        """The frame putting the vehicle pose (``p_vehicle``, ``psi_vehicle``) at the mission start."""
        return cls(wrap_angle(float(x0[5]) - psi_vehicle), np.asarray(p_vehicle, float), x0[0:3].copy())

    @property
    def R(self) -> np.ndarray:
        """Rotation of vectors from the autopilot's frame to the mission's (3, 3)."""
        return Rz(self.dpsi)

    def position(self, p_vehicle: np.ndarray) -> np.ndarray:
        """A position of the autopilot's frame in the mission's (m)."""
        return self.p_mission0 + self.R @ (np.asarray(p_vehicle, float) - self.p_vehicle0)

    def state(self, att: Any, pos: Any) -> np.ndarray:
        """The vehicle state (12,) in the mission frame from ATTITUDE and LOCAL_POSITION_NED."""
        p = self.position(np.array([pos.x, pos.y, pos.z]))
        v_ned = self.R @ np.array([pos.vx, pos.vy, pos.vz])
        theta = np.array([att.roll, att.pitch, wrap_angle(att.yaw + self.dpsi)])
        nu1 = _rotation(theta).T @ v_ned
        nu2 = np.array([att.rollspeed, att.pitchspeed, att.yawspeed])
        return np.concatenate([p, theta, nu1, nu2])

    def describe(self, p_vehicle: np.ndarray, psi_vehicle: float) -> str:
        x0p = self.p_mission0
        return (
            f"frame: vehicle start ({p_vehicle[0]:.2f}, {p_vehicle[1]:.2f}, {p_vehicle[2]:.2f}) m, "
            f"heading {math.degrees(psi_vehicle):.1f} deg -> mission start "
            f"({x0p[0]:.2f}, {x0p[1]:.2f}, {x0p[2]:.2f}) m, "
            f"{math.degrees(wrap_angle(psi_vehicle + self.dpsi)):.1f} deg"
        )


def sensors_from_telemetry(
    x: np.ndarray, flow_ned: np.ndarray, imu: Any | None
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The controller's sensors from the state and SCALED_IMU2 (None if missing or stale).

    Returns the sensor dict of :class:`auvdock.controllers.Measurement` and the specific force
    (3,) m/s^2 in {b} (NaN without a fresh IMU message).  ``accel_m_s2`` is d(nu_1)/dt:
    the accelerometer's specific force plus gravity in {b}, minus ``nu_2 x nu_1``.
    """
    R = _rotation(x[ATT])
    sensors: dict[str, np.ndarray] = {
        "pose": x[ETA].copy(),
        "gyro_rad_s": x[ANG].copy(),
        "depth_rate_m_s": np.asarray(float(R[2] @ x[LIN])),
        "relative_velocity_m_s": x[LIN] - R.T @ flow_ned,
    }
    f_b = np.full(3, np.nan)
    if imu is not None:
        f_b = np.array([imu.xacc, imu.yacc, imu.zacc]) * G / 1000.0  # mG -> m/s^2
        a_b = f_b + R.T @ np.array([0.0, 0.0, G])  # acceleration over ground in {b}
        sensors["accel_m_s2"] = a_b - np.cross(x[ANG], x[LIN])
    return sensors, f_b


def geofence_violation(fence: Any, x: np.ndarray, p_start: np.ndarray) -> str | None:
    """Why the state ``x`` is outside ``fly.geofence`` (distance from ``p_start``, depths), or None."""
    horiz = float(np.linalg.norm(x[0:2] - p_start[0:2]))
    if horiz > fence.max_distance_m:
        return f"geofence: {horiz:.2f} m from the start (limit {fence.max_distance_m:g} m)"
    if x[2] < fence.min_depth_m:
        return f"geofence: depth {x[2]:.2f} m above the minimum {fence.min_depth_m:g} m"
    if x[2] > fence.max_depth_m:
        return f"geofence: depth {x[2]:.2f} m below the maximum {fence.max_depth_m:g} m"
    return None
