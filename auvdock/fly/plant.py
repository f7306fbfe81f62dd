"""The plant of a flight: a vehicle over MAVLink, as the closed loop sees it.

:class:`MavlinkPlant` is the :class:`~auvdock.loop.closed_loop.Plant` of ``fly`` (and so of
``replay``, which hands the same session a recorded link): every instant it takes the
messages received since the last one (the tlog marks the moment), runs the session's safety
checks on them (takeover, limits, stale telemetry, the geofence, a lost camera or
LANDING_TARGET; each raises and ends the session), and reports the vehicle's own state
estimate (recorded, and judged by the docking rule), the mission's flow model at the vehicle,
and the telemetry's readings for the estimation stage.  Commands go out as RC override
channels (neutral in a dry run); the thrust the thrusters push is ArduSub's channel path
while the vehicle is armed, nothing while it is not.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from auvdock.loop.closed_loop import Applied, Observation
from auvdock.sensing.readings import Readings
from auvdock.vehicle.actuators import ActuatorCommand
from auvdock.vehicle.ardusub import NEUTRAL_CHANNELS, thrust_from_channels
from auvdock.vehicle.state import POS

if TYPE_CHECKING:
    from auvdock.controllers.base import ControlOutput
    from auvdock.fly.session import FlySession

__all__ = ["MavlinkPlant", "TELEMETRY_COLUMNS"]

#: Per-step columns of every flight beyond the loop's (name -> per-row shape).
TELEMETRY_COLUMNS: dict[str, tuple[int, ...]] = {
    "telemetry_age_s": (2,),
    "imu_specific_force_m_s2": (3,),
    "armed": (),
    "vehicle_time_s": (),
    "link_round_trip_s": (),
    "link_loss": (),
    "loop_late_s": (),
}


class MavlinkPlant:
    """A vehicle flown by a :class:`~auvdock.fly.session.FlySession` (see the module docstring)."""

    def __init__(self, session: FlySession, camera_columns: dict[str, tuple[int, ...]]) -> None:
        self.session = session
        self.columns = {**TELEMETRY_COLUMNS, **camera_columns}
        self._t_start = 0.0
        self._t = 0.0
        self._armed = False
        self._clock_set = False
        self._late = 0.0

    def start(self) -> None:
        """The loop's t = 0 is now on the session's clock (and, at the first observation, on the vehicle's:
        the dock's known motion runs on it)."""
        self._t_start = self.session.clock.now()
        self._clock_set = False

    def observe(self, t: float) -> Observation:
        """Drain the telemetry, check it, and report the vehicle at mission time ``t`` (s)."""
        s = self.session
        self._t = t
        # how late this step starts on the session's clock (the machine not keeping pace: a slow step
        # before it, a busy CPU), s; 0 in simulated time
        self._late = max(0.0, s.clock.now() - (self._t_start + t))
        s._record_camera_fixes()
        s._now_us = s._take_telemetry("auvd_step", int(round(t / s.dt)))
        if not self._clock_set:
            s._set_dock_clock(t)
            if s.camera_sensor is not None and s._mission_zero_s is not None:
                s.camera_sensor.start_mission_clock(s._mission_zero_s)
            self._clock_set = True
        s._check_takeover()
        s._check_limits()
        s._refresh_rates()
        x = s._state()
        link = s.link_health.figures()
        if s._check_telemetry() or not s._check_link(link):  # stale, or a bad link: neutral, no step
            return Observation(t, x, s.flow.velocity(x[POS], t), None)
        s._check_geofence()
        steer = True
        camera_series: dict[str, np.ndarray] = {}
        if s.camera is not None:
            s.camera.record_pose(t, x)
            steer, camera_series = s._camera_step(t)
        if steer and s.mission.dock.source == "mavlink":
            s._check_landing_target(t, x)
        v_c = s.flow.velocity(x[POS], t)
        telemetry = s._telemetry()
        self._armed = bool(telemetry["armed"])
        delay = s.autopilot.delay
        offset = None
        state_t = None
        if delay is not None:  # readings on the vehicle's clock; the command's delivery delay
            delay.command_delay_s = link.one_way_s
            delay.hold_back_s = link.hold_back_s
            delay.jitter_s, delay.loss = link.jitter_s, link.loss
            s._follow_vehicle_clock(link.offset_s)
            offset = link.offset_s
            state_t = s.telemetry.sample_time("LOCAL_POSITION_NED", t, s._now_us, offset)
        if s.camera_sensor is not None:  # the dock camera's fixes: readings of the navigation filter
            fixes, sensor_series = s.camera_sensor.take()
            camera_series.update(sensor_series)
        else:
            fixes = []
        if s.dock_telemetry is not None:  # the dock's motion record: dock_motion readings (lost: abort)
            motion, age = s._dock_motion()
            fixes = fixes + motion
            camera_series["dock_telemetry_age_s"] = np.asarray(age)
        if steer:  # the readings are taken (marked read) only when the estimation stage runs
            suite = s.telemetry.readings(t, s._now_us, offset) + fixes
            readings = Readings(t, suite, x.copy(), None, v_c, state_t=state_t)
            specific_force = s.telemetry.specific_force
        else:
            readings = Readings(t)
            specific_force = np.full(3, np.nan)
        columns = {
            "telemetry_age_s": telemetry["age_s"],
            "imu_specific_force_m_s2": specific_force,
            "armed": np.asarray(float(self._armed)),
            "vehicle_time_s": np.asarray(s.telemetry.vehicle_time_s()),
            "link_round_trip_s": np.asarray(link.rtt_s),
            "link_loss": np.asarray(link.loss),
            "loop_late_s": np.asarray(self._late),
            **camera_series,
        }
        return Observation(t, x, v_c, readings, steer, None, columns)

    def apply(self, t: float, command: ActuatorCommand) -> Applied:
        """Send the command's channels (armed flight) or neutral (dry run, or no channels)."""
        s = self.session
        if s.arm_vehicle and command.channels_us is not None:
            sent = command.channels_us
        else:
            sent = NEUTRAL_CHANNELS
        s._send_channels(sent)
        curve, n = s.vehicle.thruster_curve, s.vehicle.n_thrusters
        applied = thrust_from_channels(sent, curve) if self._armed else np.zeros(n)
        return Applied(np.asarray(sent, dtype=float), applied)

    def advance(self, t: float, t_next: float) -> bool:
        """Wait on the session's clock until ``t_next`` (s) after the loop's start."""
        self.session.clock.sleep_until(self._t_start + t_next)
        return True

    def after_step(self, out: ControlOutput) -> None:
        """The controller's step is the session's latest; too many failed solves abort."""
        self.session._t_end = self._t
        self.session._check_solves(out.status)
