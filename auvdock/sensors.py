"""Simulated sensors: their settings (noise levels) and the model that reads them off the truth.

:class:`SensorSettings` is the mission's ``sensors:`` section; :class:`SensorModel` turns
the true state into the readings a controller step gets in ``sim``, ``compare`` and
``sweep`` (:class:`auvdock.controllers.Measurement` ``sensors``).  Seeded: the same seed
gives the same readings.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydantic import Field

from .schema import NonNegFloat, Strict
from .vehicle.state import ANG, ATT, ETA, LIN

__all__ = ["SensorSettings", "SensorModel"]


class SensorSettings(Strict):
    """Simulated sensor noise (standard deviations); no velocity over ground (no DVL)."""

    position_std_m: NonNegFloat = Field(default=0.002, description="pose position noise, m")
    attitude_std_rad: NonNegFloat = Field(default=0.002, description="pose attitude noise, rad")
    gyro_std_rad_s: NonNegFloat = Field(default=0.001, description="angular-rate noise, rad/s")
    accel_std_m_s2: NonNegFloat = Field(default=0.0045, description="accelerometer noise, m/s^2")
    depth_rate_std_m_s: NonNegFloat = Field(default=0.0014, description="depth-rate noise, m/s")
    relative_velocity_std_m_s: NonNegFloat = Field(
        default=0.001,
        description="noise of the velocity through the water (Assumption 1: state (eta, nu_r)), m/s",
    )


class SensorModel:
    """Simulated inertial and pose sensors, seeded (same seed, same readings).

    Readings at t_k (noise standard deviations from :class:`SensorSettings`):
    ``pose`` (6,) eta + noise; ``gyro_rad_s`` (3,) nu_2 + noise; ``relative_velocity_m_s`` (3,)
    the linear velocity through the water nu_r1 + noise (Assumption 1 in the authors' state
    [eta; nu_r]);  ``accel_m_s2`` (3,) the mean body acceleration over the last period,
    ``(nu_1(t_k) - nu_1(t_(k-1))) / dt`` + noise (gravity removed; absent at k = 0);
    ``depth_rate_m_s`` the z component of R nu_1 + noise.

    Parameters
    ----------
    settings : SensorSettings
        Noise levels.
    seed : int
        Seed of the noise generator.
    rotation : callable
        ``R(angles)`` (3x3, {b} -> {n}) of the vehicle model.
    """

    def __init__(
        self, settings: SensorSettings, seed: int, rotation: Callable[[np.ndarray], np.ndarray]
    ) -> None:
        s = settings
        self.rng = np.random.default_rng(seed)
        self.pos_std = s.position_std_m
        self.att_std = s.attitude_std_rad
        self.gyro_std = s.gyro_std_rad_s
        self.acc_std = s.accel_std_m_s2
        self.dr_std = s.depth_rate_std_m_s
        self.vr_std = s.relative_velocity_std_m_s
        self.rot = rotation

    def read(
        self, x: np.ndarray, x_prev: np.ndarray | None, dt: float, flow_ned: np.ndarray
    ) -> dict[str, np.ndarray]:
        """The readings at state ``x`` (12,), after ``x_prev`` one period ``dt`` (s) earlier."""
        n = self.rng.standard_normal(16)
        R = self.rot(x[ATT])
        pose = x[ETA] + np.concatenate([self.pos_std * n[0:3], self.att_std * n[3:6]])
        out = {
            "pose": pose,
            "gyro_rad_s": x[ANG] + self.gyro_std * n[6:9],
            "depth_rate_m_s": np.asarray(float(R[2] @ x[LIN]) + self.dr_std * n[12]),
            "relative_velocity_m_s": x[LIN] - R.T @ flow_ned + self.vr_std * n[13:16],
        }
        if x_prev is not None:
            out["accel_m_s2"] = (x[LIN] - x_prev[LIN]) / dt + self.acc_std * n[9:12]
        return out
