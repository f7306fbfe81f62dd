"""Camera dock tracking inside a fly session (``dock.source: camera``).

:class:`CameraTracking` owns the frame source (synthetic or a real camera), the detection
thread (:class:`auvdock.fly.dock_tracker.DockTracker`) and the lost-tracking state machine
(:class:`auvdock.fly.dock_tracker.TrackingMonitor`); every control step it feeds the new fixes
to the dock filter and says whether the controller may steer (``tracking``), must hold
neutral (``searching`` / ``holding``) or the session must abort (``lost``).
"""

from __future__ import annotations

import collections
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from auvdock.config.mission import Mission
from auvdock.runtime.clock import Clock
from auvdock.vehicle.state import ETA
from auvdock.world.dock import TrackedDock, TranslatingDock

if TYPE_CHECKING:
    from auvdock.camera.video_in import FrameSource
    from auvdock.fly.dock_tracker import DockFix

__all__ = ["CAMERA_STATES", "CAMERA_SERIES", "CameraTracking", "CameraOpenError"]

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


class CameraOpenError(RuntimeError):
    """The mission's camera source could not be opened (the message says why)."""


class CameraTracking:
    """The camera side of a session: source, detection thread, lost-tracking monitor.

    Parameters
    ----------
    mission : Mission
        ``camera`` settings and the dock's markers.
    model_dock : TranslatingDock
        The mission's dock (what the synthetic camera renders, moved by its offset).
    dock : TrackedDock
        The dock filter the fixes update.
    clock : Clock
        The session's clock (frames, detection and the pose history share it).
    on_event : callable
        ``on_event(text)`` for found / lost / recovered and camera errors.
    """

    def __init__(
        self,
        mission: Mission,
        model_dock: TranslatingDock,
        dock: TrackedDock,
        clock: Clock,
        on_event: Callable[[str], None],
    ) -> None:
        from auvdock.fly.dock_tracker import DockTracker, SyntheticCamera, TrackingMonitor

        self.dock = dock
        self.clock = clock
        self._on_event = on_event
        self._pose_hist: collections.deque[tuple[float, float, np.ndarray]] = collections.deque(maxlen=400)
        self._last_fix: DockFix | None = None
        self._error_reported = False
        c = mission.camera
        cam = mission.build_camera()
        layout = mission.dock.marker_layout()
        mount = c.mount.build()
        if c.source == "synthetic":
            self.source: FrameSource = SyntheticCamera.from_mission(
                mission, model_dock, self.latest_pose, clock=clock
            )
        else:
            from auvdock.camera.video_in import open_source

            try:
                self.source = open_source(c.source, clock=clock)
            except (OSError, ValueError, RuntimeError) as e:
                raise CameraOpenError(f"camera: {e}") from None
        self.tracker = DockTracker(
            self.source,
            cam,
            layout,
            mount,
            self.pose_at,
            max_reprojection_px=c.max_reprojection_px,
            clock=clock,
        )
        self.monitor = TrackingMonitor(c.hold_s, c.abort_s)

    @property
    def description(self) -> str:
        return str(getattr(self.source, "description", type(self.source).__name__))

    def start(self, x0: np.ndarray) -> None:
        """Start detecting, with the vehicle's first pose (mission time 0)."""
        self.record_pose(0.0, x0)
        self.tracker.start()

    def stop(self) -> None:
        """Stop the detection thread and the source (never raises)."""
        self.tracker.stop()

    # -- the vehicle's poses, for the frames' capture instants ----------------------------------
    def record_pose(self, t: float, x: np.ndarray) -> None:
        """The control loop's state at mission time ``t`` (stamped with the clock's now)."""
        self._pose_hist.append((self.clock.now(), t, x))

    def latest_pose(self) -> tuple[float, np.ndarray] | None:
        """The newest (mission time, pose (6,)) the control loop saw, or None."""
        if not self._pose_hist:
            return None
        _, t, x = self._pose_hist[-1]
        return t, x[ETA]

    def pose_at(self, t_clock: float) -> tuple[float, np.ndarray] | None:
        """(mission time, pose) of the control step nearest to a clock instant."""
        hist = list(self._pose_hist)
        if not hist:
            return None
        best = min(hist, key=lambda h: abs(h[0] - t_clock))
        return best[1], best[2][0:6]

    # -- every control step -----------------------------------------------------------------------
    def step(self, t: float) -> tuple[str, dict[str, np.ndarray]]:
        """Feed new fixes to the dock filter; the tracking state and the series to record."""
        fixes = self.tracker.fixes()
        for f in fixes:
            self.dock.update(f.t, f.position_ned_m, f.covariance_ned_m2)
        if fixes:
            self._last_fix = fixes[-1]
        state, event = self.monitor.update(t, fixes[-1].t if fixes else None)
        if event is not None:
            self._on_event(event)
        if self.tracker.error is not None and not self._error_reported:
            self._error_reported = True
            self._on_event(f"camera: {self.tracker.error}")
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
