"""The dock camera as a sensor of the navigation filter on a vehicle (``sensors.dock_camera``).

What ``sim`` simulates with ``sensors.dock_camera`` (a reading of kind ``dock``: the dock's docking
point in the camera frame, :mod:`auvdock.sensing.measurements`) a flight measures:
:class:`CameraSensor` takes the newest frame of the vehicle's camera (``camera.source``), runs the
real detection + pose pipeline on it in its own thread (:class:`auvdock.camera.pose.MarkerDetector`,
:func:`auvdock.camera.pose.estimate_dock_pose`, as ``sensors.dock_camera.model: rendered`` does in
``sim``) and hands each fix to the estimation stage as a :class:`auvdock.sensing.readings.Reading`
of kind ``dock`` at the frame's capture instant (mission clock), with the pipeline's standard
deviations (the position block of its covariance, corner noise floored at 0.5 px).  The navigation
filter estimates where the dock is from them (relative navigation), and the guidance
(:mod:`auvdock.loop.guidance`) approaches, searches, backs off and gives up as in ``sim``.

Frames
------
* ``camera.source: udp:PORT`` (BlueOS's RTP/H.264 stream), a device or a file: the vehicle's camera.
* ``camera.source: synthetic`` (a rehearsal): rendered here from the **simulator's true pose**, which a
  simulated vehicle sends as SIM_STATE (``vehicle-sim``; :func:`auvdock.fly.units.sim_position_ned`),
  and the mission's true dock for its seed (``dock.position_std_m`` drawn as ``sim`` draws it) on the
  vehicle's clock, in the water of ``sensors.dock_camera.visibility_m``, at
  ``sensors.dock_camera.rate_hz``.  A real vehicle sends no SIM_STATE: fly then waits for it and says
  so (:data:`SYNTHETIC_NEEDS`).

Every wait and time stamp is on the session's clock (:class:`auvdock.runtime.clock.Clock`): under a
:class:`~auvdock.runtime.clock.SimClock` rendering and detection take no simulated time.
"""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.camera.detection_loop import DetectionLoop
from auvdock.fly.units import sim_position_ned
from auvdock.runtime.clock import Clock
from auvdock.sensing.readings import Reading

if TYPE_CHECKING:
    from auvdock.camera.video_in import Frame, FrameSource
    from auvdock.config.mission import Mission
    from auvdock.world.dock import ClockedDock

__all__ = [
    "CameraSensor",
    "RecordedCamera",
    "CAMERA_SENSOR_SERIES",
    "FIX_RECORD",
    "SYNTHETIC_NEEDS",
    "sim_state_pose",
]

#: The name of the tlog-only DEBUG_FLOAT_ARRAY in which fly records each camera fix it hands the filter
#: (data: t, the fix x y z, its std x y z, markers, latency; float32), so that replay hands a replayed
#: session the same fixes at the same steps (:class:`RecordedCamera`).
FIX_RECORD = "auvd_cam"

#: Per-step series of a flight with the dock camera as a sensor (name -> per-row shape).
CAMERA_SENSOR_SERIES: dict[str, tuple[int, ...]] = {
    "camera_fixes": (),
    "camera_markers": (),
    "camera_latency_s": (),
    "camera_frames": (),
}

#: What the synthetic camera of a flight renders from (fly waits for it, and names it when it does not come).
SYNTHETIC_NEEDS = (
    "SIM_STATE (camera.source: synthetic renders the view from a simulator's true pose; a vehicle sends "
    "none: set camera.source to its camera's stream, e.g. udp:5600)"
)


def sim_state_pose(msg: Any) -> np.ndarray:
    """The true pose eta (6,) of a SIM_STATE: NED position (m, the mission's frame) and roll, pitch,
    yaw (rad)."""
    pos = sim_position_ned(float(msg.lat), float(msg.lon), float(msg.alt))
    return np.array([*pos, float(msg.roll), float(msg.pitch), float(msg.yaw)])


@dataclass
class _Fix:
    t: float  # capture, mission clock, s
    dock_camera_m: np.ndarray
    std_camera_m: np.ndarray
    markers: int
    latency_s: float

    def row(self) -> np.ndarray:
        """The fix as recorded in the tlog (float32: what the filter is handed, live and replayed)."""
        return np.array(
            [self.t, *self.dock_camera_m, *self.std_camera_m, self.markers, self.latency_s], dtype=np.float32
        )

    @classmethod
    def of_row(cls, row: Any) -> _Fix:
        r = np.asarray(row, dtype=np.float32)[:9].astype(float)
        return cls(float(r[0]), r[1:4].copy(), r[4:7].copy(), int(round(r[7])), float(r[8]))


def _series(fixes: list[_Fix], last: _Fix | None, frames: float) -> dict[str, np.ndarray]:
    return {
        "camera_fixes": np.asarray(float(len(fixes))),
        "camera_markers": np.asarray(float(last.markers if last else 0)),
        "camera_latency_s": np.asarray(fixes[-1].latency_s if fixes else np.nan),
        "camera_frames": np.asarray(frames),
    }


def _readings(fixes: list[_Fix]) -> list[Reading]:
    return [Reading("dock", f.t, f.dock_camera_m.copy(), f.std_camera_m.copy()) for f in fixes]


class _FollowingDock:
    """The true dock on the vehicle's clock: ``position(t) = truth.position(t + clocked.offset_s)``, the
    offset that of the mission's dock on the same clock (set as the loop starts)."""

    def __init__(self, truth: Any, clocked: ClockedDock) -> None:
        self.truth = truth
        self.clocked = clocked
        self.heading_rad = float(truth.heading_rad)

    def position(self, t: float) -> np.ndarray:
        return np.asarray(self.truth.position(float(t) + self.clocked.offset_s), dtype=float)


class CameraSensor(DetectionLoop):
    """The vehicle's camera as the ``dock`` sensor (see the module docstring); its thread's loop is every
    camera path's (:class:`auvdock.camera.detection_loop.DetectionLoop`).

    Parameters
    ----------
    mission : Mission
        ``camera`` (source, calibration, mount), ``sensors.dock_camera`` (rate, visibility of the
        synthetic camera's water) and the dock's markers.
    clock : Clock
        The session's clock.
    clocked_dock : ClockedDock
        The mission's dock on the vehicle's clock (its offset places the synthetic camera's true dock).
    latest_sim_state : callable
        ``() -> (message, stamp us) | (None, None)``: the newest SIM_STATE (the synthetic camera's truth).
    on_event : callable
        ``on_event(text)`` for camera errors.

    Raises
    ------
    MissionError
        A camera file that is missing or bad.
    OSError, ValueError, RuntimeError
        A camera source that cannot be opened.
    """

    def __init__(
        self,
        mission: Mission,
        clock: Clock,
        clocked_dock: ClockedDock,
        latest_sim_state: Callable[[], tuple[Any, int | None]],
        on_event: Callable[[str], None],
    ) -> None:
        from auvdock.camera.pose import MarkerDetector
        from auvdock.camera.video_in import LatestFrameGrabber

        c = mission.camera
        s = mission.sensors.dock_camera
        self.clock = clock
        self._on_event = on_event
        self._latest_sim_state = latest_sim_state
        self.synthetic = c.source == "synthetic"
        #: The camera's stated latency before this process has a frame (``sensors.dock_camera.latency_s``:
        #: exposure, encoding, the network and FFmpeg's one-frame H.264 parser delay), s: a frame's fixes
        #: are stamped that much before it was decoded, at the scene's instant as sim stamps them.
        #: Zero for the synthetic camera, whose frames carry the truth's instant.
        self.stream_latency_s = 0.0 if self.synthetic else float(s.latency_s)
        self.camera = mission.build_camera()  # the ideal camera for a synthetic one without a file
        self.layout = mission.dock.marker_layout()
        self.mount = c.mount.build()
        #: The mission's t = 0 on the session clock's ``now()`` (frames' capture) and ``time()`` (the
        #: telemetry's stamps), s; set as the control loop starts (:meth:`start_mission_clock`).
        self.zero_s: float | None = None
        self.zero_time_s: float | None = None
        self.source: FrameSource
        if self.synthetic:
            from auvdock.camera.render import Water
            from auvdock.fly.dock_tracker import SyntheticCamera

            truth = _FollowingDock(mission.build_dock(truth=True), clocked_dock)
            self.source = SyntheticCamera(
                self.camera,
                self.layout,
                self.mount,
                truth,  # type: ignore[arg-type]  # a dock with position(t) and heading_rad
                self._true_pose,
                rate_hz=s.rate_hz,
                noise_std=c.synthetic.noise_std,
                blur_px=c.synthetic.blur_px,
                seed=mission.seed,
                clock=clock,
                water=Water(s.visibility_m),
            )
            self.description = (
                f"synthetic {self.camera.width}x{self.camera.height} at {s.rate_hz:g} Hz "
                "from the simulator's "
                f"true pose (SIM_STATE), water visibility {s.visibility_m:g} m"
            )
        else:
            from auvdock.camera.video_in import open_source

            self.source = open_source(c.source, clock=clock)
            self.description = str(getattr(self.source, "description", c.source))
        self.detector = MarkerDetector(self.layout, self.camera)
        self.max_reprojection_px = float(c.max_reprojection_px)
        self.grabber = LatestFrameGrabber(self.source, clock=clock)
        self._fixes: collections.deque[_Fix] = collections.deque(maxlen=100)
        self._lock = threading.Lock()
        self._stop = clock.event()
        self._thread: threading.Thread | None = None
        self.frames = 0
        self.frames_with_fix = 0
        self._frames_seen = 0
        self.error: BaseException | None = None
        self._error_said = False
        self._last: _Fix | None = None
        self._taken: list[_Fix] = []

    # -- the synthetic camera's truth --------------------------------------------------------------
    def _true_pose(self) -> tuple[float, np.ndarray] | None:
        """(mission time, true pose (6,)) of the newest SIM_STATE, or None (none yet, or before the loop)."""
        msg, stamp = self._latest_sim_state()
        if msg is None or stamp is None or self.zero_time_s is None:
            return None
        return stamp * 1e-6 - self.zero_time_s, sim_state_pose(msg)

    def start_mission_clock(self, zero_time_s: float) -> None:
        """The mission's t = 0 is ``zero_time_s`` on the clock's ``time()`` (the telemetry's stamps, s)."""
        self.zero_time_s = float(zero_time_s)
        self.zero_s = self.zero_time_s - (self.clock.time() - self.clock.now())

    # -- life -------------------------------------------------------------------------------------
    def start(self) -> None:
        """Start taking frames and detecting (:meth:`stop` is the detection loop's)."""
        self._start_thread("auvdock-camera-sensor")

    def process(self, frame: Frame) -> _Fix | None:
        """One frame to a fix (None: no consistent markers, or before the loop's start)."""
        from auvdock.camera.pose import estimate_dock_pose

        if self.zero_s is None:
            return None
        pose = estimate_dock_pose(
            self.detector.detect(frame.image),
            self.layout,
            self.camera,
            max_reproj_px=self.max_reprojection_px,
        )
        if pose is None:
            return None
        cov = pose.covariance[:3, :3]
        cov = 0.5 * (cov + cov.T)
        # the synthetic frame shows the truth at its SIM_STATE's instant (pts); a camera's, its capture
        t = (
            float(frame.pts_s)
            if self.synthetic and frame.pts_s is not None
            else frame.t_capture - self.stream_latency_s - self.zero_s
        )
        return _Fix(
            t=t,
            dock_camera_m=np.asarray(pose.t_cd, dtype=float).copy(),
            std_camera_m=np.sqrt(np.maximum(np.diag(cov), 0.0)),
            markers=len(pose.markers_used),
            latency_s=self.clock.now() - frame.t_capture,
        )

    # -- every control step ------------------------------------------------------------------------
    def before_drain(self) -> list[np.ndarray]:
        """Take the fixes made since the last step (held for :meth:`take`), as the rows the session records
        in the tlog before the step's messages are drained (where replay finds them at the same step)."""
        with self._lock:
            fixes = [_Fix.of_row(f.row()) for f in self._fixes]  # as recorded: float32
            self._fixes.clear()
        self._taken.extend(fixes)  # (kept for the next take when this step takes none: stale telemetry)
        return [f.row() for f in fixes]

    def feed(self, messages: list[tuple[int, Any]]) -> None:
        """Nothing: a live camera's fixes come from its thread."""

    def take(self) -> tuple[list[Reading], dict[str, np.ndarray]]:
        """The fixes taken at this step as ``dock`` readings (oldest first), and the series to record."""
        fixes, self._taken = self._taken, []
        if self.error is not None and not self._error_said:
            self._error_said = True
            self._on_event(f"camera: {self.error}")
        if fixes:
            self._last = fixes[-1]
        frames = self.frames - self._frames_seen
        self._frames_seen = self.frames
        return _readings(fixes), _series(fixes, self._last, float(frames))


class RecordedCamera:
    """A replayed flight's camera: the fixes the flight recorded in its tlog (:data:`FIX_RECORD`), handed
    over at the steps they were handed over in flight (no frames, no thread)."""

    description = "the flight's recorded fixes (replay)"

    def __init__(self) -> None:
        self._pending: list[_Fix] = []
        self._last: _Fix | None = None

    def start(self) -> None:
        """Nothing to start."""

    def stop(self) -> None:
        """Nothing to stop."""

    def start_mission_clock(self, zero_time_s: float) -> None:
        """Nothing: the recorded fixes are on the mission's clock."""

    def before_drain(self) -> list[np.ndarray]:
        """Nothing to record: the tlog has them."""
        return []

    def feed(self, messages: list[tuple[int, Any]]) -> None:
        """Take the recorded fixes among the drained messages."""
        for _, msg in messages:
            if msg.get_type() == "DEBUG_FLOAT_ARRAY" and str(msg.name) == FIX_RECORD:
                self._pending.append(_Fix.of_row(msg.data))

    def take(self) -> tuple[list[Reading], dict[str, np.ndarray]]:
        """The fixes recorded at this step, as in flight (the frames' count unknown: NaN)."""
        fixes, self._pending = self._pending, []
        if fixes:
            self._last = fixes[-1]
        return _readings(fixes), _series(fixes, self._last, float("nan"))
