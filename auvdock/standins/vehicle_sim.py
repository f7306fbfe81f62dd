"""A simulated ArduSub vehicle on MAVLink: BlueROV2 Heavy (VECTORED_6DOF) flown by auvdock's truth model.

:class:`VehicleSim` answers a topside program (a GCS, QGroundControl, ``auvdock fly``) the
way ArduSub does on a BlueROV2 Heavy, while the motion comes from this package's one 6-DOF
truth model (:meth:`auvdock.vehicle.Vehicle.stepper`, the integrator of
:func:`auvdock.loop.simulation.run_simulation`) driven through ArduSub's MANUAL thrust path
(:func:`auvdock.vehicle.ardusub.thrust_from_channels`).  Use it to test topside code on
loopback and to rehearse without a vehicle::

    from auvdock.config.mission import load_mission
    from auvdock.standins.vehicle_sim import VehicleSim

    with VehicleSim(load_mission("missions/tank_positioned.yaml"), port="udpout:127.0.0.1:14550") as sim:
        ...  # a GCS listening on udpin:127.0.0.1:14550 sees a BlueROV2

This module is the composition: the connection, the pacing, the physics step, and which
state each message carries.  Its parts, each with the MAVLink fields and units of its job:

* :mod:`auvdock.standins.commands` -- the messages handled: COMMAND_LONG / COMMAND_INT
  (arming, modes, message intervals), SET_MODE, parameter requests, RC_CHANNELS_OVERRIDE /
  MANUAL_CONTROL, the pilot-input failsafe; :class:`SimEvent`.
* :mod:`auvdock.standins.telemetry_out` -- the messages sent: HEARTBEAT, SYS_STATUS,
  ATTITUDE, LOCAL_POSITION_NED, SCALED_PRESSURE2, VFR_HUD, SCALED_IMU2 / RAW_IMU,
  SERVO_OUTPUT_RAW, RC_CHANNELS, LANDING_TARGET, STATUSTEXT; their rates (:data:`STREAMS`,
  :data:`DEFAULT_INTERVAL_US`) and sensor errors.
* :mod:`auvdock.standins.pilot_input` -- the pilot's channels
  (:func:`channels_from_override`, :func:`channels_from_manual_control`), the 3 s override
  lapse (:data:`OVERRIDE_TIMEOUT_S`) and the 3 s failsafe timer (:data:`PILOT_INPUT_TIMEOUT_S`).
* :mod:`auvdock.standins.ardusub_params` -- the parameters reported
  (:func:`default_parameters`) and PARAM_VALUE.
* :class:`auvdock.world.plant.TruthPlant` -- the physics.

Link
----
* The connection is ``mavutil.mavlink_connection(port, source_system=1, source_component=1,
  dialect="ardupilotmega")``; any pymavlink connection string works.  The default
  ``udpout:127.0.0.1:14550`` sends to a GCS listening there (a pymavlink ``udpin`` GCS replies
  to the address the packets come from).  With ``udpin:HOST:PORT`` the simulator listens and
  sends to every client it has heard from (nothing is sent before the first client speaks).
* The simulator speaks **MAVLink 2** like ArduSub (it parses MAVLink 1 and 2), whatever
  pymavlink's process-wide default is; the protocol of its connection is set without touching
  ``MAVLINK20`` in the environment.  A pymavlink GCS in MAVLink 1 mode switches itself to 2
  on the first packet (pymavlink's ``auto_mavlink_version``).
* Sender: system 1, component 1 (MAV_COMP_ID_AUTOPILOT1).
* Every received message is logged (:attr:`VehicleSim.received`); bytes that are not MAVLink
  are counted (:attr:`VehicleSim.garbage_count`) and otherwise ignored.  On UDP every
  datagram is parsed on its own (a packet never spans datagrams), so a datagram of garbage
  that looks like the start of a packet cannot swallow the packets of the next one.

Clock
-----
Every time in the simulator is **simulated time** ``t`` (s, 0 at :meth:`VehicleSim.start`):
the physics, the heartbeat, the stream intervals, the 3 s override lapse and the 3 s pilot
input failsafe, like ArduSub SITL with ``SIM_SPEEDUP``.  ``t`` advances by ``1 / rate_hz``
per physics step, paced to the simulator's :class:`auvdock.runtime.clock.Clock` times ``speed``.
With the wall clock (the default, ``auvdock vehicle-sim``), when the computer cannot keep
up, ``t`` slips (it never runs steps in a burst to catch up more than 0.25 s).  With a
:class:`auvdock.runtime.clock.SimClock` shared with a ``fly`` session (tests), the two run in
lockstep and never slip.  ``time_boot_ms`` / ``time_usec`` fields are ``t`` in ms / us.
Messages go out at most once per physics step, so the fastest telemetry rate is ``rate_hz``.

Physics
-------
Disarmed -> zero thrust.  Armed -> ``thrust_from_channels(channels)`` in **every** mode
(modes are accepted and reported but flown like MANUAL).
:class:`auvdock.world.plant.TruthPlant` (the truth plant this simulator shares with
:class:`auvdock.standins.sitl_physics.SitlPhysics`): ``Vehicle.stepper(1 / rate_hz,
substeps, flow)`` (RK4, thrust held over the step) from the mission's true start state, vehicle
and flow field.  The truth is drawn for the mission's seed as ``sim`` draws it
(:meth:`auvdock.config.mission.Mission.true_start_state`, ``build_dock(truth=True)``): the vehicle
starts ``start.position_std_m`` and the dock lies ``dock.position_std_m`` away from where the
mission charts them (nowhere else when they are zero).  ``surface=True`` (default) adds a crude
free surface the truth model lacks:
the depth z is floored at 0 m, and the upward velocity (and, in the accelerometer, the
upward acceleration) is removed there, so that a buoyant vehicle left alone floats instead
of flying out of the water.  The BlueROV2 Heavy of the shipped parameters is 2 N buoyant: it
rises at about 0.17 m/s with neutral sticks.  ``hold_start=True`` holds it at the start
state, at rest, while disarmed.

Sensor errors (``noise=True``, seeded by ``seed``, default the mission's seed) are those of
the mission's sensor suite (:mod:`auvdock.standins.telemetry_out`, Sensor errors).  Default off.

Test hooks
----------
:meth:`VehicleSim.pause_telemetry` stops (and resumes) every outgoing message, HEARTBEAT and
COMMAND_ACK included (a link lost downstream; incoming messages are still handled);
:attr:`VehicleSim.received` logs every received message as ``(clock.time() s, type, source
system, fields dict)``; :attr:`VehicleSim.events` lists :class:`SimEvent` (arm, disarm, mode,
failsafe); :attr:`~VehicleSim.armed`, :attr:`~VehicleSim.mode`, :attr:`~VehicleSim.state`,
:attr:`~VehicleSim.t`, :attr:`~VehicleSim.thrust`, :attr:`~VehicleSim.channels` read the
simulator's state thread-safely.  Each stream is sent by the instance's ``_send_<name>``
method (``_send_local_position_ned``, ...), looked up as it is sent: a test may replace one
on the instance to withhold that stream.
"""

from __future__ import annotations

import math
import select
import threading
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auvdock.config.mission import Mission, load_mission
from auvdock.controllers.base import ControlOutput
from auvdock.controllers.status import STATUS_OK
from auvdock.fly.units import pressure_hpa
from auvdock.loop import closed_loop
from auvdock.loop.recorder import LoopRecorder
from auvdock.loop.stages import Applied, LoopEnding, LoopResult, NoReadings, Observation, Stages, Unsupervised
from auvdock.loop.verdict import DockingRule
from auvdock.runtime.clock import Clock, wall_clock
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.sensing.errors import sensor_errors
from auvdock.sensing.readings import Readings
from auvdock.standins import telemetry_out
from auvdock.standins.ardusub_params import (
    COMPONENT_ID,
    OVERRIDE_TIMEOUT_S,
    PILOT_INPUT_TIMEOUT_S,
    SYSTEM_ID,
    default_parameters,
    vehicle_parameters,
)
from auvdock.standins.commands import MODE_NAMES, CommandHandler, SimEvent
from auvdock.standins.dock_out import DockTelemetryOut
from auvdock.standins.pilot_input import channels_from_manual_control, channels_from_override
from auvdock.standins.telemetry_out import (
    DEFAULT_INTERVAL_US,
    IMU_STREAMS,
    STREAMS,
    Outbox,
    PositionSource,
    SensorNoise,
    StreamSchedule,
)
from auvdock.standins.truth_record import TruthContact, TruthRecord
from auvdock.vehicle.actuators import ActuatorCommand, ArduSubActuators
from auvdock.vehicle.ardusub import thrust_from_channels
from auvdock.vehicle.state import POS
from auvdock.world.plant import TruthPlant

if TYPE_CHECKING:
    from auvdock.estimation.estimate import Estimate

__all__ = [
    "VehicleSim",
    "SimEvent",
    "STREAMS",
    "DEFAULT_INTERVAL_US",
    "OVERRIDE_TIMEOUT_S",
    "PILOT_INPUT_TIMEOUT_S",
    "channels_from_override",
    "channels_from_manual_control",
    "pressure_hpa",
    "default_parameters",
]

M = mavlink2

MAX_LAG_S = 0.25  # lag behind the clock after which simulated time slips instead of catching up
#: How long :meth:`VehicleSim.stop` waits for the simulator's thread to end (its truth file closed), s.
STOP_TIMEOUT_S = 30.0


class VehicleSim:
    """A MAVLink vehicle that behaves like ArduSub on a BlueROV2 Heavy (see the module docstring).

    Parameters
    ----------
    mission : Mission or path
        Vehicle, flow field, start state, RK4 substeps, seed and sensor noise levels.
    port : str
        pymavlink connection string (default ``udpout:127.0.0.1:14550``).
    rate_hz : float
        Physics steps per simulated second (and the fastest telemetry rate), Hz.
    speed : float
        Simulated seconds per second of the clock (read every physics step: a test may lower it in a
        session, as a simulator falls behind its rate on a busy machine).
    gcs_sysid : int
        The only system whose RC_CHANNELS_OVERRIDE / MANUAL_CONTROL are obeyed (SYSID_MYGCS).
    joystick_gain : float
        Pilot gain applied to MANUAL_CONTROL axes (ArduSub default 0.5).
    refuse_arm : bool
        Answer arming commands with MAV_RESULT_FAILED (for tests).
    params : dict, optional
        Parameter values that replace or add to :func:`default_parameters` (answered to
        PARAM_REQUEST_READ / PARAM_REQUEST_LIST; a name set to None is removed, as if the
        firmware had no such parameter).  ``SYSID_MYGCS`` / ``MAV_GCS_SYSID`` here set
        ``gcs_sysid``; ``RC_OVERRIDE_TIME`` the override lapse.
    battery_v : float
        Battery voltage reported in SYS_STATUS, V (:meth:`set_battery` changes it).
    noise : bool
        Add Gaussian sensor noise to the telemetry (levels from ``mission.sensors``).
    seed : int, optional
        Noise seed (default ``mission.seed``).
    substeps : int, optional
        RK4 substeps per physics step (default ``mission.simulation.substeps``).
    surface : bool
        Floor the depth at 0 m (a crude free surface; the truth model has none).
    hold_start : bool
        Hold the vehicle at the mission's start state, at rest, while it is disarmed (as a
        pilot would dive it there before each flight; ``vehicle-sim`` does by default), else
        it is free from the start (a buoyant vehicle floats up while disarmed).
    received_maxlen : int
        Most entries kept in :attr:`received` (oldest dropped first).
    clock : Clock, optional
        What the simulator paces itself on (default the wall clock; a
        :class:`auvdock.runtime.clock.SimClock` to run in lockstep with a fly session).
    truth_out : str or Path, optional
        Write the truth (the vehicle's and the dock's trajectories, the arming) to this results
        file (:mod:`auvdock.standins.truth_record`), complete when the simulator stops.
    """

    def __init__(
        self,
        mission: Mission | str | Path,
        port: str = "udpout:127.0.0.1:14550",
        *,
        rate_hz: float = 100.0,
        speed: float = 1.0,
        gcs_sysid: int = 255,
        joystick_gain: float = 0.5,
        refuse_arm: bool = False,
        params: dict[str, float | None] | None = None,
        battery_v: float = 16.0,
        noise: bool = False,
        seed: int | None = None,
        substeps: int | None = None,
        surface: bool = True,
        hold_start: bool = False,
        received_maxlen: int = 100_000,
        clock: Clock | None = None,
        truth_out: str | Path | None = None,
    ) -> None:
        if not isinstance(mission, Mission):
            mission = load_mission(mission)
        if not rate_hz > 0 or not speed > 0:
            raise ValueError("rate_hz and speed must be positive")
        self.mission = mission
        self.port = port
        self.rate_hz = float(rate_hz)
        self.dt = 1.0 / self.rate_hz
        self.speed = float(speed)
        vehicle_params, gcs = vehicle_parameters(params, int(gcs_sysid))
        self._battery_v = float(battery_v)
        self.surface = bool(surface)
        self.hold_start = bool(hold_start)
        self.clock: Clock = wall_clock if clock is None else clock
        self.truth_out = None if truth_out is None else Path(truth_out)

        n_sub = mission.simulation.substeps if substeps is None else int(substeps)
        # built whole: CasADi's argument type checks clear a KeyboardInterrupt raised in them
        with SigintDeferred():
            self.vehicle = mission.build_vehicle()
            self.flow = mission.build_flow()
            self.sea = mission.build_sea()  # the waves act on the vehicle here as in sim
            # the truth of this seed, as sim draws it: where the dock and the vehicle really are
            # (dock.position_std_m, start.position_std_m; the mission's own places when zero)
            self._dock = mission.build_dock(self.sea, truth=True)  # recorded, rendered; no verdict here
            self._start = mission.true_start_state()
            # docking.criterion: capture -- the truth's contact with the dock's body, recorded (not judged)
            self._contact = TruthContact.of(mission, self._dock)
            self._plant = TruthPlant(
                self.vehicle,
                self.flow,
                self._start,
                substeps=n_sub,
                surface=self.surface,
                dt=self.dt,
                sea=self.sea,
            )
        # sensors.dock_telemetry: the dock as its own MAVLink system, sending its motion (ODOMETRY)
        tel = mission.sensors.dock_telemetry
        self._dock_out: DockTelemetryOut | None = None
        if mission.estimation == "filter" and tel.enabled:
            self._dock_out = DockTelemetryOut(tel, self._dock, mission.seed)
        # each sensor's errors, defined once (auvdock.sensing.errors); the constant biases of this
        # run are drawn whether or not noise is on (same seed, same stream)
        rng = np.random.default_rng(mission.seed if seed is None else seed)
        self._sensors = SensorNoise(sensor_errors(mission.sensors), rng, enabled=bool(noise))

        self._lock = threading.RLock()
        self._stop_event = self.clock.event()
        self._ended = self.clock.event()  # the simulator thread's ending (the truth file) is done
        self._thread: threading.Thread | None = None
        self._conn: mavutil.mavfile | None = None  # the pymavlink connection once started
        self._started = False
        self._error: BaseException | None = None
        self._parser = self._new_parser()  # incoming UDP datagrams

        self._k = 0  # physics steps done; t = k dt
        self._tick_at: float | None = None  # when (the clock's time, s) the loop's next step is due
        self._thrust = np.zeros(8)
        self._target_dock: PositionSource | None = None
        self._out = Outbox()
        self._streams = StreamSchedule()
        self._commands = CommandHandler(
            vehicle_params,
            gcs_sysid=gcs,
            joystick_gain=joystick_gain,
            refuse_arm=refuse_arm,
            streams=self._streams,
            out=self._out,
            clock=self.clock,
            on_output_change=self._update_thrust,
        )
        self._received: deque[tuple[float, str, int, dict[str, Any]]] = deque(maxlen=received_maxlen)
        self._garbage = 0

    # --- settings ----------------------------------------------------------------------------
    @property
    def gcs_sysid(self) -> int:
        """The only system whose RC_CHANNELS_OVERRIDE / MANUAL_CONTROL are obeyed (SYSID_MYGCS)."""
        return self._commands.gcs_sysid

    @gcs_sysid.setter
    def gcs_sysid(self, value: int) -> None:
        with self._lock:
            self._commands.gcs_sysid = int(value)

    @property
    def joystick_gain(self) -> float:
        """Pilot gain applied to MANUAL_CONTROL axes."""
        return self._commands.joystick_gain

    @joystick_gain.setter
    def joystick_gain(self, value: float) -> None:
        with self._lock:
            self._commands.joystick_gain = float(value)

    @property
    def refuse_arm(self) -> bool:
        """Whether arming commands are answered with MAV_RESULT_FAILED."""
        return self._commands.refuse_arm

    @refuse_arm.setter
    def refuse_arm(self, value: bool) -> None:
        with self._lock:
            self._commands.refuse_arm = bool(value)

    @property
    def noise(self) -> bool:
        """Whether the telemetry carries the mission's sensor errors."""
        return self._sensors.enabled

    @noise.setter
    def noise(self, value: bool) -> None:
        with self._lock:
            self._sensors.enabled = bool(value)

    # --- public state ----------------------------------------------------------------------
    @property
    def armed(self) -> bool:
        """Whether the motors are armed."""
        with self._lock:
            return self._commands.armed

    @property
    def mode(self) -> int:
        """Current mode number (ArduSub custom_mode, :data:`~auvdock.vehicle.ardusub.MODES`)."""
        with self._lock:
            return self._commands.mode

    @property
    def mode_name(self) -> str:
        """Current mode name, e.g. "MANUAL"."""
        with self._lock:
            return MODE_NAMES[self._commands.mode]

    @property
    def state(self) -> np.ndarray:
        """Truth state (12,): [x y z NED m, phi theta psi rad, u v w body m/s over ground, p q r rad/s]."""
        with self._lock:
            return self._plant.state

    def pose(self) -> tuple[float, np.ndarray]:
        """(simulated time s, true pose eta (6,)) now; safe from any thread (the ``--camera`` stream's)."""
        with self._lock:
            return self._k * self.dt, self._plant.state[0:6].copy()

    @property
    def t(self) -> float:
        """Simulated time, s."""
        with self._lock:
            return self._k * self.dt

    @property
    def thrust(self) -> np.ndarray:
        """Thrust of T1..T8 (8,) in N (along +e_i) held over the current physics step."""
        with self._lock:
            return self._thrust.copy()

    @property
    def channels(self) -> np.ndarray:
        """Effective pilot channels 1..6 (us, CHANNELS order): the override, or neutral once lapsed."""
        with self._lock:
            return self._commands.channels(self._k * self.dt).copy()

    @property
    def received(self) -> list[tuple[float, str, int, dict[str, Any]]]:
        """Every received message: (``clock.time()`` s, type, source system, fields)."""
        with self._lock:
            return list(self._received)

    @property
    def events(self) -> list[SimEvent]:
        """Arm, disarm, mode and failsafe events, oldest first."""
        with self._lock:
            return list(self._commands.events)

    @property
    def ignored_control(self) -> int:
        """RC_CHANNELS_OVERRIDE / MANUAL_CONTROL messages ignored (wrong sender or target)."""
        with self._lock:
            return self._commands.ignored

    @property
    def garbage_count(self) -> int:
        """Received chunks that were not valid MAVLink."""
        with self._lock:
            return self._garbage

    @property
    def stream_intervals(self) -> dict[str, float]:
        """Active streams: message name -> interval (s, simulated time)."""
        with self._lock:
            return self._streams.intervals

    @property
    def local_address(self) -> tuple[str, int] | None:
        """(host, port) of the simulator's UDP socket once bound (e.g. for a second GCS), else None."""
        sock = getattr(self._conn, "port", None)
        try:
            host, port = sock.getsockname()[:2]  # type: ignore[union-attr]
        except (AttributeError, OSError):
            return None
        return (str(host), int(port)) if port else None

    @property
    def running(self) -> bool:
        """Whether the simulator thread is running."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def parameters(self) -> dict[str, float]:
        """The parameters the vehicle reports (name -> value)."""
        with self._lock:
            return dict(self._commands.params)

    def set_battery(self, volts: float) -> None:
        """The battery voltage SYS_STATUS reports from now on, V."""
        with self._lock:
            self._battery_v = float(volts)

    def set_prearm_failure(self, reason: str | None) -> None:
        """A failing pre-arm check (None: all pass): arming is refused with MAV_RESULT_FAILED and
        STATUSTEXT "Arm: REASON", and SYS_STATUS shows the pre-arm check unhealthy."""
        with self._lock:
            self._commands.prearm_failure = reason

    def arm_by_pilot(self) -> None:
        """Arm the motors as a pilot's joystick does, not by a command: a vehicle handed over armed (a
        SimEvent "arm", reason "pilot")."""
        with self._lock:
            self._commands._set_armed(True, "pilot", self._k * self.dt)

    def pause_telemetry(self, paused: bool = True) -> None:
        """Stop (True) or resume (False) every outgoing message, HEARTBEAT included."""
        with self._lock:
            self._out.paused = bool(paused)

    def set_landing_target(self, dock: PositionSource | None, rate_hz: float = 10.0) -> None:
        """Act as a positioning system on the vehicle: send LANDING_TARGET for ``dock``.

        ``dock`` is anything with ``position(t)`` (NED m at simulated time t, e.g. a
        :class:`auvdock.world.dock.HeaveDock`), or None to stop.  Sent at ``rate_hz`` in
        MAV_FRAME_BODY_FRD (the dock's position relative to the vehicle in body axes, m)
        with ``position_valid = 1``, from this vehicle's system id.
        """
        with self._lock:
            self._target_dock = dock
            period = 1.0 / float(rate_hz)
            self._streams.set_landing_target_period(None if dock is None else period, self._k * self.dt)

    # --- life cycle ------------------------------------------------------------------------
    def start(self) -> VehicleSim:
        """Open the connection and start the simulator thread (once per instance)."""
        if self._started:
            raise RuntimeError("VehicleSim.start() may be called only once")
        self._started = True
        conn = mavutil.mavlink_connection(
            self.port, source_system=SYSTEM_ID, source_component=COMPONENT_ID, dialect="ardupilotmega"
        )
        # speak MAVLink 2 like ArduSub, without pymavlink's process-wide MAVLINK20 switch
        conn.mav = M.MAVLink(conn, srcSystem=SYSTEM_ID, srcComponent=COMPONENT_ID)
        conn.mav.robust_parsing = True
        conn.WIRE_PROTOCOL_VERSION = "2.0"
        conn.first_byte = False
        self.clock.attach(conn)
        self._conn = conn
        if self._dock_out is not None:
            self._dock_out.attach(conn)
        with self._lock:
            self._out.conn = conn
            self._send_telemetry()  # the first HEARTBEAT, at t = 0 (binds a udpout socket)
        self._thread = self.clock.start_thread(self._run, name="VehicleSim")
        return self

    def stop(self) -> None:
        """Stop the simulator thread, wait for it (its truth file written and closed: at most
        :data:`STOP_TIMEOUT_S`) and close the connection (idempotent)."""
        self._stop_event.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self.clock.join(self._thread, timeout=STOP_TIMEOUT_S)
        if self._conn is not None:
            try:
                self._conn.close()
            except OSError:
                pass
            self._conn = None
            self._out.conn = None

    def run_forever(self, then: Callable[[], object] | None = None) -> bool:
        """Run (starting if needed, then calling ``then``: e.g. a camera stream's start) until Ctrl-C (or
        :meth:`stop` from elsewhere), then stop and return whether a Ctrl-C ended it; prints nothing.

        Re-raises an error that stopped the simulator thread.
        """
        interrupted = False
        try:
            if not self._started:
                self.start()
            if then is not None:
                then()
            # waits on an event, not on a join: on Python 3.11 a join that Ctrl-C interrupts leaves the
            # thread marked as ended while it still runs, so that stop() would not wait for its ending
            # (the truth file's) and the process would exit in the middle of it
            while self._thread is not None and self._thread.is_alive() and not self._ended.wait(0.2):
                pass
        except KeyboardInterrupt:
            interrupted = True
        # stopped whole: a second Ctrl-C (or SIGTERM) while stopping is noted, not obeyed, so that the
        # process never exits with the simulator's thread in the middle of the truth file (a daemon thread
        # inside HDF5 at the interpreter's exit can leave it waiting forever on HDF5's lock)
        while True:
            try:
                self.stop()
                break
            except KeyboardInterrupt:
                interrupted = True
        if self._error is not None:
            raise self._error
        return interrupted

    def __enter__(self) -> VehicleSim:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # --- main loop ---------------------------------------------------------------------------
    def _run(self) -> None:
        """The vehicle's life on the one closed loop (:func:`auvdock.loop.closed_loop.run_closed_loop`):
        its plant (:class:`_StandinPlant`: messages in, the truth stepped, telemetry out, paced on
        the clock), its pilot on the link as the control stage (:class:`_RemotePilot`) and
        ArduSub's channel path as the actuators, every ``dt`` until :meth:`stop`."""
        truth: TruthRecord | None = None
        try:
            recorder = LoopRecorder(
                [],
                vehicle=self.vehicle,
                dock=self._dock,
                extra_series={},
                plant_columns=_StandinPlant.columns_of(self),
                channels=True,
                keep=False,
            )
            if self.truth_out is not None:
                truth = TruthRecord.for_stand_in(
                    self.truth_out, "vehicle-sim", self.mission, recorder.series, self.vehicle.n_thrusters
                )
                recorder.sinks.append(truth)
            stages = Stages(
                _StandinPlant(self),
                NoReadings(),  # its pilot is on the link
                Unsupervised(),  # ArduSub's own failsafe acts in the plant
                _RemotePilot(self),
                ArduSubActuators(self.vehicle),
                DockingRule(self._dock, None),  # the flight it serves decides docking
                recorder,
            )
            closed_loop.run_closed_loop(stages, timeout_s=math.inf)  # until stopped
        except BaseException as e:  # keep it for run_forever; the thread must not die silently
            self._error = e
            self._stop_event.set()
        finally:
            try:
                if truth is not None:
                    events = "; ".join(f"{e.t:.2f} s {e.kind} ({e.detail})" for e in self.events)
                    truth.end(self._error is not None, events, self.t)
            finally:
                self._ended.set()

    def _wait_until(self, when: float) -> None:
        """Wait until ``when`` (the clock's time, s), handling messages as they arrive."""
        clock = self.clock
        conn = self._conn
        self._tick_at = when
        while not self._stop_event.is_set():
            delay = when - clock.now()
            if delay <= 0:
                return
            if conn is None or getattr(conn, "fd", None) is None:
                self._stop_event.wait(delay)
                return
            try:
                ready = clock.wait_readable(conn, min(delay, 0.05))
            except (OSError, ValueError):
                self._stop_event.wait(delay)
                return
            if ready:
                self._receive_all()

    def _physics_step(self) -> None:
        """Step the truth over one ``dt`` with the thrust the motors hold (held at the start, at
        rest, while disarmed with ``hold_start``)."""
        t = self._k * self.dt
        if self.hold_start and not self._commands.armed:
            self._plant.place(self._start)
        else:
            self._plant.step(self._thrust, t)
        self._k += 1

    def _update_thrust(self) -> None:
        """The thrust (8,, N) the motors hold from now: the pilot channels' when armed, else none."""
        curve = self.vehicle.thruster_curve
        cmd = self._commands
        t = self._k * self.dt
        self._thrust = thrust_from_channels(cmd.channels(t), curve) if cmd.armed else np.zeros(8)

    # --- incoming ----------------------------------------------------------------------------
    def _receive_all(self, limit: int = 1000) -> None:
        """Handle every message waiting on the connection (at most ``limit`` reads)."""
        conn = self._conn
        if conn is None:
            return
        if isinstance(conn, mavutil.mavudp):
            for _ in range(limit):
                try:
                    data = conn.recv()
                except OSError:
                    return
                if not data:
                    return
                self._parse_datagram(bytes(data))
            return
        fd = getattr(conn, "fd", None)
        for _ in range(limit):
            try:
                msg = conn.recv_msg()
            except Exception:  # garbage must not stop the vehicle
                with self._lock:
                    self._garbage += 1
                msg = None
            if msg is not None:
                with self._lock:
                    self._handle(msg)
                continue
            if fd is None:
                return
            try:
                ready, _, _ = select.select([fd], [], [], 0)
            except (OSError, ValueError):
                return
            if not ready:
                return

    def _parse_datagram(self, data: bytes) -> None:
        """Parse one UDP datagram on its own: a packet never spans datagrams.

        A partial packet left at the end (garbage that looked like a header) is dropped with
        its parser, so that it cannot swallow the next datagram's packets.
        """
        parser = self._parser
        try:
            msgs = parser.parse_buffer(data) or []
        except Exception:  # garbage must not stop the vehicle
            msgs = []
            parser = None
        with self._lock:
            if parser is None or parser.buf_len() > 0:
                self._garbage += 1
                self._parser = self._new_parser()
            for msg in msgs:
                self._handle(msg)

    @staticmethod
    def _new_parser() -> mavlink2.MAVLink:
        parser = M.MAVLink(None, srcSystem=SYSTEM_ID, srcComponent=COMPONENT_ID)
        parser.robust_parsing = True
        return parser

    def _handle(self, msg: mavlink2.MAVLink_message) -> None:
        """Log a received message and let the command handler act on it."""
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            self._garbage += 1
            return
        try:
            fields = msg.to_dict()
        except Exception:  # a message pymavlink cannot render
            fields = {}
        self._received.append((self.clock.time(), mtype, msg.get_srcSystem(), fields))
        # the commands act at the coming step; a TIMESYNC is answered with the vehicle's clock as it is read
        # (ArduPilot's micros at the answer), not the next step's time
        t = self._vehicle_now() if mtype == "TIMESYNC" else self._k * self.dt
        if not self._commands.handle(msg, t):
            self._garbage += 1

    def _vehicle_now(self) -> float:
        """The vehicle's clock now (s): the telemetry just sent is stamped with the last step's time ``k dt``
        a step before the next is due (:meth:`_StandinPlant.advance`), and the clock runs on from there."""
        t = self._k * self.dt
        if self._tick_at is None:
            return t
        period = self.dt / self.speed  # of the clock's time
        return t + min(self.dt, max(0.0, (self.clock.now() - (self._tick_at - period)) * self.speed))

    # --- outgoing: which state each message carries (telemetry_out encodes it) ----------------
    @property
    def _x(self) -> np.ndarray:
        """The truth state (12,), the plant's own array (read it under the lock, do not change it)."""
        return self._plant.x

    def _send_telemetry(self) -> None:
        """Send what is due at the current simulated time (and the dock's telemetry, from its own system)."""
        if self._dock_out is not None:
            self._dock_out.step(self._k * self.dt, paused=self._out.paused)
        imu: tuple[np.ndarray, np.ndarray] | None = None
        for name in self._streams.due(self._k * self.dt):
            if name in IMU_STREAMS:
                if imu is None:  # one reading of the last physics step for both IMU messages
                    imu = self._sensors.imu(*self._plant.imu())
                self._send_imu(name, *imu)
            else:  # looked up by name at each send: a test may replace one on the instance
                getattr(self, f"_send_{name.lower()}")()

    def _send_heartbeat(self) -> None:
        self._out.send(telemetry_out.heartbeat(self._commands.armed, self._commands.mode))

    def _send_landing_target(self) -> None:
        dock = self._target_dock
        if dock is not None:
            t = self._k * self.dt
            self._out.send(telemetry_out.landing_target(t, self._x, dock.position(t)))

    def _send_sys_status(self) -> None:
        prearm_ok = self._commands.prearm_failure is None
        self._out.send(telemetry_out.sys_status(self._battery_v, prearm_ok))

    def _send_rc_channels(self) -> None:
        t = self._k * self.dt
        self._out.send(telemetry_out.rc_channels(t, self._commands.channels(t)))

    def _send_attitude(self) -> None:
        self._out.send(telemetry_out.attitude(self._k * self.dt, self._x, self._sensors))

    def _send_local_position_ned(self) -> None:
        self._out.send(telemetry_out.local_position_ned(self._k * self.dt, self._x, self._sensors))

    def _send_scaled_pressure2(self) -> None:
        self._out.send(telemetry_out.scaled_pressure2(self._k * self.dt, self._x, self._sensors))

    def _send_vfr_hud(self) -> None:
        self._out.send(telemetry_out.vfr_hud(self._x, self._sensors))

    def _send_sim_state(self) -> None:
        self._out.send(telemetry_out.sim_state(self._x, self._plant.imu()[0]))

    def _send_imu(self, name: str, f_b: np.ndarray, w: np.ndarray) -> None:
        self._out.send(telemetry_out.imu(name, self._k * self.dt, f_b, w))

    def _send_servo_output_raw(self) -> None:
        t = self._k * self.dt
        self._out.send(telemetry_out.servo_output_raw(t, self._commands.armed, self._commands.channels(t)))


class _RemotePilot:
    """A stand-in vehicle's control stage: whoever flies it over the link.  Its command is the six
    RC channels the vehicle holds now (a GCS's override while it lasts, else neutral); the loop's
    actuator path (ArduSub's mixer and the thruster curve) makes the thrust."""

    extra_series: dict[str, tuple[int, ...]] = {}
    last_estimate: Estimate | None = None  # it estimates nothing
    last_step_t: float | None = None

    def __init__(self, sim: VehicleSim) -> None:
        self.sim = sim
        self.dt = sim.dt
        self.vehicle = sim.vehicle

    def finish(self, result: LoopResult) -> None:
        """Nothing to add."""

    def step(self, readings: Readings) -> ControlOutput:
        with self.sim._lock:
            channels = np.asarray(self.sim._commands.channels(readings.t), dtype=float)
        return ControlOutput(np.zeros(self.vehicle.n_thrusters), STATUS_OK, channels_us=channels)

    def set_applied(self, thrust: np.ndarray) -> None:
        """Nothing to predict with."""


class _StandinPlant:
    """A stand-in vehicle as the closed loop's plant: the messages that arrived, ArduSub's
    pilot-input failsafe, the truth stepped over ``dt`` with the motors' thrust (none while
    disarmed), the telemetry due, and the pace on the vehicle's clock (``speed`` x real time)."""

    columns: dict[str, tuple[int, ...]] = {"armed": ()}

    def __init__(self, sim: VehicleSim) -> None:
        self.sim = sim
        self._next_t = 0.0
        self.columns = self.columns_of(sim)

    @staticmethod
    def columns_of(sim: VehicleSim) -> dict[str, tuple[int, ...]]:
        """``armed``; with ``docking.criterion: capture`` also the truth's contact with the dock's body:
        ``contact_status`` (an index of :data:`auvdock.standins.truth_record.CONTACT_STATUSES`) and the
        nose in the dock frame ``nose_dock_m`` (m)."""
        out: dict[str, tuple[int, ...]] = {"armed": ()}
        if sim._contact is not None:
            out.update(sim._contact.columns)
        return out

    def start(self) -> None:
        self._next_t = self.sim.clock.now()

    def observe(self, t: float) -> Observation:
        sim = self.sim
        if sim._stop_event.is_set():
            raise LoopEnding("stopped", "vehicle-sim stopped")
        sim._receive_all()
        with sim._lock:
            sim._commands.check_failsafe(t)
            x = sim._plant.state
            columns = {"armed": np.asarray(float(sim._commands.armed))}
        if sim._contact is not None:  # recorded only: the flight it serves judges, the truth-check scores
            columns.update(sim._contact.at(x, t))
        v_c = np.asarray(sim.flow.velocity(x[POS], t), dtype=float)
        return Observation(t, x, v_c, columns)

    def apply(self, t: float, command: ActuatorCommand) -> Applied:
        sim = self.sim
        with sim._lock:
            sim._thrust = (
                command.applied_N.copy() if sim._commands.armed else np.zeros(sim.vehicle.n_thrusters)
            )
            return Applied(command.channels_us, sim._thrust.copy())

    def advance(self, t: float, t_next: float) -> bool:
        sim = self.sim
        with sim._lock:
            sim._physics_step()
            sim._send_telemetry()
        self._next_t += sim.dt / sim.speed  # (read each step: a rehearsal's simulator may fall behind)
        sim._wait_until(self._next_t)
        if sim.clock.now() - self._next_t > MAX_LAG_S:
            self._next_t = sim.clock.now()
        return True
