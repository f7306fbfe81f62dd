"""Sensors: the mission's ``sensors:`` section and the simulated sources that read the truth.

Two ways of knowing the vehicle's state, chosen by the mission's ``estimation``:

* ``truth`` (the paper's Assumption 1, the default, to reproduce it): the controllers get the
  true state; the FSE controllers' flow filter reads the paper's sensing of [eta; nu_r] with
  the noise levels of the top-level fields of :class:`SensorSettings`, simulated by
  :class:`SensorModel`.
* ``filter`` (what a BlueROV2 really knows): the sensor suite of :class:`SensorSettings`
  (``imu``, ``ahrs``, ``depth``, ``position``, ``dvl``; defaults from the manufacturers'
  figures, each with its source) is simulated by :class:`SensorSuite` as asynchronous
  :class:`auvdock.estimation.navigation_filter.Reading` s, one definition per measurement
  (:mod:`auvdock.sensing.measurements`), and the navigation filter
  (:mod:`auvdock.estimation.navigation_filter`)
  estimates the state and the current from them.

Seeded: the same seed gives the same readings.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from pydantic import Field

from auvdock.config.schema import NonNegFloat, PosFloat, Strict
from auvdock.vehicle.state import ANG, ATT, ETA, LIN

__all__ = [
    "SensorSettings",
    "ImuSettings",
    "AhrsSettings",
    "DepthSettings",
    "PositionSettings",
    "DvlSettings",
    "POSITION_SOURCES",
    "SensorModel",
    "SensorSuite",
]


class ImuSettings(Strict):
    """The autopilot's IMU (BlueROV2 Navigator: TDK InvenSense ICM-20602), read as ArduSub reports it."""

    rate_hz: PosFloat = Field(
        default=50.0, description="samples used per second, Hz (at most one per control step)"
    )
    latency_s: NonNegFloat = Field(default=0.0, description="sample to use, s")
    accel_noise_m_s2: NonNegFloat = Field(
        default=0.0044,
        description="accelerometer noise std, m/s^2 (ICM-20602 datasheet: 100 ug/sqrt(Hz), "
        "times sqrt(20 Hz), ArduPilot's INS_ACCEL_FILTER)",
    )
    accel_bias_m_s2: NonNegFloat = Field(
        default=0.02,
        description="std of a constant accelerometer bias per run, m/s^2 (assumed: residual after "
        "ArduPilot's accelerometer calibration; ICM-20602 zero-g offset before it: 25 mg)",
    )
    gyro_noise_rad_s: NonNegFloat = Field(
        default=3.1e-4,
        description="gyro noise std, rad/s (ICM-20602 datasheet: 0.004 deg/s/sqrt(Hz), times "
        "sqrt(20 Hz), ArduPilot's INS_GYRO_FILTER)",
    )
    gyro_bias_rad_s: NonNegFloat = Field(
        default=1e-3,
        description="std of a constant gyro bias per run, rad/s (assumed: residual after the gyro "
        "calibration ArduPilot does at boot; ICM-20602 offset before it: 1 deg/s)",
    )


class AhrsSettings(Strict):
    """Attitude from the autopilot's attitude estimate (ArduSub EKF3: ATTITUDE messages)."""

    rate_hz: PosFloat = Field(default=25.0, description="ATTITUDE rate, Hz (what fly requests)")
    latency_s: NonNegFloat = Field(default=0.0, description="sample to use, s")
    roll_pitch_std_rad: NonNegFloat = Field(
        default=0.0087, description="roll and pitch error std, rad (assumed 0.5 deg: no published figure)"
    )
    yaw_std_rad: NonNegFloat = Field(
        default=0.035,
        description="heading error std, rad (assumed 2 deg: magnetometer heading beside thrusters)",
    )


class DepthSettings(Strict):
    """Depth from the pressure sensor (Blue Robotics Bar30, MS5837-30BA: SCALED_PRESSURE2)."""

    rate_hz: PosFloat = Field(default=25.0, description="samples per second, Hz")
    latency_s: NonNegFloat = Field(default=0.0, description="sample to use, s")
    std_m: NonNegFloat = Field(default=0.002, description="depth noise std, m (Bar30: 2 mm resolution)")


#: Position sources and their defaults: rate (Hz), latency (s), noise std (m), source of the figures.
POSITION_SOURCES: dict[str, tuple[float, float, float, str]] = {
    "none": (1.0, 0.0, 0.0, "no position fixes: dead reckoning on the model and the IMU only"),
    "acoustic": (
        2.0,
        0.5,
        0.1,
        "acoustic positioning (Water Linked Underwater GPS G2: accuracy 1 % of range, so 0.1 m at "
        "10 m; rate and latency assumed)",
    ),
    "dvl_dead_reckoning": (
        10.0,
        0.1,
        0.02,
        "ArduSub's EKF on a DVL (Water Linked DVL A50: long-term accuracy 1.01 % of distance "
        "travelled, 2-15 Hz); noise assumed",
    ),
    "camera": (
        15.0,
        0.1,
        0.01,
        "the dock's markers (this project's pose pipeline: <= 3.1 mm at 1 m on rendered views "
        "with noise; 1 cm assumed in water); 15 Hz as the synthetic camera, latency assumed",
    ),
    "motion_capture": (
        50.0,
        0.01,
        0.001,
        "underwater motion capture in a tank (assumed 1 mm, 10 ms)",
    ),
}


class PositionSettings(Strict):
    """Where position fixes come from; rate, latency and noise default to the source's figures."""

    source: Literal["none", "acoustic", "dvl_dead_reckoning", "camera", "motion_capture"] = Field(
        default="camera", description="none, acoustic, dvl_dead_reckoning, camera or motion_capture"
    )
    rate_hz: PosFloat | None = Field(default=None, description="fixes per second, Hz (default: the source's)")
    latency_s: NonNegFloat | None = Field(default=None, description="fix to use, s (default: the source's)")
    std_m: NonNegFloat | None = Field(
        default=None, description="noise std per axis, m (default: the source's)"
    )

    def figures(self) -> tuple[float, float, float]:
        """(rate Hz, latency s, noise std m): the given values, else the source's defaults
        (:data:`POSITION_SOURCES`; kept unresolved so that changing ``source`` changes them)."""
        rate, latency, std, _ = POSITION_SOURCES[self.source]
        return (
            rate if self.rate_hz is None else float(self.rate_hz),
            latency if self.latency_s is None else float(self.latency_s),
            std if self.std_m is None else float(self.std_m),
        )


class DvlSettings(Strict):
    """An optional Doppler velocity log: velocity over ground in {b} (Water Linked DVL A50)."""

    enabled: bool = Field(default=False, description="the vehicle carries a DVL with bottom lock")
    rate_hz: PosFloat = Field(default=10.0, description="velocity reports per second, Hz (A50: 2-15 Hz)")
    latency_s: NonNegFloat = Field(default=0.1, description="report to use, s (assumed)")
    std_m_s: NonNegFloat = Field(
        default=0.01,
        description="velocity noise std per axis, m/s (assumed; A50: 0.1 mm/s resolution, 1.01 % accuracy)",
    )


class SensorSettings(Strict):
    """The sensors.  The top-level noise levels are the paper's sensing of [eta; nu_r] for
    ``estimation: truth``; ``imu``, ``ahrs``, ``depth``, ``position`` and ``dvl`` are the
    BlueROV2's sensor suite, read by the navigation filter with ``estimation: filter``."""

    position_std_m: NonNegFloat = Field(default=0.002, description="pose position noise, m")
    attitude_std_rad: NonNegFloat = Field(default=0.002, description="pose attitude noise, rad")
    gyro_std_rad_s: NonNegFloat = Field(default=0.001, description="angular-rate noise, rad/s")
    accel_std_m_s2: NonNegFloat = Field(default=0.0045, description="accelerometer noise, m/s^2")
    depth_rate_std_m_s: NonNegFloat = Field(default=0.0014, description="depth-rate noise, m/s")
    relative_velocity_std_m_s: NonNegFloat = Field(
        default=0.001,
        description="noise of the velocity through the water (Assumption 1: state (eta, nu_r)), m/s",
    )
    imu: ImuSettings = Field(default_factory=ImuSettings)
    ahrs: AhrsSettings = Field(default_factory=AhrsSettings)
    depth: DepthSettings = Field(default_factory=DepthSettings)
    position: PositionSettings = Field(default_factory=PositionSettings)
    dvl: DvlSettings = Field(default_factory=DvlSettings)


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


class _Channel:
    """One simulated sensor: sampled at the control instants where it is due, delivered after
    its latency, with a constant bias drawn per run and white noise."""

    def __init__(
        self, kind: str, rate_hz: float, latency_s: float, std: np.ndarray, bias: np.ndarray
    ) -> None:
        self.kind = kind
        self.period = 1.0 / float(rate_hz)
        self.latency = float(latency_s)
        self.std = np.asarray(std, dtype=float)
        self.bias = np.asarray(bias, dtype=float)
        self.next_sample = 0.0
        self.pending: list[Any] = []


class SensorSuite:
    """The BlueROV2's sensor suite, simulated from the truth: a list of readings per control step.

    Every reading is the one definition of its measurement (:func:`auvdock.sensing.measurements.measure`)
    at the true state, plus a bias constant over the run and white noise, both seeded.  A
    sensor is sampled at the control instants where it is due (so a sensor faster than the
    control rate gives one reading per step) and delivered once its latency has passed, with
    its sample time.

    Parameters
    ----------
    settings : SensorSettings
        The suite (``imu``, ``ahrs``, ``depth``, ``position``, ``dvl``).
    vehicle : Vehicle
        The one model the measurements are defined on.
    seed : int
        Seed of biases and noise.
    """

    def __init__(self, settings: SensorSettings, vehicle: Any, seed: int) -> None:
        self.vehicle = vehicle
        self.rng = np.random.default_rng([int(seed), 15])
        s = settings
        chans = [
            _Channel(
                "attitude",
                s.ahrs.rate_hz,
                s.ahrs.latency_s,
                np.array([s.ahrs.roll_pitch_std_rad] * 2 + [s.ahrs.yaw_std_rad]),
                np.zeros(3),
            ),
            _Channel(
                "gyro",
                s.imu.rate_hz,
                s.imu.latency_s,
                np.full(3, s.imu.gyro_noise_rad_s),
                self.rng.normal(0.0, s.imu.gyro_bias_rad_s, 3),
            ),
            _Channel(
                "accel",
                s.imu.rate_hz,
                s.imu.latency_s,
                np.full(3, s.imu.accel_noise_m_s2),
                self.rng.normal(0.0, s.imu.accel_bias_m_s2, 3),
            ),
            _Channel("depth", s.depth.rate_hz, s.depth.latency_s, np.array([s.depth.std_m]), np.zeros(1)),
        ]
        if s.position.source != "none":
            rate, latency, std = s.position.figures()
            chans.append(_Channel("position", rate, latency, np.full(3, std), np.zeros(3)))
        if s.dvl.enabled:
            chans.append(
                _Channel("dvl", s.dvl.rate_hz, s.dvl.latency_s, np.full(3, s.dvl.std_m_s), np.zeros(3))
            )
        self.channels = chans

    def read(self, t: float, x: np.ndarray, u_prev: np.ndarray, flow_ned: np.ndarray) -> list[Any]:
        """The readings delivered at control instant ``t`` (s): state ``x`` (12,), thrust held
        over the last period ``u_prev`` (n,), true flow at the vehicle ``flow_ned`` (3,)."""
        from auvdock.estimation.navigation_filter import Reading
        from auvdock.sensing.measurements import measure

        out = []
        for c in self.channels:
            if t + 1e-9 >= c.next_sample:
                value = measure(c.kind, self.vehicle, x, u_prev, flow_ned)
                noisy = value + c.bias + c.std * self.rng.standard_normal(c.std.shape)
                # the sensor's stated std is its white noise: the bias is what a filter must live with
                c.pending.append(Reading(c.kind, t, noisy, c.std.copy()))
                c.next_sample = max(c.next_sample + c.period, t + 0.5 * c.period)
            while c.pending and c.pending[0].t + c.latency <= t + 1e-9:
                out.append(c.pending.pop(0))
        return out
