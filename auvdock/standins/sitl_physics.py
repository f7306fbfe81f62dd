"""auvdock's truth model as the physics backend of ArduPilot SITL's JSON interface.

With ``ardusub --model JSON`` (or ``sim_vehicle.py -v ArduSub -f vectored_6dof --model
JSON``) the real ArduSub firmware -- mixer, modes, failsafes, EKF -- computes its motor
outputs and hands them, one frame per physics step, to a program that answers with the
vehicle's new state.  :class:`SitlPhysics` is that program: it moves the mission's vehicle
through the mission's flow field with :class:`auvdock.world.plant.TruthPlant` (the truth
plant :class:`auvdock.standins.vehicle_sim.VehicleSim` flies too)::

    physics = SitlPhysics(load_mission("missions/tank_positioned.yaml")).start()   # UDP 127.0.0.1:9002
    ...                                                                         # ardusub --model JSON
    physics.stop()

Protocol (ArduPilot ``libraries/SITL/SIM_JSON.cpp`` / ``SIM_JSON.h``)
-----------------------------------------------------------------------
* SITL sends each servo frame as one UDP datagram, little-endian: ``uint16 magic = 18458,
  uint16 frame_rate (Hz), uint32 frame_count, uint16 pwm[16] (us)`` (40 bytes), or with
  ``SERVO_32_ENABLE = 1`` magic 29569 and ``pwm[32]`` (72 bytes).  Anything else (another
  size, another magic, a frame rate of 0) is ignored and counted (:attr:`SitlPhysics.ignored`).
* The answer goes to the address the frame came from: one JSON object between two newlines,
  ``"\\n{...}\\n"`` (SITL turns newlines into string ends and parses the text between the
  last two, so the leading newline makes even the first answer complete), compact (SITL's
  parser finds each key by name and reads the value right after ``"key":`` -- no space --
  with ``sscanf("[%f, %f, %f]")`` for vectors)::

      {"timestamp":T,"imu":{"gyro":[p,q,r],"accel_body":[fx,fy,fz]},
       "position":[x,y,z],"attitude":[roll,pitch,yaw],"velocity":[vn,ve,vd]}

  ``timestamp`` physics time (s, absolute, 0 at the start); ``imu.gyro`` body rates (rad/s,
  {b}); ``imu.accel_body`` specific force in {b} (m/s^2; level and at rest (0, 0, -9.80665));
  ``position`` NED (m) in the mission's frame, relative to SITL's home (give SITL a home at
  altitude 0, the water surface: its barometer turns ``home altitude - z`` into water
  pressure for ArduSub); ``attitude`` ZYX Euler angles (rad, yaw in [-pi, pi)); ``velocity``
  over ground in NED (m/s).  The truth, without sensor noise: SITL adds its own.
  SIM_JSON has no battery field (SITL simulates the battery itself, ``SIM_BATT_VOLTAGE``).
* **Lockstep**: the vehicle moves only when a frame comes.  A frame whose ``frame_count`` is
  higher than the last one's is NEW: the plant steps exactly ``1 / frame_rate`` s and the
  answer carries ``timestamp + 1 / frame_rate``.  Each frame's own rate: SIM_JSON takes its
  rate from the answers' time steps and moves it by 1 Hz per frame towards the parameter
  ``SIM_RATE_HZ`` (1200 Hz by default, what ArduSub SITL sends), so a changed
  ``SIM_RATE_HZ`` makes every frame's rate different for a while.
  The same ``frame_count`` again (SITL resends a frame when no answer came within about a
  second, or when an answer did not parse) gets the same answer again, nothing steps
  (:attr:`SitlPhysics.repeats`).  A ``frame_count`` lower than the last one means SITL
  restarted: the vehicle starts over (see Hold), physics time at 0 (event ``reset``), and
  the frame is then stepped as new.  (SITL, for its part, takes a timestamp
  that goes back as a "physics reset" and carries on without moving its own clock back.)
* **Motors**: servo channels 1..8 are ArduSub's motors 1..8 of the VECTORED_6DOF frame, in
  the order of :data:`auvdock.vehicle.ardusub.MOTOR_FACTORS` and of the vehicle's
  allocation columns.  Motor PWM ``p`` (us; 0 -- no output -- is neutral 1500, others are
  clamped to 1100..1900) pushes thruster i along ``+e_i`` with
  the vehicle's thruster curve at ``2 * 1500 - p`` (the T200's: ``t200_pwm_to_force``), the chain of
  :func:`auvdock.vehicle.ardusub.thrust_from_channels` after the mixer.  Channels 9+ are
  ignored.
* **Hold** (``hold_until_thrust=True``, default): until the motors first push (a motor
  outside the T200's dead band), the vehicle's motion is prescribed, not integrated -- a
  buoyant vehicle would otherwise float to the surface during the tens of seconds SITL's
  EKF needs before ArduSub can arm.  Like a BlueROV2 put in the water, it boots **at the
  surface** (the start's x, y and attitude, z = 0, at rest) for :data:`SURFACE_S` s of
  physics time, is then **lowered** to the start depth along a smooth path (velocity up to
  :data:`DESCENT_SPEED_M_S`, velocity and IMU consistent with it; event ``lowering``), and
  **held at the start pose**, at rest (event ``at-start``), until the first frame with
  thrust releases it (event ``release``) from wherever it is then.  A reset starts over.
  Why the surface first: ArduSub zeroes its depth sensor at boot and re-zeroes it whenever
  it reads a positive altitude (``ArduSub/sensors.cpp``: "If we are reading a positive
  altitude, the sensor needs calibration"), so a vehicle that boots 1 m deep takes 1 m as
  its surface and can never again measure a depth shallower than that: its EKF then stays
  at the boot depth while the vehicle rises.  ``boot_at_surface=False`` holds it at the
  start pose from the first frame.  With ``hold_until_thrust=False`` the vehicle is free
  from the first frame at the start pose (ArduSub's depth is then relative to that boot
  depth, clamped as above).

Events (:attr:`SitlPhysics.events`, and ``on_event(event)`` as they happen, from the
server's thread): ``connected`` (the first frame, from where), ``peer`` (frames from
another address), ``lowering``, ``at-start``, ``release``, ``reset``, ``duration``
(``duration_s`` of physics time done).

Clock: the server's waits (for a datagram, for its thread) go through a
:class:`auvdock.runtime.clock.Clock` (default the wall clock); physics time comes from the frames
alone.
"""

from __future__ import annotations

import json
import math
import socket
import struct
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from auvdock.config.mission import Mission, load_mission
from auvdock.controllers.base import ControlOutput
from auvdock.controllers.status import STATUS_OK
from auvdock.loop import closed_loop
from auvdock.loop.recorder import LoopRecorder
from auvdock.loop.stages import Applied, LoopEnding, LoopResult, NoReadings, Observation, Stages, Unsupervised
from auvdock.loop.verdict import DockingRule
from auvdock.runtime.clock import Clock, wall_clock
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.sensing.readings import Readings
from auvdock.standins.truth_record import TruthContact, TruthRecord
from auvdock.vehicle.actuators import ActuatorCommand, IdealActuators
from auvdock.vehicle.geometry import wrap_angle
from auvdock.vehicle.state import POS
from auvdock.vehicle.thrusters import PWM_MAX_US, PWM_MIN_US, PWM_NEUTRAL_US, T200, ThrusterCurve
from auvdock.world.dock import ShiftedDock
from auvdock.world.plant import TruthPlant

if TYPE_CHECKING:
    from auvdock.estimation.estimate import Estimate

__all__ = [
    "DEFAULT_LISTEN",
    "DESCENT_SPEED_M_S",
    "MAGIC_16",
    "MAGIC_32",
    "N_MOTORS",
    "SURFACE_S",
    "PhysicsEvent",
    "PhysicsStatus",
    "ServoFrame",
    "SitlPhysics",
    "fdm_reply",
    "motor_thrust",
    "parse_listen",
    "parse_servo_frame",
]

#: Where SITL's JSON backend sends its frames by default (``--model JSON`` / ``JSON:127.0.0.1``).
DEFAULT_LISTEN = ("127.0.0.1", 9002)
#: Magic numbers of the 16- and 32-channel servo frames.
MAGIC_16 = 18458
MAGIC_32 = 29569
#: ArduSub's VECTORED_6DOF frame: motors 1..8 on servo channels 1..8.
N_MOTORS = 8
#: Hold: physics time at the surface after a (re)start, s (ArduSub zeroes its depth sensor at boot).
SURFACE_S = 2.0
#: Hold: the fastest the vehicle is lowered from the surface to the start depth, m/s.
DESCENT_SPEED_M_S = 0.25
#: Hold: the shortest descent, s.
DESCENT_MIN_S = 2.0

_HEADER = struct.Struct("<HHI")  # magic, frame_rate, frame_count
_PWM16 = struct.Struct("<16H")
_PWM32 = struct.Struct("<32H")
_SIZES = {MAGIC_16: (_HEADER.size + _PWM16.size, _PWM16), MAGIC_32: (_HEADER.size + _PWM32.size, _PWM32)}


@dataclass(frozen=True)
class ServoFrame:
    """One frame of SITL's servo outputs.

    Attributes
    ----------
    frame_rate : int
        SITL's physics rate, Hz: the frame asks for a step of ``1 / frame_rate`` s.
    frame_count : int
        SITL's frame counter (one per answer it accepted; back to 0 when SITL restarts).
    pwm : ndarray (16,) or (32,)
        Servo outputs, us (0: no output).
    """

    frame_rate: int
    frame_count: int
    pwm: np.ndarray


def parse_servo_frame(data: bytes) -> ServoFrame | None:
    """The servo frame in one datagram, or None if it is not one (size, magic, frame rate 0)."""
    if len(data) < _HEADER.size:
        return None
    magic, rate, count = _HEADER.unpack_from(data)
    spec = _SIZES.get(magic)
    if spec is None or len(data) != spec[0] or rate == 0:
        return None
    pwm = np.array(spec[1].unpack_from(data, _HEADER.size), dtype=float)
    return ServoFrame(int(rate), int(count), pwm)


def motor_thrust(pwm: np.ndarray, curve: ThrusterCurve = T200) -> np.ndarray:
    """Thrust of T1..T8 (8,), N along ``+e_i``, from servo channels 1..8 (us).

    0 (no output) is neutral; other values are clamped to 1100..1900 us; then the vehicle's
    thruster ``curve`` at ``2 * 1500 - p`` (the motor's positive command pushes along ``-e_i``;
    the T200's by default: ``t200_pwm_to_force``).
    """
    p = np.asarray(pwm, dtype=float)[:N_MOTORS]
    p = np.where(p == 0.0, PWM_NEUTRAL_US, np.clip(p, PWM_MIN_US, PWM_MAX_US))
    return curve.force(2 * PWM_NEUTRAL_US - p)


def _floats(v: np.ndarray) -> list[float]:
    return [float(a) for a in v]


def fdm_reply(t: float, x: np.ndarray, accel_body: np.ndarray, gyro: np.ndarray) -> bytes:
    """The answer to a frame: ``b"\\n{json}\\n"`` (see the module docstring).

    Parameters
    ----------
    t : float
        Physics time, s.
    x : ndarray (12,)
        Vehicle state [x y z NED m, phi theta psi rad, u v w body m/s, p q r rad/s].
    accel_body : ndarray (3,)
        Specific force in {b}, m/s^2.
    gyro : ndarray (3,)
        Body rates, rad/s.
    """
    x = np.asarray(x, dtype=float)
    att = [float(x[3]), float(x[4]), wrap_angle(float(x[5]))]
    v_ned = TruthPlant.rotation(x) @ x[6:9]
    body = {
        "timestamp": float(t),
        "imu": {"gyro": _floats(gyro), "accel_body": _floats(accel_body)},
        "position": _floats(x[POS]),
        "attitude": att,
        "velocity": _floats(v_ned),
    }
    return b"\n" + json.dumps(body, separators=(",", ":"), allow_nan=False).encode() + b"\n"


def parse_listen(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (or ``PORT``: on 127.0.0.1) as (host, port).

    Raises
    ------
    ValueError
        Naming the problem: no port, a port that is not a number or outside 1..65535.
    """
    s = text.strip()
    host, sep, port = s.rpartition(":")
    if not sep:
        host, port = DEFAULT_LISTEN[0], s
    host = host.strip("[]") or DEFAULT_LISTEN[0]
    if not port.isdigit():
        raise ValueError(f"expected HOST:PORT (e.g. 127.0.0.1:9002), got {text!r}")
    n = int(port)
    if not 1 <= n <= 65535:
        raise ValueError(f"port {n} is outside 1..65535")
    return host, n


@dataclass(frozen=True)
class PhysicsEvent:
    """Something the physics server did: ``kind`` connected, peer, reset, release or duration.

    ``wall_time`` is the clock's ``time()`` (s since the epoch), ``t`` the physics time (s)
    after the event, ``detail`` free text.
    """

    wall_time: float
    t: float
    kind: str
    detail: str


@dataclass(frozen=True)
class PhysicsStatus:
    """A snapshot of the server, for status lines.

    Attributes
    ----------
    t : float
        Physics time, s.
    frames, repeats, ignored, resets : int
        New frames stepped, repeated frames answered again, datagrams ignored, SITL restarts.
    frame_rate_hz : int
        The last frame's rate (0 before the first frame).
    state : ndarray (12,)
        The vehicle's true state.
    dock_distance_m : float
        From the vehicle's origin to the true docking point at physics time ``t``, m.
    closest_m, closest_t : float
        The closest the vehicle came to the docking point since the (re)start, m, and when
        (physics time, s); inf and nan before the first frame.
    motors_active : bool
        The last frame had thrust (a motor outside the dead band).
    hold : str
        ``surface``, ``lowering`` or ``start`` while the vehicle is held (see Hold), ``free`` after.
    peer : (str, int) or None
        Where the last frame came from.
    """

    t: float
    frames: int
    repeats: int
    ignored: int
    resets: int
    frame_rate_hz: int
    state: np.ndarray
    dock_distance_m: float
    closest_m: float
    closest_t: float
    motors_active: bool
    hold: str
    peer: tuple[str, int] | None

    @property
    def holding(self) -> bool:
        """Whether the vehicle is held (see Hold)."""
        return self.hold != "free"

    @property
    def depth_m(self) -> float:
        """Depth of the vehicle's origin, m."""
        return float(self.state[2])


class SitlPhysics:
    """The physics backend of ArduPilot SITL's JSON interface (see the module docstring).

    Parameters
    ----------
    mission : Mission or path
        Vehicle (8 thrusters: ArduSub's VECTORED_6DOF), flow field, start state, RK4
        substeps and dock.
    listen : (str, int)
        UDP address to listen on (default 127.0.0.1:9002, where SITL sends).
    hold_until_thrust : bool
        Prescribe the vehicle's motion until the motors first push (see Hold).
    boot_at_surface : bool
        Hold: boot at the surface and lower the vehicle to the start (see Hold); False: held
        at the start pose from the first frame.
    duration_s : float, optional
        Stop (after answering) once physics time reaches this, s.
    dock_offset_ned_m : array_like (3,)
        Where the true dock is relative to the mission's (NED, m; a camera mission's
        ``camera.synthetic.dock_offset_m`` when its view is streamed), for the distances.
    substeps : int, optional
        RK4 substeps per step (default ``mission.simulation.substeps``).
    surface : bool
        Floor the depth at 0 m (:class:`~auvdock.world.plant.TruthPlant`'s free surface).
    on_event : callable, optional
        ``on_event(event)`` for each :class:`PhysicsEvent`, called from the server's thread.
    clock : Clock, optional
        What the server waits on (default the wall clock).
    truth_out : str or Path, optional
        Write the truth (the vehicle's and the dock's trajectories, whether the motors push) to this
        results file (:mod:`auvdock.standins.truth_record`), complete when the server stops.

    Raises
    ------
    ValueError
        The mission's vehicle does not have 8 thrusters, or ``duration_s`` is not positive.
    """

    def __init__(
        self,
        mission: Mission | str | Path,
        *,
        listen: tuple[str, int] = DEFAULT_LISTEN,
        hold_until_thrust: bool = True,
        boot_at_surface: bool = True,
        duration_s: float | None = None,
        dock_offset_ned_m: np.ndarray | list[float] | tuple[float, ...] = (0.0, 0.0, 0.0),
        substeps: int | None = None,
        surface: bool = True,
        on_event: Callable[[PhysicsEvent], None] | None = None,
        clock: Clock | None = None,
        truth_out: str | Path | None = None,
    ) -> None:
        if not isinstance(mission, Mission):
            mission = load_mission(mission)
        self.truth_out = None if truth_out is None else Path(truth_out)
        if duration_s is not None and not duration_s > 0:
            raise ValueError(f"duration_s: must be positive, got {duration_s}")
        self.mission = mission
        self.listen = (str(listen[0]), int(listen[1]))
        self.hold_until_thrust = bool(hold_until_thrust)
        self.boot_at_surface = bool(boot_at_surface)
        self.duration_s = None if duration_s is None else float(duration_s)
        self.on_event = on_event
        self.clock: Clock = wall_clock if clock is None else clock
        n_sub = mission.simulation.substeps if substeps is None else int(substeps)
        with SigintDeferred():  # built whole: CasADi's argument checks swallow a KeyboardInterrupt
            self.vehicle = mission.build_vehicle()
            if self.vehicle.n_thrusters != N_MOTORS:
                raise ValueError(
                    f"{self.vehicle.name} has {self.vehicle.n_thrusters} thrusters; sitl-physics flies "
                    f"ArduSub's VECTORED_6DOF frame (the BlueROV2 Heavy), {N_MOTORS} thrusters"
                )
            self.flow = mission.build_flow()
            self.sea = mission.build_sea()  # the waves act on the vehicle here as in sim
            # the truth of this seed, as sim draws it (dock.position_std_m, start.position_std_m)
            self.dock = mission.build_dock(self.sea, truth=True)
            self._x_start = mission.true_start_state().astype(float)
            self.plant = TruthPlant(
                self.vehicle, self.flow, self._x_start, substeps=n_sub, surface=surface, sea=self.sea
            )
        self._dock_offset = np.array(dock_offset_ned_m, dtype=float).reshape(3)
        #: The true dock: where the camera's view puts it (the distances and the truth file measure to it).
        self.true_dock = ShiftedDock(self.dock, self._dock_offset)
        #: docking.criterion: capture -- the truth's contact with the dock's body, recorded (not judged)
        self._contact = TruthContact.of(mission, self.true_dock, built=self.dock)
        z0 = float(self._x_start[2])
        self._lowered = self.boot_at_surface and z0 > 0.0
        self._descent_s = max(DESCENT_MIN_S, 1.5 * z0 / DESCENT_SPEED_M_S) if self._lowered else 0.0

        self._lock = threading.Lock()
        self._stop_event = self.clock.event()
        self._sock: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self._events: list[PhysicsEvent] = []

        # protocol state
        self._last_count: int | None = None
        self._last_reply: bytes | None = None
        self._peer: tuple[str, int] | None = None
        self._rate = 0  # Hz of the current run of frames
        self._t_base = 0.0  # physics time where that run began, s
        self._k = 0  # steps in that run: t = t_base + k / rate
        self._t = 0.0
        self._hold = "free"
        self._motors_active = False
        self._frames = 0
        self._repeats = 0
        self._ignored = 0
        self._resets = 0
        self._skipped = 0
        self._finished = False
        self._closest = (math.inf, math.nan)
        self._pose: tuple[float, np.ndarray] = (0.0, self.plant.x[0:6].copy())
        self._start_over()

    # --- public state ------------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Physics time, s."""
        return self._t

    @property
    def state(self) -> np.ndarray:
        """The vehicle's true state (12,)."""
        with self._lock:
            return self.plant.state

    def pose(self) -> tuple[float, np.ndarray]:
        """(physics time s, pose eta (6,)) of the last step; safe from any thread (a camera's)."""
        return self._pose

    @property
    def frames(self) -> int:
        """New frames stepped."""
        return self._frames

    @property
    def repeats(self) -> int:
        """Repeated frames (same frame_count) answered again without stepping."""
        return self._repeats

    @property
    def ignored(self) -> int:
        """Datagrams that were not servo frames."""
        return self._ignored

    @property
    def resets(self) -> int:
        """SITL restarts seen (frame_count went back)."""
        return self._resets

    @property
    def skipped(self) -> int:
        """frame_counts jumped over (frames SITL sent that never arrived, or before we started)."""
        return self._skipped

    @property
    def holding(self) -> bool:
        """Whether the vehicle's motion is prescribed (see Hold)."""
        return self._hold != "free"

    @property
    def hold_phase(self) -> str:
        """``surface``, ``lowering``, ``start`` (held, see Hold) or ``free``."""
        return self._hold

    @property
    def at_start_s(self) -> float:
        """Physics time at which a held vehicle reaches the start pose (0 without the surface boot), s."""
        return SURFACE_S + self._descent_s if self._lowered else 0.0

    @property
    def events(self) -> list[PhysicsEvent]:
        """Events so far, oldest first."""
        with self._lock:
            return list(self._events)

    @property
    def finished(self) -> bool:
        """Whether ``duration_s`` of physics time is done."""
        return self._finished

    @property
    def local_address(self) -> tuple[str, int] | None:
        """(host, port) the server listens on once bound (port 0 in ``listen`` picks one), else None."""
        if self._sock is None:
            return None
        host, port = self._sock.getsockname()[:2]
        return str(host), int(port)

    @property
    def running(self) -> bool:
        """Whether the server thread runs."""
        return self._thread is not None and self._thread.is_alive()

    @property
    def error(self) -> BaseException | None:
        """What stopped the server thread, if anything did."""
        return self._error

    def status(self) -> PhysicsStatus:
        """A consistent snapshot (see :class:`PhysicsStatus`)."""
        with self._lock:
            x = self.plant.state
            t = self._t
            dist = self._dock_distance(x, t)
            return PhysicsStatus(
                t=t,
                frames=self._frames,
                repeats=self._repeats,
                ignored=self._ignored,
                resets=self._resets,
                frame_rate_hz=self._rate,
                state=x,
                dock_distance_m=dist,
                closest_m=self._closest[0],
                closest_t=self._closest[1],
                motors_active=self._motors_active,
                hold=self._hold,
                peer=self._peer,
            )

    # --- the protocol ------------------------------------------------------------------------
    def _accept(self, frame: ServoFrame, sender: tuple[str, int] | None) -> bytes | None:
        """The protocol's bookkeeping of one servo frame (see Protocol): the reply again for a
        repeated frame (answered without a step), or None for a new frame to step; a frame count
        that went back (SITL restarted) starts the vehicle over first."""
        count = frame.frame_count
        if sender is not None and sender != self._peer:
            kind = "connected" if self._peer is None else "peer"
            self._event(kind, f"servo frames from {sender[0]}:{sender[1]} at {frame.frame_rate} Hz")
            self._peer = sender
        if self._last_count is not None:
            if count == self._last_count and self._last_reply is not None:
                self._repeats += 1
                return self._last_reply
            if count < self._last_count:
                self._reset(f"frame_count went back from {self._last_count} to {count}: SITL restarted")
            elif count > self._last_count + 1:
                self._skipped += count - self._last_count - 1
        self._last_count = count
        return None

    def _step_and_reply(self, frame: ServoFrame, thrust: np.ndarray) -> bytes:
        """Step the frame with the motors' ``thrust`` (8,, N) and make the reply (see Protocol)."""
        self._step(frame, thrust)
        f_b, w = self.plant.imu()
        reply = fdm_reply(self._t, self.plant.x, f_b, w)
        self._last_reply = reply
        self._frames += 1
        if self.duration_s is not None and not self._finished and self._t >= self.duration_s - 1e-9:
            self._finished = True
            self._event("duration", f"{self.duration_s:g} s of physics time done")
            self._stop_event.set()
        return reply

    def _step(self, frame: ServoFrame, thrust: np.ndarray) -> None:
        rate = frame.frame_rate
        if rate != self._rate:
            self._t_base, self._k, self._rate = self._t, 0, rate
        t_prev = self._t
        self._k += 1
        self._t = self._t_base + self._k / rate
        self._motors_active = bool(np.any(thrust != 0.0))
        if self._hold != "free" and self._motors_active:
            self._hold = "free"
            where = (
                "at the start" if np.array_equal(self.plant.x[0:6], self._x_start[0:6]) else "where it was"
            )
            self._event(
                "release", f"motors left neutral at t = {t_prev:.3f} s: the vehicle is released {where}"
            )
        if self._hold == "free":
            self.plant.step(thrust, t_prev, 1.0 / rate)
        else:
            x, phase = self._held(self._t)
            x_prev, _ = self._held(t_prev)
            self.plant.place(x, (x[6:9] - x_prev[6:9]) / (self._t - t_prev))  # mean over the step
            if phase != self._hold:
                self._hold = phase
                if phase == "lowering":
                    self._event("lowering", f"lowered from the surface to the start, {self._descent_s:.1f} s")
                else:
                    self._event("at-start", "held at the start pose until the motors push")
        self._pose = (self._t, self.plant.x[0:6].copy())
        d = self._dock_distance(self.plant.x, self._t)
        if d < self._closest[0]:
            self._closest = (d, self._t)

    def _dock_distance(self, x: np.ndarray, t: float) -> float:
        """From the vehicle's origin to the true docking point at physics time ``t``, m."""
        p = np.asarray(self.true_dock.position(t), dtype=float)
        return float(np.linalg.norm(x[POS] - p))

    def _held(self, t: float) -> tuple[np.ndarray, str]:
        """The held vehicle's state (12,) and hold phase at physics time ``t`` (attitude fixed)."""
        x = self._x_start.copy()
        x[6:12] = 0.0
        if not self._lowered or t >= SURFACE_S + self._descent_s:
            return x, "start"
        if t < SURFACE_S:
            x[2] = 0.0
            return x, "surface"
        z0, T = float(self._x_start[2]), self._descent_s
        s = (t - SURFACE_S) / T  # smoothstep 3 s^2 - 2 s^3: at rest at both ends
        x[2] = z0 * (3 * s**2 - 2 * s**3)
        R = TruthPlant.rotation(x)
        x[6:9] = R.T @ np.array([0.0, 0.0, z0 * 6 * s * (1 - s) / T])
        return x, "lowering"

    def _start_over(self) -> None:
        """Vehicle at the start of a run: held (at the surface or the start) or free at the start pose."""
        if self.hold_until_thrust:
            x, self._hold = self._held(0.0)
            self.plant.place(x)
        else:
            self._hold = "free"
            self.plant.reset(self._x_start)
        self._pose = (self._t, self.plant.x[0:6].copy())

    def _reset(self, why: str) -> None:
        self._resets += 1
        self._t_base, self._k, self._t = 0.0, 0, 0.0
        self._last_reply = None
        self._closest = (math.inf, math.nan)
        self._start_over()
        self._event("reset", f"{why}; the vehicle starts over, physics time 0")

    def _event(self, kind: str, detail: str) -> None:
        ev = PhysicsEvent(self.clock.time(), self._t, kind, detail)
        self._events.append(ev)
        if self.on_event is not None:
            self.on_event(ev)

    # --- life cycle ----------------------------------------------------------------------------
    def bind(self) -> tuple[str, int]:
        """Open the UDP socket on ``listen``; returns the address bound (idempotent).

        Raises
        ------
        OSError
            The address is in use or not this computer's, or the host does not resolve.
        """
        if self._sock is None:
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            try:
                sock.bind(self.listen)
            except OSError:
                sock.close()
                raise
            sock.setblocking(False)
            self._sock = sock
        addr = self.local_address
        assert addr is not None
        return addr

    def start(self) -> SitlPhysics:
        """Bind (see :meth:`bind`) and answer frames in a thread of the clock until :meth:`stop`."""
        if self._thread is not None:
            raise RuntimeError("SitlPhysics.start() may be called only once")
        self.bind()
        self._thread = self.clock.start_thread(self._run, name="SitlPhysics")
        return self

    def wait(self, timeout_s: float | None = None) -> bool:
        """Wait (on the clock) until the server thread ends; True if it has."""
        if self._thread is None:
            return True
        return self.clock.join(self._thread, timeout_s)

    def stop(self) -> None:
        """Stop the server thread, wait for it and close the socket (idempotent)."""
        self._stop_event.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self.clock.join(self._thread, timeout=5.0)
        if self._sock is not None:
            try:
                self._sock.close()
            except OSError:
                pass
            self._sock = None

    def __enter__(self) -> SitlPhysics:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _run(self) -> None:
        """The server's life on the one closed loop (:func:`auvdock.loop.closed_loop.run_closed_loop`),
        one step per new servo frame (SITL's lockstep): the plant (:class:`_SitlPlant`: the next
        frame to step, repeats answered and restarts handled on the way, the truth stepped and the
        reply sent), SITL's motor outputs as the control stage (:class:`_MotorOutputs`), until
        :meth:`stop` or ``duration_s``."""
        truth: TruthRecord | None = None
        try:
            recorder = LoopRecorder(  # nothing kept in memory: it stays flat however long it runs
                [],
                vehicle=self.vehicle,
                dock=self.true_dock,
                extra_series={},
                plant_columns=_SitlPlant.columns_of(self),
                channels=False,
                keep=False,
            )
            if self.truth_out is not None:
                truth = TruthRecord.for_stand_in(
                    self.truth_out, "sitl-physics", self.mission, recorder.series, self.vehicle.n_thrusters
                )
                recorder.sinks.append(truth)
            pilot = _MotorOutputs(self)
            stages = Stages(
                _SitlPlant(self, pilot),
                NoReadings(),  # SITL reads its own sensors from the replies
                Unsupervised(),  # ArduSub's own failsafes act in SITL
                pilot,
                IdealActuators(self.vehicle),  # the motors' thrust, from SITL's own mixer
                DockingRule(self.true_dock, None),  # the flight decides docking
                recorder,
            )
            closed_loop.run_closed_loop(stages, timeout_s=math.inf)  # until stopped (or duration_s)
        except BaseException as e:  # kept for the caller; the thread must not die silently
            self._error = e
            self._stop_event.set()
        finally:
            if truth is not None:
                events = "; ".join(f"{e.t:.2f} s {e.kind}: {e.detail}" for e in self.events)
                truth.end(self._error is not None, events, self._t)


class _MotorOutputs:
    """sitl-physics' control stage: ArduSub SITL on the other end, whose motor outputs (the servo
    frame being stepped, after SITL's own VECTORED_6DOF mixer) become thrust through the
    vehicle's thruster curve (:func:`motor_thrust`)."""

    last_estimate: Estimate | None = None  # it estimates nothing
    last_step_t: float | None = None

    def __init__(self, sim: SitlPhysics) -> None:
        self.sim = sim
        self.vehicle = sim.vehicle
        self.dt = 1.0 / 1000.0  # nominal: the plant steps each frame by its own 1 / frame_rate
        self.frame: ServoFrame | None = None

    def finish(self, result: LoopResult) -> None:
        """Nothing to add."""

    @property
    def extra_series(self) -> dict[str, tuple[int, ...]]:
        """Nothing recorded beyond the loop's own columns."""
        return {}

    def step(self, readings: Readings) -> ControlOutput:
        assert self.frame is not None
        return ControlOutput(motor_thrust(self.frame.pwm, self.vehicle.thruster_curve), STATUS_OK)

    def set_applied(self, thrust: np.ndarray) -> None:
        """Nothing to predict with."""


class _SitlPlant:
    """sitl-physics as the closed loop's plant: each instant is the next new servo frame (SITL's
    lockstep: physics time follows the frames, ``t_base + k / frame_rate``, not the loop's
    nominal clock); datagrams that are not frames are counted, repeated frames answered again,
    a restart starts the vehicle over; the truth is stepped over the frame and the reply sent."""

    def __init__(self, sim: SitlPhysics, pilot: _MotorOutputs) -> None:
        self.sim = sim
        self.pilot = pilot
        self.columns = self.columns_of(sim)
        self._sender: tuple[str, int] | None = None
        self._thrust = np.zeros(N_MOTORS)

    @staticmethod
    def columns_of(sim: SitlPhysics) -> dict[str, tuple[int, ...]]:
        """``armed`` (the motors pushing); with ``docking.criterion: capture`` also the truth's contact with
        the dock's body (:class:`auvdock.standins.truth_record.TruthContact`)."""
        out: dict[str, tuple[int, ...]] = {"armed": ()}
        if sim._contact is not None:
            out.update(sim._contact.columns)
        return out

    def start(self) -> None:
        """Nothing to do: physics time is the frames'."""

    def observe(self, t: float) -> Observation:
        sim = self.sim
        while True:
            sock = sim._sock
            if sim._stop_event.is_set() or sock is None:
                raise LoopEnding("stopped", "sitl-physics stopped")
            if not sim.clock.wait_readable(sock, 0.2):
                continue
            try:
                data, sender = sock.recvfrom(65536)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:  # e.g. an ICMP "port unreachable" for an earlier reply: that peer is gone
                continue
            peer = (str(sender[0]), int(sender[1]))
            frame = parse_servo_frame(data)
            with sim._lock:
                if frame is None:
                    sim._ignored += 1
                    continue
                again = sim._accept(frame, peer)
                if again is None:  # a new frame: this instant's command
                    self.pilot.frame, self._sender = frame, peer
                    x = sim.plant.state
                    columns = {"armed": np.asarray(float(sim._motors_active))}
                    if sim._contact is not None:  # recorded only: the flight judges, the truth-check scores
                        columns.update(sim._contact.at(x, sim._t))
                    v_c = np.asarray(sim.flow.velocity(x[POS], sim._t))
                    return Observation(sim._t, x, v_c, columns)
            self._send(again, peer)

    def apply(self, t: float, command: ActuatorCommand) -> Applied:
        self._thrust = np.asarray(command.applied_N, dtype=float).copy()
        return Applied(None, self._thrust.copy())

    def advance(self, t: float, t_next: float) -> bool:
        sim, frame = self.sim, self.pilot.frame
        assert frame is not None and self._sender is not None
        with sim._lock:
            reply = sim._step_and_reply(frame, self._thrust)
        self._send(reply, self._sender)
        return True

    def _send(self, reply: bytes, peer: tuple[str, int]) -> None:
        sock = self.sim._sock
        if sock is None:
            return
        try:
            sock.sendto(reply, peer)
        except OSError:
            pass
