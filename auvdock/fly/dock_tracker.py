"""Dock tracking for ``auvdock fly`` with ``dock.source: camera``.

Pieces, each small:

* :class:`SyntheticCamera` -- a frame source that renders the dock's markers
  (:func:`auvdock.camera.render.render_view`) from the vehicle's latest pose, for rehearsal
  with ``auvdock vehicle-sim`` and for tests (``camera.source: synthetic``);
* :class:`DockTracker` -- a background thread that takes the newest camera frame
  (:class:`auvdock.camera.video_in.LatestFrameGrabber`: slow detection drops frames, it never
  lags), detects the markers, fuses the dock pose (:func:`auvdock.camera.pose.estimate_dock_pose`)
  and turns it into a dock position in the mission's NED frame with the vehicle pose at the
  frame's capture time, as a :class:`DockFix` with its covariance and latency;
* :class:`TrackingMonitor` -- the lost-tracking state machine the control loop consults
  every step: ``tracking`` while the last fix is younger than ``camera.hold_s`` (the
  controller flies on the tracking filter's prediction between frames), ``holding``
  (neutral thrust) until ``camera.abort_s``, then ``lost`` (the session aborts).

The tracking filter itself is :class:`auvdock.world.dock.TrackedDock` with a process noise: a
Kalman filter on the dock's offset from its heave model, so between frames the dock moves as
the heave model predicts (Assumption 2) and each fix is weighed by its covariance.

Detection runs in its own thread (OpenCV releases the GIL in its image work), so the 20 Hz
control loop never waits for a frame.

Every wait, frame pacing and time stamp goes through a :class:`auvdock.runtime.clock.Clock` (the
wall clock by default): with the fly session's :class:`auvdock.runtime.clock.SimClock` the synthetic
camera, the frame grabber and the detection thread run in lockstep with the control loop,
and rendering and detection take no simulated time (latency 0).
"""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from auvdock.camera.detection_loop import DetectionLoop
from auvdock.camera.layout import MarkerLayout
from auvdock.camera.model import CameraModel, CameraMount, camera_from_dock
from auvdock.camera.pose import MarkerDetector, estimate_dock_pose
from auvdock.camera.render import Water, render_view
from auvdock.camera.video_in import Frame, FrameSource, LatestFrameGrabber
from auvdock.runtime.clock import Clock, wall_clock
from auvdock.vehicle.geometry import rotation_zyx
from auvdock.vehicle.state import POS
from auvdock.world.dock import TranslatingDock

if TYPE_CHECKING:
    from auvdock.config.mission import Mission

__all__ = ["SyntheticCamera", "DockFix", "DockTracker", "TrackingMonitor"]

PoseFn = Callable[[], "tuple[float, np.ndarray] | None"]


class SyntheticCamera:
    """Rendered camera frames of the dock's markers from the vehicle's current pose.

    Parameters
    ----------
    camera : CameraModel
        Intrinsics of the rendered camera.
    layout : MarkerLayout
        The markers on the dock.
    mount : CameraMount
        Camera pose on the vehicle.
    dock : TranslatingDock
        Where the dock really is (the mission's dock, possibly moved by ``offset_ned_m``).
    pose_fn : callable
        ``pose_fn() -> (t, eta)``: mission time (s) and vehicle pose (6,) in the mission
        frame, or None before the first telemetry.
    rate_hz : float
        Frame rate, Hz (frames are paced on ``clock``).
    noise_std, blur_px : float
        Image noise (grey levels) and Gaussian blur (px).
    offset_ned_m : array_like (3,)
        Displacement of the rendered dock from ``dock`` (NED, m).
    dropout_s : list of (start, end)
        Mission-time windows (s) in which the markers are hidden (blank frames).
    seed : int
        Noise seed.
    clock : Clock, optional
        What frames are paced on and stamped with (default the wall clock).
    water : Water, optional
        The water between camera and markers (:class:`auvdock.camera.render.Water`: each marker's
        contrast attenuated with its range); None: clear.
    """

    def __init__(
        self,
        camera: CameraModel,
        layout: MarkerLayout,
        mount: CameraMount,
        dock: TranslatingDock,
        pose_fn: PoseFn,
        *,
        rate_hz: float = 15.0,
        noise_std: float = 2.0,
        blur_px: float = 0.5,
        offset_ned_m: np.ndarray | Sequence[float] = (0.0, 0.0, 0.0),
        dropout_s: list[list[float]] | None = None,
        seed: int = 0,
        clock: Clock | None = None,
        water: Water | None = None,
    ) -> None:
        if rate_hz <= 0:
            raise ValueError(f"rate_hz must be positive, got {rate_hz}")
        self.camera, self.layout, self.mount, self.dock = camera, layout, mount, dock
        self.pose_fn = pose_fn
        self.period = 1.0 / float(rate_hz)
        self.noise_std, self.blur_px = float(noise_std), float(blur_px)
        self.offset = np.asarray(offset_ned_m, dtype=float)
        self.dropout = [(float(a), float(b)) for a, b in (dropout_s or [])]
        self._rng = np.random.default_rng(seed)
        self.water = water
        self.clock: Clock = wall_clock if clock is None else clock
        self._next = self.clock.now()
        self._index = 0
        self._closed = False
        self.description = f"synthetic camera {camera.width}x{camera.height} at {rate_hz:g} Hz"

    @classmethod
    def from_mission(
        cls,
        mission: Mission,
        dock: TranslatingDock,
        pose_fn: PoseFn,
        *,
        seed: int | None = None,
        clock: Clock | None = None,
    ) -> SyntheticCamera:
        """The mission's synthetic camera: ``mission.build_camera()``, ``camera.mount``, the
        dock's markers and ``camera.synthetic`` (rate, noise, blur, dock offset, dropouts),
        rendering ``dock``; image noise seeded with ``seed`` (default ``mission.seed``).

        Raises ``MissionError`` for a camera file that is missing or does not read."""
        c = mission.camera
        sy = c.synthetic
        return cls(
            mission.build_camera(),
            mission.dock.marker_layout(),
            c.mount.build(),
            dock,
            pose_fn,
            rate_hz=sy.rate_hz,
            noise_std=sy.noise_std,
            blur_px=sy.blur_px,
            offset_ned_m=sy.dock_offset_m,
            dropout_s=sy.dropout_s,
            seed=mission.seed if seed is None else int(seed),
            clock=clock,
        )

    def hidden(self, t: float) -> bool:
        """Whether the markers are hidden at mission time ``t`` (s)."""
        return any(a <= t < b for a, b in self.dropout)

    def render(self, t: float, eta: np.ndarray) -> np.ndarray:
        """The camera's view (h, w) uint8 with the vehicle at pose ``eta`` (6,) at mission time ``t`` (s).

        The dock at ``t`` (moved by ``offset_ned_m``), image noise and blur from this camera's
        seeded generator; a blank grey frame inside a dropout window.  No pacing.
        """
        if self.hidden(t):
            return np.full((self.camera.height, self.camera.width), 110, dtype=np.uint8)
        p_dock = self.dock.position(t) + self.offset
        R_cd, t_cd = camera_from_dock(eta, p_dock, self.dock.heading_rad, self.mount)
        return render_view(
            self.camera,
            self.layout,
            R_cd,
            t_cd,
            noise_std=self.noise_std,
            blur_px=self.blur_px,
            rng=self._rng,
            water=self.water,
        )

    def read(self, timeout_s: float = 1.0) -> Frame | None:
        """The next frame (paced at the frame rate), or None on timeout / before any pose."""
        clock = self.clock
        deadline = clock.now() + timeout_s
        while not self._closed:
            now = clock.now()
            if now < self._next:
                if self._next > deadline:
                    clock.sleep(max(0.0, deadline - now))
                    return None
                clock.sleep(self._next - now)
            self._next = max(self._next + self.period, clock.now())
            pose = self.pose_fn()
            if pose is None:
                if clock.now() > deadline:
                    return None
                continue
            t, eta = pose
            t_capture = clock.now()
            img = self.render(t, eta)
            self._index += 1
            return Frame(image=img, t_capture=t_capture, index=self._index, pts_s=t)
        return None

    def close(self) -> None:
        self._closed = True

    def __enter__(self) -> SyntheticCamera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass
class DockFix:
    """One camera measurement of the dock.

    Attributes
    ----------
    t : float
        Mission time of the frame's capture, s.
    position_ned_m : ndarray (3,)
        Dock origin (docking point) in the mission's NED frame, m.
    covariance_ned_m2 : ndarray (3, 3)
        Its covariance, m^2 (camera pose covariance rotated into NED).
    yaw_rel_rad : float
        Dock heading relative to the vehicle's, rad.
    markers : int
        Markers used in the fused pose.
    reprojection_px : float
        RMS reprojection error of the fused pose, px.
    latency_s : float
        From the frame's capture to the fix being ready, s.
    """

    t: float
    position_ned_m: np.ndarray
    covariance_ned_m2: np.ndarray
    yaw_rel_rad: float
    markers: int
    reprojection_px: float
    latency_s: float


class DockTracker(DetectionLoop):
    """Detect the dock's markers in a background thread and publish :class:`DockFix` es.

    Parameters
    ----------
    source : FrameSource
        Any source with ``read(timeout_s)`` and ``close()`` (:mod:`auvdock.camera.video_in`,
        :class:`SyntheticCamera`).
    camera, layout, mount :
        Intrinsics, dock markers, camera pose on the vehicle.
    pose_at : callable
        ``pose_at(t_capture) -> (t, eta) | None``: the mission time and the vehicle's pose
        (6,) at a clock instant (the control loop's pose history).
    max_reprojection_px : float
        Marker rejection threshold of the fused pose, px.
    clock : Clock, optional
        What the thread waits on and latencies are measured with (default the wall clock;
        the source must use the same clock).
    """

    def __init__(
        self,
        source: FrameSource,
        camera: CameraModel,
        layout: MarkerLayout,
        mount: CameraMount,
        pose_at: Callable[[float], tuple[float, np.ndarray] | None],
        *,
        max_reprojection_px: float = 3.0,
        clock: Clock | None = None,
    ) -> None:
        self.clock: Clock = wall_clock if clock is None else clock
        self.camera, self.layout, self.mount = camera, layout, mount
        self.detector = MarkerDetector(layout, camera)
        self.pose_at = pose_at
        self.max_reprojection_px = float(max_reprojection_px)
        self.grabber = LatestFrameGrabber(source, clock=self.clock)
        self._fixes: collections.deque[DockFix] = collections.deque(maxlen=100)
        self._lock = threading.Lock()
        self._stop = self.clock.event()
        self._thread: threading.Thread | None = None
        self.frames = 0
        self.frames_with_fix = 0
        self.error: BaseException | None = None

    def start(self) -> DockTracker:
        self._start_thread("auvdock-dock-tracker")
        return self

    def fixes(self) -> list[DockFix]:
        """The fixes made since the last call (oldest first)."""
        with self._lock:
            out = list(self._fixes)
            self._fixes.clear()
        return out

    def process(self, frame: Frame) -> DockFix | None:
        """One frame to a fix (None: no consistent markers or no pose for its time)."""
        pose_t = self.pose_at(frame.t_capture)
        if pose_t is None:
            return None
        t, eta = pose_t
        detections = self.detector.detect(frame.image)
        pose = estimate_dock_pose(
            detections, self.layout, self.camera, max_reproj_px=self.max_reprojection_px
        )
        if pose is None:
            return None
        p_b, yaw_rel, cov4 = pose.in_body(self.mount)
        R_nb = rotation_zyx(float(eta[3]), float(eta[4]), float(eta[5]))
        p_ned = np.asarray(eta[POS], dtype=float) + R_nb @ p_b
        cov_ned = R_nb @ cov4[0:3, 0:3] @ R_nb.T
        return DockFix(
            t=t,
            position_ned_m=p_ned,
            covariance_ned_m2=cov_ned,
            yaw_rel_rad=float(yaw_rel),
            markers=len(pose.markers_used),
            reprojection_px=float(pose.reproj_rms_px),
            latency_s=self.clock.now() - frame.t_capture,
        )


class TrackingMonitor:
    """Lost-tracking states from the age of the last fix.

    ``tracking`` (age <= hold_s), ``holding`` (hold_s < age <= abort_s: neutral thrust),
    ``lost`` (age > abort_s: abort).  Before the first fix the age counts from the start.
    :meth:`update` returns the state and an event text when it changed (else None).
    """

    def __init__(self, hold_s: float, abort_s: float) -> None:
        if not 0 < hold_s < abort_s:
            raise ValueError(f"need 0 < hold_s < abort_s, got {hold_s} and {abort_s}")
        self.hold_s, self.abort_s = float(hold_s), float(abort_s)
        self.last_fix_t: float | None = None
        self.state = "searching"
        self.losses = 0

    def age(self, t: float) -> float:
        """Seconds since the last fix (since t = 0 before the first)."""
        return t - (0.0 if self.last_fix_t is None else self.last_fix_t)

    def update(self, t: float, fix_t: float | None) -> tuple[str, str | None]:
        """The state at mission time ``t`` (s), given the newest fix's time (None: no new fix)."""
        previous = self.last_fix_t
        if fix_t is not None:
            self.last_fix_t = fix_t if self.last_fix_t is None else max(self.last_fix_t, fix_t)
        age = self.age(t)
        if self.last_fix_t is None:
            new = "searching" if age <= self.abort_s else "lost"
        elif age <= self.hold_s:
            new = "tracking"
        elif age <= self.abort_s:
            new = "holding"
        else:
            new = "lost"
        event = None
        if new != self.state:
            if new == "tracking" and self.state == "searching":
                event = f"camera: dock found at t = {t:.2f} s"
            elif new == "tracking":
                gap = (self.last_fix_t or 0.0) - (previous or 0.0)
                event = f"camera: dock recovered at t = {t:.2f} s (no fix for {gap:.2f} s)"
            elif new == "holding":
                self.losses += 1
                event = f"camera: dock lost for {age:.2f} s: neutral thrust, holding"
            elif new == "lost" and self.last_fix_t is None:
                event = f"camera: no dock markers seen within {self.abort_s:g} s"
            else:
                event = f"camera: dock lost for {age:.2f} s (limit {self.abort_s:g} s)"
            self.state = new
        return new, event
