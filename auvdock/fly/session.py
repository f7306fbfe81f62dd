"""One docking session on a vehicle over MAVLink: :class:`FlySession`.

The session in named steps (:meth:`FlySession.run`)::

    _connect          wait for the ArduSub HEARTBEAT, request the telemetry rates
    _wait_telemetry   wait for the telemetry the estimation needs (TelemetrySensors.required)
    _set_frame        map the vehicle's pose onto the mission's start
    _start_camera     (dock.source: camera) the frame source and the detection thread
    _arm              --arm: MANUAL mode, arm; else a dry run
    _open_results     the results file
    _control_loop     every dt, on the session's clock: _step
        _step             _take_telemetry -> _check_telemetry -> state -> _check_geofence -> camera
                          -> _check_landing_target -> docked? -> _control (the controller-and-
                          estimator step on the sensor readings, RC override, one row)
    _finish           the one ending: neutral, release, disarm if we armed, link closed, outcome written

What the controller knows comes through :class:`auvdock.fly.telemetry.TelemetrySensors`:
the vehicle's messages received since the last step are taken from the link at once
(:meth:`MavlinkLink.drain`, which marks the moment in the tlog), so that ``auvdock replay``
can hand the same session code the same messages at the same steps and reproduce its
outputs.  With ``estimation: filter`` the navigation filter reads the sensor readings (IMU,
attitude, depth, the position source); with ``truth`` the controller takes the autopilot's
own estimate (ATTITUDE, LOCAL_POSITION_NED) as the state.  Oracle and Kinematic MPC read the
mission's flow model as their forecast of the current (their definition; the events say so);
no other controller ever sees it.

Safety (each ends the session the same way, :meth:`FlySession._finish`): nothing is armed
without ``arm=True``; telemetry older than ``fly.stale_neutral_s``: neutral at once, older
than ``fly.stale_abort_s``: abort; leaving ``fly.geofence`` aborts; overrides stream at the
control rate all session (ArduSub disarms after 3 s without pilot input).

Ctrl-C (SIGINT) at any moment ends the session with reason "interrupted" (exit code 130):
results rows and the results file's creation are written whole (SIGINT held back over them),
and from the start of the ending a SIGINT is only noted, so the ending always runs to its end
and the results file is always closed readable.
"""

from __future__ import annotations

import dataclasses
import signal
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil

from ..autopilot import build_autopilot
from ..clock import Clock
from ..controllers import Measurement
from ..controllers.registry import CONTROLLERS, split_controller
from ..controllers.status import FAILURE_CODES, STATUS_NAMES, STATUS_NO_STEP
from ..dock import HeaveDock, TrackedDock
from ..geometry import rotation_zyx
from ..hardware.ardusub import NEUTRAL_CHANNELS, channels_for_thrust, thrust_from_channels
from ..hardware.link import LinkError, MavlinkLink
from ..interrupts import SigintDeferred
from ..mission import Mission, MissionError
from ..vehicle.state import ATT, POS
from .camera import CAMERA_SERIES, CameraOpenError, CameraTracking
from .record import FlyRecorder
from .telemetry import TELEMETRY_MESSAGES, TelemetrySensors, geofence_violation

__all__ = ["FlySession", "FlyResult", "FlyAbortError"]

#: ArduSub's VECTORED_6DOF frame (the BlueROV2 Heavy), the only one the channel mapping knows.
N_THRUSTERS = 8


class FlyAbortError(RuntimeError):
    """The session was aborted for a safety reason (the message says which)."""


@dataclass
class FlyResult:
    """How a session ended."""

    reason: str  # "docked", "timeout", "aborted", "interrupted"
    message: str
    outcome: dict[str, Any] = field(default_factory=dict)
    results_path: Path | None = None
    events: list[tuple[float, str]] = field(default_factory=list)

    @property
    def exit_code(self) -> int:
        return {"docked": 0, "timeout": 1, "interrupted": 130}.get(self.reason, 3)


@dataclass
class _Ending:
    reason: str
    message: str
    docked: bool = False
    contact: np.ndarray | None = None
    t_end: float = 0.0


_INTERRUPTED = ("interrupted", "interrupted (Ctrl-C)")


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
        A camera file that is missing or bad, a vehicle that is not an 8-thruster
        BlueROV2 Heavy (ArduSub VECTORED_6DOF), or a flow-estimating controller with
        ``estimation: truth`` (the paper's simulated sensing of the water-relative
        velocity, which no vehicle has).
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
        self._t0 = self.clock.now()
        self._frame: Any = None
        self._now_us = 0
        self._failed_solves = 0
        self._rec: FlyRecorder | None = None
        self._we_armed = False
        self._last_target: int | None = None
        self._t_end = 0.0
        self._progress: Any = None
        self._sigint = _SigintLatch()
        self.link.on_event = self._event

    def _build(self, mission: Mission, controller: str | None) -> None:
        """The vehicle model, the dock (model or filter), the flow and the controller step."""
        self.vehicle = mission.build_vehicle()
        if self.vehicle.n_thrusters != N_THRUSTERS:
            raise MissionError(
                mission.source or mission.name,
                "vehicle",
                f"fly flies ArduSub's VECTORED_6DOF frame (8 thrusters, BlueROV2 Heavy); "
                f"{self.vehicle.name} has {self.vehicle.n_thrusters}",
            )
        name, _ = split_controller(controller or mission.controller.type)
        if mission.estimation == "truth" and CONTROLLERS[name].estimates_flow:
            raise MissionError(
                mission.source or mission.name,
                "estimation",
                f"{name} learns the current from the vehicle's sensors; on a vehicle that needs "
                "estimation: filter (fly --estimation filter; truth is the paper's simulated "
                "water-relative velocity sensor)",
            )
        self.telemetry = TelemetrySensors(mission.sensors, mission.estimation)
        self._model_dock: HeaveDock = mission.build_dock()
        self.dock: HeaveDock | TrackedDock = self._model_dock
        if mission.dock.source == "mavlink":
            self.dock = TrackedDock(self._model_dock)
        elif mission.dock.source == "camera":
            self.dock = TrackedDock(self._model_dock, process_noise=mission.camera.process_noise_m_s)
            mission.build_camera()  # a missing or bad camera file is a mission error, before connecting
        self.flow = mission.build_flow()
        self.autopilot = build_autopilot(mission, self.vehicle, self.dock, controller)

    # ------------------------------------------------------------------------------------
    def run(self, progress=None) -> FlyResult:
        """Fly the session to its end; never raises for the vehicle's or the link's behaviour.

        ``progress(t, distance_m, status_text)`` is called every control step if given.
        Ctrl-C (KeyboardInterrupt, SIGINT) ends the session like an abort, with reason
        "interrupted", at any moment (see the module docstring).
        """
        self._progress = progress
        ending: _Ending | None = None
        try:
            ending = self._fly()
        except KeyboardInterrupt:
            ending = _Ending(*_INTERRUPTED)
        finally:
            # the one ending; a KeyboardInterrupt can only come before its SIGINT latch is in
            # place, and then nothing of it has run yet: run it again
            result: FlyResult | None = None
            try:
                while result is None:
                    try:
                        result = self._finish(ending)
                    except KeyboardInterrupt:
                        ending = _Ending(*_INTERRUPTED)
            finally:
                self._sigint.restore()
        if self._sigint.hit and result.reason != "interrupted":  # Ctrl-C during the ending
            result = dataclasses.replace(
                result, reason="interrupted", message=f"interrupted (Ctrl-C): {result.message}"
            )
        return result

    def _fly(self) -> _Ending:
        """Everything up to the ending; safety aborts and Ctrl-C become the ending's reason."""
        try:
            self._connect()
            self._wait_telemetry()
            self._set_frame()
            self._start_camera()
            self._arm()
            self._open_results()
            return self._control_loop()
        except FlyAbortError as e:
            self._event(f"abort: {e}")
            return _Ending("aborted", str(e))
        except KeyboardInterrupt:
            self._event(_INTERRUPTED[1])
            return _Ending(*_INTERRUPTED)

    # -- before the loop ------------------------------------------------------------------
    def _connect(self) -> None:
        """Wait for the vehicle's HEARTBEAT, then request the telemetry streams."""
        try:
            self.link.connect(timeout_s=self.connect_timeout_s)
        except LinkError as e:
            raise FlyAbortError(str(e)) from None
        # in the tlog only: what replay needs to rebuild this session
        self.link.note(f"auvdock fly {self.autopilot.name} dt={self.dt:g} timeout={self.timeout_s:g}")
        rate = self.mission.fly.telemetry_rate_hz
        for name in TELEMETRY_MESSAGES:
            msg_id = getattr(mavutil.mavlink, f"MAVLINK_MSG_ID_{name}")
            try:
                result = self.link.request_rate(msg_id, rate)
                self._event(f"rate {name} {rate:g} Hz: MAV_RESULT {result}")
            except LinkError as e:
                self._event(f"rate {name}: {e}")
            self.link.send_neutral()
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

    def _take_telemetry(self, marker: str, value: int = 0) -> int:
        """The messages received since the last call into :attr:`telemetry`; returns now (us,
        the tlog's clock).  The link marks the moment in the tlog (for replay)."""
        now_us, messages = self.link.drain(marker, value)
        self.telemetry.feed(messages)
        for _, msg in messages:  # the vehicle's own words (pre-arm checks, failsafes), shown and recorded
            if msg.get_type() == "STATUSTEXT":
                self._event(f"vehicle: {str(msg.text).strip()}")
        return now_us

    def _wait_telemetry(self) -> None:
        """Stream neutral overrides until the telemetry the estimation needs arrives."""
        clock = self.clock
        deadline = clock.now() + self.connect_timeout_s
        while clock.now() < deadline:
            self.link.send_neutral()
            now_us = self._take_telemetry("auvd_wait")
            if not self.telemetry.missing() and self.telemetry.age_s(now_us) < 0.5:
                return
            clock.sleep(self.dt)
        missing = self.telemetry.missing() or ["fresh " + " and ".join(
            "/".join(g) for g in self.telemetry.required)]  # fmt: skip
        hint = " (does the autopilot have a position source and origin?)" if any(
            "LOCAL_POSITION_NED" in name for name in missing) else ""  # fmt: skip
        raise FlyAbortError(
            f"no {', '.join(missing)} from {self.link.port} within {self.connect_timeout_s:g} s{hint}"
        )

    def _set_frame(self) -> None:
        """Map the vehicle's current pose onto the mission's start pose."""
        self._take_telemetry("auvd_frame")
        self._frame = self.telemetry.set_frame(self.mission.start_state())
        self._event(self.telemetry.describe_frame())

    def _start_camera(self) -> None:
        """dock.source: camera -- open the frame source and start detecting."""
        if self.mission.dock.source != "camera":
            return
        try:
            self.camera = CameraTracking(self.mission, self._model_dock, self.dock, self.clock, self._event)
        except CameraOpenError as e:
            raise FlyAbortError(str(e)) from None
        self.camera.start(self._state())
        self._event(f"camera: {self.camera.description}")

    def _arm(self) -> None:
        """--arm: MANUAL mode and arm (checked); otherwise say it is a dry run."""
        if not self.arm_vehicle:
            self._event("dry run: not arming, sending neutral overrides only")
            return
        self.link.send_neutral()
        try:
            self.link.set_mode("MANUAL")
            self.link.send_neutral()
            self._we_armed = True  # from the arm command on, every ending disarms (Ctrl-C before its ack too)
            self.link.arm()
        except LinkError as e:
            raise FlyAbortError(str(e)) from None

    def _open_results(self) -> None:
        m = self.mission
        self._rec = FlyRecorder(
            self.out,
            mission=m,
            autopilot=self.autopilot,
            vehicle=self.vehicle,
            flow=self.flow,
            dock=self.dock,
            extra_series=CAMERA_SERIES if self.camera is not None else {},
            attrs={
                "tolerance_m": m.docking.tolerance_m,
                "timeout_s": self.timeout_s,
                "dt_s": self.dt,
                "flow": self.flow.describe(),
                "vehicle": self.vehicle.name,
                "solver": self.autopilot.solver,
                "reads_true_flow": self.autopilot.reads_true_flow,
                "estimation": m.estimation,
                # the map from the autopilot's NED frame to the mission's (MissionFrame)
                "frame_heading_offset_rad": self._frame.dpsi,
                "frame_vehicle_start_m": self._frame.p_vehicle0,
                "frame_mission_start_m": self._frame.p_mission0,
                "source": f"fly {self.link.port}" + ("" if self.arm_vehicle else " (dry run)"),
            },
        )
        self._rec.open()

    # -- the loop -------------------------------------------------------------------------
    def _control_loop(self) -> _Ending:
        """A step every dt on the clock until an ending (docked) or the timeout."""
        t_start = self.clock.now()
        k = 0
        while (t := k * self.dt) <= self.timeout_s + 1e-9:
            self.clock.sleep_until(t_start + t)
            ending = self._step(t, k)
            if ending is not None:
                return ending
            k += 1
        return _Ending("timeout", f"not docked within {self.timeout_s:g} s", t_end=self._t_end)

    def _step(self, t: float, k: int) -> _Ending | None:
        """Control step ``k`` at mission time ``t``; an ending (docked) or None."""
        self._now_us = self._take_telemetry("auvd_step", k)
        if self._check_telemetry():
            return None
        x = self._state()
        self._check_geofence(x)
        camera_series: dict[str, np.ndarray] = {}
        if self.camera is not None:
            self.camera.record_pose(t, x)
            steer, camera_series = self._camera_step(t)
            if not steer:  # no dock to steer to: neutral thrust and hold, recorded
                self.link.send_neutral()
                self._rec.held(
                    t, x, channels=NEUTRAL_CHANNELS, telemetry=self._telemetry(), series=camera_series
                )
                return None
        if self.mission.dock.source == "mavlink":
            self._check_landing_target(t, x)
        dist = float(np.linalg.norm(x[POS] - self.dock.position(t)))
        if dist <= self.mission.docking.tolerance_m:
            self._rec.distances.append(dist)
            self._rec.held(  # the state in which docking is declared, as sim records it
                t,
                x,
                channels=NEUTRAL_CHANNELS,
                telemetry=self._telemetry(),
                series=camera_series,
                status=STATUS_NO_STEP,
            )
            return _Ending("docked", f"docked at t = {t:.2f} s", docked=True, contact=x.copy(), t_end=t)
        self._control(t, x, dist, camera_series)
        return None

    def _control(self, t: float, x: np.ndarray, dist: float, camera_series: dict[str, np.ndarray]) -> None:
        """The controller-and-estimator step on the sensor readings, its thrust as RC overrides,
        one results row.  The mission's flow model is handed on as a forecast; the Autopilot
        strips it for every controller whose definition does not read it."""
        v_c = self.flow.velocity(x[POS], t)
        readings = self.telemetry.readings(t, self._now_us)
        f_b = self.telemetry.specific_force
        with SigintDeferred():  # a whole controller step (CasADi may swallow a KeyboardInterrupt)
            out = self.autopilot.step(Measurement(t=t, state=x, flow_ned=v_c, readings=readings))
        channels = channels_for_thrust(out.thrust, self.vehicle.allocation)
        telemetry = self._telemetry()
        if self.arm_vehicle:
            self.link.send_override(channels)
        else:
            self.link.send_neutral()
        # what the thrusters will really push (ArduSub's channel path; nothing while disarmed)
        sent = channels if self.arm_vehicle else NEUTRAL_CHANNELS
        applied = thrust_from_channels(sent) if telemetry["armed"] else np.zeros(self.vehicle.n_thrusters)
        self.autopilot.set_applied(applied)
        series = dict(out.series)
        if "flow_body_true_m_s" in self.autopilot.extra_series:  # unknown on a vehicle
            series["flow_body_true_m_s"] = np.full(3, np.nan)
        self._rec.flown(
            t,
            x,
            dist,
            out,
            channels=channels if self.arm_vehicle else NEUTRAL_CHANNELS,
            specific_force=f_b,
            telemetry=telemetry,
            series={**series, **camera_series},
        )
        self._t_end = t
        self._check_solves(out.status)
        if self._progress is not None:
            self._progress(t, dist, STATUS_NAMES.get(out.status, str(out.status)))

    # -- safety checks --------------------------------------------------------------------
    def _check_telemetry(self) -> bool:
        """Stale telemetry: neutral (returns True: skip this step); lost: abort."""
        stale = self._stale()
        fly = self.mission.fly
        if stale > fly.stale_abort_s:
            names = [n for n, age in self.telemetry.ages(self._now_us).items() if age > fly.stale_abort_s]
            raise FlyAbortError(f"telemetry lost: no {', '.join(names)} for {stale:.1f} s")
        if stale > fly.stale_neutral_s:
            self.link.send_neutral()
            if not self.events or not self.events[-1][1].startswith("telemetry stale"):
                self._event(f"telemetry stale ({stale:.2f} s): neutral")
            return True
        return False

    def _check_solves(self, status: int) -> None:
        """Abort after ``fly.max_failed_solves`` steps in a row without a converged solve."""
        self._failed_solves = self._failed_solves + 1 if status in FAILURE_CODES else 0
        limit = self.mission.fly.max_failed_solves
        if self._failed_solves >= limit:
            raise FlyAbortError(
                f"controller: {limit} steps in a row without a converged solve "
                f"(last status {STATUS_NAMES.get(status, status)})"
            )

    def _check_geofence(self, x: np.ndarray) -> None:
        fence = geofence_violation(self.mission.fly.geofence, x, self._frame.p_mission0)
        if fence is not None:
            raise FlyAbortError(fence)

    def _camera_step(self, t: float) -> tuple[bool, dict[str, np.ndarray]]:
        """The camera's fixes into the dock filter: (may steer?, series); aborts when lost."""
        state, series = self.camera.step(t)
        if state == "lost":
            raise FlyAbortError(self.events[-1][1] if self.events else "camera: dock lost")
        return state == "tracking", series

    def _check_landing_target(self, t: float, x: np.ndarray) -> None:
        """dock.source: mavlink -- re-anchor the dock; abort without (or after losing) LANDING_TARGET."""
        limit = self.mission.fly.stale_abort_s
        age = self._landing_target(t, x)
        if self.dock.measurements == 0 and t > limit:
            raise FlyAbortError(f"no LANDING_TARGET with a position within {limit:g} s")
        if self.dock.measurements and age > limit:
            raise FlyAbortError(f"dock lost: no LANDING_TARGET for {age:.1f} s")

    def _landing_target(self, t: float, x: np.ndarray) -> float:
        """Re-anchor the dock from the latest LANDING_TARGET; returns its age (s).

        Accepted frames: MAV_FRAME_BODY_FRD (x, y, z from the vehicle in {b}) and
        MAV_FRAME_LOCAL_NED (the autopilot's NED frame, mapped to the mission frame).
        Messages without ``position_valid`` are ignored.
        """
        lt, stamp = self.telemetry.latest("LANDING_TARGET")
        if lt is None or not getattr(lt, "position_valid", 0):
            return float("inf")
        age = (self._now_us - stamp) * 1e-6
        if id(lt) == self._last_target:
            return age
        self._last_target = id(lt)
        rel = np.array([lt.x, lt.y, lt.z])
        if lt.frame == mavutil.mavlink.MAV_FRAME_BODY_FRD:
            p = x[POS] + rotation_zyx(*map(float, x[ATT])) @ rel
        elif lt.frame == mavutil.mavlink.MAV_FRAME_LOCAL_NED:
            p = self._frame.position(rel)
        else:
            return float("inf")
        self.dock.update(t, p)
        return age

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
        self.events.append((self.clock.now() - self._t0, text))

    # -- the ending -----------------------------------------------------------------------
    def _finish(self, ending: _Ending | None) -> FlyResult:
        """The one ending (``None``: an unexpected error, which propagates after it).

        Neutral overrides, override release, disarm if we armed, link closed, outcome
        written and the results file closed; a SIGINT meanwhile is only noted.
        """
        self._sigint.install()
        self._shutdown()
        rec = self._rec
        if ending is None:
            if rec is not None and rec.writer is not None:
                rec.close()
            return FlyResult("aborted", "error", {}, None, list(self.events))
        if self._sigint.hit and ending.reason != "interrupted":
            ending = _Ending("interrupted", f"interrupted (Ctrl-C) while ending: {ending.message}")
        self._event(f"end: {ending.reason}: {ending.message}")
        outcome: dict[str, Any] = {}
        if rec is not None and rec.writer is not None:
            outcome = rec.outcome(
                ending.reason,
                ending.message,
                docked=ending.docked,
                contact=ending.contact,
                t_end=ending.t_end,
                extra={"events_json": rec.events_json(self.events), "armed_by_us": self._we_armed},
            )
            rec.finish(outcome)
        path = self.out if rec is not None and rec.writer is not None else None
        return FlyResult(ending.reason, ending.message, outcome, path, list(self.events))

    def _shutdown(self) -> None:
        """Camera stopped, neutral, overrides released, disarmed if we armed, link closed.  Never raises."""
        if self.camera is not None:
            self.camera.stop()
        for action in (self.link.send_neutral, self.link.release_overrides):
            try:
                action()
            except Exception:  # noqa: BLE001
                pass
        if self._we_armed:
            try:
                self.link.disarm()
            except Exception:  # noqa: BLE001
                self._event("disarm failed")
        try:
            self.link.close()
        except Exception:  # noqa: BLE001
            pass
