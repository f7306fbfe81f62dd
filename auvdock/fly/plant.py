"""The plant of a flight: a vehicle over MAVLink, as the closed loop sees it.

:class:`MavlinkPlant` is the :class:`~auvdock.loop.stages.Plant` of ``fly`` (and so of ``replay``, which
hands the same session a recorded link): every instant it writes the camera's fixes taken so far to the
tlog, drains the messages received since the last instant (:class:`auvdock.fly.vehicle_io.VehicleIO`;
the tlog marks the moment), at the first instant sets the mission's clock on the vehicle's and then
follows it (:class:`auvdock.fly.mission_clock.MissionClock`: the periods are paced on the vehicle's
clock, which in a rehearsal slower than its rate falls behind the session's), re-requests the telemetry
rates now and then, and reports the vehicle's own state estimate (recorded, and judged by the docking rule)
with the flight's columns (telemetry ages, armed, the vehicle's clock, the link, the loop's lateness,
the mission's flow model at the vehicle).  Whether the step flies is the supervisor's
(:class:`auvdock.fly.supervisor.FlySupervisor`), what the sensors read the readings stage's
(:class:`auvdock.fly.readings.FlyReadings`).  Commands go out as RC override channels (neutral in a dry
run); the thrust the thrusters push is ArduSub's channel path while the vehicle is armed, nothing while
it is not.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from pymavlink import mavutil

from auvdock.fly.camera_sensor import FIX_RECORD
from auvdock.loop.stages import Applied, Observation
from auvdock.vehicle.actuators import ActuatorCommand
from auvdock.vehicle.ardusub import NEUTRAL_CHANNELS, thrust_from_channels
from auvdock.vehicle.state import POS

if TYPE_CHECKING:
    from auvdock.fly.camera_sensor import CameraSensor, RecordedCamera
    from auvdock.fly.mission_clock import MissionClock
    from auvdock.fly.vehicle_io import VehicleIO
    from auvdock.vehicle import Vehicle
    from auvdock.world.flow import FlowField

__all__ = ["MavlinkPlant", "TELEMETRY_COLUMNS"]

#: Per-step columns of every flight beyond the loop's (name -> per-row shape).
TELEMETRY_COLUMNS: dict[str, tuple[int, ...]] = {
    "telemetry_age_s": (2,),
    "armed": (),
    "vehicle_time_s": (),
    "link_round_trip_s": (),
    "link_loss": (),
    "loop_late_s": (),
    "flow_model_ned_m_s": (3,),
}


class MavlinkPlant:
    """A vehicle over MAVLink (see the module docstring).

    Parameters
    ----------
    io : VehicleIO
        The vehicle's link.
    vehicle : Vehicle
        The model (its thruster curve: the thrust the channels push).
    flow : FlowField
        The mission's flow model (recorded as ``flow_model_ned_m_s``: the truth is unknown on a vehicle).
    mission_clock : MissionClock
        The mission's dock, set on the vehicle's clock at the first instant.
    streams : dict
        The telemetry streams requested (name -> Hz), re-requested every ``rates_refresh_s``.
    rates_refresh_s : float
        How often (s): a ground station (QGroundControl, Cockpit) may have reset them.
    dt : float
        The control period, s (the tlog marks each drain with the step's number).
    arm : bool
        Send the commands' channels (an armed flight); False: neutral (a dry run).
    camera_sensor : CameraSensor or RecordedCamera, optional
        The dock camera: its fixes are written to the tlog before each drain (replay finds them at the
        same step).
    """

    columns = TELEMETRY_COLUMNS

    def __init__(
        self,
        io: VehicleIO,
        vehicle: Vehicle,
        flow: FlowField,
        mission_clock: MissionClock,
        streams: dict[str, float],
        rates_refresh_s: float,
        dt: float,
        *,
        arm: bool,
        camera_sensor: CameraSensor | RecordedCamera | None = None,
    ) -> None:
        self.io = io
        self.vehicle = vehicle
        self.flow = flow
        self.mission_clock = mission_clock
        self.streams = dict(streams)
        self.rates_refresh_s = float(rates_refresh_s)
        self.arm = bool(arm)
        self.camera_sensor = camera_sensor
        self.dt = float(dt)
        self.rate_refreshes = 0
        self._next_rates = 0.0
        self._t_start = 0.0
        self._armed = False
        self._clock_set = False
        self._span: tuple[float, float, float] | None = None  # (session s, session s, mission s) of the loop

    def start(self) -> None:
        """The loop's t = 0 is now on the session's clock (and, at the first observation, on the vehicle's:
        the dock's known motion runs on it)."""
        self._t_start = self.io.clock.now()
        self._clock_set = False

    def observe(self, t: float) -> Observation:
        """Drain the telemetry and report the vehicle at mission time ``t`` (s)."""
        io = self.io
        self._record_camera_fixes()
        io.take("auvd_step", int(round(t / self.dt)))
        clock = self.mission_clock
        if not self._clock_set:
            clock.start(t, io)
            self._clock_set = True
        clock.follow(io.figures().offset_now_s(io.now_us * 1e-6))  # mission t = 0 as the vehicle runs
        if self.camera_sensor is not None and clock.zero_s is not None:
            self.camera_sensor.start_mission_clock(clock.zero_s)
        # how late this step is on the mission's clock (the vehicle's; the machine not keeping pace: a slow
        # step before it, a busy CPU), s; 0 in simulated time
        if clock.zero_s is not None:
            now_s = io.now_us * 1e-6
            self._span = (now_s if self._span is None else self._span[0], now_s, t)
            late = max(0.0, now_s - (clock.zero_s + t))
        else:
            late = max(0.0, io.clock.now() - (self._t_start + t))
        self._refresh_rates()
        x = io.telemetry.state()
        link = io.figures()
        ages = [io.age_s(io.telemetry.latest(m)[1]) for m in ("ATTITUDE", "LOCAL_POSITION_NED")]
        hb, _ = io.telemetry.latest("HEARTBEAT")
        self._armed = hb is not None and bool(hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        columns = {
            "telemetry_age_s": np.array(ages),
            "armed": np.asarray(float(self._armed)),
            "vehicle_time_s": np.asarray(io.telemetry.vehicle_time_s()),
            "link_round_trip_s": np.asarray(link.rtt_s),
            "link_loss": np.asarray(link.loss),
            "loop_late_s": np.asarray(late),
            "flow_model_ned_m_s": np.asarray(self.flow.velocity(x[POS], t), dtype=float),
        }
        return Observation(t, x, None, columns)

    def apply(self, t: float, command: ActuatorCommand) -> Applied:
        """Send the command's channels (armed flight) or neutral (dry run, or no channels); the thrust is
        that of the channels that went to the vehicle (in a replay the flight's, which moved it)."""
        sent: Any = command.channels_us if self.arm and command.channels_us is not None else NEUTRAL_CHANNELS
        went = self.io.send_channels(sent)
        curve, n = self.vehicle.thruster_curve, self.vehicle.n_thrusters
        applied = thrust_from_channels(np.asarray(went, dtype=float), curve) if self._armed else np.zeros(n)
        return Applied(np.asarray(sent, dtype=float), applied)

    def advance(self, t: float, t_next: float) -> bool:
        """Wait until mission time ``t_next`` (s): on the vehicle's clock as last measured
        (:class:`auvdock.fly.mission_clock.MissionClock`), else ``t_next`` after the loop's start on the
        session's."""
        clock = self.io.clock
        zero = self.mission_clock.zero_s
        if zero is None:
            clock.sleep_until(self._t_start + t_next)
        else:
            clock.sleep_until(clock.now() + (zero + t_next - clock.time()))
        return True

    def vehicle_clock_rate(self) -> float:
        """The vehicle's clock's rate against the session's over the loop so far (mission s per session s;
        NaN over less than a second): 1 in the field and in a rehearsal that keeps its rate."""
        if self._span is None or self._span[1] - self._span[0] < 1.0:
            return math.nan
        first, last, t = self._span
        return t / (last - first)

    def _record_camera_fixes(self) -> None:
        """The camera's fixes of this step, taken now and written to the tlog before the step's messages are
        drained: replay finds them at the same step (:class:`auvdock.fly.camera_sensor.RecordedCamera`)."""
        if self.camera_sensor is not None:
            rows = self.camera_sensor.before_drain()
            if rows:
                self.io.link.record_rows(FIX_RECORD, rows)

    def _refresh_rates(self) -> None:
        """Re-request the telemetry rates every :attr:`rates_refresh_s` (not waited for)."""
        now = self.io.clock.now()
        if now < self._next_rates:
            return
        if self._next_rates > 0:
            for name, rate in self.streams.items():
                self.io.link.send_rate(getattr(mavutil.mavlink, f"MAVLINK_MSG_ID_{name}"), rate)
            self.rate_refreshes += 1
        self._next_rates = now + self.rates_refresh_s
