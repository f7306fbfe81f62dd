"""Fly a real BlueROV2 (ArduSub) to the dock: the sim's controller step on MAVLink telemetry.

One session (:class:`FlySession`)::

    connect (wait for the ArduSub HEARTBEAT) -> request telemetry rates -> wait for pose
    -> [--arm: MANUAL mode, arm]  -> every dt: telemetry -> Measurement -> Autopilot.step
    -> thrust -> RC override channels (ArduSub's mixer inverted) -> send
    -> end: neutral overrides, release, disarm if we armed, results closed

Only where measurements come from and where commands go differ from ``auvdock sim``: the
controller-and-estimator step is the same :class:`auvdock.autopilot.Autopilot`.

Frames.  The mission is written in its own NED frame, in which the vehicle starts at
``start.state``.  The vehicle's telemetry (LOCAL_POSITION_NED, ATTITUDE) is in the
autopilot's frame; at the start the session maps the vehicle's pose onto the mission's
start pose (translation and a rotation about down), and every later reading through the
same map.  The dock (``dock.source: model``) is therefore where the mission puts it
relative to the start, as in the paper's tank trials.

Safety (each ends the session the same way: neutral overrides, override release, disarm
if we armed, results closed):

* nothing is armed without ``arm=True`` (``--arm``); without it the session is a dry run
  that computes and records commands but sends only neutral overrides;
* no ATTITUDE or position for ``fly.stale_neutral_s`` (0.3 s): neutral at once; for
  ``fly.stale_abort_s`` (2 s): abort;
* leaving the geofence (``fly.geofence``) aborts;
* overrides are streamed at the control rate for the whole session (ArduSub disarms after
  3 s without pilot input).

The controllers that need the flow (Kinematic, Oracle) are given the mission's flow model
(still water in the tank).  The flow-estimating controllers get the accelerometer
(SCALED_IMU2), the depth rate and the relative velocity ``nu_1 - R^T v_c(model)``.
"""

from __future__ import annotations

import collections
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil

from .autopilot import Autopilot
from .controllers import Measurement
from .dock import HeaveDock, TrackedDock
from .hardware.ardusub import NEUTRAL_CHANNELS, channels_for_thrust
from .hardware.link import LinkError, MavlinkLink
from .mission import Mission
from .results import STATUS_FALLBACK_ZERO, STATUS_NAMES, RunWriter
from .simulation import run_outcome

__all__ = ["FlySession", "FlyResult", "FlyAbortError", "TELEMETRY_MESSAGES", "CAMERA_STATES"]

#: ``camera_state`` codes recorded with dock.source: camera (index into this tuple).
CAMERA_STATES = ("searching", "tracking", "holding", "lost")
#: Per-step series recorded with dock.source: camera (name -> per-row shape).
CAMERA_SERIES = {
    "camera_fix_age_s": (),
    "camera_state": (),
    "camera_markers": (),
    "camera_latency_s": (),
    "camera_dock_position_m": (3,),
    "camera_fixes": (),
}

G = 9.80665
TELEMETRY_MESSAGES = ("ATTITUDE", "LOCAL_POSITION_NED", "SCALED_IMU2", "SCALED_PRESSURE2", "SERVO_OUTPUT_RAW")


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


def _rz(psi: float) -> np.ndarray:
    c, s = math.cos(psi), math.sin(psi)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class FlySession:
    """One docking session on a vehicle.

    Parameters
    ----------
    mission : Mission
        The mission (controller, dock, geofence, telemetry settings).
    link : MavlinkLink
        The link (not yet connected).
    arm : bool
        Arm and command thrust; False: dry run, neutral overrides only.
    out : str or Path
        Results file (the ``auvdock sim`` layout plus telemetry series).
    controller : str, optional
        Override of the mission's controller.
    timeout_s : float, optional
        Override of ``docking.timeout_s``.
    connect_timeout_s : float
        How long to wait for the vehicle's HEARTBEAT and first telemetry.
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
        self.arm_vehicle = bool(arm)
        self.out = Path(out)
        self.timeout_s = mission.docking.timeout_s if timeout_s is None else float(timeout_s)
        self.connect_timeout_s = connect_timeout_s
        self.vehicle = mission.build_vehicle()
        self.dock: HeaveDock | TrackedDock = mission.build_dock()
        self._model_dock = self.dock
        if mission.dock.source == "mavlink":
            self.dock = TrackedDock(self.dock)
        self.tracker = None
        self.monitor = None
        self._camera_source = None
        self._pose_hist: collections.deque[tuple[float, float, np.ndarray]] = collections.deque(maxlen=400)
        if mission.dock.source == "camera":
            self.dock = TrackedDock(self.dock, process_noise=mission.camera.process_noise_m_s)
            mission.build_camera()  # a missing or bad camera file is a mission error, before connecting
        self.flow = mission.build_flow()
        self.autopilot = Autopilot(mission, self.vehicle, self.dock, controller)
        self.dt = mission.controller.dt_s
        self.events: list[tuple[float, str]] = []
        self._t0 = time.monotonic()
        self._last_fix = None
        self._camera_error_reported = False
        self._we_armed = False
        self._last_target: int | None = None
        rot = self.vehicle.model.function("rotation")
        self._R = lambda angles: np.asarray(rot(angles))
        self.link.on_event = self._event

    # ------------------------------------------------------------------------------------
    def _build_camera(self) -> None:
        """The frame source, the detection thread and the lost-tracking monitor (not started)."""
        from .camera.model import CameraMount
        from .camera.tracker import DockTracker, SyntheticCamera, TrackingMonitor

        c = self.mission.camera
        cam = self.mission.build_camera()
        layout = self.mission.dock.marker_layout()
        mount = CameraMount(tuple(c.mount.position_body_m), tuple(c.mount.rpy_deg))
        if c.source == "synthetic":
            sy = c.synthetic
            self._camera_source = SyntheticCamera(
                cam,
                layout,
                mount,
                self._model_dock,
                self._latest_pose,
                rate_hz=sy.rate_hz,
                noise_std=sy.noise_std,
                blur_px=sy.blur_px,
                offset_ned_m=sy.dock_offset_m,
                dropout_s=sy.dropout_s,
                seed=self.mission.seed,
            )
        else:
            from .camera.video import open_source

            try:
                self._camera_source = open_source(c.source)
            except (OSError, ValueError, RuntimeError) as e:
                raise FlyAbortError(f"camera: {e}") from None
        self.tracker = DockTracker(
            self._camera_source, cam, layout, mount, self._pose_at, max_reprojection_px=c.max_reprojection_px
        )
        self.monitor = TrackingMonitor(c.hold_s, c.abort_s)

    def _latest_pose(self) -> tuple[float, np.ndarray] | None:
        """The newest (mission time, pose (6,)) the control loop saw, or None."""
        if not self._pose_hist:
            return None
        _, t, x = self._pose_hist[-1]
        return t, x[0:6]

    def _pose_at(self, t_mono: float) -> tuple[float, np.ndarray] | None:
        """(mission time, pose) of the control step nearest to a ``time.monotonic()`` instant."""
        hist = list(self._pose_hist)
        if not hist:
            return None
        best = min(hist, key=lambda h: abs(h[0] - t_mono))
        return best[1], best[2][0:6]

    def _camera_step(self, t: float) -> tuple[str, dict[str, np.ndarray]]:
        """Feed new camera fixes to the dock filter; the tracking state and series to record."""
        fixes = self.tracker.fixes()
        for f in fixes:
            self.dock.update(f.t, f.position_ned_m, f.covariance_ned_m2)
        if fixes:
            self._last_fix = fixes[-1]
        state, event = self.monitor.update(t, fixes[-1].t if fixes else None)
        if event is not None:
            self._event(event)
        if self.tracker.error is not None and not self._camera_error_reported:
            self._camera_error_reported = True
            self._event(f"camera: {self.tracker.error}")
        last = self._last_fix
        series = {
            "camera_fix_age_s": np.asarray(self.monitor.age(t)),
            "camera_state": np.asarray(float(CAMERA_STATES.index(state))),
            "camera_markers": np.asarray(float(last.markers if last else 0)),
            "camera_latency_s": np.asarray(last.latency_s if last else np.nan),
            "camera_dock_position_m": last.position_ned_m if last else np.full(3, np.nan),
            "camera_fixes": np.asarray(float(len(fixes))),
        }
        return state, series

    def _event(self, text: str) -> None:
        self.events.append((time.monotonic() - self._t0, text))

    def _stale(self) -> float:
        _, a = self.link.latest("ATTITUDE")
        _, p = self.link.latest("LOCAL_POSITION_NED")
        return max(a, p)

    def _wait_telemetry(self) -> None:
        deadline = time.monotonic() + self.connect_timeout_s
        while time.monotonic() < deadline:
            self.link.send_neutral()
            if self._stale() < 0.5:
                return
            time.sleep(self.dt)
        raise FlyAbortError(
            f"no ATTITUDE and LOCAL_POSITION_NED from {self.link.port} within {self.connect_timeout_s:g} s "
            "(does the autopilot have a position source and origin?)"
        )

    def _vehicle_pose(self) -> tuple[np.ndarray, float]:
        att, _ = self.link.latest("ATTITUDE")
        pos, _ = self.link.latest("LOCAL_POSITION_NED")
        return np.array([pos.x, pos.y, pos.z]), float(att.yaw)

    def _set_frame(self) -> None:
        """Map the vehicle's current pose onto the mission's start pose."""
        p, psi = self._vehicle_pose()
        x0 = self.mission.start_state()
        self._dpsi = _wrap(float(x0[5]) - psi)
        self._Rf = _rz(self._dpsi)
        self._p_vehicle0 = p
        self._p_mission0 = x0[0:3].copy()
        self._event(
            f"frame: vehicle start ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) m, "
            f"heading {math.degrees(psi):.1f} deg -> mission start "
            f"({x0[0]:.2f}, {x0[1]:.2f}, {x0[2]:.2f}) m, {math.degrees(x0[5]):.1f} deg"
        )

    def _state(self) -> np.ndarray:
        """The vehicle state in the mission frame from the latest telemetry (12,)."""
        att, _ = self.link.latest("ATTITUDE")
        pos, _ = self.link.latest("LOCAL_POSITION_NED")
        p = self._p_mission0 + self._Rf @ (np.array([pos.x, pos.y, pos.z]) - self._p_vehicle0)
        v_ned = self._Rf @ np.array([pos.vx, pos.vy, pos.vz])
        theta = np.array([att.roll, att.pitch, _wrap(att.yaw + self._dpsi)])
        nu1 = self._R(theta).T @ v_ned
        nu2 = np.array([att.rollspeed, att.pitchspeed, att.yawspeed])
        return np.concatenate([p, theta, nu1, nu2])

    def _sensors(self, x: np.ndarray, flow_ned: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
        R = self._R(x[3:6])
        sensors: dict[str, np.ndarray] = {
            "pose": x[0:6].copy(),
            "gyro_rad_s": x[9:12].copy(),
            "depth_rate_m_s": np.asarray(float(R[2] @ x[6:9])),
            "relative_velocity_m_s": x[6:9] - R.T @ flow_ned,
        }
        imu, age = self.link.latest("SCALED_IMU2")
        f_b = np.full(3, np.nan)
        if imu is not None and age < 0.5:
            f_b = np.array([imu.xacc, imu.yacc, imu.zacc]) * G / 1000.0  # specific force, m/s^2
            a_b = f_b + R.T @ np.array([0.0, 0.0, G])  # acceleration over ground in {b}
            sensors["accel_m_s2"] = a_b - np.cross(x[9:12], x[6:9])  # d(nu_1)/dt
        return sensors, f_b

    def _landing_target(self, t: float, x: np.ndarray) -> float:
        """Re-anchor the dock from the latest LANDING_TARGET; returns its age (s).

        Accepted frames: MAV_FRAME_BODY_FRD (x, y, z from the vehicle in {b}) and
        MAV_FRAME_LOCAL_NED (the autopilot's NED frame, mapped to the mission frame).
        Messages without ``position_valid`` are ignored.
        """
        lt, age = self.link.latest("LANDING_TARGET")
        if lt is None or not getattr(lt, "position_valid", 0):
            return float("inf")
        if id(lt) == self._last_target:
            return age
        self._last_target = id(lt)
        rel = np.array([lt.x, lt.y, lt.z])
        if lt.frame == mavutil.mavlink.MAV_FRAME_BODY_FRD:
            p = x[0:3] + self._R(x[3:6]) @ rel
        elif lt.frame == mavutil.mavlink.MAV_FRAME_LOCAL_NED:
            p = self._p_mission0 + self._Rf @ (rel - self._p_vehicle0)
        else:
            return float("inf")
        self.dock.update(t, p)
        return age

    def _geofence(self, x: np.ndarray) -> str | None:
        g = self.mission.fly.geofence
        horiz = float(np.linalg.norm(x[0:2] - self._p_mission0[0:2]))
        if horiz > g.max_distance_m:
            return f"geofence: {horiz:.2f} m from the start (limit {g.max_distance_m:g} m)"
        if x[2] < g.min_depth_m:
            return f"geofence: depth {x[2]:.2f} m above the minimum {g.min_depth_m:g} m"
        if x[2] > g.max_depth_m:
            return f"geofence: depth {x[2]:.2f} m below the maximum {g.max_depth_m:g} m"
        return None

    # ------------------------------------------------------------------------------------
    def run(self, progress=None) -> FlyResult:
        """Fly the session to its end; never raises for the vehicle's or the link's behaviour.

        ``progress(t, distance_m, status_text)`` is called every step if given.  Ctrl-C
        (KeyboardInterrupt) ends the session like an abort, with reason "interrupted".
        """
        m = self.mission
        writer: RunWriter | None = None
        states: list[np.ndarray] = []
        distances: list[float] = []
        solve_times: list[float] = []
        statuses: list[int] = []
        reason, message = "timeout", f"not docked within {self.timeout_s:g} s"
        docked, contact, t_end = False, None, 0.0
        try:
            try:
                self.link.connect(timeout_s=self.connect_timeout_s)
            except LinkError as e:
                raise FlyAbortError(str(e)) from None
            rate = m.fly.telemetry_rate_hz
            for name in TELEMETRY_MESSAGES:
                msg_id = getattr(mavutil.mavlink, f"MAVLINK_MSG_ID_{name}")
                try:
                    result = self.link.request_rate(msg_id, rate)
                    self._event(f"rate {name} {rate:g} Hz: MAV_RESULT {result}")
                except LinkError as e:
                    self._event(f"rate {name}: {e}")
                self.link.send_neutral()
            self._wait_telemetry()
            self._set_frame()
            if m.dock.source == "camera":
                self._build_camera()
                self._pose_hist.append((time.monotonic(), 0.0, self._state()))
                self.tracker.start()
                self._event(f"camera: {self._camera_source.description}")
            if self.arm_vehicle:
                self.link.send_neutral()
                self.link.set_mode("MANUAL")
                self.link.send_neutral()
                try:
                    self.link.arm()
                except LinkError as e:
                    raise FlyAbortError(str(e)) from None
                self._we_armed = True
            else:
                self._event("dry run: not arming, sending neutral overrides only")

            writer = RunWriter(
                self.out,
                "/",
                mission_yaml=m.to_yaml(),
                mission_name=m.name,
                controller=self.autopilot.name,
                extra_series={
                    **self.autopilot.extra_series,
                    "channels_us": (6,),
                    "telemetry_age_s": (2,),
                    "imu_specific_force_m_s2": (3,),
                    "armed": (),
                    **(CAMERA_SERIES if self.tracker is not None else {}),
                },
                attrs={
                    "tolerance_m": m.docking.tolerance_m,
                    "timeout_s": self.timeout_s,
                    "dt_s": self.dt,
                    "flow": self.flow.describe(),
                    "vehicle": self.vehicle.name,
                    "source": f"fly {self.link.port}" + ("" if self.arm_vehicle else " (dry run)"),
                },
            )
            tol = m.docking.tolerance_m
            t_start = time.monotonic()
            k = 0
            while True:
                t = k * self.dt
                if t > self.timeout_s + 1e-9:
                    break
                # pace to the control period
                wait = t_start + t - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
                stale = self._stale()
                if stale > m.fly.stale_abort_s:
                    raise FlyAbortError(f"telemetry lost: no ATTITUDE or position for {stale:.1f} s")
                if stale > m.fly.stale_neutral_s:
                    self.link.send_neutral()
                    if not self.events or not self.events[-1][1].startswith("telemetry stale"):
                        self._event(f"telemetry stale ({stale:.2f} s): neutral")
                    k += 1
                    continue
                x = self._state()
                fence = self._geofence(x)
                if fence is not None:
                    raise FlyAbortError(fence)
                self._pose_hist.append((time.monotonic(), t, x))
                cam_series: dict[str, np.ndarray] = {}
                if self.tracker is not None:
                    cam_state, cam_series = self._camera_step(t)
                    if cam_state == "lost":
                        raise FlyAbortError(self.events[-1][1] if self.events else "camera: dock lost")
                    if cam_state != "tracking":
                        # no dock to steer to: neutral thrust and hold, recorded
                        self.link.send_neutral()
                        self._append_idle(writer, t, x, cam_series)
                        k += 1
                        continue
                if m.dock.source == "mavlink":
                    age_t = self._landing_target(t, x)
                    if self.dock.measurements == 0 and t > m.fly.stale_abort_s:
                        raise FlyAbortError(
                            f"no LANDING_TARGET with a position within {m.fly.stale_abort_s:g} s"
                        )
                    if self.dock.measurements and age_t > m.fly.stale_abort_s:
                        raise FlyAbortError(f"dock lost: no LANDING_TARGET for {age_t:.1f} s")
                p_dock = self.dock.position(t)
                dist = float(np.linalg.norm(x[0:3] - p_dock))
                if dist <= tol:
                    docked, contact, t_end, reason = True, x.copy(), t, "docked"
                    message = f"docked at t = {t:.2f} s"
                    distances.append(dist)
                    break
                v_c = self.flow.velocity(x[0:3], t)
                sensors, f_b = self._sensors(x, v_c)
                out = self.autopilot.step(Measurement(t=t, state=x, flow_ned=v_c, sensors=sensors))
                channels = channels_for_thrust(out.thrust, self.vehicle.allocation)
                if self.arm_vehicle:
                    self.link.send_override(channels)
                else:
                    self.link.send_neutral()
                series = dict(out.series)
                if "flow_body_true_m_s" in self.autopilot.extra_series:
                    series["flow_body_true_m_s"] = self._R(x[3:6]).T @ v_c
                self._record(
                    writer,
                    t,
                    x,
                    thrust=out.thrust,
                    status=out.status,
                    solve_time_s=out.solve_time_s,
                    channels=channels if self.arm_vehicle else NEUTRAL_CHANNELS,
                    specific_force=f_b,
                    series={**series, **cam_series},
                )
                states.append(x)
                distances.append(dist)
                solve_times.append(out.solve_time_s)
                statuses.append(out.status)
                t_end = t
                if progress is not None:
                    progress(t, dist, STATUS_NAMES.get(out.status, str(out.status)))
                k += 1
        except FlyAbortError as e:
            reason, message = "aborted", str(e)
            self._event(f"abort: {message}")
        except KeyboardInterrupt:
            reason, message = "interrupted", "interrupted (Ctrl-C)"
            self._event(message)
        finally:
            self._end()
        self._event(f"end: {reason}: {message}")
        outcome: dict[str, Any] = {}
        if writer is not None:
            if states:
                outcome = run_outcome(
                    docked=docked,
                    t_end=t_end,
                    states=states,
                    distances=distances,
                    solve_times=solve_times,
                    statuses=statuses,
                    contact_state=contact,
                    dock_velocity=self.dock.velocity(t_end) if docked else None,
                    dock_heading=self.dock.heading_rad,
                    rotation=self._R,
                    wall_time_s=time.monotonic() - self._t0,
                    reason=reason,
                )
            outcome["reason"] = reason
            outcome["message"] = message
            outcome["events_json"] = json.dumps(self.events)
            outcome["armed_by_us"] = self._we_armed
            writer.finish(outcome)
            writer.close()
        return FlyResult(
            reason, message, outcome, self.out if writer is not None else None, list(self.events)
        )

    def _append_idle(self, writer: RunWriter, t: float, x: np.ndarray, cam_series: dict) -> None:
        """Record a step flown with neutral thrust (no dock to steer to)."""
        series = {name: np.full(shape, np.nan) for name, shape in self.autopilot.extra_series.items()}
        self._record(
            writer,
            t,
            x,
            thrust=np.zeros(8),
            status=STATUS_FALLBACK_ZERO,
            solve_time_s=0.0,
            channels=NEUTRAL_CHANNELS,
            specific_force=np.full(3, np.nan),
            series={**series, **cam_series},
        )

    def _record(
        self,
        writer: RunWriter,
        t: float,
        x: np.ndarray,
        *,
        thrust: np.ndarray,
        status: int,
        solve_time_s: float,
        channels,
        specific_force: np.ndarray,
        series: dict[str, np.ndarray],
    ) -> None:
        """One row of the results file: the ``sim`` layout plus the telemetry series."""
        _, age_a = self.link.latest("ATTITUDE")
        _, age_p = self.link.latest("LOCAL_POSITION_NED")
        p_dock = self.dock.position(t)
        writer.append(
            time_s=t,
            state=x,
            thrust_N=thrust,
            wrench=self.vehicle.allocation @ thrust,
            flow_ned_m_s=self.flow.velocity(x[0:3], t),
            dock_position_m=p_dock,
            dock_velocity_m_s=self.dock.velocity(t),
            distance_m=float(np.linalg.norm(x[0:3] - p_dock)),
            solve_time_s=solve_time_s,
            solver_status=status,
            channels_us=channels,
            telemetry_age_s=np.array([age_a, age_p]),
            imu_specific_force_m_s2=specific_force,
            armed=np.asarray(float(self.link.armed)),
            **series,
        )

    def _end(self) -> None:
        """Neutral, release the overrides, disarm if we armed, close the link.  Never raises."""
        if self.tracker is not None:
            self.tracker.stop()
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
