"""The detection thread's loop, one for every camera path (no OpenCV at import: ``fly`` loads it lazily).

:class:`DetectionLoop` is the loop of :class:`auvdock.fly.dock_tracker.DockTracker` (``dock.source:
camera``) and :class:`auvdock.fly.camera_sensor.CameraSensor` (``sensors.dock_camera``).
"""

from __future__ import annotations

import collections
import threading
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from auvdock.camera.video_in import Frame, LatestFrameGrabber
    from auvdock.runtime.clock import Clock

__all__ = ["DetectionLoop"]


class DetectionLoop:
    """The detection thread's loop, one for every camera path (:class:`auvdock.fly.dock_tracker.DockTracker`,
    :class:`auvdock.fly.camera_sensor.CameraSensor`): take each new frame from ``grabber`` (the newest:
    slow detection drops frames, it never lags), count it, ``process`` it, keep what it gives in
    ``_fixes`` (under ``_lock``) until ``_stop``; the grabber's error, or one of ``process``, ends it and
    is kept in ``error`` (the control loop then sees no fixes and says so)."""

    grabber: LatestFrameGrabber
    clock: Clock
    _thread: threading.Thread | None
    _stop: threading.Event
    _lock: threading.Lock
    _fixes: collections.deque[Any]
    frames: int
    frames_with_fix: int
    error: BaseException | None

    def process(self, frame: Frame) -> Any:  # pragma: no cover - each path's own
        raise NotImplementedError

    def _start_thread(self, name: str) -> None:
        """Start the loop in a thread of the clock (once)."""
        if self._thread is None:
            self._thread = self.clock.start_thread(self._loop, name=name)

    def stop(self) -> None:
        """Stop the thread and the frame source (never raises)."""
        self._stop.set()
        try:
            self.grabber.stop()
        except Exception:  # noqa: BLE001
            pass
        if self._thread is not None and self._thread.is_alive():
            self.clock.join(self._thread, timeout=2.0)

    def _loop(self) -> None:
        last = -1
        try:
            while not self._stop.is_set():
                frame = self.grabber.wait_new(last, timeout_s=0.2)
                if frame is None:
                    if self.grabber.error is not None:
                        self.error = self.grabber.error
                        return
                    continue
                last = frame.index
                self.frames += 1
                fix = self.process(frame)
                if fix is not None:
                    self.frames_with_fix += 1
                    with self._lock:
                        self._fixes.append(fix)
        except Exception as e:  # noqa: BLE001 -- kept in .error: the control loop sees no fixes
            self.error = e
