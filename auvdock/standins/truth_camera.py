"""The synthetic camera's view of a simulated vehicle, streamed as RTP/H.264 the way BlueOS streams a camera.

:class:`TruthCameraStream` renders the dock's markers as the vehicle's camera sees them from
the vehicle's **true** pose (:meth:`auvdock.fly.dock_tracker.SyntheticCamera.render`: the
mission's camera model, mount, markers, dock and ``camera.synthetic`` settings) and sends
the frames with :func:`auvdock.camera.video_out.stream_rtp` in a thread.  A ``fly`` session
whose mission has ``camera.source: udp:PORT`` receives them exactly as it would from a
BlueROV2's camera, through the same decoder, detector and tracking filter::

    stream = TruthCameraStream.from_mission(mission, physics.pose, "127.0.0.1", 5600).start()
    ...
    stream.stop()

Frames go out at ``camera.synthetic.rate_hz`` on the stream's clock; each shows the newest
pose ``pose_fn()`` gives at that moment (a simulator's state, e.g.
:meth:`auvdock.standins.sitl_physics.SitlPhysics.pose`), with the dock where it is at that
pose's time.  Rendering and encoding happen in the stream's thread.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

import numpy as np

from auvdock.camera.video_out import stream_rtp
from auvdock.fly.dock_tracker import SyntheticCamera
from auvdock.runtime.clock import Clock, wall_clock

if TYPE_CHECKING:
    from auvdock.config.mission import Mission

__all__ = ["TruthCameraStream", "PoseFn"]

#: ``pose_fn() -> (t, eta)``: mission time (s) and the vehicle's true pose (6,) in the mission frame.
PoseFn = Callable[[], "tuple[float, np.ndarray]"]


class TruthCameraStream:
    """Render the camera's view of the true pose and stream it as RTP/H.264 (see the module docstring).

    Parameters
    ----------
    renderer : SyntheticCamera
        What renders a view (its camera model, markers, mount, dock, noise, offset and dropouts).
    pose_fn : callable
        ``pose_fn() -> (t, eta)``: time (s) and true pose (6,) now.
    host, port : str, int
        Where the RTP stream goes (RTCP to ``port + 1``).
    rate_hz : float
        Frames per second.
    encoder : str, optional
        FFmpeg H.264 encoder (default :func:`auvdock.camera.video_out.h264_encoder`).
    clock : Clock, optional
        What the frames are paced on (default the wall clock).
    """

    def __init__(
        self,
        renderer: SyntheticCamera,
        pose_fn: PoseFn,
        host: str,
        port: int,
        *,
        rate_hz: float = 15.0,
        encoder: str | None = None,
        clock: Clock | None = None,
    ) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be positive, got {rate_hz}")
        self.renderer = renderer
        self.pose_fn = pose_fn
        self.host, self.port = str(host), int(port)
        self.rate_hz = float(rate_hz)
        self.encoder = encoder
        self.clock: Clock = wall_clock if clock is None else clock
        self._stop = self.clock.event()
        self._thread: threading.Thread | None = None
        self._sent = 0
        self._error: BaseException | None = None
        self.description = (
            f"{renderer.camera.width}x{renderer.camera.height} at {self.rate_hz:g} Hz "
            f"as RTP/H.264 to {self.host}:{self.port}"
        )

    @classmethod
    def from_mission(
        cls,
        mission: Mission,
        pose_fn: PoseFn,
        host: str,
        port: int,
        *,
        seed: int | None = None,
        encoder: str | None = None,
        clock: Clock | None = None,
    ) -> TruthCameraStream:
        """The mission's camera: ``mission.build_camera()`` (its calibration file, or the ideal
        640x480 80 deg camera for ``camera.source: synthetic``), ``camera.mount``, the dock's
        markers, ``camera.synthetic`` (rate, noise, blur, dock offset, dropouts); image noise
        seeded with ``seed`` (default ``mission.seed``).  With the dock camera as a sensor
        (``sensors.dock_camera``, ``estimation: filter``) it renders what ``sim`` sees: the true dock
        for the mission's seed (``dock.position_std_m``), in the water of
        ``sensors.dock_camera.visibility_m``, at ``sensors.dock_camera.rate_hz``; ``pose_fn``'s time
        must then be the clock the stand-in moves its dock on (vehicle-sim's ``t``).

        Raises
        ------
        MissionError
            The mission's camera file is missing or does not read.
        """
        s = mission.sensors.dock_camera
        if mission.estimation == "filter" and s.enabled:  # the camera as a sensor: the truth, as sim sees it
            from auvdock.camera.render import Water

            c = mission.camera
            renderer = SyntheticCamera(
                mission.build_camera(),
                mission.dock.marker_layout(),
                c.mount.build(),
                mission.build_dock(truth=True),
                pose_fn,
                rate_hz=s.rate_hz,
                noise_std=c.synthetic.noise_std,
                blur_px=c.synthetic.blur_px,
                seed=mission.seed if seed is None else int(seed),
                clock=clock,
                water=Water(s.visibility_m),
            )
            rate = s.rate_hz
        else:
            dock = mission.dock.build()
            renderer = SyntheticCamera.from_mission(mission, dock, pose_fn, seed=seed, clock=clock)
            rate = mission.camera.synthetic.rate_hz
        return cls(renderer, pose_fn, host, port, rate_hz=rate, encoder=encoder, clock=clock)

    # --- frames ------------------------------------------------------------------------------
    def frame(self) -> np.ndarray:
        """One view (h, w) uint8 from the pose ``pose_fn()`` gives now."""
        t, eta = self.pose_fn()
        return self.renderer.render(float(t), np.asarray(eta, dtype=float))

    def _frames(self) -> Iterator[np.ndarray]:
        while not self._stop.is_set():
            yield self.frame()

    # --- life cycle ----------------------------------------------------------------------------
    @property
    def frames_sent(self) -> int:
        """Frames handed to the RTP muxer so far."""
        return self._sent

    @property
    def error(self) -> BaseException | None:
        """What stopped the stream early (an encoder or socket error), if anything."""
        return self._error

    @property
    def running(self) -> bool:
        """Whether the streaming thread runs."""
        return self._thread is not None and self._thread.is_alive()

    def start(self) -> TruthCameraStream:
        """Start streaming in a thread of the clock (once)."""
        if self._thread is not None:
            raise RuntimeError("TruthCameraStream.start() may be called only once")
        self._thread = self.clock.start_thread(self._run, name="TruthCameraStream")
        return self

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop streaming (the muxer sends its RTCP BYE) and wait for the thread (idempotent)."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self.clock.join(self._thread, timeout=timeout_s)

    def _run(self) -> None:
        def sent(k: int, t: float) -> None:
            self._sent = k + 1

        try:
            stream_rtp(
                self._frames(),
                self.port,
                host=self.host,
                fps=self.rate_hz,
                encoder=self.encoder,
                stop=self._stop,
                on_sent=sent,
                clock=self.clock,
            )
        except Exception as e:  # noqa: BLE001 - kept for the caller (error), never raised in the thread
            self._error = e

    def __enter__(self) -> TruthCameraStream:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
