"""The readings of a flight: the vehicle's telemetry, the dock camera and the dock's own telemetry.

:class:`FlyReadings` is the :class:`~auvdock.loop.stages.ReadingsStage` of ``fly`` and ``replay``: every
period, on the messages the plant just drained (:class:`auvdock.fly.vehicle_io.VehicleIO`):

* the older camera tracker (``dock.source: camera``): its fixes re-anchor the dock; while it has lost
  the dock the loop holds depth and attitude, and when it gives up the flight aborts;
* the LANDING_TARGET dock (``dock.source: mavlink``): re-anchored; lost: abort;
* the link's figures into the delay compensation (the command's delivery delay, the jitter), and the
  state's sample time on the vehicle's clock;
* the dock camera as a sensor of the navigation filter (``sensors.dock_camera``): its fixes, as readings
  of kind ``dock``;
* the dock's telemetry (``sensors.dock_telemetry``): ``dock_motion`` readings on the mission's clock;
  none for longer than ``fly.stale_abort_s``: abort (the forecast would run on an old record);
* the telemetry's readings (:meth:`auvdock.fly.telemetry.TelemetrySensors.readings`: marked read only
  when taken here, so a step that holds takes none).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from auvdock.fly.camera import CAMERA_SERIES
from auvdock.fly.camera_sensor import CAMERA_SENSOR_SERIES
from auvdock.fly.dock_telemetry import DOCK_TELEMETRY_SERIES
from auvdock.loop.stages import LoopEnding, Sensed
from auvdock.sensing.readings import Reading, Readings

if TYPE_CHECKING:
    from auvdock.config.mission import Mission
    from auvdock.estimation.delay import DelayCompensation
    from auvdock.fly.camera import CameraTracking
    from auvdock.fly.camera_sensor import CameraSensor, RecordedCamera
    from auvdock.fly.dock_source import LandingTargetSource
    from auvdock.fly.dock_telemetry import DockTelemetryIn
    from auvdock.fly.mission_clock import MissionClock
    from auvdock.fly.telemetry import MissionFrame
    from auvdock.fly.vehicle_io import VehicleIO
    from auvdock.loop.stages import Observation

__all__ = ["FlyReadings"]


class FlyReadings:
    """What a vehicle's sensors deliver each period (see the module docstring).

    Parameters
    ----------
    io : VehicleIO
        The vehicle's link, drained by the plant.
    mission : Mission
        ``fly.stale_abort_s``, ``dock.source``.
    mission_clock : MissionClock
        The mission's dock on the vehicle's clock.
    frame : MissionFrame
        The map from the autopilot's frame to the mission's.
    delay : DelayCompensation, optional
        The autopilot's delay compensation (``fly.delay_compensation``), told the link's figures.
    camera, camera_sensor, dock_telemetry, landing : optional
        The older camera tracker, the dock camera sensor, the dock's telemetry, the LANDING_TARGET dock
        (whichever the mission flies).
    """

    def __init__(
        self,
        io: VehicleIO,
        mission: Mission,
        mission_clock: MissionClock,
        frame: MissionFrame,
        *,
        delay: DelayCompensation | None = None,
        camera: CameraTracking | None = None,
        camera_sensor: CameraSensor | RecordedCamera | None = None,
        dock_telemetry: DockTelemetryIn | None = None,
        landing: LandingTargetSource | None = None,
    ) -> None:
        self.io = io
        self.mission = mission
        self.mission_clock = mission_clock
        self.frame = frame
        self.delay = delay
        self.camera = camera
        self.camera_sensor = camera_sensor
        self.dock_telemetry = dock_telemetry
        self.landing = landing
        self.columns: dict[str, tuple[int, ...]] = {"imu_specific_force_m_s2": (3,)}
        if camera is not None:
            self.columns.update(CAMERA_SERIES)
        if camera_sensor is not None:
            self.columns.update(CAMERA_SENSOR_SERIES)
        if dock_telemetry is not None:
            self.columns.update(DOCK_TELEMETRY_SERIES)

    def read(self, obs: Observation) -> Sensed:
        """The readings at ``obs.t``; raises :class:`~auvdock.loop.stages.LoopEnding` ("aborted") when a
        sensor the flight needs is lost."""
        io, t, x = self.io, obs.t, obs.state
        steer = True
        columns: dict[str, np.ndarray] = {}
        if self.camera is not None:
            self.camera.record_pose(t, x)
            state, series = self.camera.step(t)
            if state == "lost":
                raise LoopEnding("aborted", io.events.last() or "camera: dock lost")
            steer = state == "tracking"
            columns.update(series)
        if steer and self.landing is not None:  # dock.source: mavlink -- re-anchor; lost: abort
            why = self.landing.lost(t, x, io.now_us, self.frame)
            if why is not None:
                raise LoopEnding("aborted", why)
        offset = state_t = None
        if self.delay is not None:  # readings on the vehicle's clock; the command's delivery delay
            link = io.figures()
            delay = self.delay
            delay.command_delay_s = link.one_way_s
            delay.hold_back_s = link.hold_back_s
            delay.jitter_s, delay.loss = link.jitter_s, link.loss
            # readings on the mission's clock
            offset = self.mission_clock.reading_offset_s(t, io.now_us * 1e-6)
            state_t = io.telemetry.sample_time("LOCAL_POSITION_NED", t, io.now_us, offset)
        fixes: list[Reading] = []
        if self.camera_sensor is not None:  # the dock camera's fixes: readings of the navigation filter
            fixes, sensor_series = self.camera_sensor.take()
            columns.update(sensor_series)
        if self.dock_telemetry is not None:  # the dock's motion record: dock_motion readings (lost: abort)
            fixes = fixes + self._dock_motion()
            columns["dock_telemetry_age_s"] = np.asarray(self.dock_telemetry.age_s(io.now_us))
        if not steer:
            columns["imu_specific_force_m_s2"] = np.full(3, np.nan)
            return Sensed(Readings(t), False, columns)
        # the readings are taken (marked read) only when the estimation stage runs
        suite = io.telemetry.readings(t, io.now_us, offset) + fixes
        # the mission's flow model at the vehicle, as the plant recorded it: what Kinematic and Oracle read
        v_model = obs.columns["flow_model_ned_m_s"]
        readings = Readings(t, suite, x.copy(), None, v_model, state_t=state_t)
        columns["imu_specific_force_m_s2"] = io.telemetry.specific_force
        return Sensed(readings, True, columns)

    def _dock_motion(self) -> list[Reading]:
        """The dock's new telemetry as ``dock_motion`` readings on the mission's clock; none for longer
        than ``fly.stale_abort_s``: abort."""
        tel = self.dock_telemetry
        assert tel is not None
        age = tel.age_s(self.io.now_us)
        if age > self.mission.fly.stale_abort_s:
            raise LoopEnding(
                "aborted",
                f"the dock's telemetry lost: no ODOMETRY from system {tel.system} for {age:.1f} s "
                "(fly.stale_abort_s)",
            )
        return tel.readings(self.mission_clock.offset_s)
