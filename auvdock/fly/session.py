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
from auvdock.fly.camera import CAMERA_SERIES, CameraOpenError, CameraTracking
from auvdock.fly.camera_sensor import (
    CAMERA_SENSOR_SERIES,
    FIX_RECORD,
    SYNTHETIC_NEEDS,
    CameraSensor,
    RecordedCamera,
)
from auvdock.fly.conformance import PARAMETER_GROUPS, check_parameters, describe, parameter_names
from auvdock.fly.dock_source import LandingTargetSource
from auvdock.fly.dock_telemetry import DOCK_TELEMETRY_SERIES, DockTelemetryIn
from auvdock.fly.link import LinkError, MavlinkLink
from auvdock.fly.link_health import LinkFigures, LinkHealth
from auvdock.fly.plant import MavlinkPlant
from auvdock.fly.record import FlyRecorder
from auvdock.fly.safety import (
    FailedSolves,
    limit_reason,
    link_problem,
    preflight_problems,
    staleness,
    takeover_reason,
)
from auvdock.fly.telemetry import (
    PRESSURE_PARAMETERS,
    TELEMETRY_MESSAGES,
    TelemetrySensors,
    frame_turns,
    geofence_violation,
)
from auvdock.fly.vehicle_state import VehicleState
from auvdock.loop import closed_loop
from auvdock.loop.autopilot import build_autopilot
from auvdock.loop.closed_loop import LoopResult
from auvdock.loop.closed_loop import Progress as LoopProgress
from auvdock.loop.verdict import CaptureVerdict, MarginVerdict, Verdict
from auvdock.runtime.clock import Clock
from auvdock.runtime.interrupts import SigintDeferred, interrupt_name
from auvdock.runtime.stderr_capture import StderrCapture
from auvdock.sensing.readings import Reading
from auvdock.vehicle import Vehicle
from auvdock.vehicle.actuators import ArduSubActuators
from auvdock.vehicle.ardusub import MODES, NEUTRAL_CHANNELS
from auvdock.world.dock import ClockedDock, TrackedDock

__all__ = ["FlySession", "FlyResult", "FlyAbortError", "FlyTakeoverError", "EXIT_CODES", "check_flyable"]

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


class FlyTakeoverError(RuntimeError):
    """Someone else took the vehicle: a disarm or a mode change fly did not command, or pilot
    input from another ground station.  fly stops commanding at once and releases the channels."""


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


@dataclass
class _Ending:
    reason: str
    message: str
    docked: bool = False
    contact: np.ndarray | None = None
    t_end: float = 0.0
    verdict: Verdict | None = None


def _interrupted() -> _Ending:
    """The ending of a Ctrl-C (or a SIGTERM, which interrupts as one)."""
    return _Ending("interrupted", f"interrupted ({interrupt_name()})")


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
        sensing of the water-relative velocity, which no vehicle has), a WEC dock in a sea and the dock's
        telemetry (not yet flown: each says what a vehicle would need), the dock camera as a sensor
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
    if mission.dock.wec is not None:
        raise MissionError(
            where,
            "dock.wec",
            "fly does not yet fly a WEC dock in a sea (sim only: a vehicle would need the dock's telemetry); "
            "fly needs the dock's motion model (dock.heave)",
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
        with SigintDeferred():
            self._build(mission, controller)
        self.dt = self.autopilot.dt
        self.events: list[tuple[float, str]] = []
        self.camera: CameraTracking | None = None
        #: The dock camera as the navigation filter's sensor (sensors.dock_camera), once started (a replay:
        #: the flight's recorded fixes).
        self.camera_sensor: CameraSensor | RecordedCamera | None = None
        self._t0 = self.clock.now()
        self._frame: Any = None
        self._now_us = 0
        self._failed_solves = FailedSolves(mission.fly.max_failed_solves)
        self._rec: FlyRecorder | None = None
        self._loop_t0 = time.perf_counter()
        self._we_armed = False
        self._handed_over_armed = False  # the vehicle was armed before fly armed it (a pilot's)
        self._t_end = 0.0
        self._progress: Any = None
        self._on_event: Any = None
        self._sigint = _SigintLatch()
        self._refusals: list[str] = []
        self.state = VehicleState()  # what the vehicle has said (parameters, acks, battery, texts)
        self._t_armed: float | None = None
        self._next_rates = 0.0
        self._rate_refreshes = 0
        self.hold = DepthAttitudeHold(self.vehicle, mission.fly.hold_bandwidth_rad_s)
        self._stderr = StderrCapture(on_new=lambda line: self._event(f"solver says: {line}"))
        self.link.on_event = self._event

    def _build(self, mission: Mission, controller: str | None) -> None:
        """The vehicle model, the dock (model or filter), the flow and the controller step."""
        self.vehicle = check_flyable(mission, controller)
        self.telemetry = TelemetrySensors(mission.sensors, mission.estimation)
        # the mission's dock motion on the vehicle's clock (its offset set as the control loop starts)
        self._model_dock = ClockedDock(mission.dock.build())
        self._mission_zero_s: float | None = None  # mission t = 0 on the session's clock (s), once set
        self.dock: ClockedDock | TrackedDock = self._model_dock
        self._landing: LandingTargetSource | None = None
        if mission.dock.source == "mavlink":
            self.dock = TrackedDock(self._model_dock)
        elif mission.dock.source == "camera":
            self.dock = TrackedDock(self._model_dock, process_noise=mission.camera.process_noise_m_s)
        self.flow = mission.build_flow()
        self.autopilot = build_autopilot(mission, self.vehicle, self.dock, controller)
        self.actuators = ArduSubActuators(self.vehicle)  # what fly sends: ArduSub's channel path
        self.link_health = LinkHealth()
        self._next_timesync = -math.inf
        self._link_bad_since: float | None = None
        if mission.fly.delay_compensation:
            self.autopilot.delay = DelayCompensation(self.vehicle)
        #: sensors.dock_telemetry: the dock's own motion record, received from its MAVLink system
        tel = mission.sensors.dock_telemetry
        self.dock_telemetry = DockTelemetryIn(tel) if mission.estimation == "filter" and tel.enabled else None
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
        self._on_event = on_event
        ending: _Ending | None = None
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

    def _fly(self) -> _Ending:
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
            self._event(f"abort: {e}")
            return _Ending("aborted", str(e), t_end=self._t_end)
        except FlyTakeoverError as e:
            self._event(f"takeover: {e}")
            return _Ending("takeover", str(e), t_end=self._t_end)
        except KeyboardInterrupt:
            ending = _interrupted()
            self._event(ending.message)
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
                self._event(f"rate {name} {rate:g} Hz: MAV_RESULT {result}")
            except LinkError as e:
                self._event(f"rate {name}: {e}")
            self._send_neutral()
        m = self.mission
        name = self.autopilot.name
        if m.estimation == "filter":
            pos = m.sensors.position.source
            what = "IMU, attitude, depth" + ("" if pos == "none" else f" and position ({pos})")
            self._event(f"estimation: filter (the navigation filter on the {what})")
        else:
            self._event("estimation: truth (the autopilot's ATTITUDE and LOCAL_POSITION_NED as the state)")
        if self.autopilot.reads_true_flow:
            self._event(
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

    def _record_camera_fixes(self) -> None:
        """The camera's fixes of this step, taken now and written to the tlog before the step's messages are
        drained: replay finds them at the same step (:class:`auvdock.fly.camera_sensor.RecordedCamera`)."""
        if self.camera_sensor is not None:
            rows = self.camera_sensor.before_drain()
            if rows:
                self.link.record_rows(FIX_RECORD, rows)

    def _take_telemetry(self, marker: str, value: int = 0) -> int:
        """The messages received since the last call into :attr:`telemetry` and :attr:`state`
        (:class:`auvdock.fly.vehicle_state.VehicleState`: parameters, acks, battery, the vehicle's
        texts, another station flying); returns now (us, the tlog's clock).  The link marks the
        moment in the tlog (for replay)."""
        now_us, messages = self.link.drain(marker, value)
        self.telemetry.feed(messages)
        if self.dock_telemetry is not None:
            self.dock_telemetry.feed(messages)
        if self.camera_sensor is not None:
            self.camera_sensor.feed(messages)
        self.link_health.feed(messages, getattr(self.link, "target_system", 1))
        link = self.link_health.figures()
        rtt = max(link.rtt_s, link.rtt_latest_s)  # (NaN before a TIMESYNC answer)
        self.state.round_trip_us = int(rtt * 1e6) if math.isfinite(rtt) else 0
        self.state.clock_offset_s = link.offset_s
        if self.clock.now() >= self._next_timesync:  # the round trip and the vehicle's clock
            self._next_timesync = self.clock.now() + self.mission.fly.timesync_period_s
            self.link.send_timesync(LinkHealth.request_ns(now_us * 1e-6))
        for text in self.state.feed(messages, getattr(self.link, "target_system", 1)):
            self._event(text)
        return now_us

    def _send_channels(self, channels: Any) -> None:
        """RC overrides for channels 1..6, remembered (the RC_CHANNELS check compares with them)."""
        ch = tuple(int(round(c)) for c in channels)
        self.link.send_override(ch)
        self.state.sent_channels(int(self.clock.time() * 1e6), ch)

    def _send_neutral(self) -> None:
        self._send_channels(NEUTRAL_CHANNELS)

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
                missing = [n for n in names if n not in self.state.params]
                self.link.request_parameters(missing[:PARAM_BATCH])
                next_ask = clock.now() + PARAM_BATCH_PERIOD_S
            self._send_neutral()
            self._take_telemetry("auvd_param")
            if all(any(n in self.state.params for n in g) for g in wanted) and (
                all(n in self.state.params for n in PRESSURE_PARAMETERS) or clock.now() >= deadline - 1.0
            ):
                break
            clock.sleep(self.dt)
        self._event(describe(self.state.params))
        self._event(self.telemetry.set_pressure_reference(self.state.params))
        self._refusals = check_parameters(
            self.state.params, sysid=getattr(self.link, "sysid", 255), dt=self.dt, expected=fly.parameters
        )
        for problem in self._refusals:
            self._event(f"parameter check: {problem}")

    def _missing(self) -> list[str]:
        """What the session still waits for: the estimation's telemetry, a pressure reading (the
        depth limits act on it) and, with a battery floor, SYS_STATUS."""
        out = self.telemetry.missing()
        if self.telemetry.measured_depth() is None:
            out.append("SCALED_PRESSURE2 or SCALED_PRESSURE or VFR_HUD")
        if self.mission.fly.min_battery_v > 0 and not self.state.battery_reported:
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
            self._send_neutral()
            now_us = self._take_telemetry("auvd_wait")
            missing = self._missing()
            if missing and clock.now() >= next_ask:  # a rate request (or its ack) lost on the link: again
                next_ask = clock.now() + RATE_RETRY_S
                for name, rate in self._streams().items():
                    if self.telemetry.latest(name)[0] is None:
                        self.link.send_rate(getattr(mavutil.mavlink, f"MAVLINK_MSG_ID_{name}"), rate)
            if not missing and self.telemetry.age_s(now_us) < 0.5:
                if clock.now() - t0 >= PROGRESS_EVERY_S:
                    self._event(f"telemetry complete after {clock.now() - t0:.0f} s")
                return
            if clock.now() >= next_note:
                next_note += PROGRESS_EVERY_S
                what = ", ".join(missing) if missing else "fresh telemetry"
                self._event(f"waiting for {what}: {clock.now() - t0:.0f} s of {limit:g} s")
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

        self._take_telemetry("auvd_frame")
        if not enough():
            self._await("auvd_frame", enough, window)
        turn = frame_turns(self.mission.fly.frame_heading, self.mission.sensors.position.source)
        self._frame = tel.set_frame(self.mission.start_state(), window, turn)
        n_pos, n_att = tel.frame_readings
        how = "" if turn else "; not turned: the positions are fixes in the position source's frame"
        self._event(f"{tel.describe_frame()} (the mean of {n_pos} positions and {n_att} headings{how})")

    def _start_camera(self) -> None:
        """The camera: sensors.dock_camera (a sensor of the navigation filter) or dock.source: camera
        (the older tracker of a point dock) -- open the frame source and start detecting."""
        m = self.mission
        if m.estimation == "filter" and m.sensors.dock_camera.enabled:
            if getattr(self.link, "replaying", False):  # the flight's fixes, as recorded in its tlog
                self.camera_sensor = RecordedCamera()
                self._event(f"camera: {self.camera_sensor.description}")
                return
            try:
                self.camera_sensor = CameraSensor(
                    m, self.clock, self._model_dock, lambda: self.telemetry.latest("SIM_STATE"), self._event
                )
            except (OSError, ValueError, RuntimeError) as e:
                raise FlyAbortError(f"camera: {e}") from None
            self.camera_sensor.start()
            self._event(f"camera: {self.camera_sensor.description}, a sensor of the navigation filter")
            return
        if self.mission.dock.source != "camera":
            return
        assert isinstance(self.dock, TrackedDock)  # dock.source: camera tracks the dock (_build)
        try:
            self.camera = CameraTracking(self.mission, self._model_dock, self.dock, self.clock, self._event)
        except CameraOpenError as e:
            raise FlyAbortError(str(e)) from None
        self.camera.start(self._state())
        self._event(f"camera: {self.camera.description}")

    def _preflight(self) -> None:
        """Before arming, on measured values: the parameter checks, the pressure sensor's depth
        inside the geofence and near the mission's start depth, the dock inside the geofence,
        the battery above its floor.  With --arm any problem refuses to arm (one line, all of
        them in the events); a dry run reports them and goes on.  The depth is the median of the
        pressure sensor's readings over the last ``fly.preflight_window_s`` (gathered with the frame's:
        :meth:`_set_frame`)."""
        window = self.mission.fly.preflight_window_s
        problems = preflight_problems(
            self.mission,
            self._refusals,
            self.telemetry.filtered_depth(window),
            np.asarray(self._model_dock.position(0.0), dtype=float),
            self.state.battery_v,
            self.link_health.figures(),
        )
        self._event(f"link: {self.link_health.figures().describe()}")
        if not problems:
            self._event("pre-flight checks pass")
            return
        for problem in problems:
            self._event(f"pre-flight: {problem}")
        if not self.arm_vehicle:
            self._event(f"dry run: arming would be refused ({len(problems)} problem(s))")
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
            self._send_neutral()
            self._take_telemetry(marker)
            if done():
                return True
            clock.sleep(self.dt)
        return False

    def _vehicle_mode(self) -> tuple[bool, int | None]:
        """(armed, custom_mode) of the vehicle's latest HEARTBEAT ((False, None) before one)."""
        hb, _ = self.telemetry.latest("HEARTBEAT")
        if hb is None:
            return False, None
        return bool(hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED), int(hb.custom_mode)

    def _arm(self) -> None:
        """--arm: MANUAL mode, then arm, retried every ARM_RETRY_S while the vehicle refuses
        (its pre-arm reasons appear as events) until ``fly.arm_timeout_s``; else a dry run."""
        if not self.arm_vehicle:
            armed = " (the vehicle is armed, not by fly)" if self._vehicle_mode()[0] else ""
            self._event(f"dry run: not arming, sending neutral overrides only{armed}")
            self._t_armed = self.clock.now()
            return
        manual = MODES["MANUAL"]
        if not self._await("auvd_mode", lambda: self._vehicle_mode()[1] == manual, MODE_TIMEOUT_S,
                           resend=lambda: self.link.send_mode("MANUAL")):  # fmt: skip
            raise FlyAbortError(
                f"vehicle did not change to MANUAL (mode {manual}) within {MODE_TIMEOUT_S:g} s"
            )
        self._event("mode MANUAL")
        if self._vehicle_mode()[0]:  # handed over armed: fly did not arm it, and will not disarm it
            self._handed_over_armed = True
            self._t_armed = self.clock.now()
            self._event(
                "taking over an armed vehicle: it was armed before fly (not by fly), and is left armed at "
                "the end, overrides released"
            )
            return
        self._we_armed = True  # from the arm command on, every ending disarms (Ctrl-C before its ack too)
        limit = self.mission.fly.arm_timeout_s
        self._event("arming (waits for the vehicle's pre-arm checks)")
        if not self._await("auvd_arm", lambda: self._vehicle_mode()[0], limit,
                           resend=lambda: self.link.send_arm(True), every_s=ARM_RETRY_S):  # fmt: skip
            arm = mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM
            results = [r for c, r in self.state.acks if c == arm]
            why = self.state.last_arm_text or (f"MAV_RESULT {results[-1]}" if results else "no COMMAND_ACK")
            raise FlyAbortError(f"arming refused for {limit:g} s (fly.arm_timeout_s): {why}")
        self._t_armed = self.clock.now()
        self._event("armed")

    def _open_results(self) -> None:
        m = self.mission
        camera_series = CAMERA_SERIES if self.camera is not None else {}
        if self.camera_sensor is not None:
            camera_series = CAMERA_SENSOR_SERIES
        if self.dock_telemetry is not None:
            camera_series = {**camera_series, **DOCK_TELEMETRY_SERIES}
        self._plant = MavlinkPlant(self, camera_series)
        self._rec = FlyRecorder(
            self.out,
            mission=m,
            autopilot=self.autopilot,
            vehicle=self.vehicle,
            dock=self.dock,
            plant_columns=self._plant.columns,
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
    def _control_loop(self) -> _Ending:
        """The one closed loop (:func:`auvdock.loop.closed_loop.run_closed_loop`) on this vehicle:
        a step every dt on the session's clock until docked, the timeout or an abort."""
        assert self._rec is not None
        progress = None
        if self._progress is not None:
            user = self._progress

            def progress(p: LoopProgress) -> None:
                user(p.t, p.distance_m, STATUS_NAMES.get(p.status, str(p.status)))

        @contextlib.contextmanager
        def quiet() -> Iterator[None]:  # what CasADi's C code prints is counted, not shown per step
            with self._stderr.capture():
                yield

        result = closed_loop.run_closed_loop(
            plant=self._plant,
            autopilot=self.autopilot,
            actuators=self.actuators,
            recorder=self._rec.loop,
            dock=self.dock,
            tolerance_m=self.mission.docking.tolerance_m,
            timeout_s=self.timeout_s,
            hold=self.hold,
            progress=progress,
            on_event=self._event,
            control_guard=quiet,
            verdict=self._verdict(),
        )
        return _Ending(
            result.reason,
            result.message,
            docked=result.docked,
            contact=result.contact,
            t_end=result.t_end,
            verdict=result.verdict,
        )

    def _verdict(self) -> MarginVerdict | CaptureVerdict:
        """The docking rule on the estimate (:mod:`auvdock.loop.verdict`): the point rule, or with
        ``docking.criterion: capture`` captured with a margin, against the dock's body."""
        m = self.mission
        point = MarginVerdict(
            m.docking.tolerance_m,
            self.dock,
            m.sensors.position.figures()[2],
            frame_cov=self.telemetry.frame_cov,
            position_bias_std_m=m.sensors.position.bias_std_m,
        )
        contact = m.build_contact(self._model_dock.dock)
        return point if contact is None else CaptureVerdict(point, contact)

    # -- safety checks --------------------------------------------------------------------
    def _check_takeover(self) -> None:
        """Someone else flies (:func:`auvdock.fly.safety.takeover_reason`): raises FlyTakeoverError."""
        armed, mode = self._vehicle_mode()
        in_control = self._we_armed or self._handed_over_armed  # flying an armed vehicle
        why = takeover_reason(
            self.state.foreign, in_control, armed, mode, self._vehicle_text_since_arming()
        )
        if why is not None:
            raise FlyTakeoverError(why)

    def _vehicle_text_since_arming(self) -> str:
        """The vehicle's latest STATUSTEXT since arming ("" if none)."""
        for _, text in reversed(self.events):
            if text == "armed":
                return ""
            if text.startswith("vehicle: "):
                return text[len("vehicle: ") :]
        return ""

    def _check_limits(self) -> None:
        """The battery floor and the time limit since arming (:func:`auvdock.fly.safety.limit_reason`)."""
        since = None if self._t_armed is None else self.clock.now() - self._t_armed
        why = limit_reason(self.mission.fly, self.state.battery_v, since, self.timeout_s)
        if why is not None:
            raise FlyAbortError(why)

    def _refresh_rates(self) -> None:
        """Re-request the telemetry rates every ``fly.rates_refresh_s`` (not waited for): a ground
        station (QGroundControl, Cockpit) may have reset them."""
        now = self.clock.now()
        if now < self._next_rates:
            return
        if self._next_rates > 0:
            for name, rate in self._streams().items():
                self.link.send_rate(getattr(mavutil.mavlink, f"MAVLINK_MSG_ID_{name}"), rate)
            self._rate_refreshes += 1
        self._next_rates = now + self.mission.fly.rates_refresh_s

    def _check_telemetry(self) -> bool:
        """Stale telemetry: True (no control step on old readings; the loop sends neutral); lost: abort."""
        stale = self._stale()
        fly = self.mission.fly
        action = staleness(fly, stale)
        if action == "abort":
            names = [n for n, age in self.telemetry.ages(self._now_us).items() if age > fly.stale_abort_s]
            raise FlyAbortError(f"telemetry lost: no {', '.join(names)} for {stale:.1f} s")
        if action == "neutral":
            if not self.events or not self.events[-1][1].startswith("telemetry stale"):
                self._event(f"telemetry stale ({stale:.2f} s): neutral")
            return True
        return False

    def _check_solves(self, status: int) -> None:
        """Abort after ``fly.max_failed_solves`` steps in a row without a converged solve."""
        why = self._failed_solves.update(status)
        if why is not None:
            raise FlyAbortError(why)

    def _check_geofence(self) -> None:
        """The geofence on measured values: the pressure sensor's depth, the vehicle's own
        position estimate's distance from the start.  A pressure reading older than
        ``fly.stale_abort_s`` aborts too (the depth limits cannot act without it)."""
        measured = self.telemetry.measured_depth()
        if measured is None:
            raise FlyAbortError("telemetry lost: no pressure reading (the depth limits need it)")
        depth, source = measured
        _, stamp = self.telemetry.latest(source)
        age = math.inf if stamp is None else (self._now_us - stamp) * 1e-6
        if age > self.mission.fly.stale_abort_s:
            raise FlyAbortError(f"telemetry lost: no {source} for {age:.1f} s (the depth limits need it)")
        fence = geofence_violation(self.mission.fly.geofence, depth, self.telemetry.distance_from_start())
        if fence is not None:
            raise FlyAbortError(f"{fence} ({source})" if "depth" in fence else fence)

    def _dock_motion(self) -> tuple[list[Reading], float]:
        """The dock's new telemetry as ``dock_motion`` readings on the mission's clock, and its age (s);
        none for longer than ``fly.stale_abort_s``: abort (the forecast would run on an old record)."""
        assert self.dock_telemetry is not None
        age = self.dock_telemetry.age_s(self._now_us)
        if age > self.mission.fly.stale_abort_s:
            raise FlyAbortError(
                f"the dock's telemetry lost: no ODOMETRY from system {self.dock_telemetry.system} for "
                f"{age:.1f} s (fly.stale_abort_s)"
            )
        return self.dock_telemetry.readings(self._model_dock.offset_s), age

    def _camera_step(self, t: float) -> tuple[bool, dict[str, np.ndarray]]:
        """The camera's fixes into the dock filter: (may steer?, series); aborts when lost."""
        assert self.camera is not None
        state, series = self.camera.step(t)
        if state == "lost":
            raise FlyAbortError(self.events[-1][1] if self.events else "camera: dock lost")
        return state == "tracking", series

    def _set_dock_clock(self, t: float) -> None:
        """The mission's dock motion runs on the vehicle's clock (:class:`auvdock.world.dock.ClockedDock`):
        mission time ``t`` (s) is now; the vehicle's time now is the session's plus the clocks' offset
        measured with TIMESYNC (:class:`auvdock.fly.link_health.LinkHealth`), or without an answer the
        newest ATTITUDE's ``time_boot_ms`` plus that message's age on arrival (its delivery delay not
        counted: over a 250 ms link the dock would be a quarter second out of phase)."""
        att, stamp = self.telemetry.latest("ATTITUDE")
        self._mission_zero_s = self._now_us * 1e-6 - t  # mission t = 0 on the session's clock
        offset = self.link_health.figures().offset_s
        if math.isfinite(offset):  # the vehicle's clock now, from TIMESYNC (not the newest ATTITUDE's)
            vehicle_now = self._now_us * 1e-6 + offset
        elif att is not None and stamp is not None:
            vehicle_now = float(att.time_boot_ms) * 1e-3 + max(0, self._now_us - stamp) * 1e-6
        else:
            return
        self._model_dock.offset_s = vehicle_now - t
        offset = vehicle_now - t
        self._event(f"dock: its motion on the vehicle's clock (mission t = 0 at vehicle time {offset:.3f} s)")

    def _follow_vehicle_clock(self, offset_s: float) -> None:
        """Keep the dock's clock on the link's estimate of the vehicle's clock (``offset_s``, s: the
        vehicle's minus the session's, :class:`auvdock.fly.link_health.LinkFigures`): the readings are
        stamped with the same estimate, so when a less-queued TIMESYNC answer refines it, readings and
        dock move together (the relative position, which the verdict judges, does not jump)."""
        zero = self._mission_zero_s
        if zero is not None and math.isfinite(offset_s):
            self._model_dock.offset_s = zero + offset_s

    def _check_link(self, link: LinkFigures) -> bool:
        """The link within its limits (:func:`auvdock.fly.safety.link_problem`)?  Beyond them: False (the
        step holds neutral), an event when the hold starts and ends, and FlyAbortError once it has lasted
        ``fly.link_hold_s``."""
        why = link_problem(self.mission.fly, link)
        now = self.clock.now()
        if why is None:
            if self._link_bad_since is not None:
                self._event(f"link recovered ({link.describe()}): flying again")
                self._link_bad_since = None
            return True
        if self._link_bad_since is None:
            self._link_bad_since = now
            self._event(f"{why}: holding (neutral) for up to {self.mission.fly.link_hold_s:g} s")
        elif now - self._link_bad_since >= self.mission.fly.link_hold_s:
            raise FlyAbortError(f"{why} for {now - self._link_bad_since:.1f} s (fly.link_hold_s)")
        return False

    def _check_landing_target(self, t: float, x: np.ndarray) -> None:
        """dock.source: mavlink -- re-anchor the dock; abort without (or after losing) LANDING_TARGET."""
        assert self._landing is not None
        why = self._landing.lost(t, x, self._now_us, self._frame)
        if why is not None:
            raise FlyAbortError(why)

    # -- telemetry --------------------------------------------------------------------------
    def _stale(self) -> float:
        """Age (s) of the stalest telemetry the estimation needs, at this step's drain."""
        return self.telemetry.age_s(self._now_us)

    def _state(self) -> np.ndarray:
        """The autopilot's estimate of the state (12,) in the mission frame (latest telemetry)."""
        return self.telemetry.state()

    def _telemetry(self) -> dict[str, Any]:
        ages = []
        for mtype in ("ATTITUDE", "LOCAL_POSITION_NED"):
            _, stamp = self.telemetry.latest(mtype)
            ages.append(np.inf if stamp is None else (self._now_us - stamp) * 1e-6)
        hb, _ = self.telemetry.latest("HEARTBEAT")
        armed = hb is not None and bool(hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        return {"age_s": np.array(ages), "armed": armed}

    def _event(self, text: str) -> None:
        item = (self.clock.now() - self._t0, text)
        self.events.append(item)
        if self._on_event is not None:
            self._on_event(*item)

    # -- the ending -----------------------------------------------------------------------
    def _finish(self, ending: _Ending | None) -> FlyResult:
        """The one ending (``None``: an unexpected error, which propagates after it).

        Neutral overrides, override release, disarm if we armed, link closed, outcome
        written and the results file closed; a SIGINT meanwhile is only noted.
        """
        self._sigint.install()
        self._shutdown(takeover=ending is not None and ending.reason == "takeover")
        if self._stderr.lines:
            self._event(f"solver output: {self._stderr.summary()}")
        nav = getattr(self.autopilot, "navigation", None)
        gated = getattr(getattr(nav, "filter", None), "gated", None)
        if gated:  # readings the navigation filter left out as implausible: is a sensor's std right?
            what = ", ".join(f"{k} {n}" for k, n in sorted(gated.items()))
            self._event(f"navigation: readings left out as implausible (beyond 4.9 sigma): {what}")
        if self._rate_refreshes:
            self._event(f"telemetry rates re-requested {self._rate_refreshes} time(s)")
        rec = self._rec
        if ending is None:
            if rec is not None and rec.writer is not None:
                rec.close()
            return FlyResult("aborted", "error", {}, None, list(self.events))
        if self._sigint.hit and ending.reason != "interrupted":
            said = f"interrupted ({interrupt_name()}) while ending: {ending.message}"
            ending = _Ending("interrupted", said)
        self._event(f"end: {ending.reason}: {ending.message}")
        outcome: dict[str, Any] = {}
        if rec is not None and rec.writer is not None:
            result = LoopResult(
                ending.reason,
                ending.message,
                ending.t_end,
                ending.docked,
                ending.contact,
                time.perf_counter() - self._loop_t0,
            )
            outcome = rec.outcome(
                ending.reason,
                ending.message,
                result=result,
                extra={
                    "events_json": rec.events_json(self.events),
                    "armed_by_us": self._we_armed,
                    "handed_over_armed": self._handed_over_armed,
                    "solver_stderr_lines": self._stderr.lines,
                    "vehicle_parameters_json": json.dumps(self.state.params, sort_keys=True),
                    **_verdict_outcome(ending.verdict, self._model_dock.offset_s),
                },
            )
            rec.finish(outcome)
        path = self.out if rec is not None and rec.writer is not None else None
        return FlyResult(ending.reason, ending.message, outcome, path, list(self.events))

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
                self._event("disarm failed")
        elif self._handed_over_armed and not takeover:
            self._event("left armed, as it was handed over: fly disarms only a vehicle it armed")
        try:
            self.link.close()
        except Exception:  # noqa: BLE001
            pass
