"""One docking session on a vehicle over MAVLink: :class:`FlySession`.

The session in named steps (:meth:`FlySession.run`)::

    _connect          wait for the ArduSub HEARTBEAT, request the telemetry rates (the estimation's
                      streams; HEARTBEAT at the control rate, SYS_STATUS, RC_CHANNELS)
    _read_parameters  PARAM_REQUEST_READ for what fly depends on; conformance.check_parameters
    _wait_telemetry   wait for the telemetry the estimation needs, a pressure reading and the
                      battery (progress every 5 s names what is missing; fly.telemetry_timeout_s)
    _set_frame        map the vehicle's pose onto the mission's start
    _start_camera     (dock.source: camera) the frame source and the detection thread
    _preflight        on measured values: parameters, pressure depth vs geofence and start depth,
                      the dock inside the fence, the battery; --arm refuses on any problem
    _arm              --arm: MANUAL mode, arm retried while pre-arm checks fail
                      (fly.arm_timeout_s); else a dry run
    _open_results     the results file
    _control_loop     the one closed loop (auvdock.loop.closed_loop.run_closed_loop) on this
                      vehicle (auvdock.fly.plant.MavlinkPlant): every dt, on the session's clock,
                      the telemetry drained and checked (auvdock.fly.safety), the state, the camera
                      (lost: hold), the LANDING_TARGET dock (auvdock.fly.dock_source), docked?, the
                      estimation-and-control step on the readings, RC overrides, one row
    _finish           the one ending: neutral, release, disarm if we armed, link closed, outcome
                      written (a takeover: release only)

What the controller knows comes through :class:`auvdock.fly.telemetry.TelemetrySensors`:
the vehicle's messages received since the last step are taken from the link at once
(:meth:`MavlinkLink.drain`, which marks the moment in the tlog), so that ``auvdock replay``
can hand the same session code the same messages at the same steps and reproduce its
outputs.  Every decision (parameters read, mode reached, armed, takeover) is made on those
drained messages, never on the link's own state, for the same reason.  With ``estimation:
filter`` the navigation filter reads the sensor readings (IMU, attitude, depth, the position
source); with ``truth`` the controller takes the autopilot's own estimate (ATTITUDE,
LOCAL_POSITION_NED) as the state.  Oracle and Kinematic MPC read the mission's flow model as
their forecast of the current (their definition; the events say so); no other controller
ever sees it.

Safety (each ends the session the same way, :meth:`FlySession._finish`): nothing is armed
without ``arm=True``, and nothing while a parameter or pre-flight check fails; telemetry
older than ``fly.stale_neutral_s``: neutral at once, older than ``fly.stale_abort_s``: abort;
the geofence acts on the pressure sensor's depth and the vehicle's own position estimate;
a battery below ``fly.min_battery_v`` (low-passed) or ``fly.time_limit_s`` after arming
aborts; overrides stream at the control rate all session (ArduSub disarms after 3 s without
pilot input).  Someone else taking the vehicle (a disarm or a mode change fly did not
command, another station's MANUAL_CONTROL / RC_CHANNELS_OVERRIDE on our link, RC_CHANNELS
showing channels fly did not send) ends the session as a takeover (exit code 4): the
channels are released at once and the vehicle is left to them.  While the camera has lost
the dock the vehicle holds depth and attitude (:class:`auvdock.controllers.hold.DepthAttitudeHold`).
What CasADi's C code prints during the controller steps is counted and recorded
(:class:`auvdock.runtime.stderr_capture.StderrCapture`), not shown per step.

Ctrl-C (SIGINT) at any moment ends the session with reason "interrupted" (exit code 130):
results rows and the results file's creation are written whole (SIGINT held back over them),
and from the start of the ending a SIGINT is only noted, so the ending always runs to its end
and the results file is always closed readable.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import signal
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil

from auvdock.config.mission import Mission, MissionError
from auvdock.controllers.hold import DepthAttitudeHold
from auvdock.controllers.registry import CONTROLLERS, split_controller
from auvdock.controllers.status import STATUS_NAMES
from auvdock.estimation.delay import DelayCompensation
from auvdock.fly.camera import CameraOpenError, CameraTracking
from auvdock.fly.camera_sensor import SYNTHETIC_NEEDS, CameraSensor, RecordedCamera
from auvdock.fly.conformance import PARAMETER_GROUPS, check_parameters, describe, parameter_names
from auvdock.fly.dock_source import LandingTargetSource
from auvdock.fly.dock_telemetry import DockTelemetryIn
from auvdock.fly.events import EventLog
from auvdock.fly.link import LinkError, MavlinkLink
from auvdock.fly.mission_clock import MissionClock
from auvdock.fly.plant import MavlinkPlant
from auvdock.fly.readings import FlyReadings
from auvdock.fly.record import FlyRecorder
from auvdock.fly.safety import clock_rate_problem, preflight_problems
from auvdock.fly.supervisor import FlySupervisor, vehicle_mode
from auvdock.fly.telemetry import (
    PRESSURE_PARAMETERS,
    TELEMETRY_MESSAGES,
    TelemetrySensors,
    frame_turns,
)
from auvdock.fly.vehicle_io import VehicleIO
from auvdock.loop import closed_loop
from auvdock.loop.assemble import build_autopilot
from auvdock.loop.stages import LoopResult, Progress, Stages, Verdict
from auvdock.loop.verdict import CaptureVerdict, DockingRule, MarginVerdict
from auvdock.runtime.clock import Clock, ScaledClock
from auvdock.runtime.interrupts import SigintDeferred, interrupt_name
from auvdock.runtime.stderr_capture import StderrCapture
from auvdock.vehicle import Vehicle
from auvdock.vehicle.actuators import ArduSubActuators
from auvdock.vehicle.ardusub import MODES
from auvdock.world.dock import ClockedDock, TrackedDock

__all__ = ["FlySession", "FlyResult", "FlyAbortError", "EXIT_CODES", "check_flyable"]

#: ArduSub's VECTORED_6DOF frame (the BlueROV2 Heavy), the only one the channel mapping knows.
N_THRUSTERS = 8


#: How long the parameters may take to arrive (ArduPilot answers each PARAM_REQUEST_READ within
#: a few ms, and nothing for a name it does not have), s.
PARAM_TIMEOUT_S = 3.0
#: Parameters requested per batch, and how often a batch goes (ArduPilot's request queue is short).
PARAM_BATCH = 6
PARAM_BATCH_PERIOD_S = 0.2
#: The pre-flight depth check's median waits for at least this many pressure readings.
PREFLIGHT_MIN_READINGS = 10
#: Arming is retried this often while the vehicle refuses (pre-arm checks settling), s.
ARM_RETRY_S = 2.0
#: A mode change is waited for this long, s.
MODE_TIMEOUT_S = 3.0
#: Waits show their progress this often, s.
PROGRESS_EVERY_S = 5.0
#: The vehicle's clock's rate against fly's is said at the ending when it was further than this from 1
#: (a rehearsal whose simulator fell behind its rate; the field's clocks differ by parts per million).
VEHICLE_RATE_SAID = 0.01
#: While a stream has not come, its rate is requested again this often, s (a request lost on the link).
RATE_RETRY_S = 2.0
#: Streams requested besides TELEMETRY_MESSAGES: name -> rate (None: the control rate): the
#: HEARTBEAT (armed bit, mode: a takeover is seen within a control period), SYS_STATUS
#: (battery), RC_CHANNELS (the channels the vehicle uses: another station's joystick).
CONTROL_STREAMS: dict[str, float | None] = {"HEARTBEAT": None, "SYS_STATUS": 2.0, "RC_CHANNELS": None}
#: Exit codes of ``fly`` / ``replay`` by ending.
EXIT_CODES = {"docked": 0, "timeout": 1, "aborted": 3, "takeover": 4, "interrupted": 130}


class FlyAbortError(RuntimeError):
    """The session was aborted for a safety reason (the message says which)."""


@dataclass
class FlyResult:
    """How a session ended."""

    reason: str  # "docked", "timeout", "aborted", "takeover", "interrupted"
    message: str
    outcome: dict[str, Any] = field(default_factory=dict)
    results_path: Path | None = None
    events: list[tuple[float, str]] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        return EXIT_CODES.get(self.reason, EXIT_CODES["aborted"])


def _interrupted(t_end: float = 0.0) -> LoopResult:
    """The ending of a Ctrl-C (or a SIGTERM, which interrupts as one)."""
    return LoopResult("interrupted", f"interrupted ({interrupt_name()})", t_end)


def _verdict_outcome(verdict: Verdict | None, vehicle_clock_offset_s: float) -> dict[str, Any]:
    """The outcome figures of the docking verdict (:mod:`auvdock.loop.verdict`): its basis, the
    estimated distance and its 95 % bound when docked was declared, else the smallest bound reached
    (the closest it came to a verdict), and the instant judged on the vehicle's clock (s: mission time
    plus ``vehicle_clock_offset_s``, where a rehearsal's truth is scored)."""
    if verdict is None:
        return {
            "verdict_basis": "",
            "verdict_distance_m": math.nan,
            "verdict_bound_m": math.nan,
            "verdict_vehicle_time_s": math.nan,
        }
    return {
        "verdict_basis": verdict.basis,
        "verdict_distance_m": verdict.distance_m,
        "verdict_bound_m": verdict.bound_m,
        "verdict_vehicle_time_s": verdict.t + vehicle_clock_offset_s,
    }


class _SigintLatch:
    """While installed, SIGINT only sets :attr:`hit` (main thread only; elsewhere it does nothing)."""

    def __init__(self) -> None:
        self.hit = False
        self._old: Any = None
        self._installed = False

    def _handler(self, signum: int, frame: Any) -> None:
        self.hit = True

    def install(self) -> None:
        if self._installed or threading.current_thread() is not threading.main_thread():
            return
        try:
            self._old = signal.signal(signal.SIGINT, self._handler)
        except ValueError:
            return
        self._installed = True

    def restore(self) -> None:
        if self._installed:
            signal.signal(signal.SIGINT, self._old)
            self._installed = False


def check_flyable(mission: Mission, controller: str | None = None) -> Vehicle:
    """Whether fly can fly ``mission`` (with ``controller``, default the mission's), on the mission
    alone: no link, nothing opened or written.  The one place of these rules: ``auvdock fly`` asks it
    before it says anything or opens the link and the tlog, and :class:`FlySession` (and so replay)
    builds on it.  Returns the mission's vehicle model (checked).

    Raises
    ------
    MissionError
        Naming the mission's field: a vehicle that is not an 8-thruster BlueROV2 Heavy (ArduSub
        VECTORED_6DOF), a flow-estimating controller with ``estimation: truth`` (the paper's simulated
        sensing of the water-relative velocity, which no vehicle has), a WEC dock without the dock's
        telemetry or with a controller told its true motion (Oracle, Kinematic), the dock camera as a sensor
        together with ``dock.source: camera`` (one camera path per flight), a camera file that is
        missing or bad (a real camera's is required; the synthetic one is the ideal camera without).
    """
    where = mission.source or mission.name
    vehicle = mission.build_vehicle()
    if vehicle.n_thrusters != N_THRUSTERS:
        raise MissionError(
            where,
            "vehicle",
            f"fly flies ArduSub's VECTORED_6DOF frame (8 thrusters, BlueROV2 Heavy); "
            f"{vehicle.name} has {vehicle.n_thrusters}",
        )
    name, _ = split_controller(controller or mission.controller.type)
    if mission.estimation == "truth" and CONTROLLERS[name].estimates_flow:
        raise MissionError(
            where,
            "estimation",
            f"{name} learns the current from the vehicle's sensors; on a vehicle that needs "
            "estimation: filter (fly --estimation filter; truth is the paper's simulated "
            "water-relative velocity sensor)",
        )
    if mission.dock.wec is not None:  # its motion is the sea's: on a vehicle, known from its telemetry only
        telemetry = mission.estimation == "filter" and mission.sensors.dock_telemetry.enabled
        if not telemetry:
            raise MissionError(
                where,
                "dock.wec",
                "a WEC dock moves with the sea, which a vehicle knows only from the dock's own telemetry: "
                "enable sensors.dock_telemetry (with estimation: filter)",
            )
        if CONTROLLERS[name].reads_true_flow:
            raise MissionError(
                where,
                "dock.wec",
                f"{name} is told the dock's true motion in the realised sea (its definition), which no "
                "vehicle knows; fly a controller that forecasts it from the dock's telemetry "
                "(-c ce, sequential, optimized or naive)",
            )
    camera_sensor = mission.estimation == "filter" and mission.sensors.dock_camera.enabled
    if camera_sensor and mission.dock.source != "model":
        raise MissionError(
            where,
            "sensors.dock_camera",
            f"the dock camera is a sensor of the navigation filter, and dock.source: {mission.dock.source} "
            "tracks the dock apart from it; choose one (dock.source: model with sensors.dock_camera)",
        )
    if camera_sensor:
        mission.build_camera()  # a missing or bad camera file; a real camera's is required
    if mission.dock.source == "camera":
        mission.build_camera()  # a missing or bad camera file
    return vehicle


class FlySession:
    """One docking session on a vehicle.

    Parameters
    ----------
    mission : Mission
        The mission (controller, dock, geofence, telemetry settings).
    link : MavlinkLink
        The link (not yet connected).  The session runs on the link's clock.
    arm : bool
        Arm and command thrust; False: dry run, neutral overrides only.
    out : str or Path
        Results file (the ``auvdock sim`` layout plus telemetry series).
    controller : str, optional
        Override of the mission's controller.
    timeout_s : float, optional
        Override of ``docking.timeout_s``.
    connect_timeout_s : float
        How long to wait for the vehicle's HEARTBEAT and first telemetry (on the clock).

    Raises
    ------
    MissionError
        A mission fly cannot fly (:func:`check_flyable`).
    """

    def __init__(
        self,
        mission: Mission,
        link: MavlinkLink,
        *,
        arm: bool,
        out: str | Path,
        controller: str | None = None,
        timeout_s: float | None = None,
        connect_timeout_s: float = 10.0,
    ) -> None:
        self.mission = mission
        self.link = link
        self.clock: Clock = link.clock
        self.arm_vehicle = bool(arm)
        self.out = Path(out)
        self.timeout_s = mission.docking.timeout_s if timeout_s is None else float(timeout_s)
        self.connect_timeout_s = connect_timeout_s
        # built whole: CasADi's argument type checks clear a KeyboardInterrupt raised in them, so
        # a Ctrl-C while the model and the controller are built is held back and raised after
        #: The session's events (also in the result).
        self.log = EventLog(self.clock)
        with SigintDeferred():
            self._build(mission, controller)
        self.dt = self.autopilot.dt
        self.camera: CameraTracking | None = None
        #: The dock camera as the navigation filter's sensor (sensors.dock_camera), once started (a replay:
        #: the flight's recorded fixes).
        self.camera_sensor: CameraSensor | RecordedCamera | None = None
        self._frame: Any = None
        self._rec: FlyRecorder | None = None
        self._plant: MavlinkPlant | None = None
        self._loop_t0 = time.perf_counter()
        self._we_armed = False
        self._handed_over_armed = False  # the vehicle was armed before fly armed it (a pilot's)
        self._t_end = 0.0
        self._progress: Any = None
        self._sigint = _SigintLatch()
        self._refusals: list[str] = []
        self._t_armed: float | None = None
        self.hold = DepthAttitudeHold(self.vehicle, mission.fly.hold_bandwidth_rad_s)
        self._stderr = StderrCapture(on_new=lambda line: self.log.add(f"solver says: {line}"))
        self.link.on_event = self.log.add

    def _build(self, mission: Mission, controller: str | None) -> None:
        """The vehicle model, the dock (model or filter), the flow and the controller step."""
        self.vehicle = check_flyable(mission, controller)
        self.telemetry = TelemetrySensors(mission.sensors, mission.estimation)
        # the mission's dock motion on the vehicle's clock (its offset set as the control loop starts)
        self._model_dock = ClockedDock(mission.dock.build())
        self.mission_clock = MissionClock(self._model_dock, self.log)
        self.dock: ClockedDock | TrackedDock = self._model_dock
        self._landing: LandingTargetSource | None = None
        if mission.dock.source == "mavlink":
            self.dock = TrackedDock(self._model_dock)
        elif mission.dock.source == "camera":
            self.dock = TrackedDock(self._model_dock, process_noise=mission.camera.process_noise_m_s)
        self.flow = mission.build_flow()
        self.autopilot = build_autopilot(mission, self.vehicle, self.dock, controller)
        self.actuators = ArduSubActuators(self.vehicle)  # what fly sends: ArduSub's channel path
        #: what goes to and comes from the vehicle: drained messages into what reads them, overrides out
        self.io = VehicleIO(self.link, self.telemetry, self.log, mission.fly.timesync_period_s)
        if mission.fly.delay_compensation:
            self.autopilot.delay = DelayCompensation(self.vehicle)
        #: sensors.dock_telemetry: the dock's own motion record, received from its MAVLink system
        tel = mission.sensors.dock_telemetry
        self.dock_telemetry = DockTelemetryIn(tel) if mission.estimation == "filter" and tel.enabled else None
        if self.dock_telemetry is not None:
            self.io.feeds.append(self.dock_telemetry)
        if isinstance(self.dock, TrackedDock) and mission.dock.source == "mavlink":
            self._landing = LandingTargetSource(self.dock, self.telemetry, mission.fly.stale_abort_s)

    # ------------------------------------------------------------------------------------
    def run(self, progress=None, on_event=None) -> FlyResult:
        """Fly the session to its end; never raises for the vehicle's or the link's behaviour.

        ``progress(t, distance_m, status_text)`` is called every control step if given;
        ``on_event(t, text)`` with each event as it happens (they are also in the result).
        Ctrl-C (KeyboardInterrupt, SIGINT) ends the session like an abort, with reason
        "interrupted", at any moment (see the module docstring).
        """
        self._progress = progress
        self.log.on_event = on_event
        ending: LoopResult | None = None
        try:
            ending = self._fly()
        except KeyboardInterrupt:
            ending = _interrupted()
        finally:
            # the one ending; a KeyboardInterrupt can only come before its SIGINT latch is in
            # place, and then nothing of it has run yet: run it again
            result: FlyResult | None = None
            try:
                while result is None:
                    try:
                        result = self._finish(ending)
                    except KeyboardInterrupt:
                        ending = _interrupted()
            finally:
                self._sigint.restore()
        if self._sigint.hit and result.reason != "interrupted":  # Ctrl-C during the ending
            result = dataclasses.replace(
                result, reason="interrupted", message=f"interrupted ({interrupt_name()}): {result.message}"
            )
        return result

    def _fly(self) -> LoopResult:
        """Everything up to the ending; safety aborts and Ctrl-C become the ending's reason."""
        try:
            self._connect()
            self._read_parameters()
            self._wait_telemetry()
            self._set_frame()
            self._start_camera()
            self._preflight()
            self._arm()
            self._open_results()
            return self._control_loop()
        except FlyAbortError as e:
            self.log.add(f"abort: {e}")
            return LoopResult("aborted", str(e), self._t_end)
        except KeyboardInterrupt:
            ending = _interrupted()
            self.log.add(ending.message)
            return ending

    # -- before the loop ------------------------------------------------------------------
    def _connect(self) -> None:
        """Wait for the vehicle's HEARTBEAT, then request the telemetry streams."""
        try:
            self.link.connect(timeout_s=self.connect_timeout_s)
        except LinkError as e:
            raise FlyAbortError(str(e)) from None
        # in the tlog only: what replay needs to rebuild this session
        self.link.note(f"auvdock fly {self.autopilot.name} dt={self.dt:g} timeout={self.timeout_s:g}")
        for name, rate in self._streams().items():
            msg_id = getattr(mavutil.mavlink, f"MAVLINK_MSG_ID_{name}")
            try:
                result = self.link.request_rate(msg_id, rate)
                self.log.add(f"rate {name} {rate:g} Hz: MAV_RESULT {result}")
            except LinkError as e:
                self.log.add(f"rate {name}: {e}")
            self.io.send_neutral()
        m = self.mission
        name = self.autopilot.name
        if m.estimation == "filter":
            pos = m.sensors.position.source
            what = "IMU, attitude, depth" + ("" if pos == "none" else f" and position ({pos})")
            self.log.add(f"estimation: filter (the navigation filter on the {what})")
        else:
            self.log.add("estimation: truth (the autopilot's ATTITUDE and LOCAL_POSITION_NED as the state)")
        if self.autopilot.reads_true_flow:
            self.log.add(
                f"{name} reads the mission's flow model as its forecast of the current: "
                f"{self.flow.describe()}"
            )

    def _streams(self) -> dict[str, float]:
        """Every stream requested, name -> rate (Hz)."""
        rate = self.mission.fly.telemetry_rate_hz
        out = {name: rate for name in TELEMETRY_MESSAGES}
        for name, r in CONTROL_STREAMS.items():
            out[name] = 1.0 / self.dt if r is None else r
        if self._synthetic_sensor:  # the simulator's truth the synthetic camera renders from
            out["SIM_STATE"] = max(rate, self.mission.sensors.dock_camera.rate_hz)
        return out

    @property
    def _synthetic_sensor(self) -> bool:
        """The dock camera is a sensor and its frames are rendered here (camera.source: synthetic)."""
        m = self.mission
        return m.estimation == "filter" and m.sensors.dock_camera.enabled and m.camera.source == "synthetic"

    def _read_parameters(self) -> None:
        """Ask the vehicle for the parameters fly depends on; record them; keep the problems
        (:func:`auvdock.fly.conformance.check_parameters`) for the pre-flight check."""
        fly = self.mission.fly
        names = parameter_names(fly.parameters) + list(PRESSURE_PARAMETERS)
        wanted = list(PARAMETER_GROUPS) + [(n,) for n in fly.parameters]
        clock = self.clock
        deadline = clock.now() + PARAM_TIMEOUT_S
        next_ask = clock.now()
        while clock.now() < deadline:
            if clock.now() >= next_ask:  # a few at a time: ArduPilot queues only a few requests
                missing = [n for n in names if n not in self.io.state.params]
                self.link.request_parameters(missing[:PARAM_BATCH])
                next_ask = clock.now() + PARAM_BATCH_PERIOD_S
            self.io.send_neutral()
            self.io.take("auvd_param")
            if all(any(n in self.io.state.params for n in g) for g in wanted) and (
                all(n in self.io.state.params for n in PRESSURE_PARAMETERS) or clock.now() >= deadline - 1.0
            ):
                break
            clock.sleep(self.dt)
        self.log.add(describe(self.io.state.params))
        self.log.add(self.telemetry.set_pressure_reference(self.io.state.params))
        self._refusals = check_parameters(
            self.io.state.params, sysid=getattr(self.link, "sysid", 255), dt=self.dt, expected=fly.parameters
        )
        for problem in self._refusals:
            self.log.add(f"parameter check: {problem}")

    def _missing(self) -> list[str]:
        """What the session still waits for: the estimation's telemetry, a pressure reading (the
        depth limits act on it) and, with a battery floor, SYS_STATUS."""
        out = self.telemetry.missing()
        if self.telemetry.measured_depth() is None:
            out.append("SCALED_PRESSURE2 or SCALED_PRESSURE or VFR_HUD")
        if self.mission.fly.min_battery_v > 0 and not self.io.state.battery_reported:
            out.append("SYS_STATUS (battery)")
        if self._synthetic_sensor and self.telemetry.latest("SIM_STATE")[0] is None:
            out.append(SYNTHETIC_NEEDS)
        if self.dock_telemetry is not None:
            record = self.dock_telemetry.missing()
            if record is not None:
                out.append(record)
        return out

    def _wait_telemetry(self) -> None:
        """Stream neutral overrides until the telemetry the session needs arrives, showing what
        is missing every few seconds (ArduSub's position estimate can take 40 s after boot)."""
        clock = self.clock
        limit = self.mission.fly.telemetry_timeout_s
        if self.dock_telemetry is not None:  # and the dock's record the forecaster starts on
            limit += self.dock_telemetry.history_s
        t0 = clock.now()
        deadline = t0 + limit
        next_note = t0 + PROGRESS_EVERY_S
        next_ask = t0 + RATE_RETRY_S
        while clock.now() < deadline:
            self.io.send_neutral()
            now_us = self.io.take("auvd_wait")
            missing = self._missing()
            if missing and clock.now() >= next_ask:  # a rate request (or its ack) lost on the link: again
                next_ask = clock.now() + RATE_RETRY_S
                for name, rate in self._streams().items():
                    if self.telemetry.latest(name)[0] is None:
                        self.link.send_rate(getattr(mavutil.mavlink, f"MAVLINK_MSG_ID_{name}"), rate)
            if not missing and self.telemetry.age_s(now_us) < 0.5:
                if clock.now() - t0 >= PROGRESS_EVERY_S:
                    self.log.add(f"telemetry complete after {clock.now() - t0:.0f} s")
                return
            if clock.now() >= next_note:
                next_note += PROGRESS_EVERY_S
                what = ", ".join(missing) if missing else "fresh telemetry"
                self.log.add(f"waiting for {what}: {clock.now() - t0:.0f} s of {limit:g} s")
            clock.sleep(self.dt)
        missing = self._missing() or ["fresh " + " and ".join(
            "/".join(g) for g in self.telemetry.required)]  # fmt: skip
        hint = ""
        if any("LOCAL_POSITION_NED" in name for name in missing):
            hint = " (ArduSub's position estimate: does the vehicle have a position source and an origin?)"
        which = "fly.telemetry_timeout_s" if self.dock_telemetry is None else (
            "fly.telemetry_timeout_s + sensors.dock_telemetry.history_s"
        )  # fmt: skip
        said = f"no {', '.join(missing)} from {self.link.port} within {limit:g} s ({which}){hint}"
        raise FlyAbortError(said)

    def _set_frame(self) -> None:
        """Map the vehicle's pose onto the mission's start pose: averaged over the last
        ``fly.preflight_window_s`` of readings (at least :data:`PREFLIGHT_MIN_READINGS` of each,
        awaited while streaming neutral if fewer have come)."""
        window = self.mission.fly.preflight_window_s
        tel = self.telemetry
        def enough() -> bool:
            return min(tel.pose_readings(window), tel.depth_readings(window)) >= PREFLIGHT_MIN_READINGS

        self.io.take("auvd_frame")
        if not enough():
            self._await("auvd_frame", enough, window)
        turn = frame_turns(self.mission.fly.frame_heading, self.mission.sensors.position.source)
        self._frame = tel.set_frame(self.mission.start_state(), window, turn)
        n_pos, n_att = tel.frame_readings
        how = "" if turn else "; not turned: the positions are fixes in the position source's frame"
        self.log.add(f"{tel.describe_frame()} (the mean of {n_pos} positions and {n_att} headings{how})")

    def _start_camera(self) -> None:
        """The camera: sensors.dock_camera (a sensor of the navigation filter) or dock.source: camera
        (the older tracker of a point dock) -- open the frame source and start detecting."""
        m = self.mission
        if m.estimation == "filter" and m.sensors.dock_camera.enabled:
            if getattr(self.link, "replaying", False):  # the flight's fixes, as recorded in its tlog
                self.camera_sensor = RecordedCamera()
                self.io.feeds.append(self.camera_sensor)
                self.log.add(f"camera: {self.camera_sensor.description}")
                return
            try:
                self.camera_sensor = CameraSensor(
                    m, self.clock, self._model_dock, lambda: self.telemetry.latest("SIM_STATE"), self.log.add
                )
            except (OSError, ValueError, RuntimeError) as e:
                raise FlyAbortError(f"camera: {e}") from None
            self.io.feeds.append(self.camera_sensor)
            self.camera_sensor.start()
            self.log.add(f"camera: {self.camera_sensor.description}, a sensor of the navigation filter")
            return
        if self.mission.dock.source != "camera":
            return
        assert isinstance(self.dock, TrackedDock)  # dock.source: camera tracks the dock (_build)
        try:
            self.camera = CameraTracking(self.mission, self._model_dock, self.dock, self.clock, self.log.add)
        except CameraOpenError as e:
            raise FlyAbortError(str(e)) from None
        self.camera.start(self.telemetry.state())
        self.log.add(f"camera: {self.camera.description}")

    def _preflight(self) -> None:
        """Before arming, on measured values: the parameter checks, the pressure sensor's depth
        inside the geofence and near the mission's start depth, the dock inside the geofence,
        the battery above its floor, the vehicle's clock at fly's pace (a simulator slower than real
        time: :func:`auvdock.fly.safety.clock_rate_problem`).  With --arm any problem refuses to arm (one
        line, all of them in the events); a dry run reports them and goes on.  The depth is the median of the
        pressure sensor's readings over the last ``fly.preflight_window_s`` (gathered with the frame's:
        :meth:`_set_frame`)."""
        window = self.mission.fly.preflight_window_s
        problems = preflight_problems(
            self.mission,
            self._refusals,
            self.telemetry.filtered_depth(window),
            np.asarray(self._model_dock.position(0.0), dtype=float),
            self.io.state.battery_v,
            self.io.figures(),
        )
        rate, span = self.io.clock_rate()  # a simulator that cannot keep fly's pace: refused
        fly_rate = self.clock.rate if isinstance(self.clock, ScaledClock) else 1.0
        clock = clock_rate_problem(rate, span, fly_rate)
        if clock is not None:
            problems.append(clock)
        self.log.add(f"link: {self.io.figures().describe()}")
        if not problems:
            self.log.add("pre-flight checks pass")
            return
        for problem in problems:
            self.log.add(f"pre-flight: {problem}")
        if not self.arm_vehicle:
            self.log.add(f"dry run: arming would be refused ({len(problems)} problem(s))")
            return
        more = "" if len(problems) == 1 else f" (and {len(problems) - 1} more, in the events)"
        raise FlyAbortError(f"refusing to arm: {problems[0]}{more}")

    def _await(
        self, marker: str, done: Any, timeout_s: float, resend: Any = None, every_s: float = 1.0
    ) -> bool:
        """Stream neutral and take telemetry every dt until ``done()``; ``resend()`` at once and
        every ``every_s``.  Decided on the drained messages only, so a replay decides the same."""
        clock = self.clock
        deadline = clock.now() + timeout_s
        next_send = clock.now()
        while clock.now() < deadline:
            if resend is not None and clock.now() >= next_send:
                resend()
                next_send = clock.now() + every_s
            self.io.send_neutral()
            self.io.take(marker)
            if done():
                return True
            clock.sleep(self.dt)
        return False

    def _arm(self) -> None:
        """--arm: MANUAL mode, then arm, retried every ARM_RETRY_S while the vehicle refuses
        (its pre-arm reasons appear as events) until ``fly.arm_timeout_s``; else a dry run."""
        if not self.arm_vehicle:
            armed = " (the vehicle is armed, not by fly)" if vehicle_mode(self.io)[0] else ""
            self.log.add(f"dry run: not arming, sending neutral overrides only{armed}")
            self._t_armed = self.clock.now()
            return
        manual = MODES["MANUAL"]
        if not self._await("auvd_mode", lambda: vehicle_mode(self.io)[1] == manual, MODE_TIMEOUT_S,
                           resend=lambda: self.link.send_mode("MANUAL")):  # fmt: skip
            raise FlyAbortError(
                f"vehicle did not change to MANUAL (mode {manual}) within {MODE_TIMEOUT_S:g} s"
            )
        self.log.add("mode MANUAL")
        if vehicle_mode(self.io)[0]:  # handed over armed: fly did not arm it, and will not disarm it
            self._handed_over_armed = True
            self._t_armed = self.clock.now()
            self.log.add(
                "taking over an armed vehicle: it was armed before fly (not by fly), and is left armed at "
                "the end, overrides released"
            )
            return
        self._we_armed = True  # from the arm command on, every ending disarms (Ctrl-C before its ack too)
        limit = self.mission.fly.arm_timeout_s
        self.log.add("arming (waits for the vehicle's pre-arm checks)")
        if not self._await("auvd_arm", lambda: vehicle_mode(self.io)[0], limit,
                           resend=lambda: self.link.send_arm(True), every_s=ARM_RETRY_S):  # fmt: skip
            arm = mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM
            results = [r for c, r in self.io.state.acks if c == arm]
            said = f"MAV_RESULT {results[-1]}" if results else "no COMMAND_ACK"
            why = self.io.state.last_arm_text or said
            raise FlyAbortError(f"arming refused for {limit:g} s (fly.arm_timeout_s): {why}")
        self._t_armed = self.clock.now()
        self.log.add("armed")

    def _open_results(self) -> None:
        """The plant and the readings of this flight, and its results file."""
        m = self.mission
        self._plant = MavlinkPlant(
            self.io,
            self.vehicle,
            self.flow,
            self.mission_clock,
            self._streams(),
            m.fly.rates_refresh_s,
            self.dt,
            arm=self.arm_vehicle,
            camera_sensor=self.camera_sensor,
        )
        self._readings = FlyReadings(
            self.io,
            m,
            self.mission_clock,
            self._frame,
            delay=self.autopilot.delay,
            camera=self.camera,
            camera_sensor=self.camera_sensor,
            dock_telemetry=self.dock_telemetry,
            landing=self._landing,
        )
        self._rec = FlyRecorder(
            self.out,
            mission=m,
            autopilot=self.autopilot,
            vehicle=self.vehicle,
            dock=self.dock,
            plant_columns={**self._plant.columns, **self._readings.columns},
            attrs={
                "tolerance_m": m.docking.tolerance_m,
                "timeout_s": self.timeout_s,
                "dt_s": self.dt,
                "flow": self.flow.describe(),
                "vehicle": self.vehicle.name,
                "solver": self.autopilot.solver,
                "reads_true_flow": self.autopilot.reads_true_flow,
                "estimation": m.estimation,
                "actuators": "ardusub: RC override channels through the vehicle's own mixer",
                # the map from the autopilot's NED frame to the mission's (MissionFrame)
                "frame_heading_offset_rad": self._frame.dpsi,
                "frame_vehicle_start_m": self._frame.p_vehicle0,
                "frame_mission_start_m": self._frame.p_mission0,
                "source": f"fly {self.link.port}" + ("" if self.arm_vehicle else " (dry run)"),
            },
        )
        self._rec.open()
        self._loop_t0 = time.perf_counter()

    # -- the loop -------------------------------------------------------------------------
    def _control_loop(self) -> LoopResult:
        """The one closed loop (:func:`auvdock.loop.closed_loop.run_closed_loop`) on this vehicle:
        a step every dt on the session's clock until docked, the timeout or an ending."""
        assert self._rec is not None and self._plant is not None
        user = self._progress

        def progress(p: Progress) -> None:
            self._t_end = p.t  # the last controller step (an ending from outside the loop's stages)
            if user is not None:
                user(p.t, p.distance_m, STATUS_NAMES.get(p.status, str(p.status)))

        @contextlib.contextmanager
        def quiet() -> Iterator[None]:  # what CasADi's C code prints is counted, not shown per step
            with self._stderr.capture():
                yield

        supervisor = FlySupervisor(
            self.io,
            self.mission.fly,
            self.timeout_s,
            in_control=self._we_armed or self._handed_over_armed,
            t_armed=self._t_armed,
        )
        stages = Stages(
            self._plant,
            self._readings,
            supervisor,
            self.autopilot,
            self.actuators,
            DockingRule(self.dock, self.mission.docking.tolerance_m, self._verdict()),
            self._rec.loop,
            self.hold,
        )
        result = closed_loop.run_closed_loop(
            stages, timeout_s=self.timeout_s, progress=progress, on_event=self.log.add, control_guard=quiet
        )
        if result.reason in ("aborted", "takeover"):
            self.log.add(f"{'abort' if result.reason == 'aborted' else 'takeover'}: {result.message}")
        return result

    def _verdict(self) -> MarginVerdict | CaptureVerdict:
        """The docking rule on the estimate (:mod:`auvdock.loop.verdict`): the point rule, or with
        ``docking.criterion: capture`` captured with a margin, against the dock's body."""
        m = self.mission
        point = MarginVerdict(
            m.docking.tolerance_m,
            self.autopilot.dock,  # the dock the estimate is relative to (with telemetry: its forecast)
            m.sensors.position.figures()[2],
            frame_cov=self.telemetry.frame_cov,
            position_bias_std_m=m.sensors.position.bias_std_m,
        )
        contact = m.build_contact(self._model_dock.dock)
        return point if contact is None else CaptureVerdict(point, contact)

    # -- the ending -----------------------------------------------------------------------
    def _finish(self, ending: LoopResult | None) -> FlyResult:
        """The one ending (``None``: an unexpected error, which propagates after it).

        Neutral overrides, override release, disarm if we armed, link closed, outcome
        written and the results file closed; a SIGINT meanwhile is only noted.
        """
        self._sigint.install()
        self._shutdown(takeover=ending is not None and ending.reason == "takeover")
        if self._stderr.lines:
            self.log.add(f"solver output: {self._stderr.summary()}")
        nav = getattr(self.autopilot, "navigation", None)
        gated = getattr(getattr(nav, "filter", None), "gated", None)
        if gated:  # readings the navigation filter left out as implausible: is a sensor's std right?
            what = ", ".join(f"{k} {n}" for k, n in sorted(gated.items()))
            self.log.add(f"navigation: readings left out as implausible (beyond 4.9 sigma): {what}")
        refreshes = 0 if self._plant is None else self._plant.rate_refreshes
        if refreshes:
            self.log.add(f"telemetry rates re-requested {refreshes} time(s)")
        rate = math.nan if self._plant is None else self._plant.vehicle_clock_rate()
        if abs(rate - 1.0) > VEHICLE_RATE_SAID:  # a rehearsal's simulator that fell behind (NaN: False)
            self.log.add(
                f"the vehicle's clock ran at {rate:.2f} of fly's over the flight: the loop paced on it "
                f"(its clock's offset followed {self.io.health.drift_restarts} time(s))"
            )
        rec = self._rec
        if ending is None:
            if rec is not None and rec.writer is not None:
                rec.close()
            return FlyResult("aborted", "error", {}, None, list(self.log.items))
        if self._sigint.hit and ending.reason != "interrupted":
            said = f"interrupted ({interrupt_name()}) while ending: {ending.message}"
            ending = LoopResult("interrupted", said, ending.t_end)
        self.log.add(f"end: {ending.reason}: {ending.message}")
        outcome: dict[str, Any] = {}
        if rec is not None and rec.writer is not None:
            result = dataclasses.replace(ending, wall_time_s=time.perf_counter() - self._loop_t0)
            outcome = rec.outcome(
                ending.reason,
                ending.message,
                result=result,
                extra={
                    "events_json": rec.events_json(self.log.items),
                    "armed_by_us": self._we_armed,
                    "handed_over_armed": self._handed_over_armed,
                    "solver_stderr_lines": self._stderr.lines,
                    "vehicle_parameters_json": json.dumps(self.io.state.params, sort_keys=True),
                    **_verdict_outcome(ending.verdict, self._model_dock.offset_s),
                },
            )
            rec.finish(outcome)
        path = self.out if rec is not None and rec.writer is not None else None
        return FlyResult(ending.reason, ending.message, outcome, path, list(self.log.items))

    def _shutdown(self, takeover: bool = False) -> None:
        """Camera stopped, neutral, overrides released, disarmed if we armed, link closed.  Never raises.

        After a takeover only the release: the channels go back at once to whoever took the
        vehicle (a neutral override from us would fight their input), and the vehicle is left
        armed or disarmed as they left it."""
        if self.camera is not None:
            self.camera.stop()
        if self.camera_sensor is not None:
            self.camera_sensor.stop()
        actions = (
            (self.link.release_overrides,)
            if takeover
            else (self.link.send_neutral, self.link.release_overrides)
        )
        for action in actions:
            try:
                action()
            except Exception:  # noqa: BLE001
                pass
        self._stderr.close()
        if self._we_armed and not takeover:
            try:
                self.link.disarm()
            except Exception:  # noqa: BLE001
                self.log.add("disarm failed")
        elif self._handed_over_armed and not takeover:
            self.log.add("left armed, as it was handed over: fly disarms only a vehicle it armed")
        try:
            self.link.close()
        except Exception:  # noqa: BLE001
            pass
