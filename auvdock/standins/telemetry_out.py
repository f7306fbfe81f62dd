"""What the simulated ArduSub vehicle sends: its telemetry's encoders, rates and sensor errors.

The encoders (:func:`heartbeat`, :func:`attitude`, ...) are pure: the vehicle's state in,
one MAVLink message out, that :class:`Outbox` sends on the vehicle's connection.
:class:`StreamSchedule` keeps the rates a GCS set (``MAV_CMD_SET_MESSAGE_INTERVAL``) and says
which messages are due; :class:`SensorNoise` adds the mission's sensor errors.
:class:`auvdock.standins.vehicle_sim.VehicleSim` puts them together.

State and times
---------------
``x`` is the truth state (12,) of :class:`auvdock.world.plant.TruthPlant`:
``[x y z NED m, phi theta psi rad, u v w body m/s over ground, p q r rad/s]``.  ``t`` is
simulated time (s, 0 at the start); ``time_boot_ms`` / ``time_usec`` fields are ``t`` in
ms / us (:func:`time_boot_ms`, :func:`time_usec`).

Messages
--------
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
    ``g_n = [0, 0, 9.80665]`` m/s^2; level and at rest it reads (0, 0, -1000) mG
    (:meth:`auvdock.world.plant.TruthPlant.imu`).  Gyro = p, q, r in mrad/s; magnetometer 0;
    temperature 1500 cdegC.
  - ``SERVO_OUTPUT_RAW``: servo1_raw..servo8_raw = motor PWM (us) =
    ``motor_pwm(mix((channels - 1500) / 400))`` when armed, 1500 when disarmed.
  - ``VFR_HUD``: heading (deg, 0..359), alt = minus the depth (m), climb = the upward
    velocity (m/s); airspeed and groundspeed the horizontal speed over ground, throttle 0.
  - ``HEARTBEAT`` (1 Hz by default), ``SYS_STATUS`` (voltage_battery in mV, the
    ``MAV_SYS_STATUS_PREARM_CHECK`` bit present, enabled and healthy while every pre-arm
    check passes; current and remaining -1, unknown) and ``RC_CHANNELS`` (the six channels in
    use, overrides included, in us; channels 7..18 1500, chancount 18, rssi 255) can be
    requested too.

  ``MAV_CMD_SET_MESSAGE_INTERVAL`` (:meth:`StreamSchedule.set_interval`): param1 = message
  id, param2 = interval in us (-1 stops the stream, 0 = default interval
  :data:`DEFAULT_INTERVAL_US` = 4 Hz, intervals under 1000 us become 1 ms) ->
  ``MAV_RESULT_ACCEPTED``; a message id not in :data:`STREAMS` or another negative interval
  -> ``MAV_RESULT_DENIED``.  Messages go out at most once per physics step, so the fastest
  rate is the physics rate.
* ``SIM_STATE`` (:func:`sim_state`), a stream like the others (ArduPilot's SITL sends it too): the
  simulator's **true** pose and velocity, for a rehearsal's synthetic camera
  (:mod:`auvdock.fly.camera_sensor`) -- roll, pitch, yaw (rad) and q1..q4 (w, x, y, z) of {b} in NED;
  lat, lon (deg) and alt (m) of the true position with the mission's frame placed at latitude 0,
  longitude 0 on a sphere (``lat = north / R``, ``lon = east /
  R``, ``alt = -down``: :func:`auvdock.fly.units.sim_latlon`); lat_int, lon_int the same in degE7; vn, ve,
  vd the velocity over ground (m/s); the body rates (rad/s) and the IMU's specific force (m/s^2) of
  the last step, no errors.  A real vehicle sends no SIM_STATE.
* ``LANDING_TARGET`` (:func:`landing_target`), when the vehicle acts as a positioning system:
  the dock's position relative to the vehicle in body axes (x, y, z in m, frame
  ``MAV_FRAME_BODY_FRD``), distance its norm (m), angles and sizes 0, q identity, type
  ``LANDING_TARGET_TYPE_VISION_FIDUCIAL``, position_valid 1.
* ``STATUSTEXT`` (:meth:`Outbox.statustext`): as ArduPilot sends a long text, 50-byte chunks
  sharing an id and numbered by chunk_seq (a text of at most 50 bytes goes whole, id 0).

Sensor errors
-------------
With noise on (:class:`SensorNoise`, seeded by the simulator's ``seed``), the telemetry
carries the errors of the mission's sensor suite, each defined once in
:mod:`auvdock.sensing.errors` (the same definitions ``sim`` simulates with ``estimation:
filter``): attitude ``ahrs.roll_pitch_std_rad`` / ``ahrs.yaw_std_rad``; the IMU's white noise
``imu.accel_noise_m_s2`` / ``imu.gyro_noise_rad_s`` plus a constant bias per run drawn with
``imu.accel_bias_m_s2`` / ``imu.gyro_bias_rad_s``; depth ``depth.std_m`` (SCALED_PRESSURE2,
VFR_HUD); LOCAL_POSITION_NED's position the position source's noise
(``position.figures()``) and its velocity ``dvl.std_m_s``.  ATTITUDE's body rates are the
autopilot's bias-corrected rates (gyro white noise only).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Protocol

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from auvdock.fly.units import MG_M_S2, MRAD_S, pressure_hpa, sim_latlon
from auvdock.sensing.errors import SensorErrors, draw_bias
from auvdock.vehicle.ardusub import PWM_PER_UNIT, mix, motor_pwm
from auvdock.vehicle.geometry import wrap_angle
from auvdock.vehicle.state import ANG, ATT, LIN, POS
from auvdock.vehicle.thrusters import PWM_NEUTRAL_US
from auvdock.world.plant import TruthPlant

if TYPE_CHECKING:
    from pymavlink import mavutil

__all__ = [
    "STREAMS",
    "STREAM_NAMES",
    "DEFAULT_INTERVAL_US",
    "HEARTBEAT_PERIOD_S",
    "PREARM_CHECK_BIT",
    "IMU_STREAMS",
    "Outbox",
    "StreamSchedule",
    "SensorNoise",
    "PositionSource",
    "time_boot_ms",
    "time_usec",
    "heartbeat",
    "sys_status",
    "rc_channels",
    "attitude",
    "local_position_ned",
    "scaled_pressure2",
    "vfr_hud",
    "imu",
    "servo_output_raw",
    "landing_target",
    "sim_state",
]

M = mavlink2

WATER_TEMPERATURE_CDEG = 1500  # 15 C, in cdegC
HEARTBEAT_PERIOD_S = 1.0
HEARTBEAT_MAVLINK_VERSION = 3  # the HEARTBEAT's mavlink_version field, as pymavlink sends it
DEFAULT_INTERVAL_US = 250_000  # interval 0 in SET_MESSAGE_INTERVAL: 4 Hz

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
        "SIM_STATE": M.MAVLINK_MSG_ID_SIM_STATE,
    }
)

#: Message id -> name of :data:`STREAMS`.
STREAM_NAMES: dict[int, str] = {v: k for k, v in STREAMS.items()}
#: SYS_STATUS's sensor bit for "pre-arm checks pass" (MAV_SYS_STATUS_PREARM_CHECK).
PREARM_CHECK_BIT = M.MAV_SYS_STATUS_PREARM_CHECK
#: The streams that carry the IMU's reading (one reading per physics step serves both).
IMU_STREAMS = ("SCALED_IMU2", "RAW_IMU")


# --- sending -----------------------------------------------------------------------------------
class Outbox:
    """The sending end of the vehicle's connection: every message it sends goes through here.

    ``conn`` is the pymavlink connection (None: nothing is sent); :attr:`paused` stops every
    message (a link lost downstream).  Errors of the socket and of packing are dropped.
    """

    def __init__(self) -> None:
        #: The pymavlink connection once opened, else None.
        self.conn: mavutil.mavfile | None = None
        self.paused = False
        self._text_id = 0

    def send(self, msg: mavlink2.MAVLink_message) -> None:
        """Send ``msg`` (nothing while paused or without a connection)."""
        if self.paused or self.conn is None:
            return
        try:
            self.conn.mav.send(msg)
        except (OSError, ValueError, OverflowError):
            pass

    def send_all(self, msgs: Iterable[mavlink2.MAVLink_message]) -> None:
        """Send each of ``msgs``, in order."""
        for msg in msgs:
            self.send(msg)

    def statustext(self, severity: int, text: str) -> None:
        """STATUSTEXT as ArduPilot sends a long one: 50-byte chunks sharing an id, numbered by
        chunk_seq (a text of at most 50 bytes goes whole, with id 0)."""
        data = text.encode()
        if len(data) <= 50:
            self.send(M.MAVLink_statustext_message(severity, data, 0, 0))
            return
        self._text_id = self._text_id % 65535 + 1
        for seq, i in enumerate(range(0, len(data), 50)):
            self.send(M.MAVLink_statustext_message(severity, data[i : i + 50], self._text_id, seq))


class StreamSchedule:
    """Which telemetry is due when: the HEARTBEAT's period, the streams a GCS set with
    MAV_CMD_SET_MESSAGE_INTERVAL and the LANDING_TARGET's rate (simulated s throughout)."""

    #: The name :meth:`due` gives the LANDING_TARGET (not a stream a GCS can set).
    LANDING_TARGET = "LANDING_TARGET"

    def __init__(self) -> None:
        self._intervals: dict[int, float] = {}  # message id -> interval, s
        self._next_due: dict[int, float] = {}  # message id -> next time, s (in request order)
        self._heartbeat_period = HEARTBEAT_PERIOD_S
        self._next_heartbeat = 0.0
        self._target_period: float | None = None  # None: no LANDING_TARGET
        self._next_target = 0.0

    @property
    def intervals(self) -> dict[str, float]:
        """Active streams: message name -> interval (s)."""
        return {STREAM_NAMES[k]: v for k, v in self._intervals.items()}

    def set_interval(self, param1: float, param2: float, t: float) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL at ``t`` (s): param1 the message id, param2 the interval (us);
        the MAV_RESULT (see the module docstring).  A stream set starts at once."""
        if not (math.isfinite(param1) and math.isfinite(param2)):
            return M.MAV_RESULT_DENIED
        msg_id = int(param1)
        interval_us = int(param2)
        if msg_id not in STREAM_NAMES:
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
            self._next_heartbeat = t
            return M.MAV_RESULT_ACCEPTED
        self._intervals[msg_id] = max(interval_us, 1000) / 1e6
        self._next_due[msg_id] = t
        return M.MAV_RESULT_ACCEPTED

    def set_landing_target_period(self, period_s: float | None, t: float) -> None:
        """Send LANDING_TARGET every ``period_s`` (s) from ``t`` (s) on; None: stop."""
        self._target_period = period_s
        self._next_target = t

    def due(self, t: float) -> list[str]:
        """The messages due at ``t`` (s), in sending order (HEARTBEAT, LANDING_TARGET, then the
        streams in the order they were requested); each one's next time moves on."""
        eps = 1e-9
        out: list[str] = []
        if t + eps >= self._next_heartbeat:
            out.append("HEARTBEAT")
            self._next_heartbeat += self._heartbeat_period
            if self._next_heartbeat <= t:
                self._next_heartbeat = t + self._heartbeat_period
        if self._target_period is not None and t + eps >= self._next_target:
            out.append(self.LANDING_TARGET)
            self._next_target = max(self._next_target + self._target_period, t)
        for msg_id in [m for m, when in self._next_due.items() if t + eps >= when]:
            out.append(STREAM_NAMES[msg_id])
            interval = self._intervals[msg_id]
            nxt = self._next_due[msg_id] + interval
            self._next_due[msg_id] = nxt if nxt > t else t + interval
        return out


class SensorNoise:
    """The mission's sensor errors on the telemetry: white noise per message, a bias per run.

    ``errors`` are :func:`auvdock.sensing.errors.sensor_errors` of the mission's sensors; the
    constant biases of the run are drawn from ``rng`` here (in ``errors`` order), whether or
    not ``enabled`` (same seed, same stream).  With ``enabled`` False every draw is zero.
    """

    def __init__(self, errors: dict[str, SensorErrors], rng: np.random.Generator, enabled: bool) -> None:
        self.errors = errors
        self.enabled = bool(enabled)
        self._rng = rng
        self.bias = {kind: draw_bias(err, rng) for kind, err in errors.items()}

    def white(self, kind: str) -> np.ndarray:
        """One draw of sensor ``kind``'s white noise (zeros with noise off)."""
        std = self.errors[kind].noise_std
        if not self.enabled or not np.any(std > 0):
            return np.zeros(std.shape)
        return self._rng.normal(0.0, std, std.shape)

    def imu(self, f_b: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """An ideal IMU's (specific force m/s^2, body rates rad/s) with the IMU's bias and noise."""
        if self.enabled:
            f_b = f_b + self.bias["accel"] + self.white("accel")
            w = w + self.bias["gyro"] + self.white("gyro")
        return f_b, w


class PositionSource(Protocol):
    """What a LANDING_TARGET is sent for: anything with a position in time, e.g.
    :class:`auvdock.world.dock.HeaveDock`."""

    def position(self, t: float) -> np.ndarray:
        """Position (3,) NED, m, at simulated time ``t`` (s)."""
        ...


# --- encoders ----------------------------------------------------------------------------------
def time_boot_ms(t: float) -> int:
    """A ``time_boot_ms`` field (uint32, ms) of simulated time ``t`` (s)."""
    return int(round(t * 1000.0)) % (1 << 32)


def time_usec(t: float) -> int:
    """A ``time_usec`` field (uint64, us) of simulated time ``t`` (s)."""
    return int(round(t * 1e6))


def _i16(v: float) -> int:
    return int(np.clip(round(v), -32768, 32767))


def heartbeat(armed: bool, mode: int) -> mavlink2.MAVLink_message:
    """HEARTBEAT of a submarine in ArduSub mode ``mode`` (custom_mode), armed or not."""
    base = M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | M.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
    if armed:
        base |= M.MAV_MODE_FLAG_SAFETY_ARMED
    status = M.MAV_STATE_ACTIVE if armed else M.MAV_STATE_STANDBY
    return M.MAVLink_heartbeat_message(
        M.MAV_TYPE_SUBMARINE, M.MAV_AUTOPILOT_ARDUPILOTMEGA, base, mode, status, HEARTBEAT_MAVLINK_VERSION
    )


def sys_status(battery_v: float, prearm_ok: bool) -> mavlink2.MAVLink_message:
    """SYS_STATUS: the battery at ``battery_v`` (V, sent in mV), the pre-arm check healthy or not."""
    sensors = PREARM_CHECK_BIT
    health = PREARM_CHECK_BIT if prearm_ok else 0
    return M.MAVLink_sys_status_message(
        sensors, sensors, health, 0, int(round(battery_v * 1000.0)), -1, -1, 0, 0, 0, 0, 0, 0
    )


def rc_channels(t: float, channels: np.ndarray) -> mavlink2.MAVLink_message:
    """RC_CHANNELS at ``t`` (s): channels 1..6 (us) in use, 7..18 neutral."""
    ch = [int(round(v)) for v in channels] + [int(PWM_NEUTRAL_US)] * 12
    return M.MAVLink_rc_channels_message(time_boot_ms(t), 18, *ch, 255)


def attitude(t: float, x: np.ndarray, noise: SensorNoise) -> mavlink2.MAVLink_message:
    """ATTITUDE at ``t`` (s) of state ``x``: Euler angles (rad) and body rates (rad/s)."""
    att = x[ATT] + noise.white("attitude")
    w = x[ANG] + noise.white("gyro")  # the autopilot's bias-corrected rates
    return M.MAVLink_attitude_message(
        time_boot_ms(t),
        wrap_angle(float(att[0])),
        wrap_angle(float(att[1])),
        wrap_angle(float(att[2])),
        float(w[0]),
        float(w[1]),
        float(w[2]),
    )


def local_position_ned(t: float, x: np.ndarray, noise: SensorNoise) -> mavlink2.MAVLink_message:
    """LOCAL_POSITION_NED at ``t`` (s) of state ``x``: position NED (m), velocity over ground NED (m/s)."""
    p = x[POS] + noise.white("position") + (noise.bias["position"] if noise.enabled else 0.0)
    v = TruthPlant.rotation(x) @ x[LIN] + noise.white("dvl")
    return M.MAVLink_local_position_ned_message(time_boot_ms(t), *map(float, (*p, *v)))


def scaled_pressure2(t: float, x: np.ndarray, noise: SensorNoise) -> mavlink2.MAVLink_message:
    """SCALED_PRESSURE2 at ``t`` (s) of state ``x``: the Bar30's absolute pressure at its depth (hPa)."""
    depth = float(x[2]) + float(noise.white("depth")[0])
    press_abs = pressure_hpa(depth)
    return M.MAVLink_scaled_pressure2_message(time_boot_ms(t), press_abs, 0.0, WATER_TEMPERATURE_CDEG)


def vfr_hud(x: np.ndarray, noise: SensorNoise) -> mavlink2.MAVLink_message:
    """VFR_HUD of state ``x``: speeds over ground (m/s), heading (deg), alt (-depth, m), climb (m/s)."""
    v_ned = TruthPlant.rotation(x) @ x[LIN]
    depth = float(x[2]) + float(noise.white("depth")[0])
    speed = float(np.hypot(v_ned[0], v_ned[1]))
    heading = int(math.degrees(float(x[5])) % 360.0)
    return M.MAVLink_vfr_hud_message(speed, speed, heading, 0, -depth, float(-v_ned[2]))


def imu(name: str, t: float, f_b: np.ndarray, w: np.ndarray) -> mavlink2.MAVLink_message:
    """SCALED_IMU2 or RAW_IMU (``name``) at ``t`` (s): specific force ``f_b`` (m/s^2, sent in mG)
    and body rates ``w`` (rad/s, sent in mrad/s)."""
    acc = [_i16(v / MG_M_S2) for v in f_b]
    gyro = [_i16(v / MRAD_S) for v in w]
    if name == "SCALED_IMU2":
        return M.MAVLink_scaled_imu2_message(
            time_boot_ms(t), *acc, *gyro, 0, 0, 0, temperature=WATER_TEMPERATURE_CDEG
        )
    return M.MAVLink_raw_imu_message(time_usec(t), *acc, *gyro, 0, 0, 0, temperature=WATER_TEMPERATURE_CDEG)


def servo_output_raw(t: float, armed: bool, channels: np.ndarray) -> mavlink2.MAVLink_message:
    """SERVO_OUTPUT_RAW at ``t`` (s): the eight motors' PWM (us) the channels (us) mix to when armed,
    1500 when disarmed."""
    if armed:
        pwm_us = motor_pwm(mix((channels - PWM_NEUTRAL_US) / PWM_PER_UNIT))
    else:
        pwm_us = np.full(8, PWM_NEUTRAL_US)
    pwm = [int(round(v)) for v in pwm_us]
    return M.MAVLink_servo_output_raw_message(time_usec(t) % (1 << 32), 0, *pwm)


def landing_target(t: float, x: np.ndarray, target_ned: np.ndarray) -> mavlink2.MAVLink_message:
    """LANDING_TARGET at ``t`` (s): ``target_ned`` (3,, NED m) relative to the vehicle of state ``x``,
    in body axes (MAV_FRAME_BODY_FRD, m)."""
    R = TruthPlant.rotation(x)  # {b} -> {n}
    rel = R.T @ (np.asarray(target_ned, dtype=float) - x[POS])
    return M.MAVLink_landing_target_message(
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


def sim_state(x: np.ndarray, f_b: np.ndarray) -> mavlink2.MAVLink_message:
    """SIM_STATE of the true state ``x`` (12,) with the last step's specific force ``f_b`` (3,, m/s^2):
    the simulator's truth, no sensor errors (see the module docstring for the frame)."""
    roll, pitch, yaw = (float(v) for v in x[ATT])
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    q = (
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    )
    lat, lon, alt = sim_latlon(*(float(v) for v in x[POS]))
    v = TruthPlant.rotation(x) @ x[LIN]
    w = x[ANG]
    return M.MAVLink_sim_state_message(
        *q,
        roll,
        pitch,
        wrap_angle(yaw),
        *(float(a) for a in f_b),
        *(float(a) for a in w),
        lat,
        lon,
        alt,
        0.0,
        0.0,
        *(float(a) for a in v),
        int(round(lat * 1e7)),
        int(round(lon * 1e7)),
    )

