"""Camera frame sources for live dock tracking: BlueOS RTP/H.264, V4L2 devices, video files, image folders.

The fiducial detector wants grayscale ``uint8`` frames, shape (h, w) px, with a capture time stamp (s, on a
:class:`auvdock.runtime.clock.Clock`), and the 20 Hz control loop must never wait for the camera.
:func:`open_source` turns a source string into a :class:`FrameSource` (``read(timeout_s)`` / ``close()``);
:class:`LatestFrameGrabber` reads any source in a background thread and keeps only the newest frame, so a
slow consumer skips frames instead of falling behind. The sending side (H.264 over RTP, as BlueOS does it)
is :mod:`auvdock.camera.video_out`.

Sources (``spec`` strings of :func:`open_source`)
-------------------------------------------------
``udp:PORT``, ``udp:HOST:PORT``, ``rtp://HOST:PORT``
    RTP/H.264 over UDP as BlueOS streams it (payload type 96, 90 kHz clock; BlueOS default port 5600),
    received and decoded by FFmpeg through PyAV from a generated SDP description, in a background thread.
    ``HOST`` is the address the stream is sent to: ``0.0.0.0`` (default: every interface), one of this
    computer's IPv4 addresses (receive on that interface only) or an IPv4 multicast group (joined).
    FFmpeg also binds ``PORT + 1`` for RTCP. QGroundControl listens on UDP 5600 too: close its video (or
    have BlueOS stream to a second port) before opening the same port here.
``/dev/videoN``, ``v4l2:N``
    A V4L2 camera (USB) through OpenCV, read in a background thread.
a video file (mp4, mkv, avi, ...)
    Decoded by PyAV; with ``realtime=True`` frames are released at the file's frame timing, as a live camera
    would give them, else as fast as they are decoded.
a directory of images (or one image file)
    Via :func:`auvdock.camera.image_files.image_sources` (sorted by name); ``image_fps`` paces them when
    ``realtime``.

Latency (measured on loopback, PyAV 18.1 / FFmpeg 8.1, x264 ``zerolatency``): a 320x240 frame is decoded one
frame interval plus ~1.5 ms after it was sent (51.5 ms at 20 fps, 34.6 ms at 30 fps); 1920x1080 at 30 fps
takes ~70 ms including the x264 encode. The frame interval comes from FFmpeg's H.264 parser, which completes
a frame only when the next one begins.

Clock. Times are s on a :class:`auvdock.runtime.clock.Clock` (``time.monotonic()`` with the default wall
clock). The sources that pace themselves (video files and image folders with ``realtime``) and
:class:`LatestFrameGrabber` take a ``clock``, so that they can run in simulated time
(:class:`auvdock.runtime.clock.SimClock`, for tests); live sources (RTP, V4L2) run on the wall clock only:
their frames come from devices and FFmpeg in real time.
"""

from __future__ import annotations

import collections
import errno
import logging
import math
import os
import re
import socket
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, Protocol, Self, runtime_checkable

import cv2
import numpy as np

from auvdock.camera.model import gray_image
from auvdock.camera.video_common import (
    RTP_PAYLOAD_TYPE,
    VideoSourceError,
    check_payload_type,
    check_rtp_port,
    import_av,
)
from auvdock.runtime.clock import Clock, wall_clock

__all__ = [
    "SOURCE_FORMS",
    "Frame",
    "FrameSource",
    "ImageFolderSource",
    "LatestFrameGrabber",
    "RtpSource",
    "V4l2Source",
    "VideoFileSource",
    "open_source",
]

log = logging.getLogger(__name__)

#: The accepted ``spec`` forms of :func:`open_source`, as quoted in its error messages.
SOURCE_FORMS = (
    "udp:PORT, udp:HOST:PORT, rtp://HOST:PORT, /dev/videoN, v4l2:N, a video file or a directory of images"
)

_RTP_OPEN_TIMEOUT_S = 0.3  # FFmpeg's stream probing waits at most this long for the first packets
_POLL_S = 0.1  # demux / capture threads check for close() at least this often (FFmpeg polls at 100 ms)
_RTP_BUFFER_BYTES = 4 * 1024 * 1024  # UDP receive buffer asked for (the kernel caps it at net.core.rmem_max)
_MAX_CONSECUTIVE_ERRORS = 50


@dataclass
class Frame:
    """One camera frame.

    Attributes
    ----------
    image : ndarray, uint8, shape (h, w)
        Grayscale image.
    t_capture : float
        Clock time (s; ``time.monotonic()`` on the wall clock) at which this process had the decoded
        frame: just after decoding for RTP streams, just after ``VideoCapture.read`` for V4L2 devices, at
        release (after decoding and pacing) for video files and image folders. It does not include the
        latency before (exposure, encoding, network and FFmpeg's one-frame parser delay for RTP: see the
        module doc).
    index : int
        Frame counter of the source, from 0, one per frame the source produced (decoded); a gap means the
        source dropped frames (e.g. its queue was full).
    pts_s : float or None
        Presentation time in the stream, s (RTP: the sender's 90 kHz timestamps counted from the first packet
        received, jumping if the sender restarts; files: the container's timestamps), None when the source has
        none (V4L2, images, the first RTP frame).
    """

    image: np.ndarray
    t_capture: float
    index: int
    pts_s: float | None = None

    def __post_init__(self) -> None:
        image = self.image
        if not isinstance(image, np.ndarray) or image.ndim != 2 or image.dtype != np.uint8:
            desc = f"{image.dtype} {image.shape}" if isinstance(image, np.ndarray) else type(image).__name__
            raise ValueError(f"Frame.image: expected a (h, w) uint8 grayscale array, got {desc}")

    @property
    def shape(self) -> tuple[int, int]:
        """(h, w) in px."""
        return self.image.shape

    def age_s(self, now: float | None = None) -> float:
        """Time since capture, s (``now`` defaults to ``time.monotonic()``)."""
        return (time.monotonic() if now is None else now) - self.t_capture


@runtime_checkable
class FrameSource(Protocol):
    """A camera or recording giving :class:`Frame` objects.

    ``read(timeout_s)`` returns the next frame, or None if none came within ``timeout_s`` seconds; it raises
    ``EOFError`` once a finite source (file, images) is exhausted and :class:`VideoSourceError` when the
    source failed. ``close()`` releases it (idempotent). Implementations are context managers.
    """

    description: str

    def read(self, timeout_s: float) -> Frame | None: ...

    def close(self) -> None: ...

    def __enter__(self) -> Self: ...

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None: ...


def _check_timeout(timeout_s: float) -> float:
    timeout_s = float(timeout_s)
    if not (timeout_s >= 0.0) or math.isinf(timeout_s):
        raise ValueError(f"timeout_s: expected a finite value >= 0 s, got {timeout_s}")
    return timeout_s


def _to_gray(image: np.ndarray) -> np.ndarray:
    """A decoded frame as contiguous grayscale uint8 (:func:`auvdock.camera.model.gray_image`)."""
    try:
        return np.ascontiguousarray(gray_image(image))
    except ValueError:
        raise VideoSourceError(f"unsupported frame: dtype {image.dtype}, shape {image.shape}") from None


class _SourceBase:
    description: str = ""
    _closed: bool = False

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open"
        return f"<{type(self).__name__} {self.description} ({state})>"

    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._closed

    def _check_open(self) -> None:
        if self._closed:
            raise VideoSourceError(f"{self.description}: source is closed")

    def close(self) -> None:  # pragma: no cover - overridden
        self._closed = True


class _ThreadedSource(_SourceBase):
    """A producer thread pushes frames into a short queue that drops its oldest frame when full."""

    def __init__(self, description: str, queue_len: int, clock: Clock | None = None) -> None:
        if isinstance(queue_len, bool) or not isinstance(queue_len, int) or queue_len < 1:
            raise ValueError(f"queue_len: expected a positive integer, got {queue_len!r}")
        self.description = description
        #: What a frame's capture instant is read on (the session's clock: ``auvdock --clock-rate``
        #: scales it); the frames themselves come in real time from their device.
        self._clock = wall_clock if clock is None else clock
        self._queue: collections.deque[Frame] = collections.deque(maxlen=queue_len)
        self._cond = threading.Condition()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None
        self._done = False
        self._produced = 0
        self._dropped = 0

    def _start(self, name: str) -> None:
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            self._produce()
        except BaseException as exc:  # noqa: BLE001 - reported through read()
            if not self._stop.is_set():
                log.warning("%s: stopped: %s", self.description, exc)
                self._error = exc
        finally:
            with self._cond:
                self._done = True
                self._cond.notify_all()

    def _produce(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def _push(self, image: np.ndarray, pts_s: float | None) -> None:
        frame = Frame(image, self._clock.now(), self._produced, pts_s)
        with self._cond:
            if len(self._queue) == self._queue.maxlen:
                self._dropped += 1
            self._queue.append(frame)
            self._produced += 1
            self._cond.notify_all()

    @property
    def frames_produced(self) -> int:
        """Frames decoded / captured so far."""
        return self._produced

    @property
    def frames_dropped(self) -> int:
        """Frames discarded because the queue was full (the consumer did not read fast enough)."""
        return self._dropped

    def read(self, timeout_s: float = 1.0) -> Frame | None:
        """Oldest queued frame, waiting up to ``timeout_s`` s for one; None on timeout.

        Raises
        ------
        VideoSourceError
            The source is closed or its thread stopped on an error (chained as ``__cause__``).
        """
        timeout_s = _check_timeout(timeout_s)
        self._check_open()
        with self._cond:
            self._cond.wait_for(lambda: self._queue or self._done or self._closed, timeout_s)
            if self._queue:
                return self._queue.popleft()
            if self._closed:
                raise VideoSourceError(f"{self.description}: source is closed")
            if self._done:
                if self._error is not None:
                    raise VideoSourceError(f"{self.description}: {self._error}") from self._error
                raise EOFError(f"{self.description}: end of stream")
        return None

    def close(self) -> None:
        """Stop the thread (waits up to ~1 s) and release the source; idempotent."""
        if self._closed:
            return
        self._stop.set()
        with self._cond:
            self._closed = True
            self._cond.notify_all()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5 * _POLL_S + 1.0)
            if self._thread.is_alive():  # pragma: no cover - native call stuck
                log.warning("%s: reader thread did not stop", self.description)
                return
        self._release()

    def _release(self) -> None:  # pragma: no cover - overridden
        pass


def _sdp(host: str, port: int, payload_type: int) -> str:
    return "\n".join(
        [
            "v=0",
            "o=- 0 0 IN IP4 127.0.0.1",
            "s=auvdock",
            f"c=IN IP4 {host}",
            "t=0 0",
            f"m=video {port} RTP/AVP {payload_type}",
            f"a=rtpmap:{payload_type} H264/90000",
            "",
        ]
    )


def _is_multicast(host: str) -> bool:
    try:
        first = int(host.split(".")[0])
    except ValueError:
        return False
    return 224 <= first <= 239


class RtpSource(_ThreadedSource):
    """RTP/H.264 over UDP (BlueOS camera stream), decoded by FFmpeg (PyAV) in a background thread.

    The UDP port (and ``port + 1`` for RTCP) is bound when the constructor returns, so a sender may start
    right after. Decoding starts at the first key frame (SPS/PPS must be in-band, as BlueOS and
    :func:`auvdock.camera.video_out.stream_rtp` send them); frames that the decoder flags as corrupt (after
    packet loss) are skipped and counted in :attr:`frames_corrupt`.

    Parameters
    ----------
    port : int
        UDP port, 1-65534 (BlueOS default 5600).
    host : str
        IPv4 address the stream is sent to: ``"0.0.0.0"`` (every interface), a local address or a
        multicast group.
    payload_type : int
        RTP payload type of the H.264 stream (96-127).
    queue_len : int
        Decoded frames kept for :meth:`read`; the oldest is dropped when full.

    Raises
    ------
    VideoSourceError
        The port cannot be bound (e.g. already in use by QGroundControl) or FFmpeg rejects the stream setup.
    """

    def __init__(
        self,
        port: int,
        host: str = "0.0.0.0",
        *,
        payload_type: int = RTP_PAYLOAD_TYPE,
        queue_len: int = 8,
        clock: Clock | None = None,
    ) -> None:
        check_rtp_port(port, f"port {port}")
        check_payload_type(payload_type)
        super().__init__(f"rtp://{host}:{port} (H.264, payload type {payload_type})", queue_len, clock)
        av = import_av()
        self.port = port
        self.host = host
        self._corrupt = 0
        self._decode_errors = 0
        self._av = av
        options = {
            "protocol_whitelist": "file,udp,rtp",
            # Probe as little as possible: the codec is known from the SDP and the decoder reads the frame
            # size from the in-band SPS. No "fflags=nobuffer": it discards the probed packets, i.e. the first
            # key frame, and decoding would wait for the next one.
            "probesize": "32",
            "analyzeduration": "0",
            "buffer_size": str(_RTP_BUFFER_BYTES),
        }
        if host != "0.0.0.0" and not _is_multicast(host):
            options["localaddr"] = host
        if not _is_multicast(host):
            _check_free(host, port)
        fd, sdp_path = tempfile.mkstemp(prefix="auvdock-", suffix=".sdp")
        try:
            with os.fdopen(fd, "w") as f:
                f.write(_sdp(host, port, payload_type))
            # Opening binds the sockets and then probes for up to the open timeout (returns at the first
            # packet); without a sender yet it gives up, and the decoder learns the frame size later.
            self._container = av.open(
                sdp_path, container_options=options, timeout=(_RTP_OPEN_TIMEOUT_S, _POLL_S)
            )
        except av.error.FFmpegError as exc:
            raise VideoSourceError(f"cannot receive RTP on udp://{host}:{port}: {exc}") from exc
        finally:
            os.unlink(sdp_path)
        self._stream = self._container.streams.video[0]
        ctx = self._stream.codec_context
        ctx.flags |= av.codec.context.Flags.low_delay  # no frame reordering delay in the decoder
        self._start(f"auvdock-rtp-{port}")

    @property
    def frames_corrupt(self) -> int:
        """Decoded frames skipped because the decoder flagged them corrupt (lost packets)."""
        return self._corrupt

    @property
    def decode_errors(self) -> int:
        """Packets the decoder rejected (lost or damaged data); decoding resumes at the next good frame."""
        return self._decode_errors

    def _produce(self) -> None:
        av = self._av
        errors = 0
        while not self._stop.is_set():
            try:
                for packet in self._container.demux(self._stream):
                    errors = 0
                    if self._stop.is_set():
                        return
                    if packet.size == 0:
                        # PyAV's end-of-stream flush packet (after an RTCP BYE): skip it so that the decoder
                        # stays usable when the sender starts again.
                        continue
                    try:
                        decoded = packet.decode()
                    except av.error.FFmpegError as exc:
                        self._decode_errors += 1
                        log.debug("%s: decode error: %s", self.description, exc)
                        continue
                    for vf in decoded:
                        if vf.is_corrupt:
                            self._corrupt += 1
                            continue
                        self._push(vf.to_ndarray(format="gray"), None if vf.time is None else float(vf.time))
            except av.error.ExitError:
                continue  # read timeout (no packet for _POLL_S): check for close() and wait again
            except av.error.FFmpegError as exc:
                errors += 1
                if errors >= _MAX_CONSECUTIVE_ERRORS:
                    raise
                log.debug("%s: receive error: %s", self.description, exc)
                time.sleep(0.01)
            # EOF (the sender said RTCP BYE) ends demux() quietly: keep listening for a new sender.

    def _release(self) -> None:
        self._container.close()


def _check_free(host: str, port: int) -> None:
    """Bind-test ``port`` and ``port + 1`` (FFmpeg's own message for a busy port is "Invalid data found")."""
    for p in (port, port + 1):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            try:
                sock.bind((host, p))
            except OSError as exc:
                what = "RTP" if p == port else "RTCP (RTP port + 1)"
                hint = (
                    " (another program is receiving on it, e.g. QGroundControl's video or a second auvdock)"
                    if exc.errno == errno.EADDRINUSE
                    else ""
                )
                raise VideoSourceError(
                    f"cannot receive RTP on udp://{host}:{port}: {what} port {p}: {exc.strerror}{hint}"
                ) from exc


class V4l2Source(_ThreadedSource):
    """A V4L2 camera (``/dev/videoN``) read by OpenCV in a background thread; frames converted to gray.

    Parameters
    ----------
    device : int or str
        Device number N or path ``/dev/videoN``.
    queue_len : int
        Captured frames kept for :meth:`read`; the oldest is dropped when full.

    Raises
    ------
    VideoSourceError
        ``"cannot open V4L2 device /dev/videoN"`` (with the reason when known).
    """

    def __init__(self, device: int | str, *, queue_len: int = 2, clock: Clock | None = None) -> None:
        if isinstance(device, str):
            m = re.fullmatch(r"/dev/video(\d+)", device)
            if m is None:
                raise ValueError(f"device: expected N or /dev/videoN, got {device!r}")
            number = int(m.group(1))
        elif isinstance(device, int) and not isinstance(device, bool) and device >= 0:
            number = device
        else:
            raise ValueError(f"device: expected N or /dev/videoN, got {device!r}")
        path = f"/dev/video{number}"
        super().__init__(f"V4L2 device {path}", queue_len, clock)
        self.path = path
        if not os.path.exists(path):
            raise VideoSourceError(f"cannot open V4L2 device {path}: no such device")
        cap = cv2.VideoCapture(number, cv2.CAP_V4L2)
        if not cap.isOpened():
            cap.release()
            raise VideoSourceError(
                f"cannot open V4L2 device {path}: not a capture device, busy or no permission "
                "(see `v4l2-ctl --list-devices`; the user needs the 'video' group)"
            )
        self._cap = cap
        self._start(f"auvdock-v4l2-{number}")

    def _produce(self) -> None:
        failures = 0
        while not self._stop.is_set():
            ok, image = self._cap.read()
            if not ok or image is None:
                failures += 1
                if failures >= _MAX_CONSECUTIVE_ERRORS:
                    raise VideoSourceError(f"{self.path}: no frame in {failures} reads (camera unplugged?)")
                time.sleep(0.01)
                continue
            failures = 0
            self._push(_to_gray(image), None)

    def _release(self) -> None:
        self._cap.release()


class VideoFileSource(_SourceBase):
    """A video file decoded by PyAV, in the calling thread.

    Parameters
    ----------
    path : str or Path
        Any container/codec FFmpeg reads (mp4, mkv, avi, ...); its first video stream is used.
    realtime : bool
        Release each frame at its presentation time after the first one (as a live camera would; frames are
        not skipped when the reader is slow); False gives them as fast as they decode.
    clock : Clock, optional
        What pacing and ``t_capture`` use (default the wall clock).

    Raises
    ------
    ValueError
        No such file.
    VideoSourceError
        FFmpeg cannot open it or it has no video stream.
    """

    def __init__(self, path: str | Path, *, realtime: bool = True, clock: Clock | None = None) -> None:
        av = import_av()
        self.clock: Clock = wall_clock if clock is None else clock
        self.path = Path(path)
        self.realtime = bool(realtime)
        if not self.path.is_file():
            raise ValueError(f"{self.path}: no such file")
        try:
            self._container = av.open(str(self.path))
        except av.error.FFmpegError as exc:
            raise VideoSourceError(f"{self.path}: cannot open as a video: {exc}") from exc
        if not self._container.streams.video:
            self._container.close()
            raise VideoSourceError(f"{self.path}: no video stream")
        stream = self._container.streams.video[0]
        stream.thread_type = "AUTO"
        rate = stream.average_rate or stream.guessed_rate
        self.fps: float | None = float(rate) if rate else None
        self.description = f"video file {self.path}" + (f" ({self.fps:.3g} fps)" if self.fps else "")
        self._frames: Iterator[Any] = self._container.decode(stream)
        self._pending: tuple[np.ndarray, float | None] | None = None
        self._index = 0
        self._t0: float | None = None
        self._pts0: float | None = None
        self._av = av

    def _due(self, pts_s: float | None) -> float:
        assert self._t0 is not None
        if pts_s is not None and self._pts0 is not None:
            return self._t0 + (pts_s - self._pts0)
        if self.fps:
            return self._t0 + self._index / self.fps
        return self.clock.now()

    def read(self, timeout_s: float = 1.0) -> Frame | None:
        """Next frame; None if (``realtime``) it is not due within ``timeout_s`` s.

        Raises
        ------
        EOFError
            At the end of the file.
        VideoSourceError
            Closed, or a decoding error.
        """
        timeout_s = _check_timeout(timeout_s)
        self._check_open()
        if self._pending is None:
            try:
                vf = next(self._frames)
            except StopIteration:
                raise EOFError(f"{self.description}: end of file") from None
            except self._av.error.FFmpegError as exc:
                raise VideoSourceError(f"{self.description}: {exc}") from exc
            self._pending = (vf.to_ndarray(format="gray"), None if vf.time is None else float(vf.time))
        image, pts_s = self._pending
        clock = self.clock
        if self.realtime:
            if self._t0 is None:
                self._t0, self._pts0 = clock.now(), pts_s
            wait = self._due(pts_s) - clock.now()
            if wait > timeout_s:
                clock.sleep(timeout_s)
                return None
            if wait > 0:
                clock.sleep(wait)
        self._pending = None
        frame = Frame(np.ascontiguousarray(image), clock.now(), self._index, pts_s)
        self._index += 1
        return frame

    def close(self) -> None:
        """Close the file; idempotent."""
        if not self._closed:
            self._closed = True
            self._container.close()


class ImageFolderSource(_SourceBase):
    """Images of a directory (sorted by name) or one image file, as frames (``pts_s`` None).

    Parameters
    ----------
    path : str or Path
        Read with :func:`auvdock.camera.image_files.image_sources`.
    fps : float or None
        Release rate when given (frames/s), else as fast as they are read.
    clock : Clock, optional
        What pacing and ``t_capture`` use (default the wall clock).

    Raises
    ------
    ValueError
        Missing path, or a directory without images (from ``image_sources``).
    """

    def __init__(self, path: str | Path, *, fps: float | None = None, clock: Clock | None = None) -> None:
        from auvdock.camera.image_files import image_sources

        self.clock: Clock = wall_clock if clock is None else clock
        if fps is not None and not (math.isfinite(fps) and fps > 0):
            raise ValueError(f"fps: expected a positive frame rate, got {fps}")
        self.path = Path(path)
        self.fps = fps
        self._images = image_sources(self.path)
        kind = "image folder" if self.path.is_dir() else "image"
        self.description = f"{kind} {self.path}" + (f" ({fps:g} fps)" if fps else "")
        self._index = 0
        self._t0: float | None = None
        self._pending: np.ndarray | None = None

    def read(self, timeout_s: float = 1.0) -> Frame | None:
        """Next image; None if (paced) it is not due within ``timeout_s`` s. ``EOFError`` after the last."""
        timeout_s = _check_timeout(timeout_s)
        self._check_open()
        if self._pending is None:
            try:
                self._pending = next(self._images)
            except StopIteration:
                raise EOFError(f"{self.description}: no more images") from None
        clock = self.clock
        if self.fps:
            if self._t0 is None:
                self._t0 = clock.now()
            wait = self._t0 + self._index / self.fps - clock.now()
            if wait > timeout_s:
                clock.sleep(timeout_s)
                return None
            if wait > 0:
                clock.sleep(wait)
        image, self._pending = self._pending, None
        frame = Frame(image, clock.now(), self._index, None)
        self._index += 1
        return frame

    def close(self) -> None:
        """Stop reading; idempotent."""
        self._closed = True
        close = getattr(self._images, "close", None)
        if close is not None:
            close()


_UDP = re.compile(r"udp:(?:(?P<host>[^:/\s]+):)?(?P<port>\d+)")
_RTP = re.compile(r"rtp://(?P<host>[^:/\s]*):(?P<port>\d+)/?")
_V4L2 = re.compile(r"(?:/dev/video|v4l2:)(?P<n>\d+)")
_IPV4 = re.compile(r"\d{1,3}(?:\.\d{1,3}){3}")


def open_source(
    spec: str, *, realtime: bool = True, image_fps: float = 10.0, clock: Clock | None = None
) -> FrameSource:
    """Open a camera, stream or recording as a :class:`FrameSource`.

    Parameters
    ----------
    spec : str
        ``"udp:5600"`` / ``"udp:HOST:5600"`` / ``"rtp://0.0.0.0:5600"`` (RTP/H.264, payload type 96, see
        :class:`RtpSource`), ``"/dev/video0"`` / ``"v4l2:0"`` (:class:`V4l2Source`), a video file
        (:class:`VideoFileSource`) or a directory of images / one image (:class:`ImageFolderSource`).
    realtime : bool
        Files and image folders only: release frames at the file's frame timing (images: ``image_fps``),
        as a live camera would; False gives them as fast as they are read. Live sources ignore it.
    image_fps : float
        Frame rate of image folders when ``realtime``, frames/s.
    clock : Clock, optional
        The clock a frame's capture instant is read on, and files and image folders pace on (default
        the wall clock).

    Returns
    -------
    FrameSource
        Close it (or use it as a context manager) when done.

    Raises
    ------
    ValueError
        ``spec`` matches none of the forms (the message lists them: :data:`SOURCE_FORMS`), a port is out of
        range, or the file / directory does not exist.
    VideoSourceError
        The source exists but cannot be opened (device, busy port, undecodable file).
    """
    if not isinstance(spec, str):
        raise ValueError(f"video source: expected a string ({SOURCE_FORMS}), got {type(spec).__name__}")
    s = spec.strip()
    if m := _UDP.fullmatch(s) or _RTP.fullmatch(s):
        host = m.group("host") or "0.0.0.0"
        if not _IPV4.fullmatch(host) or any(int(b) > 255 for b in host.split(".")):
            raise ValueError(f"video source {spec!r}: HOST must be an IPv4 address, got {host!r}")
        port = int(m.group("port"))
        return RtpSource(check_rtp_port(port, f"video source {spec!r}"), host, clock=clock)
    if m := _V4L2.fullmatch(s):
        return V4l2Source(int(m.group("n")), clock=clock)
    if s and not re.match(r"(udp|rtp|v4l2|rtsp|https?|tcp):", s):
        path = Path(s).expanduser()
        if path.is_dir():
            return ImageFolderSource(path, fps=image_fps if realtime else None, clock=clock)
        if path.is_file():
            from auvdock.camera.image_files import IMAGE_SUFFIXES

            if path.suffix.lower() in IMAGE_SUFFIXES:
                return ImageFolderSource(path, fps=None, clock=clock)
            return VideoFileSource(path, realtime=realtime, clock=clock)
        if path.suffix or os.sep in s:
            raise ValueError(f"video source {spec!r}: no such file or directory (accepted: {SOURCE_FORMS})")
    raise ValueError(f"video source {spec!r} not recognised; accepted: {SOURCE_FORMS}")


class LatestFrameGrabber:
    """Read a :class:`FrameSource` continuously in a daemon thread, keeping only the newest frame.

    A consumer slower than the camera gets the most recent frame instead of a growing backlog; frames
    replaced before anyone took them are counted in :attr:`frames_dropped`. Nothing here raises into the
    caller's thread: a source error (or ``EOFError`` at the end of a file) stops the thread and is kept in
    :attr:`error`.

    Parameters
    ----------
    source : FrameSource
    poll_s : float
        ``read`` timeout of the thread, s (how often it checks for :meth:`stop`).
    close_source : bool
        Close the source in :meth:`stop` (default).
    clock : Clock, optional
        What the reader thread and :meth:`wait_new` wait on (default the wall clock; the source's own
        waits must use the same clock).

    Use as a context manager, or call :meth:`stop`::

        with LatestFrameGrabber(open_source("udp:5600")) as grabber:
            frame = grabber.wait_new(-1, timeout_s=5.0)
            ...
            frame = grabber.latest()  # each control tick; check frame.index / frame.t_capture for freshness
    """

    def __init__(
        self,
        source: FrameSource,
        *,
        poll_s: float = 0.1,
        close_source: bool = True,
        clock: Clock | None = None,
    ) -> None:
        if not (math.isfinite(poll_s) and poll_s > 0):
            raise ValueError(f"poll_s: expected a positive time, s, got {poll_s}")
        self.clock: Clock = wall_clock if clock is None else clock
        self.source = source
        self.description = getattr(source, "description", type(source).__name__)
        self._poll_s = float(poll_s)
        self._close_source = close_source
        self._cond = self.clock.condition()
        self._stop_event = self.clock.event()
        self._latest: Frame | None = None
        self._taken = True
        self._frames_read = 0
        self._frames_dropped = 0
        self._error: BaseException | None = None
        self._running = True
        self._stopped = False
        self._thread = self.clock.start_thread(self._run, name="auvdock-frame-grabber")

    def _run(self) -> None:
        try:
            while not self._stop_event.is_set():
                frame = self.source.read(self._poll_s)
                if frame is None:
                    continue
                with self._cond:
                    if not self._taken:
                        self._frames_dropped += 1
                    self._latest = frame
                    self._taken = False
                    self._frames_read += 1
                    self._cond.notify_all()
        except BaseException as exc:  # noqa: BLE001 - kept for the caller, never raised into its thread
            if not self._stop_event.is_set():
                if isinstance(exc, EOFError):
                    log.info("%s: %s", self.description, exc)
                else:
                    log.warning("%s: frame grabber stopped: %r", self.description, exc)
                self._error = exc
        finally:
            with self._cond:
                self._running = False
                self._cond.notify_all()

    @property
    def frames_read(self) -> int:
        """Frames read from the source."""
        return self._frames_read

    @property
    def frames_dropped(self) -> int:
        """Frames replaced by a newer one before :meth:`latest` / :meth:`wait_new` took them."""
        return self._frames_dropped

    @property
    def error(self) -> BaseException | None:
        """The exception that stopped the source (``EOFError`` at the end of a file), else None."""
        return self._error

    @property
    def running(self) -> bool:
        """True while the reader thread runs (False after :meth:`stop`, an error or the end of a file)."""
        return self._running

    def latest(self) -> Frame | None:
        """Newest frame (possibly one already returned: compare ``index``), None before the first; no wait."""
        with self._cond:
            self._taken = True
            return self._latest

    def wait_new(self, after_index: int = -1, timeout_s: float = 1.0) -> Frame | None:
        """Newest frame with ``index > after_index``, waiting up to ``timeout_s`` s.

        Returns None on timeout, or at once when the reader has stopped and no such frame is held.
        """
        with self._cond:
            ok = self._cond.wait_for(
                lambda: (self._latest is not None and self._latest.index > after_index) or not self._running,
                max(0.0, float(timeout_s)),
            )
            if ok and self._latest is not None and self._latest.index > after_index:
                self._taken = True
                return self._latest
            return None

    def stop(self, timeout_s: float = 2.0) -> None:
        """Stop the thread (joins it, up to ``timeout_s`` s) and close the source if ``close_source``."""
        if self._stopped:
            return
        self._stopped = True
        self._stop_event.set()
        if self._thread is not threading.current_thread():
            self.clock.join(self._thread, timeout=max(0.0, float(timeout_s)))
        if self._thread.is_alive():  # pragma: no cover - source read stuck in native code
            log.warning("%s: frame grabber thread did not stop; source left open", self.description)
            return
        if self._close_source:
            try:
                self.source.close()
            except Exception as exc:  # noqa: BLE001 - never raise into the caller
                log.warning("%s: error closing the source: %r", self.description, exc)

    close = stop

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()
