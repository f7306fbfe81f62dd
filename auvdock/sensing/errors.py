"""Each sensor's errors, defined once: rate, latency, white noise and a per-run bias.

:func:`sensor_errors` reads the mission's ``sensors`` section
(:class:`~auvdock.sensing.settings.SensorSettings`) into one :class:`SensorErrors` per sensor
kind, in the order of :data:`SENSORS`; every consumer takes them from here -- the simulated
suite (:class:`auvdock.sensing.simulated.SensorSuite`), the MAVLink stand-in vehicle
(:class:`auvdock.standins.vehicle_sim.VehicleSim`), and the readings fly builds from telemetry
(:class:`auvdock.fly.telemetry.TelemetrySensors`) -- and the navigation filter reads the same
noise figures with every reading.  A new sensor is its measurement
(:mod:`auvdock.sensing.measurements`), its settings and one entry in :data:`SENSORS`.

Units: those of the kind's measurement (rad, rad/s, m/s^2, m, m/s); rates in Hz, latencies in s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from auvdock.sensing.settings import SensorSettings

__all__ = ["SensorErrors", "SENSORS", "sensor_errors", "draw_bias"]


@dataclass(frozen=True)
class SensorErrors:
    """The errors of one sensor.

    Attributes
    ----------
    kind : str
        The measurement kind (:data:`auvdock.sensing.measurements.KINDS`).
    rate_hz, latency_s : float
        Samples per second, Hz; sample to use, s.
    noise_std : ndarray (KINDS[kind],)
        White-noise standard deviation per component.
    bias_std : ndarray (KINDS[kind],) or None
        Standard deviation of a constant bias drawn once per run (None: the sensor has none).
    enabled : bool
        The vehicle carries it (a position source other than ``none``; a DVL with ``enabled``).
    """

    kind: str
    rate_hz: float
    latency_s: float
    noise_std: np.ndarray
    bias_std: np.ndarray | None
    enabled: bool = True


def _attitude(s: SensorSettings) -> SensorErrors:
    std = np.array([s.ahrs.roll_pitch_std_rad] * 2 + [s.ahrs.yaw_std_rad])
    return SensorErrors("attitude", s.ahrs.rate_hz, s.ahrs.latency_s, std, None)


def _gyro(s: SensorSettings) -> SensorErrors:
    imu = s.imu
    return SensorErrors(
        "gyro", imu.rate_hz, imu.latency_s, np.full(3, imu.gyro_noise_rad_s), np.full(3, imu.gyro_bias_rad_s)
    )


def _accel(s: SensorSettings) -> SensorErrors:
    imu = s.imu
    return SensorErrors(
        "accel", imu.rate_hz, imu.latency_s, np.full(3, imu.accel_noise_m_s2), np.full(3, imu.accel_bias_m_s2)
    )


def _depth(s: SensorSettings) -> SensorErrors:
    return SensorErrors("depth", s.depth.rate_hz, s.depth.latency_s, np.array([s.depth.std_m]), None)


def _position(s: SensorSettings) -> SensorErrors:
    rate, latency, std = s.position.figures()
    bias = np.full(3, s.position.bias_std_m) if s.position.bias_std_m > 0 else None  # None: no draw
    return SensorErrors("position", rate, latency, np.full(3, std), bias, s.position.source != "none")


def _dvl(s: SensorSettings) -> SensorErrors:
    d = s.dvl
    return SensorErrors("dvl", d.rate_hz, d.latency_s, np.full(3, d.std_m_s), None, d.enabled)


def _dock(s: SensorSettings) -> SensorErrors:
    # the noise of each fix comes from the camera's geometry (auvdock.sensing.camera_fix): none here
    c = s.dock_camera
    return SensorErrors("dock", c.rate_hz, c.latency_s, np.zeros(3), None, c.enabled)


#: Every sensor kind and how its errors follow from the settings, in the order channels are built
#: (and biases drawn).
SENSORS: dict[str, Callable[[SensorSettings], SensorErrors]] = {
    "attitude": _attitude,
    "gyro": _gyro,
    "accel": _accel,
    "depth": _depth,
    "position": _position,
    "dvl": _dvl,
    "dock": _dock,
}


def sensor_errors(settings: SensorSettings) -> dict[str, SensorErrors]:
    """Every sensor's errors (enabled or not), kind -> :class:`SensorErrors`, in :data:`SENSORS` order."""
    return {kind: build(settings) for kind, build in SENSORS.items()}


def draw_bias(errors: SensorErrors, rng: np.random.Generator) -> np.ndarray:
    """This run's constant bias of a sensor (zeros for one without a bias term; drawn from ``rng``
    only for one with, so that the same seed gives the same biases)."""
    if errors.bias_std is None:
        return np.zeros_like(errors.noise_std)
    return rng.normal(0.0, errors.bias_std, errors.bias_std.shape)
