"""A simulated ArduSub vehicle on MAVLink: BlueROV2 Heavy (VECTORED_6DOF) flown by auvdock's truth model.

:class:`VehicleSim` answers a topside program (a GCS, QGroundControl, ``auvdock fly``) the
way ArduSub does on a BlueROV2 Heavy, while the motion comes from this package's one 6-DOF
truth model (:meth:`auvdock.vehicle.Vehicle.stepper`, the integrator of
:func:`auvdock.loop.simulation.simulate`) driven through ArduSub's MANUAL thrust path
(:func:`auvdock.vehicle.ardusub.thrust_from_channels`).  Use it to test topside code on
loopback and to rehearse without a vehicle::

    from auvdock.config.mission import load_mission
    from auvdock.standins.vehicle_sim import VehicleSim

    with VehicleSim(load_mission("missions/tank_0p6hz.yaml"), port="udpout:127.0.0.1:14550") as sim:
        ...  # a GCS listening on udpin:127.0.0.1:14550 sees a BlueROV2

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

Messages sent
-------------
* ``HEARTBEAT`` at 1 Hz, from the start: type ``MAV_TYPE_SUBMARINE``, autopilot
  ``MAV_AUTOPILOT_ARDUPILOTMEGA``, base_mode = ``MAV_MODE_FLAG_CUSTOM_MODE_ENABLED |
  MAV_MODE_FLAG_MANUAL_INPUT_ENABLED`` (| ``MAV_MODE_FLAG_SAFETY_ARMED`` when armed),
  custom_mode = the mode number (:data:`auvdock.vehicle.ardusub.MODES`; boots in MANUAL, 19),
  system_status ``MAV_STATE_STANDBY`` disarmed / ``MAV_STATE_ACTIVE`` armed.
* Nothing else is streamed until a GCS asks with ``MAV_CMD_SET_MESSAGE_INTERVAL``
  (real ArduSub streams by its ``SRn_*`` parameters; here every stream starts off).
  Streams (:data:`STREAMS`), units of the MAVLink spec:

  - ``ATTITUDE``: roll, pitch, yaw (rad, ZYX Euler angles of {b} in NED, yaw wrapped to
    [-pi, pi)); rollspeed, pitchspeed, yawspeed = body rates p, q, r (rad/s).
  - ``LOCAL_POSITION_NED``: x, y, z = the **absolute** NED position of the simulation (m; the
    mission's frame, not relative to the start position); vx, vy, vz = velocity over ground
    in NED, ``R(Theta) nu_1`` (m/s).
  - ``SCALED_PRESSURE2`` (ArduSub's external Bar30 depth sensor): press_abs =
    1013.25 + 1025 * 9.80665 * z / 100 hPa (z = depth, m), press_diff 0, temperature
    1500 cdegC (15 C water).
  - ``SCALED_IMU2`` and ``RAW_IMU`` (same values): accelerometer = body-frame specific force
    ``a_b - R^T g_n`` in mG (1 mG = 9.80665e-3 m/s^2), where ``a_b = nu_1_dot + nu_2 x nu_1``
    is the acceleration of the body origin over ground expressed in {b}, with ``nu_1_dot``
    the mean over the last physics step of the truth model's integration,
    ``(nu_1(t) - nu_1(t - 1 / rate_hz)) rate_hz`` (an IMU's averaged sample; the model's
    stepper is the only place the flow and its rate along the path enter), and
    ``g_n = [0, 0, 9.80665]`` m/s^2; level and at rest it reads (0, 0, -1000) mG.
    Gyro = p, q, r in mrad/s; magnetometer 0.
  - ``SERVO_OUTPUT_RAW``: servo1_raw..servo8_raw = motor PWM (us) =
    ``motor_pwm(mix((channels - 1500) / 400))`` when armed, 1500 when disarmed.
  - ``VFR_HUD``: heading (deg, 0..359), alt = minus the depth (m), climb = the upward
    velocity (m/s); airspeed and groundspeed the horizontal speed over ground, throttle 0.

  Sensor errors (``noise=True``, seeded by ``seed``, default the mission's seed) are those of
  the mission's sensor suite, each defined once in :mod:`auvdock.sensing.errors` (the same
  definitions ``sim`` simulates with ``estimation: filter``): attitude
  ``ahrs.roll_pitch_std_rad`` / ``ahrs.yaw_std_rad``; the IMU's white noise
  ``imu.accel_noise_m_s2`` / ``imu.gyro_noise_rad_s`` plus a constant bias per run drawn with
  ``imu.accel_bias_m_s2`` / ``imu.gyro_bias_rad_s``; depth ``depth.std_m``;
  LOCAL_POSITION_NED's position the position source's noise (``position.figures()``) and its
  velocity ``dvl.std_m_s``.  ATTITUDE's body rates are the autopilot's bias-corrected rates
  (gyro white noise only).  Default off.
* ``COMMAND_ACK`` for every command (below), ``STATUSTEXT`` "Arming motors",
  "Disarming motors" and "Lost manual control" (severity CRITICAL, on the failsafe).

Messages handled
----------------
* ``COMMAND_LONG`` and ``COMMAND_INT`` whose target_system is 1 or 0 (broadcast), from any
  system; the ``COMMAND_ACK`` carries the command, the result and the sender as target:

  - ``MAV_CMD_COMPONENT_ARM_DISARM``: param1 = 1 arms, 0 disarms -> ``MAV_RESULT_ACCEPTED``
    (also when already in that state); arming with ``refuse_arm=True`` ->
    ``MAV_RESULT_FAILED``; other param1 -> ``MAV_RESULT_DENIED``.
  - ``MAV_CMD_DO_SET_MODE``: param1 = base mode (must have
    ``MAV_MODE_FLAG_CUSTOM_MODE_ENABLED``, else ``MAV_RESULT_DENIED`` as in ArduPilot),
    param2 = custom mode -> ``MAV_RESULT_ACCEPTED``; a number not in ``MODES`` ->
    ``MAV_RESULT_DENIED`` (real ArduPilot answers FAILED).
  - ``MAV_CMD_SET_MESSAGE_INTERVAL``: param1 = message id, param2 = interval in us
    (-1 stops the stream, 0 = default interval :data:`DEFAULT_INTERVAL_US` = 4 Hz, intervals
    under 1000 us become 1 ms) -> ``MAV_RESULT_ACCEPTED``; a message id not in :data:`STREAMS`
    or another negative interval -> ``MAV_RESULT_DENIED``.  Messages go out at most once per
    physics step, so the fastest rate is ``rate_hz``.
    ``HEARTBEAT`` (1 Hz by default), ``SYS_STATUS`` (battery voltage, the pre-arm check bit
    of the sensors' health) and ``RC_CHANNELS`` (the channels in use) can be requested too.
  - arming while a pre-arm check fails (:meth:`VehicleSim.set_prearm_failure`) ->
    ``MAV_RESULT_FAILED`` and STATUSTEXT "Arm: REASON", as ArduPilot reports it.
  - any other command -> ``MAV_RESULT_UNSUPPORTED``.
* ``PARAM_REQUEST_READ`` (by name, or by index in name order) and ``PARAM_REQUEST_LIST``
  (target_system 1 or 0) -> ``PARAM_VALUE`` (REAL32) of :func:`default_parameters` as changed
  by ``params``; like ArduPilot, nothing for a name the vehicle does not have.
* ``SET_MODE`` (target_system 1 or 0): as ``MAV_CMD_DO_SET_MODE`` with base_mode and
  custom_mode; acknowledged, like ArduPilot, by a ``COMMAND_ACK`` whose command is 11 (the
  message id of SET_MODE).
* ``RC_CHANNELS_OVERRIDE`` and ``MANUAL_CONTROL``: pilot input, accepted **only** from
  system ``gcs_sysid`` (ArduSub's ``SYSID_MYGCS``, default 255) **and** with target 1; others
  are ignored and counted (:attr:`VehicleSim.ignored_control`).

  - ``RC_CHANNELS_OVERRIDE``: chan1..chan6 (pitch, roll, throttle, yaw, forward, lateral,
    :data:`auvdock.vehicle.ardusub.CHANNELS`); 0 and 65535 (release / ignore) count as
    neutral 1500 (simplification: ArduPilot keeps the previous value for 65535 and releases
    to the RC radio, i.e. trim, for 0); other values are clamped to 1100..1900 us.
    Channels 7+ are ignored.
  - ``MANUAL_CONTROL`` (ArduSub ``transform_manual_control_to_rc_override``): x forward,
    y lateral, r yaw in -1000..1000 and z throttle in 0..1000 (500 neutral) are scaled to
    [-1, 1] (x / 1000, y / 1000, r / 1000, (z - 500) / 500; INT16_MAX = axis invalid ->
    neutral), multiplied by ``joystick_gain`` (ArduSub's default gain 0.5) and become the
    channels ``trunc(1500 + 400 gain s)`` clamped to 1100..1900; pitch and roll stay 1500.
    Buttons and the s / t / aux extensions are ignored.
  - Either message replaces all six channels; the override lapses 3 s (ArduPilot's
    ``RC_OVERRIDE_TIME``) after its last message, leaving neutral channels.
* Everything else is only logged (:attr:`VehicleSim.received`); bytes that are not MAVLink
  are counted (:attr:`VehicleSim.garbage_count`) and otherwise ignored.  On UDP every
  datagram is parsed on its own (a packet never spans datagrams), so a datagram of garbage
  that looks like the start of a packet cannot swallow the packets of the next one.

Vehicle behaviour
-----------------
* Arming: by command only (no pre-arm checks).  Disarmed -> zero thrust.  Armed ->
  ``thrust_from_channels(channels)`` in **every** mode: STABILIZE, ALT_HOLD, POSHOLD, ... are
  accepted and reported but flown like MANUAL (simplification: no attitude, depth or position
  controllers).
* Pilot input failsafe (``FS_PILOT_INPUT`` = disarm, ``FS_PILOT_TIMEOUT`` = 3 s): while
  armed, 3 s without an accepted ``RC_CHANNELS_OVERRIDE`` / ``MANUAL_CONTROL`` -> neutral
  channels, disarm, "Lost manual control"; events ``failsafe`` then ``disarm``.  The 3 s are
  counted from the later of the last pilot input and the arming (real ArduSub latches the
  failsafe once per loss and so may not disarm a vehicle armed during a loss; SITL builds of
  ArduSub skip this failsafe altogether).
* Physics: :class:`auvdock.world.plant.TruthPlant` (the truth plant this simulator shares
  with :class:`auvdock.standins.sitl_physics.SitlPhysics`): ``Vehicle.stepper(1 / rate_hz,
  substeps, flow)`` (RK4, thrust held over the step) from the mission's start state, vehicle
  and flow field.  ``surface=True`` (default) adds a
  crude free surface the truth model lacks: the depth z is floored at 0 m, and the upward
  velocity (and, in the accelerometer, the upward acceleration) is removed there, so that a
  buoyant vehicle left alone floats instead of flying out of the water.  The BlueROV2 Heavy
  of the shipped parameters is 2 N buoyant: it rises at about 0.17 m/s with neutral sticks.

Test hooks
----------
:meth:`VehicleSim.pause_telemetry` stops (and resumes) every outgoing message, HEARTBEAT and
COMMAND_ACK included (a link lost downstream; incoming messages are still handled);
:attr:`VehicleSim.received` logs every received message as ``(clock.time() s, type, source
system, fields dict)``; :attr:`VehicleSim.events` lists :class:`SimEvent` (arm, disarm, mode,
failsafe); :attr:`~VehicleSim.armed`, :attr:`~VehicleSim.mode`, :attr:`~VehicleSim.state`,
:attr:`~VehicleSim.t`, :attr:`~VehicleSim.thrust`, :attr:`~VehicleSim.channels` read the
simulator's state thread-safely.
"""

from __future__ import annotations

import math
import select
import threading
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auvdock.config.mission import Mission, load_mission
from auvdock.fly.units import ATMOSPHERE_HPA, MG_M_S2, MRAD_S, WATER_DENSITY, pressure_hpa
from auvdock.runtime.clock import Clock, wall_clock
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.sensing.errors import draw_bias, sensor_errors
from auvdock.vehicle.ardusub import (
    MODES,
    NEUTRAL_CHANNELS,
    PWM_PER_UNIT,
    mix,
    motor_pwm,
    thrust_from_channels,
)
from auvdock.vehicle.geometry import wrap_angle
from auvdock.vehicle.state import ANG, ATT, LIN, POS
from auvdock.vehicle.thrusters import PWM_MAX_US, PWM_MIN_US, PWM_NEUTRAL_US
from auvdock.world.plant import TruthPlant

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

SYSTEM_ID = 1
COMPONENT_ID = 1
WATER_TEMPERATURE_CDEG = 1500  # 15 C, in cdegC
HEARTBEAT_PERIOD_S = 1.0
OVERRIDE_TIMEOUT_S = 3.0  # ArduPilot RC_OVERRIDE_TIME
PILOT_INPUT_TIMEOUT_S = 3.0  # ArduSub FS_PILOT_TIMEOUT
DEFAULT_INTERVAL_US = 250_000  # interval 0 in SET_MESSAGE_INTERVAL: 4 Hz
MAX_LAG_S = 0.25  # lag behind the clock after which simulated time slips instead of catching up

#: Streams a GCS can request with MAV_CMD_SET_MESSAGE_INTERVAL: message name -> message id.
STREAMS: dict[str, int] = {
    "ATTITUDE": M.MAVLINK_MSG_ID_ATTITUDE,
    "LOCAL_POSITION_NED": M.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
    "SCALED_PRESSURE2": M.MAVLINK_MSG_ID_SCALED_PRESSURE2,
    "SCALED_IMU2": M.MAVLINK_MSG_ID_SCALED_IMU2,
    "RAW_IMU": M.MAVLINK_MSG_ID_RAW_IMU,
    "SERVO_OUTPUT_RAW": M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW,
    "VFR_HUD": M.MAVLINK_MSG_ID_VFR_HUD,
}
#: Telemetry whose rate a GCS may set too, besides :data:`STREAMS`: the HEARTBEAT (1 Hz by
#: default, like ArduPilot's deferred HEARTBEAT), SYS_STATUS (battery, pre-arm health) and
#: RC_CHANNELS (the channels the vehicle is using, overrides included).
STREAMS.update(
    {
        "HEARTBEAT": M.MAVLINK_MSG_ID_HEARTBEAT,
        "SYS_STATUS": M.MAVLINK_MSG_ID_SYS_STATUS,
        "RC_CHANNELS": M.MAVLINK_MSG_ID_RC_CHANNELS,
    }
)
_STREAM_NAMES = {v: k for k, v in STREAMS.items()}
#: SYS_STATUS's sensor bit for "pre-arm checks pass" (MAV_SYS_STATUS_PREARM_CHECK).
PREARM_CHECK_BIT = M.MAV_SYS_STATUS_PREARM_CHECK


def default_parameters(gcs_sysid: int = 255) -> dict[str, float]:
    """The parameters a BlueROV2 Heavy's ArduSub reports, as far as ``fly`` checks them
    (:mod:`auvdock.fly.conformance`): ArduSub's defaults with FRAME_CONFIG 2 (Vectored_6DOF),
    motors 1..8 on outputs 1..8 (SERVOn_FUNCTION 33..40), every MOT_n_DIRECTION 1."""
    params: dict[str, float] = {
        "SYSID_MYGCS": float(gcs_sysid),
        "FRAME_CONFIG": 2.0,
        "RC_OVERRIDE_TIME": OVERRIDE_TIMEOUT_S,
        "FS_PILOT_INPUT": 2.0,
        "FS_PILOT_TIMEOUT": PILOT_INPUT_TIMEOUT_S,
        "FS_GCS_ENABLE": 2.0,
        "FS_GCS_TIMEOUT": 5.0,
        # the depth calibration its SCALED_PRESSURE2 follows: standard atmosphere, sea water
        "BARO1_GND_PRESS": ATMOSPHERE_HPA * 100.0,
        "BARO2_GND_PRESS": ATMOSPHERE_HPA * 100.0,
        "BARO_SPEC_GRAV": WATER_DENSITY / 1000.0,
    }
    for n in range(1, 9):
        params[f"MOT_{n}_DIRECTION"] = 1.0
        params[f"SERVO{n}_FUNCTION"] = float(32 + n)
    return params


_MODE_NAMES = {v: k for k, v in MODES.items()}
_INT16_MAX = 32767


@dataclass(frozen=True)
class SimEvent:
    """Something the vehicle did: ``kind`` is "arm", "disarm", "mode" or "failsafe".

    ``wall_time`` is the clock's ``time()`` (s since the epoch; ``time.time()`` on the wall
    clock), ``t`` the simulated time (s), ``detail`` free text
    (e.g. "gcs command", "pilot input failsafe", "MANUAL -> ALT_HOLD").
    """

    wall_time: float
    t: float
    kind: str
    detail: str


def channels_from_override(values: list[int] | np.ndarray) -> np.ndarray:
    """Channels 1..6 (us, CHANNELS order) of an RC_CHANNELS_OVERRIDE's chan1_raw..chan6_raw.

    0 and 65535 (release / ignore) give 1500; other values are clamped to 1100..1900.
    """
    v = np.asarray(values, dtype=float)[:6]
    out = np.clip(v, PWM_MIN_US, PWM_MAX_US)
    return np.where((v == 0) | (v == 65535), PWM_NEUTRAL_US, out)


def channels_from_manual_control(x: int, y: int, z: int, r: int, gain: float = 0.5) -> np.ndarray:
    """Channels 1..6 (us, CHANNELS order) of a MANUAL_CONTROL, as ArduSub's joystick code forms them.

    ``x`` forward, ``y`` lateral, ``r`` yaw in -1000..1000; ``z`` throttle in 0..1000 (500
    neutral); INT16_MAX marks an invalid axis (neutral).  Each axis becomes s in [-1, 1] and
    the channel ``trunc(1500 + 400 gain s)`` clamped to 1100..1900 us; pitch and roll are 1500.
    """

    def axis(value: int, centre: float, half: float) -> float:
        if value == _INT16_MAX:
            return 0.0
        return float(np.clip((value - centre) / half, -1.0, 1.0))

    def chan(s: float) -> float:
        return float(np.clip(math.trunc(PWM_NEUTRAL_US + PWM_PER_UNIT * gain * s), PWM_MIN_US, PWM_MAX_US))

    return np.array(
        [
            PWM_NEUTRAL_US,
            PWM_NEUTRAL_US,
            chan(axis(z, 500.0, 500.0)),
            chan(axis(r, 0.0, 1000.0)),
            chan(axis(x, 0.0, 1000.0)),
            chan(axis(y, 0.0, 1000.0)),
        ]
    )


def _i16(v: float) -> int:
    return int(np.clip(round(v), -32768, 32767))


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
        Simulated seconds per wall-clock second.
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
        self.gcs_sysid = int(gcs_sysid)
        self.joystick_gain = float(joystick_gain)
        self.refuse_arm = bool(refuse_arm)
        self._params = default_parameters(self.gcs_sysid)
        for name, value in (params or {}).items():
            if value is None:
                self._params.pop(name, None)
            else:
                self._params[name] = float(value)
        for name in ("SYSID_MYGCS", "MAV_GCS_SYSID"):
            if name in (params or {}) and params[name] is not None:
                self.gcs_sysid = int(params[name])
        self._override_timeout_s = float(self._params.get("RC_OVERRIDE_TIME", OVERRIDE_TIMEOUT_S))
        self._battery_v = float(battery_v)
        self._prearm_failure: str | None = None
        self._text_id = 0
        self.noise = bool(noise)
        self.surface = bool(surface)
        self.hold_start = bool(hold_start)
        self.clock: Clock = wall_clock if clock is None else clock

        n_sub = mission.simulation.substeps if substeps is None else int(substeps)
        # built whole: CasADi's argument type checks clear a KeyboardInterrupt raised in them
        with SigintDeferred():
            self.vehicle = mission.build_vehicle()
            self.flow = mission.build_flow()
            self._plant = TruthPlant(
                self.vehicle,
                self.flow,
                mission.start_state(),
                substeps=n_sub,
                surface=self.surface,
                dt=self.dt,
            )
        self._rng = np.random.default_rng(mission.seed if seed is None else seed)
        # each sensor's errors, defined once (auvdock.sensing.errors); the constant biases of this
        # run are drawn whether or not noise is on (same seed, same stream)
        self._errors = sensor_errors(mission.sensors)
        self._bias = {kind: draw_bias(err, self._rng) for kind, err in self._errors.items()}

        self._lock = threading.RLock()
        self._stop_event = self.clock.event()
        self._thread: threading.Thread | None = None
        self._conn: Any = None
        self._started = False
        self._error: BaseException | None = None
        self._parser = self._new_parser()  # incoming UDP datagrams

        self._k = 0  # physics steps done; t = k dt
        self._target_dock: Any | None = None
        self._target_period = 0.1
        self._next_target = 0.0
        self._armed = False
        self._armed_at = 0.0
        self._mode = MODES["MANUAL"]
        self._override = NEUTRAL_CHANNELS.astype(float).copy()
        self._last_override_t = -math.inf
        self._last_pilot_input_t = -math.inf
        self._thrust = np.zeros(8)
        self._intervals: dict[int, float] = {}
        self._next_due: dict[int, float] = {}
        self._next_heartbeat = 0.0
        self._heartbeat_period = HEARTBEAT_PERIOD_S
        self._paused = False
        self._received: deque[tuple[float, str, int, dict[str, Any]]] = deque(maxlen=received_maxlen)
        self._events: list[SimEvent] = []
        self._ignored = 0
        self._garbage = 0

    # --- public state ----------------------------------------------------------------------
    @property
    def armed(self) -> bool:
        """Whether the motors are armed."""
        with self._lock:
            return self._armed

    @property
    def mode(self) -> int:
        """Current mode number (ArduSub custom_mode, :data:`~auvdock.vehicle.ardusub.MODES`)."""
        with self._lock:
            return self._mode

    @property
    def mode_name(self) -> str:
        """Current mode name, e.g. "MANUAL"."""
        with self._lock:
            return _MODE_NAMES[self._mode]

    @property
    def state(self) -> np.ndarray:
        """Truth state (12,): [x y z NED m, phi theta psi rad, u v w body m/s over ground, p q r rad/s]."""
        with self._lock:
            return self._plant.state

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
            return self._channels_now().copy()

    @property
    def received(self) -> list[tuple[float, str, int, dict[str, Any]]]:
        """Every received message: (``clock.time()`` s, type, source system, fields)."""
        with self._lock:
            return list(self._received)

    @property
    def events(self) -> list[SimEvent]:
        """Arm, disarm, mode and failsafe events, oldest first."""
        with self._lock:
            return list(self._events)

    @property
    def ignored_control(self) -> int:
        """RC_CHANNELS_OVERRIDE / MANUAL_CONTROL messages ignored (wrong sender or target)."""
        with self._lock:
            return self._ignored

    @property
    def garbage_count(self) -> int:
        """Received chunks that were not valid MAVLink."""
        with self._lock:
            return self._garbage

    @property
    def stream_intervals(self) -> dict[str, float]:
        """Active streams: message name -> interval (s, simulated time)."""
        with self._lock:
            return {_STREAM_NAMES[k]: v for k, v in self._intervals.items()}

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
            return dict(self._params)

    def set_battery(self, volts: float) -> None:
        """The battery voltage SYS_STATUS reports from now on, V."""
        with self._lock:
            self._battery_v = float(volts)

    def set_prearm_failure(self, reason: str | None) -> None:
        """A failing pre-arm check (None: all pass): arming is refused with MAV_RESULT_FAILED and
        STATUSTEXT "Arm: REASON", and SYS_STATUS shows the pre-arm check unhealthy."""
        with self._lock:
            self._prearm_failure = reason

    def pause_telemetry(self, paused: bool = True) -> None:
        """Stop (True) or resume (False) every outgoing message, HEARTBEAT included."""
        with self._lock:
            self._paused = bool(paused)

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
        with self._lock:
            self._send_telemetry()  # the first HEARTBEAT, at t = 0 (binds a udpout socket)
        self._thread = self.clock.start_thread(self._run, name="VehicleSim")
        return self

    def stop(self) -> None:
        """Stop the simulator thread, wait for it and close the connection (idempotent)."""
        self._stop_event.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self.clock.join(self._thread, timeout=5.0)
        if self._conn is not None:
            try:
                self._conn.close()
            except OSError:
                pass
            self._conn = None

    def run_forever(self) -> None:
        """Run (starting if needed) until Ctrl-C, then stop and return; prints nothing.

        Re-raises an error that stopped the simulator thread.
        """
        if not self._started:
            self.start()
        try:
            while self._thread is not None and self._thread.is_alive():
                self.clock.join(self._thread, 0.2)
        except KeyboardInterrupt:
            pass
        finally:
            self.stop()
        if self._error is not None:
            raise self._error

    def __enter__(self) -> VehicleSim:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # --- model pieces ------------------------------------------------------------------------
    @property
    def _x(self) -> np.ndarray:
        """The truth state (12,), the plant's own array (read it under the lock, do not change it)."""
        return self._plant.x

    _rotation = staticmethod(TruthPlant.rotation)

    def _channels_now(self) -> np.ndarray:
        t = self._k * self.dt
        lapse = self._override_timeout_s
        if self._params.get("RC_OVERRIDE_TIME", 1.0) == 0.0:  # overrides disabled
            return NEUTRAL_CHANNELS.astype(float)
        if lapse < 0 or t - self._last_override_t < lapse:
            return self._override
        return NEUTRAL_CHANNELS.astype(float)

    def _update_thrust(self) -> None:
        curve = self.vehicle.thruster_curve
        self._thrust = thrust_from_channels(self._channels_now(), curve) if self._armed else np.zeros(8)

    # --- main loop ---------------------------------------------------------------------------
    def _run(self) -> None:
        clock = self.clock
        try:
            next_t = clock.now()
            period = self.dt / self.speed
            while not self._stop_event.is_set():
                self._receive_all()
                with self._lock:
                    self._physics_step()
                    self._send_telemetry()
                next_t += period
                self._wait_until(next_t)
                if clock.now() - next_t > MAX_LAG_S:
                    next_t = clock.now()
        except BaseException as e:  # keep it for run_forever; the thread must not die silently
            self._error = e
            self._stop_event.set()

    def _wait_until(self, when: float) -> None:
        """Wait until ``when`` (the clock's time, s), handling messages as they arrive."""
        clock = self.clock
        conn = self._conn
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
    def _new_parser() -> Any:
        parser = M.MAVLink(None, srcSystem=SYSTEM_ID, srcComponent=COMPONENT_ID)
        parser.robust_parsing = True
        return parser

    def _physics_step(self) -> None:
        t = self._k * self.dt
        self._check_failsafe(t)
        self._update_thrust()
        if self.hold_start and not self._armed:  # held at the start, at rest, while disarmed
            self._plant.place(self.mission.start_state())
        else:
            self._plant.step(self._thrust, t)
        self._k += 1

    def _check_failsafe(self, t: float) -> None:
        if not self._armed:
            return
        since = max(self._last_pilot_input_t, self._armed_at)
        if t - since >= PILOT_INPUT_TIMEOUT_S:
            self._event("failsafe", "pilot input: no RC_CHANNELS_OVERRIDE / MANUAL_CONTROL for 3 s")
            self._statustext(M.MAV_SEVERITY_CRITICAL, "Lost manual control")
            self._override = NEUTRAL_CHANNELS.astype(float).copy()
            self._last_override_t = -math.inf
            self._set_armed(False, "pilot input failsafe")

    # --- incoming ----------------------------------------------------------------------------
    def _handle(self, msg: Any) -> None:
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            self._garbage += 1
            return
        try:
            fields = msg.to_dict()
        except Exception:  # a message pymavlink cannot render
            fields = {}
        src = msg.get_srcSystem()
        self._received.append((self.clock.time(), mtype, src, fields))
        handler: Callable[[Any], None] | None = {
            "COMMAND_LONG": self._on_command,
            "COMMAND_INT": self._on_command,
            "SET_MODE": self._on_set_mode,
            "RC_CHANNELS_OVERRIDE": self._on_rc_override,
            "MANUAL_CONTROL": self._on_manual_control,
            "PARAM_REQUEST_READ": self._on_param_request_read,
            "PARAM_REQUEST_LIST": self._on_param_request_list,
        }.get(mtype)
        if handler is not None:
            try:
                handler(msg)
            except (ValueError, TypeError, OverflowError, AttributeError):  # malformed but CRC-valid
                self._garbage += 1

    def _on_command(self, msg: Any) -> None:
        if msg.target_system not in (0, SYSTEM_ID):
            return
        cmd = int(msg.command)
        if cmd == M.MAV_CMD_COMPONENT_ARM_DISARM:
            result = self._cmd_arm(float(msg.param1))
        elif cmd == M.MAV_CMD_DO_SET_MODE:
            if math.isfinite(msg.param1) and math.isfinite(msg.param2):
                result = self._set_mode(int(msg.param1), int(msg.param2))
            else:
                result = M.MAV_RESULT_DENIED
        elif cmd == M.MAV_CMD_SET_MESSAGE_INTERVAL:
            result = self._set_interval(msg.param1, msg.param2)
        else:
            result = M.MAV_RESULT_UNSUPPORTED
        self._ack(cmd, result, msg)

    def _on_param_request_read(self, msg: Any) -> None:
        if msg.target_system not in (0, SYSTEM_ID):
            return
        names = sorted(self._params)
        index = int(msg.param_index)
        if index >= 0:
            if index < len(names):
                self._send_param(names[index])
            return
        name = msg.param_id.decode() if isinstance(msg.param_id, bytes) else str(msg.param_id)
        name = name.rstrip("\x00")
        if name in self._params:  # like ArduPilot: no answer for an unknown name
            self._send_param(name)

    def _on_param_request_list(self, msg: Any) -> None:
        if msg.target_system not in (0, SYSTEM_ID):
            return
        for name in sorted(self._params):
            self._send_param(name)

    def _send_param(self, name: str) -> None:
        names = sorted(self._params)
        self._send(
            self._conn.mav.param_value_send,
            name.encode(),
            float(self._params[name]),
            M.MAV_PARAM_TYPE_REAL32,
            len(names),
            names.index(name),
        )

    def _on_set_mode(self, msg: Any) -> None:
        if msg.target_system not in (0, SYSTEM_ID):
            return
        result = self._set_mode(int(msg.base_mode), int(msg.custom_mode))
        self._ack(M.MAVLINK_MSG_ID_SET_MODE, result, msg)

    def _pilot_input_allowed(self, msg: Any, target: int) -> bool:
        if msg.get_srcSystem() != self.gcs_sysid or target != SYSTEM_ID:
            self._ignored += 1
            return False
        return True

    def _on_rc_override(self, msg: Any) -> None:
        if not self._pilot_input_allowed(msg, int(msg.target_system)):
            return
        raw = [int(getattr(msg, f"chan{i}_raw")) for i in range(1, 7)]
        self._set_override(channels_from_override(raw))

    def _on_manual_control(self, msg: Any) -> None:
        if not self._pilot_input_allowed(msg, int(msg.target)):
            return
        ch = channels_from_manual_control(int(msg.x), int(msg.y), int(msg.z), int(msg.r), self.joystick_gain)
        self._set_override(ch)

    def _set_override(self, channels: np.ndarray) -> None:
        t = self._k * self.dt
        self._override = np.asarray(channels, dtype=float)
        self._last_override_t = t
        self._last_pilot_input_t = t
        self._update_thrust()

    def _cmd_arm(self, param1: float) -> int:
        if param1 == 1.0:
            if self.refuse_arm:
                return M.MAV_RESULT_FAILED
            if self._prearm_failure is not None and not self._armed:
                self._statustext(M.MAV_SEVERITY_CRITICAL, f"Arm: {self._prearm_failure}")
                return M.MAV_RESULT_FAILED
            self._set_armed(True, "gcs command")
            return M.MAV_RESULT_ACCEPTED
        if param1 == 0.0:
            self._set_armed(False, "gcs command")
            return M.MAV_RESULT_ACCEPTED
        return M.MAV_RESULT_DENIED

    def _set_armed(self, armed: bool, reason: str) -> None:
        if armed == self._armed:
            return
        self._armed = armed
        if armed:
            self._armed_at = self._k * self.dt
        self._event("arm" if armed else "disarm", reason)
        self._statustext(M.MAV_SEVERITY_INFO, "Arming motors" if armed else "Disarming motors")
        self._update_thrust()

    def _set_mode(self, base_mode: int, custom_mode: int) -> int:
        if not base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED or custom_mode not in _MODE_NAMES:
            return M.MAV_RESULT_DENIED
        if custom_mode != self._mode:
            self._event("mode", f"{_MODE_NAMES[self._mode]} -> {_MODE_NAMES[custom_mode]}")
            self._mode = custom_mode
        return M.MAV_RESULT_ACCEPTED

    def _set_interval(self, param1: float, param2: float) -> int:
        if not (math.isfinite(param1) and math.isfinite(param2)):
            return M.MAV_RESULT_DENIED
        msg_id = int(param1)
        interval_us = int(param2)
        if msg_id not in _STREAM_NAMES:
            return M.MAV_RESULT_DENIED
        if interval_us == -1:
            self._intervals.pop(msg_id, None)
            self._next_due.pop(msg_id, None)
            return M.MAV_RESULT_ACCEPTED
        if interval_us < -1:
            return M.MAV_RESULT_DENIED
        if interval_us == 0:
            interval_us = DEFAULT_INTERVAL_US
        if msg_id == M.MAVLINK_MSG_ID_HEARTBEAT:  # ArduPilot's deferred HEARTBEAT: its period
            self._heartbeat_period = max(interval_us, 1000) / 1e6
            self._next_heartbeat = self._k * self.dt
            return M.MAV_RESULT_ACCEPTED
        self._intervals[msg_id] = max(interval_us, 1000) / 1e6
        self._next_due[msg_id] = self._k * self.dt
        return M.MAV_RESULT_ACCEPTED

    def _event(self, kind: str, detail: str) -> None:
        self._events.append(SimEvent(self.clock.time(), self._k * self.dt, kind, detail))

    # --- outgoing ----------------------------------------------------------------------------
    def _send(self, fn: Callable[..., None], *args: Any, **kwargs: Any) -> None:
        if self._paused or self._conn is None:
            return
        try:
            fn(*args, **kwargs)
        except (OSError, ValueError, OverflowError):
            pass

    def _ack(self, command: int, result: int, msg: Any) -> None:
        mav = self._conn.mav
        self._send(
            mav.command_ack_send,
            command,
            result,
            target_system=msg.get_srcSystem(),
            target_component=msg.get_srcComponent(),
        )

    def _statustext(self, severity: int, text: str) -> None:
        """STATUSTEXT as ArduPilot sends a long one: 50-byte chunks sharing an id, numbered by
        chunk_seq (a text of at most 50 bytes goes whole, with id 0)."""
        data = text.encode()
        if len(data) <= 50:
            self._send(self._conn.mav.statustext_send, severity, data, 0, 0)
            return
        self._text_id = self._text_id % 65535 + 1
        for seq, i in enumerate(range(0, len(data), 50)):
            self._send(self._conn.mav.statustext_send, severity, data[i : i + 50], self._text_id, seq)

    def _send_telemetry(self) -> None:
        t = self._k * self.dt
        eps = 1e-9
        if t + eps >= self._next_heartbeat:
            self._send_heartbeat()
            self._next_heartbeat += self._heartbeat_period
            if self._next_heartbeat <= t:
                self._next_heartbeat = t + self._heartbeat_period
        if self._target_dock is not None and t + eps >= self._next_target:
            self._send_landing_target(t)
            self._next_target = max(self._next_target + self._target_period, t)
        due = [m for m, when in self._next_due.items() if t + eps >= when]
        if not due:
            return
        imu: tuple[np.ndarray, np.ndarray] | None = None
        for msg_id in due:
            name = _STREAM_NAMES[msg_id]
            if name in ("SCALED_IMU2", "RAW_IMU"):
                if imu is None:
                    imu = self._imu()
                self._send_imu(name, *imu)
            else:
                getattr(self, f"_send_{name.lower()}")()
            interval = self._intervals[msg_id]
            nxt = self._next_due[msg_id] + interval
            self._next_due[msg_id] = nxt if nxt > t else t + interval

    def set_landing_target(self, dock: Any | None, rate_hz: float = 10.0) -> None:
        """Act as a positioning system on the vehicle: send LANDING_TARGET for ``dock``.

        ``dock`` is anything with ``position(t)`` (NED m at simulated time t, e.g. a
        :class:`auvdock.world.dock.HeaveDock`), or None to stop.  Sent at ``rate_hz`` in
        MAV_FRAME_BODY_FRD (the dock's position relative to the vehicle in body axes, m)
        with ``position_valid = 1``, from this vehicle's system id.
        """
        with self._lock:
            self._target_dock = dock
            self._target_period = 1.0 / float(rate_hz)
            self._next_target = self._k * self.dt

    def _send_landing_target(self, t: float) -> None:
        x = self._x
        p = np.asarray(self._target_dock.position(t), dtype=float)
        R = self._rotation(x)  # {b} -> {n}
        rel = R.T @ (p - x[POS])
        self._send(
            self._conn.mav.landing_target_send,
            int(t * 1e6),
            0,
            M.MAV_FRAME_BODY_FRD,
            0.0,
            0.0,
            float(np.linalg.norm(rel)),
            0.0,
            0.0,
            float(rel[0]),
            float(rel[1]),
            float(rel[2]),
            [1.0, 0.0, 0.0, 0.0],
            M.LANDING_TARGET_TYPE_VISION_FIDUCIAL,
            1,
        )

    def _noise(self, kind: str) -> np.ndarray:
        """One draw of sensor ``kind``'s white noise (zeros with noise off)."""
        std = self._errors[kind].noise_std
        if not self.noise or not np.any(std > 0):
            return np.zeros(std.shape)
        return self._rng.normal(0.0, std, std.shape)

    def _time_boot_ms(self) -> int:
        return int(round(self._k * self.dt * 1000.0)) % (1 << 32)

    def _send_heartbeat(self) -> None:
        base = M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | M.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        if self._armed:
            base |= M.MAV_MODE_FLAG_SAFETY_ARMED
        status = M.MAV_STATE_ACTIVE if self._armed else M.MAV_STATE_STANDBY
        self._send(
            self._conn.mav.heartbeat_send,
            M.MAV_TYPE_SUBMARINE,
            M.MAV_AUTOPILOT_ARDUPILOTMEGA,
            base,
            self._mode,
            status,
        )

    def _send_sys_status(self) -> None:
        sensors = PREARM_CHECK_BIT
        health = 0 if self._prearm_failure is not None else PREARM_CHECK_BIT
        self._send(
            self._conn.mav.sys_status_send,
            sensors,
            sensors,
            health,
            0,
            int(round(self._battery_v * 1000.0)),
            -1,
            -1,
            0,
            0,
            0,
            0,
            0,
            0,
        )

    def _send_rc_channels(self) -> None:
        ch = [int(round(v)) for v in self._channels_now()] + [int(PWM_NEUTRAL_US)] * 12
        self._send(self._conn.mav.rc_channels_send, self._time_boot_ms(), 18, *ch, 255)

    def _send_attitude(self) -> None:
        x = self._x
        att = x[ATT] + self._noise("attitude")
        w = x[ANG] + self._noise("gyro")  # the autopilot's bias-corrected rates
        self._send(
            self._conn.mav.attitude_send,
            self._time_boot_ms(),
            wrap_angle(float(att[0])),
            wrap_angle(float(att[1])),
            wrap_angle(float(att[2])),
            float(w[0]),
            float(w[1]),
            float(w[2]),
        )

    def _send_local_position_ned(self) -> None:
        x = self._x
        p = x[POS] + self._noise("position")
        v = self._rotation(x) @ x[LIN] + self._noise("dvl")
        self._send(self._conn.mav.local_position_ned_send, self._time_boot_ms(), *map(float, (*p, *v)))

    def _send_scaled_pressure2(self) -> None:
        depth = float(self._x[2]) + float(self._noise("depth")[0])
        self._send(
            self._conn.mav.scaled_pressure2_send,
            self._time_boot_ms(),
            pressure_hpa(depth),
            0.0,
            WATER_TEMPERATURE_CDEG,
        )

    def _send_vfr_hud(self) -> None:
        x = self._x
        v_ned = self._rotation(x) @ x[LIN]
        depth = float(x[2]) + float(self._noise("depth")[0])
        speed = float(np.hypot(v_ned[0], v_ned[1]))
        heading = int(math.degrees(float(x[5])) % 360.0)
        self._send(self._conn.mav.vfr_hud_send, speed, speed, heading, 0, -depth, float(-v_ned[2]))

    def _imu(self) -> tuple[np.ndarray, np.ndarray]:
        """(specific force in {b} m/s^2, body rates rad/s): the last physics step's mean acceleration."""
        f_b, w = self._plant.imu()
        if self.noise:
            f_b = f_b + self._bias["accel"] + self._noise("accel")
            w = w + self._bias["gyro"] + self._noise("gyro")
        return f_b, w

    def _send_imu(self, name: str, f_b: np.ndarray, w: np.ndarray) -> None:
        acc = [_i16(v / MG_M_S2) for v in f_b]
        gyro = [_i16(v / MRAD_S) for v in w]
        if name == "SCALED_IMU2":
            self._send(
                self._conn.mav.scaled_imu2_send,
                self._time_boot_ms(),
                *acc,
                *gyro,
                0,
                0,
                0,
                temperature=WATER_TEMPERATURE_CDEG,
            )
        else:
            time_usec = int(round(self._k * self.dt * 1e6))
            self._send(
                self._conn.mav.raw_imu_send,
                time_usec,
                *acc,
                *gyro,
                0,
                0,
                0,
                temperature=WATER_TEMPERATURE_CDEG,
            )

    def _servo_pwm(self) -> np.ndarray:
        if not self._armed:
            return np.full(8, PWM_NEUTRAL_US)
        return motor_pwm(mix((self._channels_now() - PWM_NEUTRAL_US) / PWM_PER_UNIT))

    def _send_servo_output_raw(self) -> None:
        pwm = [int(round(v)) for v in self._servo_pwm()]
        time_usec = int(round(self._k * self.dt * 1e6)) % (1 << 32)
        self._send(self._conn.mav.servo_output_raw_send, time_usec, 0, *pwm)
