"""The simulated sensors of a closed-loop run: readings made from the truth, seeded.

Two sources, as the mission's ``estimation`` asks (:class:`SimulatedSensors` picks them):

* :class:`SensorModel`: the paper's sensing of ``[eta; nu_r]`` under Assumption 1
  (``estimation: truth``), with the noise levels of the top-level fields of
  :class:`~auvdock.sensing.settings.SensorSettings`;
* :class:`SensorSuite`: the BlueROV2's sensor suite (``estimation: filter``): asynchronous
  :class:`~auvdock.sensing.readings.Reading` s, one definition per measurement
  (:mod:`auvdock.sensing.measurements`), each sensor with its rate, latency, bias and noise
  from :class:`~auvdock.sensing.settings.SensorSettings`.

Seeded: the same seed gives the same readings.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from auvdock.sensing.errors import draw_bias, sensor_errors
from auvdock.sensing.measurements import measure
from auvdock.sensing.motion_unit import MotionUnit
from auvdock.sensing.readings import FlowSensing, Reading, Readings
from auvdock.sensing.settings import SensorSettings
from auvdock.vehicle.state import ANG, ATT, ETA, LIN

if TYPE_CHECKING:
    from auvdock.sensing.camera_fix import CameraFixSource
    from auvdock.vehicle import Vehicle
    from auvdock.world.dock import DockMotion

__all__ = ["SensorModel", "SensorSuite", "SimulatedSensors"]


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

    def read(self, x: np.ndarray, x_prev: np.ndarray | None, dt: float, flow_ned: np.ndarray) -> FlowSensing:
        """The readings at state ``x`` (12,), after ``x_prev`` one period ``dt`` (s) earlier."""
        n = self.rng.standard_normal(16)
        R = self.rot(x[ATT])
        pose = x[ETA] + np.concatenate([self.pos_std * n[0:3], self.att_std * n[3:6]])
        accel = None if x_prev is None else (x[LIN] - x_prev[LIN]) / dt + self.acc_std * n[9:12]
        return FlowSensing(
            pose=pose,
            gyro_rad_s=x[ANG] + self.gyro_std * n[6:9],
            relative_velocity_m_s=x[LIN] - R.T @ flow_ned + self.vr_std * n[13:16],
            depth_rate_m_s=float(R[2] @ x[LIN]) + self.dr_std * n[12],
            accel_m_s2=accel,
        )


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
        self.pending: list[Reading] = []


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
    camera_fix : CameraFixSource, optional
        With ``dock_camera.enabled``, the camera (:mod:`auvdock.sensing.camera_fix`) whose fixes of
        ``dock`` are the readings of kind ``dock``: only when it sees the dock's markers.
    dock : DockMotion, optional
        The true dock the camera looks at, and whose motion ``dock_telemetry`` sends (readings of
        kind ``dock_motion``: its displacement from its mean, NED m).
    """

    def __init__(
        self,
        settings: SensorSettings,
        vehicle: Vehicle,
        seed: int,
        *,
        camera_fix: CameraFixSource | None = None,
        dock: DockMotion | None = None,
    ) -> None:
        self.vehicle = vehicle
        self.rng = np.random.default_rng([int(seed), 15])
        self.camera_fix = camera_fix if settings.dock_camera.enabled else None
        self.dock = dock
        if settings.dock_camera.enabled and (camera_fix is None or dock is None):
            raise ValueError(
                "sensors.dock_camera: the simulated camera needs its model and the dock it looks at"
            )
        chans = []
        for err in sensor_errors(settings).values():
            if not err.enabled:
                continue
            # the sensor's stated std is its white noise: the bias is what a filter must live with
            chans.append(
                _Channel(err.kind, err.rate_hz, err.latency_s, err.noise_std, draw_bias(err, self.rng))
            )
        self.channels = chans
        tel = settings.dock_telemetry
        self.telemetry: _Channel | None = None
        if tel.enabled:
            if dock is None:
                raise ValueError("sensors.dock_telemetry: the simulated telemetry needs its dock")
            self.telemetry = _Channel("dock_motion", tel.rate_hz, tel.latency_s, np.zeros(3), np.zeros(3))
            self.telemetry_dropout = float(tel.dropout)
            self.telemetry_history_s = float(tel.history_s)
            self.telemetry_rng = np.random.default_rng([int(seed), 16])  # the other sensors' draws unchanged
            self.motion_unit = MotionUnit(tel, np.random.default_rng([int(seed), 17]))
        self._started = False

    def read(
        self,
        t: float,
        x: np.ndarray,
        u_prev: np.ndarray,
        flow_ned: np.ndarray,
        flow_ned_dot: np.ndarray | None = None,
        water_accel_ned: np.ndarray | None = None,
    ) -> list[Reading]:
        """The readings delivered at control instant ``t`` (s): state ``x`` (12,), thrust held
        over the last period ``u_prev`` (n,), true flow at the vehicle ``flow_ned`` (3,), and in
        waves the flow's rate along the vehicle's path and the water's acceleration (3,, m/s^2,
        {n}), which the accelerometer feels."""
        from auvdock.sensing.readings import Reading

        out = []
        if self.telemetry is not None:
            out.extend(self._read_telemetry(t))
        for c in self.channels:
            if t + 1e-9 >= c.next_sample and c.kind == "dock":
                # the camera's fix: only when it sees the dock's markers, its noise from the geometry
                assert self.dock is not None and self.camera_fix is not None
                fix = self.camera_fix.fix(x, self.dock.position(t), self.dock.heading_rad, self.rng)
                if fix is not None:
                    c.pending.append(Reading(c.kind, t, fix.dock_camera_m, fix.std_camera_m))
                c.next_sample = max(c.next_sample + c.period, t + 0.5 * c.period)
            elif t + 1e-9 >= c.next_sample:
                value = measure(c.kind, self.vehicle, x, u_prev, flow_ned, flow_ned_dot, water_accel_ned)
                noisy = value + c.bias + c.std * self.rng.standard_normal(c.std.shape)
                # the sensor's stated std is its white noise: the bias is what a filter must live with
                c.pending.append(Reading(c.kind, t, noisy, c.std.copy()))
                c.next_sample = max(c.next_sample + c.period, t + 0.5 * c.period)
            while c.pending and c.pending[0].t + c.latency <= t + 1e-9:
                out.append(c.pending.pop(0))
        return out

    def _read_telemetry(self, t: float) -> list[Reading]:
        """The dock's telemetry delivered at ``t``: its displacement from its mean, sampled where due
        (at the first instant, also the record of the last ``history_s`` before it)."""
        c = self.telemetry
        assert c is not None and self.dock is not None
        anchor = np.asarray(self.dock.position_ned_m, dtype=float)
        if not self._started:
            self._started = True
            n = int(math.floor(self.telemetry_history_s / c.period + 1e-9))
            c.next_sample = t - n * c.period
        while t + 1e-9 >= c.next_sample:
            ts = c.next_sample
            lost = self.telemetry_rng.random() < self.telemetry_dropout
            # the unit samples whether or not the link loses the sample (its slow error runs on)
            value = np.asarray(self.dock.position(ts), dtype=float) - anchor
            sample = self.motion_unit.sample(ts, value, np.asarray(self.dock.velocity(ts), dtype=float))
            if not lost:
                c.pending.extend(sample)
            c.next_sample = ts + c.period
        out = []
        while c.pending and c.pending[0].t + c.latency <= t + 1e-9:
            out.append(c.pending.pop(0))
        return out


class SimulatedSensors:
    """The sensor source of a simulated run: the readings of one instant from the truth.

    Parameters
    ----------
    settings : SensorSettings
        The mission's ``sensors``.
    estimation : str
        The mission's ``estimation``: ``truth`` reads the true state (Assumption 1) and the
        paper's sensing (:class:`SensorModel`); ``filter`` the sensor suite (:class:`SensorSuite`).
    vehicle : Vehicle
        The one model the measurements are defined on.
    seed : int
        The mission's seed.
    camera_fix, dock : CameraFixSource, DockMotion, optional
        For ``sensors.dock_camera``: the camera model and the true dock it looks at.
    """

    def __init__(
        self,
        settings: SensorSettings,
        estimation: str,
        vehicle: Vehicle,
        seed: int,
        *,
        camera_fix: CameraFixSource | None = None,
        dock: DockMotion | None = None,
    ) -> None:
        rotation = vehicle.model.function("rotation")
        self.paper: SensorModel | None = None
        self.suite: SensorSuite | None = None
        if estimation == "truth":
            self.paper = SensorModel(settings, seed, lambda a: np.asarray(rotation(a)))
        else:
            self.suite = SensorSuite(settings, vehicle, seed, camera_fix=camera_fix, dock=dock)

    def read(
        self,
        t: float,
        x: np.ndarray,
        x_prev: np.ndarray | None,
        dt: float,
        u_applied: np.ndarray,
        flow_ned: np.ndarray,
        flow_ned_dot: np.ndarray | None = None,
        water_accel_ned: np.ndarray | None = None,
    ) -> Readings:
        """The readings at instant ``t`` (s) of the true state ``x`` (12,), ``x_prev`` (12,) one
        period ``dt`` (s) earlier (None at the first instant), with ``u_applied`` (n,, N) the
        thrust applied over that period and ``flow_ned`` (3,, m/s) the true flow at the vehicle;
        in waves ``flow_ned_dot`` its rate along the path and ``water_accel_ned`` the water's
        acceleration (3,, m/s^2), for the accelerometer."""
        if self.paper is not None:  # Assumption 1: the true state, the paper's sensing
            sensing = self.paper.read(x, x_prev, dt, flow_ned)
            return Readings(t, [], x.copy(), sensing, flow_ned)
        assert self.suite is not None
        readings = self.suite.read(t, x, u_applied, flow_ned, flow_ned_dot, water_accel_ned)
        return Readings(t, readings, None, None, flow_ned)
