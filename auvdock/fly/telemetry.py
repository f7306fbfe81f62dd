"""Telemetry as the sensor interface: ArduSub's messages mapped into the mission frame and
turned into the sensor suite's readings.

The mission is written in its own NED frame, in which the vehicle starts at ``start.state``.
The vehicle's telemetry (LOCAL_POSITION_NED, ATTITUDE) is in the autopilot's frame; at the
start of a session :class:`MissionFrame` maps the vehicle's pose onto the mission's start
pose (a translation and a rotation about down), and every later reading through the same
map.

:class:`TelemetrySensors` is the third source of the one sensor interface (beside the
simulated suite, :class:`auvdock.sensing.simulated.SensorSuite`): fed the vehicle's messages as they
were received, it gives, per control step, the :class:`auvdock.estimation.navigation_filter.Reading` s of the
messages that are new since the last step, one definition per measurement kind
(:mod:`auvdock.sensing.measurements`):

=============================  ==========  =================================================
message                        kind        value
=============================  ==========  =================================================
ATTITUDE                       attitude    roll, pitch, yaw + the frame's heading offset, rad
SCALED_IMU2 (else RAW_IMU)     accel       xacc, yacc, zacc: specific force in {b}, mG -> m/s^2
SCALED_IMU2 (else RAW_IMU)     gyro        xgyro, ygyro, zgyro, mrad/s -> rad/s
SCALED_PRESSURE2 (else         depth       the depth change since the frame was set (pressure,
VFR_HUD)                                   sea water; VFR_HUD: minus alt) + the start depth, m
LOCAL_POSITION_NED             position    x, y, z mapped into the mission frame, m
                                           (when ``sensors.position.source`` is not none:
                                           ArduSub's EKF fed by a DVL, acoustic positioning...)
LOCAL_POSITION_NED             dvl         vx, vy, vz rotated into {b} (``sensors.dvl.enabled``)
=============================  ==========  =================================================

The body-frame quantities (IMU) do not change with the frame (a rotation about down).  Each
reading's standard deviation is the mission's figure for its sensor (``sensors.*``), the IMU's
with the rounding to whole mG / mrad/s added (:mod:`auvdock.fly.units`).  A reading is
stamped with the control step's time: ArduSub's attitude, pressure and EKF position are
current when sent.  The same object serves ``fly`` (fed from the link at each step) and
``replay`` (fed from the tlog up to each step's marker), so both see the same readings.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.fly.units import (
    ACCEL_LSB_STD_M_S2,
    ATMOSPHERE_HPA,
    GYRO_LSB_STD_RAD_S,
    MG_M_S2,
    MRAD_S,
    WATER_DENSITY,
    depth_from_pressure,
)
from auvdock.sensing.errors import sensor_errors
from auvdock.sensing.readings import Reading
from auvdock.sensing.settings import DEAD_RECKONED_SOURCES, SensorSettings
from auvdock.vehicle.geometry import Rz, rotation_of, wrap_angle

if TYPE_CHECKING:
    from auvdock.config.mission import GeofenceSpec

__all__ = [
    "TELEMETRY_MESSAGES",
    "PRESSURE_PARAMETERS",
    "MissionFrame",
    "TelemetrySensors",
    "geofence_violation",
    "frame_turns",
    "boot_time_s",
    "age_s",
]

#: The streams a session requests (MAV_CMD_SET_MESSAGE_INTERVAL) at ``fly.telemetry_rate_hz``.
TELEMETRY_MESSAGES = ("ATTITUDE", "LOCAL_POSITION_NED", "SCALED_IMU2", "SCALED_PRESSURE2", "SERVO_OUTPUT_RAW")
_IMU_TYPES = ("SCALED_IMU2", "RAW_IMU")
_DEPTH_TYPES = ("SCALED_PRESSURE2", "VFR_HUD")
#: The pressure messages and the ArduSub parameter of each one's surface pressure (Pa).
_PRESSURE_GROUND = {"SCALED_PRESSURE2": "BARO2_GND_PRESS", "SCALED_PRESSURE": "BARO1_GND_PRESS"}
#: The depth sources, most preferred first (measured_depth, filtered_depth).
_PRESSURE_SOURCES = ("SCALED_PRESSURE2", "SCALED_PRESSURE", "VFR_HUD")
#: The pose messages the mission frame is set on (averaged over a window, as the pre-flight depth is).
_FRAME_SOURCES = ("ATTITUDE", "LOCAL_POSITION_NED")
#: Readings kept per source for the pre-flight median and the frame's mean (a minute at 25 Hz).
READING_HISTORY = 1500
#: Parameters read for the depth (not checked): the surface pressures and the water's density.
PRESSURE_PARAMETERS = ("BARO1_GND_PRESS", "BARO2_GND_PRESS", "BARO_SPEC_GRAV")


@dataclass(frozen=True)
class MissionFrame:
    """The map from the autopilot's NED frame to the mission's.

    Attributes
    ----------
    dpsi : float
        Heading added to the vehicle's (rad): mission heading = vehicle heading + dpsi.
    p_vehicle0, p_mission0 : ndarray (3,)
        The vehicle's start position in the autopilot's frame and in the mission's (m).
    """

    dpsi: float
    p_vehicle0: np.ndarray
    p_mission0: np.ndarray

    @classmethod
    def at_start(
        cls, p_vehicle: np.ndarray, psi_vehicle: float, x0: np.ndarray, turn: bool = True
    ) -> MissionFrame:
        """The frame putting the vehicle pose (``p_vehicle``, ``psi_vehicle``) at the mission start; with
        ``turn`` False only its position (the mission drawn in the position source's frame: the axes
        are the autopilot's, the vehicle's heading what it reads)."""
        dpsi = wrap_angle(float(x0[5]) - psi_vehicle) if turn else 0.0
        return cls(dpsi, np.asarray(p_vehicle, float), x0[0:3].copy())

    @property
    def R(self) -> np.ndarray:
        """Rotation of vectors from the autopilot's frame to the mission's (3, 3)."""
        return Rz(self.dpsi)

    def position(self, p_vehicle: np.ndarray) -> np.ndarray:
        """A position of the autopilot's frame in the mission's (m)."""
        return self.p_mission0 + self.R @ (np.asarray(p_vehicle, float) - self.p_vehicle0)

    def state(self, att: Any, pos: Any) -> np.ndarray:
        """The vehicle state (12,) in the mission frame from ATTITUDE and LOCAL_POSITION_NED."""
        p = self.position(np.array([pos.x, pos.y, pos.z]))
        v_ned = self.R @ np.array([pos.vx, pos.vy, pos.vz])
        theta = np.array([att.roll, att.pitch, wrap_angle(att.yaw + self.dpsi)])
        nu1 = rotation_of(theta).T @ v_ned
        nu2 = np.array([att.rollspeed, att.pitchspeed, att.yawspeed])
        return np.concatenate([p, theta, nu1, nu2])

    def describe(self, p_vehicle: np.ndarray, psi_vehicle: float) -> str:
        x0p = self.p_mission0
        return (
            f"frame: vehicle start ({p_vehicle[0]:.2f}, {p_vehicle[1]:.2f}, {p_vehicle[2]:.2f}) m, "
            f"heading {math.degrees(psi_vehicle):.1f} deg -> mission start "
            f"({x0p[0]:.2f}, {x0p[1]:.2f}, {x0p[2]:.2f}) m, "
            f"{math.degrees(wrap_angle(psi_vehicle + self.dpsi)):.1f} deg"
        )


def frame_turns(frame_heading: str, position_source: str) -> bool:
    """Whether the mission frame turns by the vehicle's measured heading (``fly.frame_heading``):
    ``vehicle`` yes, ``source`` no, ``auto`` for dead-reckoned positions only
    (:data:`auvdock.sensing.settings.DEAD_RECKONED_SOURCES`).  Positions fixed in an outside frame do not
    turn with the compass: turning them by its heading puts its error into every position (against SITL,
    whose GPS is such a fix, a 2 deg heading error put the dock 6 cm to the side at 2 m)."""
    if frame_heading == "auto":
        return position_source in DEAD_RECKONED_SOURCES
    return frame_heading == "vehicle"


def boot_time_s(msg: Any) -> float | None:
    """A message's sample time on the vehicle's clock, s since its boot (``time_boot_ms``, or RAW_IMU's
    ``time_usec``); None for a message without one (VFR_HUD)."""
    ms = getattr(msg, "time_boot_ms", None)
    if ms is not None:
        return float(ms) * 1e-3
    us = getattr(msg, "time_usec", None)
    return None if us is None else float(us) * 1e-6


def age_s(msg: Any, stamp_us: int, now_us: int, clock_offset_s: float | None) -> float:
    """How old (s, >= 0) a message received at ``stamp_us`` is at ``now_us`` (both on the tlog's clock):
    from its sample time on the vehicle's clock where the clocks' offset (vehicle minus tlog, s) is known
    and the message carries its time, else from its arrival."""
    boot = boot_time_s(msg)
    if boot is not None and clock_offset_s is not None and math.isfinite(clock_offset_s):
        return max(0.0, now_us * 1e-6 - (boot - clock_offset_s))
    return max(0.0, (now_us - stamp_us) * 1e-6)


def geofence_violation(fence: GeofenceSpec, depth_m: float, distance_m: float | None) -> str | None:
    """Why a measured depth (m, the pressure sensor's) and horizontal distance from the start (m,
    the vehicle's own position estimate; None: unknown) are outside ``fly.geofence``, or None."""
    if distance_m is not None and distance_m > fence.max_distance_m:
        return f"geofence: {distance_m:.2f} m from the start (limit {fence.max_distance_m:g} m)"
    if depth_m < fence.min_depth_m:
        return f"geofence: depth {depth_m:.2f} m above the minimum {fence.min_depth_m:g} m"
    if depth_m > fence.max_depth_m:
        return f"geofence: depth {depth_m:.2f} m below the maximum {fence.max_depth_m:g} m"
    return None


class TelemetrySensors:
    """The vehicle's MAVLink telemetry as the sensor interface (see the module docstring).

    Parameters
    ----------
    sensors : SensorSettings
        The mission's sensor suite: which position source and DVL the vehicle has, and the
        noise figures the readings carry.
    estimation : str
        ``"truth"``: the state is the autopilot's own estimate (ATTITUDE and
        LOCAL_POSITION_NED); ``"filter"``: the navigation filter reads :meth:`readings`.
    """

    def __init__(self, sensors: SensorSettings, estimation: str) -> None:
        self.sensors = sensors
        self.estimation = estimation
        self._latest: dict[str, tuple[Any, int]] = {}
        # the pressure and pose readings of the last minute or so, per message type (the pre-flight median,
        # the mission frame's mean)
        self._history: dict[str, deque[tuple[int, Any]]] = {}
        #: How many positions and headings the mission frame was set on (:meth:`set_frame`).
        self.frame_readings = (0, 0)
        #: Whether the mission frame turned the vehicle's heading onto the mission's (:meth:`set_frame`).
        self.frame_turned = True
        self._new: dict[str, tuple[Any, int]] = {}
        self.frame: MissionFrame | None = None
        self._depth0: float | None = None
        self._depth_type: str | None = None
        self._surface_hpa = {m: ATMOSPHERE_HPA for m in _PRESSURE_GROUND}
        self._density = WATER_DENSITY
        self.specific_force = np.full(3, np.nan)
        # each reading's noise: the sensor's own (auvdock.sensing.errors), and for the IMU the
        # resolution of its MAVLink fields (mG, mrad/s) on top
        self._std = {kind: err.noise_std.copy() for kind, err in sensor_errors(sensors).items()}
        self._std["gyro"] = np.hypot(self._std["gyro"], GYRO_LSB_STD_RAD_S)
        self._std["accel"] = np.hypot(self._std["accel"], ACCEL_LSB_STD_M_S2)
        # each raw sensor's stated latency, sample to message (s): a message's time_boot_ms is when ArduSub
        # sent it, so its reading is stamped that much earlier, as sim's sensors stamp theirs.  Not the
        # position's: LOCAL_POSITION_NED is ArduSub's EKF output, which allows for its sources' delays itself.
        errors = sensor_errors(sensors)
        self._latency = {kind: errors[kind].latency_s for kind in ("attitude", "gyro", "accel", "depth")}

    @property
    def required(self) -> tuple[tuple[str, ...], ...]:
        """The telemetry a session waits for and keeps fresh: groups of message types, one of
        each group (ATTITUDE and LOCAL_POSITION_NED always; with ``filter`` an IMU message and
        a depth message too)."""
        groups: tuple[tuple[str, ...], ...] = (("ATTITUDE",), ("LOCAL_POSITION_NED",))
        if self.estimation == "filter":
            groups += (_IMU_TYPES, _DEPTH_TYPES)
        return groups

    def missing(self) -> list[str]:
        """The required telemetry not received yet, by name (``A or B`` for a group)."""
        return [" or ".join(g) for g in self.required if not any(m in self._latest for m in g)]

    def ages(self, now_us: int) -> dict[str, float]:
        """Per required group (``A or B``), the age (s) at ``now_us`` (the tlog's clock, us) of
        its newest message (``inf`` if none has come)."""
        out = {}
        for g in self.required:
            stamps = [self._latest[m][1] for m in g if m in self._latest]
            out[" or ".join(g)] = (now_us - max(stamps)) * 1e-6 if stamps else math.inf
        return out

    def age_s(self, now_us: int) -> float:
        """Age (s) at ``now_us`` of the stalest required telemetry (:meth:`ages`)."""
        return max(self.ages(now_us).values())

    # -- input --------------------------------------------------------------------------------
    def feed(self, messages: list[tuple[int, Any]]) -> None:
        """Take the messages received since the last call, ``(stamp us, message)`` in order."""
        for stamp, msg in messages:
            mtype = msg.get_type()
            self._latest[mtype] = (msg, int(stamp))
            self._new[mtype] = (msg, int(stamp))
            if mtype in _PRESSURE_SOURCES or mtype in _FRAME_SOURCES:
                self._history.setdefault(mtype, deque(maxlen=READING_HISTORY)).append((int(stamp), msg))

    def set_pressure_reference(self, params: dict[str, float]) -> str:
        """Take ArduSub's depth calibration from its parameters: the surface pressure of each
        pressure sensor (``BAROn_GND_PRESS``, Pa, measured at boot) and the water's density
        (1000 ``BARO_SPEC_GRAV``); the standard atmosphere and sea water where not reported.
        Returns a description for the events."""
        for mtype, pname in _PRESSURE_GROUND.items():
            if params.get(pname, 0.0) > 0:
                self._surface_hpa[mtype] = float(params[pname]) / 100.0
        if params.get("BARO_SPEC_GRAV", 0.0) > 0:
            self._density = 1000.0 * float(params["BARO_SPEC_GRAV"])
        return (
            f"depth from pressure: surface {self._surface_hpa['SCALED_PRESSURE2']:.2f} hPa "
            f"(SCALED_PRESSURE2), water {self._density:g} kg/m^3"
        )

    def _depth_of(self, msg: Any) -> float:
        """Depth (m, down) of a pressure message (absolute pressure) or VFR_HUD (alt, up)."""
        mtype = msg.get_type()
        if mtype == "VFR_HUD":
            return -float(msg.alt)
        return depth_from_pressure(msg.press_abs, self._surface_hpa[mtype], self._density)

    def measured_depth(self) -> tuple[float, str] | None:
        """The vehicle's depth (m) from its pressure sensor (SCALED_PRESSURE2, else SCALED_PRESSURE,
        else ArduSub's VFR_HUD), and the message it came from; None before any arrives.  The
        geofence's depth limits act on this, not on the mission frame's depth."""
        for mtype in _PRESSURE_SOURCES:
            msg, _ = self.latest(mtype)
            if msg is not None:
                return self._depth_of(msg), mtype
        return None

    def filtered_depth(self, window_s: float) -> tuple[float, str] | None:
        """The depth (m) the pre-flight checks read: the median of the pressure sensor's readings (the
        source :meth:`measured_depth` reads) received within ``window_s`` of its newest, and what it is
        (``"SCALED_PRESSURE2, median of 50 readings over 1.96 s"``); None before any arrives."""
        for mtype in _PRESSURE_SOURCES:
            history = self._history.get(mtype)
            if history:
                newest = history[-1][0]
                recent = [(s, m) for s, m in history if newest - s <= window_s * 1e6]
                depth = float(np.median([self._depth_of(m) for _, m in recent]))
                span = (newest - recent[0][0]) * 1e-6
                return depth, f"{mtype}, median of {len(recent)} readings over {span:.2f} s"
        return None

    def depth_readings(self, window_s: float) -> int:
        """How many readings of the depth source :meth:`filtered_depth` reads are within ``window_s``
        of its newest (0 before any)."""
        for mtype in _PRESSURE_SOURCES:
            history = self._history.get(mtype)
            if history:
                newest = history[-1][0]
                return sum(1 for s, _ in history if newest - s <= window_s * 1e6)
        return 0

    def sample_time(self, mtype: str, t: float, now_us: int, clock_offset_s: float | None) -> float:
        """Mission time (s) at which the newest ``mtype`` was sampled, the step being at ``t`` (s) and
        ``now_us`` (the tlog's clock): see :func:`age_s`; ``t`` before one arrives."""
        msg, stamp = self.latest(mtype)
        if msg is None or stamp is None:
            return t
        return t - age_s(msg, stamp, now_us, clock_offset_s)

    def vehicle_time_s(self) -> float:
        """The vehicle's own clock (s since its boot) of the newest ATTITUDE (``time_boot_ms``): the
        time a rehearsal's truth is recorded on (NaN before one)."""
        att, _ = self.latest("ATTITUDE")
        return math.nan if att is None else float(att.time_boot_ms) * 1e-3

    def distance_from_start(self) -> float | None:
        """Horizontal distance (m) of the vehicle's own position estimate (LOCAL_POSITION_NED)
        from where the frame was set; None before."""
        pos, _ = self.latest("LOCAL_POSITION_NED")
        if pos is None or self.frame is None:
            return None
        return float(math.hypot(pos.x - self.frame.p_vehicle0[0], pos.y - self.frame.p_vehicle0[1]))

    def latest(self, mtype: str) -> tuple[Any, int | None]:
        """The latest message of a type and its stamp (us), or ``(None, None)``."""
        item = self._latest.get(mtype)
        return (None, None) if item is None else item

    # -- the frame and the state -------------------------------------------------------------
    def _recent(self, mtype: str, window_s: float) -> list[Any]:
        """The messages of ``mtype`` received within ``window_s`` of its newest (oldest first)."""
        history = self._history.get(mtype)
        if not history:
            return []
        newest = history[-1][0]
        return [m for s, m in history if newest - s <= window_s * 1e6]

    def pose_readings(self, window_s: float) -> int:
        """How many of the ATTITUDE and of the LOCAL_POSITION_NED readings (the fewer) are within
        ``window_s`` of each one's newest: what :meth:`set_frame` averages."""
        return min(len(self._recent(m, window_s)) for m in _FRAME_SOURCES)

    def set_frame(self, x0: np.ndarray, window_s: float = 0.0, turn: bool = True) -> MissionFrame:
        """Map the vehicle's pose onto the mission start ``x0`` (12,): the mean of the LOCAL_POSITION_NED
        positions and the circular mean of the ATTITUDE headings received within ``window_s`` (s) of
        the newest (0: the latest only; one heading of a 2 deg noisy compass turns the whole frame, 7 cm
        at a dock 2 m away); the depth sensor's reading now becomes the start depth.  ``turn``
        (:func:`frame_turns`): the frame turns the vehicle's heading onto the mission's; else it only
        moves the positions."""
        atts = self._recent("ATTITUDE", window_s) or [self.latest("ATTITUDE")[0]]
        poss = self._recent("LOCAL_POSITION_NED", window_s) or [self.latest("LOCAL_POSITION_NED")[0]]
        p = np.mean([[m.x, m.y, m.z] for m in poss], axis=0)
        yaws = np.array([float(m.yaw) for m in atts])
        psi = float(np.arctan2(np.mean(np.sin(yaws)), np.mean(np.cos(yaws))))
        self.frame = MissionFrame.at_start(p, psi, x0, turn)
        self.frame_turned = bool(turn)
        self.frame_readings = (len(poss), len(atts))
        for mtype in _DEPTH_TYPES:
            msg, _ = self.latest(mtype)
            if msg is not None:
                self._depth_type, self._depth0 = mtype, self._depth_of(msg)
                break
        self._new.clear()  # readings start after the frame
        return self.frame

    def frame_cov(self, p_mission: np.ndarray) -> np.ndarray:
        """The covariance (3, 3, m^2) the mission frame's own error adds to a position ``p_mission``
        (m) mapped through it: its origin, the mean of ``n`` positions (the position noise / sqrt(n)
        per axis), and, where the frame turned (:attr:`frame_turned`), its heading, the mean of ``m``
        headings (the heading noise / sqrt(m)), which turns every position about the start by that angle
        (1 cm at 2 m for 2 deg over 50 readings).  The heading's noise is taken as white: a compass's
        bias is not in it (SITL's EKF heading read 2 deg off its physics', 7 cm at 2 m)."""
        frame = self._mission_frame()
        n_pos, n_att = (max(1, n) for n in self.frame_readings)
        std_p = np.asarray(self._std["position"], dtype=float) / math.sqrt(n_pos)
        std_psi = float(self._std["attitude"][2]) / math.sqrt(n_att) if self.frame_turned else 0.0
        lever = np.asarray(p_mission, dtype=float) - frame.p_mission0
        turn = np.array([-lever[1], lever[0], 0.0])  # d p / d psi of a rotation about down
        return np.diag(std_p**2) + std_psi**2 * np.outer(turn, turn)

    def _mission_frame(self) -> MissionFrame:
        """:attr:`frame`, which :meth:`set_frame` sets before any state or reading is asked for."""
        if self.frame is None:
            raise RuntimeError("telemetry: no mission frame yet (call set_frame first)")
        return self.frame

    def describe_frame(self) -> str:
        att, _ = self.latest("ATTITUDE")
        pos, _ = self.latest("LOCAL_POSITION_NED")
        return self._mission_frame().describe(np.array([pos.x, pos.y, pos.z]), float(att.yaw))

    def state(self) -> np.ndarray:
        """The autopilot's estimate of the state (12,) in the mission frame (latest ATTITUDE and
        LOCAL_POSITION_NED): the geofence and the docking check act on it, and with
        ``estimation: truth`` the controller too."""
        att, _ = self.latest("ATTITUDE")
        pos, _ = self.latest("LOCAL_POSITION_NED")
        return self._mission_frame().state(att, pos)

    # -- readings -----------------------------------------------------------------------------
    def readings(
        self, t: float, now_us: int | None = None, clock_offset_s: float | None = None
    ) -> list[Reading]:
        """The readings of the messages new since the last call, at mission time ``t`` (s).

        ``now_us``: the moment ``t`` on the tlog's clock (us); each reading is then stamped with its
        sample time (:meth:`age_s`): on the vehicle's clock where ``clock_offset_s`` (the vehicle's
        clock minus the tlog's, s: :class:`auvdock.fly.link_health.LinkHealth`) is known, else its
        arrival (ArduSub sends a sample as it takes it: on a 25 Hz stream read at 20 Hz a reading
        is up to 40 ms old, 12 mm of position at 0.3 m/s; over a link, the link's delay more).
        None: every reading stamped ``t``.
        Also sets :attr:`specific_force` (3,, m/s^2; NaN without a new IMU message)."""
        fresh, self._new = self._new, {}
        new = {k: m for k, (m, _) in fresh.items()}

        def at(mtype: str, kind: str) -> float:
            if now_us is None:
                return t
            msg, stamp = fresh[mtype]
            return t - age_s(msg, stamp, now_us, clock_offset_s) - self._latency.get(kind, 0.0)

        out: list[Reading] = []
        frame = self._mission_frame()
        std = self._std
        att = new.get("ATTITUDE")
        if att is not None:
            value = np.array([att.roll, att.pitch, wrap_angle(att.yaw + frame.dpsi)], dtype=float)
            out.append(Reading("attitude", at("ATTITUDE", "attitude"), value, std["attitude"].copy()))
        imu_type = "SCALED_IMU2" if "SCALED_IMU2" in new else "RAW_IMU"
        imu = new.get(imu_type)
        self.specific_force = np.full(3, np.nan)
        if imu is not None:
            gyro = np.array([imu.xgyro, imu.ygyro, imu.zgyro], dtype=float) * MRAD_S
            f_b = np.array([imu.xacc, imu.yacc, imu.zacc], dtype=float) * MG_M_S2
            self.specific_force = f_b
            out.append(Reading("gyro", at(imu_type, "gyro"), gyro, std["gyro"].copy()))
            out.append(Reading("accel", at(imu_type, "accel"), f_b.copy(), std["accel"].copy()))
        depth_type, depth0 = self._depth_type, self._depth0  # set together by set_frame
        depth_msg = new.get(depth_type) if depth_type is not None else None
        if depth_msg is not None and depth_type is not None and depth0 is not None:
            d = frame.p_mission0[2] + (self._depth_of(depth_msg) - depth0)
            out.append(Reading("depth", at(depth_type, "depth"), np.array([d]), std["depth"].copy()))
        pos = new.get("LOCAL_POSITION_NED")
        if pos is not None and self.sensors.position.source != "none":
            p = frame.position(np.array([pos.x, pos.y, pos.z]))
            out.append(Reading("position", at("LOCAL_POSITION_NED", "position"), p, std["position"].copy()))
        if pos is not None and self.sensors.dvl.enabled:
            a, _ = self.latest("ATTITUDE")
            theta = np.array([a.roll, a.pitch, wrap_angle(a.yaw + frame.dpsi)])
            v_b = rotation_of(theta).T @ (frame.R @ np.array([pos.vx, pos.vy, pos.vz]))
            out.append(Reading("dvl", at("LOCAL_POSITION_NED", "dvl"), v_b, std["dvl"].copy()))
        return out
