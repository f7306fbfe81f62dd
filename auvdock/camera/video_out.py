"""The sender's side of the camera stream: frames encoded to H.264 and sent as RTP over UDP, as BlueOS does.

:func:`stream_rtp` lets tests and rehearsals feed :func:`auvdock.camera.video_in.open_source`
(``"udp:PORT"``) or a ``fly`` session with rendered or recorded frames, uint8 (h, w) gray or (h, w, 3) BGR
images of even size, paced at a frame rate in frames/s on a :class:`auvdock.runtime.clock.Clock` (the wall
clock by default, a :class:`auvdock.runtime.clock.SimClock` in tests); :func:`h264_encoder` picks the
first H.264 encoder that PyAV's FFmpeg can open. Payload type and port conventions are those of
:mod:`auvdock.camera.video_common`.
"""

from __future__ import annotations

import functools
import logging
import math
import threading
from collections.abc import Callable, Iterable
from fractions import Fraction

import numpy as np

from auvdock.camera.video_common import (
    RTP_PAYLOAD_TYPE,
    VideoSourceError,
    check_payload_type,
    check_rtp_port,
    import_av,
)
from auvdock.runtime.clock import Clock, wall_clock

__all__ = [
    "h264_encoder",
    "stream_rtp",
]

log = logging.getLogger(__name__)

#: H.264 encoders tried by :func:`h264_encoder`, in order of preference.
H264_ENCODERS = (
    "libx264",
    "libopenh264",
    "h264_nvenc",
    "h264_qsv",
    "h264_vaapi",
    "h264_videotoolbox",
    "h264_mf",
    "h264_amf",
    "h264_v4l2m2m",
)


@functools.cache
def h264_encoder() -> str:
    """Name of the H.264 encoder :func:`stream_rtp` uses: the first of :data:`H264_ENCODERS` that opens.

    Raises
    ------
    VideoSourceError
        PyAV's FFmpeg has no working H.264 encoder.
    """
    av = import_av()
    tried = []
    for name in H264_ENCODERS:
        try:
            ctx = av.CodecContext.create(name, "w")
            ctx.width, ctx.height, ctx.pix_fmt, ctx.time_base = 64, 64, "yuv420p", Fraction(1, 20)
            ctx.open()
        except Exception as exc:  # noqa: BLE001 - unknown or unusable (e.g. no GPU): try the next
            tried.append(f"{name} ({type(exc).__name__})")
            continue
        if tried:
            log.info("H.264 encoder: %s (unusable: %s)", name, ", ".join(tried))
        return name
    raise VideoSourceError(f"no working H.264 encoder in PyAV's FFmpeg; tried {', '.join(tried)}")


def _frame_size(image: np.ndarray) -> tuple[int, int, str]:
    if image.dtype != np.uint8 or not (image.ndim == 2 or (image.ndim == 3 and image.shape[2] == 3)):
        raise ValueError(
            f"frames: expected uint8 (h, w) gray or (h, w, 3) BGR arrays, got {image.dtype} {image.shape}"
        )
    h, w = image.shape[:2]
    if h % 2 or w % 2 or h < 16 or w < 16:
        raise ValueError(f"frames: H.264 4:2:0 needs even sizes >= 16 px, got {w}x{h}")
    return h, w, "gray" if image.ndim == 2 else "bgr24"


def stream_rtp(
    frames: Iterable[np.ndarray],
    port: int,
    *,
    host: str = "127.0.0.1",
    fps: float = 20.0,
    payload_type: int = RTP_PAYLOAD_TYPE,
    encoder: str | None = None,
    stop: threading.Event | None = None,
    on_sent: Callable[[int, float], None] | None = None,
    clock: Clock | None = None,
) -> int:
    """Encode frames to H.264 and send them as RTP to ``host:port`` (what BlueOS does), paced at ``fps``.

    Blocking; run it in a thread to rehearse against :func:`open_source` ``("udp:PORT")``. The encoder is
    :func:`h264_encoder` (libx264 with ``preset=ultrafast``, ``tune=zerolatency``: one packet per frame, no
    B-frames), a key frame with in-band SPS/PPS every second (so a receiver can join at any time), FFmpeg's
    ``rtp`` muxer (packetization mode 1, RTCP sender reports to ``port + 1``, RTCP BYE at the end).

    Parameters
    ----------
    frames : iterable of ndarray
        uint8 (h, w) grayscale or (h, w, 3) BGR images, all of the first one's size (even width and height);
        may be a generator (rendered on the fly).
    port : int
        Destination UDP port (1-65534).
    host : str
        Destination address.
    fps : float
        Frame rate, frames/s: frame k is sent at ``k / fps`` s after the first (if the iterable keeps up;
        a late frame is sent at once and the schedule restarts from it, no burst).
    payload_type : int
        RTP payload type (96-127).
    encoder : str or None
        FFmpeg encoder name; None picks :func:`h264_encoder`.
    stop : threading.Event or None
        Set it to stop early (checked between frames).
    on_sent : callable or None
        ``on_sent(k, t)``: called after frame k was handed to the muxer at clock time t (s).
    clock : Clock, optional
        What the pacing uses (default the wall clock).

    Returns
    -------
    int
        Number of frames sent.
    """
    av = import_av()
    check_rtp_port(port, "port")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps: expected a positive frame rate, got {fps}")
    check_payload_type(payload_type)
    it = iter(frames)
    first = next(it, None)
    if first is None:
        return 0
    first = np.asarray(first)
    h, w, _ = _frame_size(first)
    name = encoder or h264_encoder()
    rate = Fraction(fps).limit_denominator(1001)
    out = av.open(
        f"rtp://{host}:{port}", "w", format="rtp", container_options={"payload_type": str(payload_type)}
    )
    sent = 0
    try:
        options = {"preset": "ultrafast", "tune": "zerolatency"} if name == "libx264" else {}
        stream = out.add_stream(name, rate=rate, options=options)
        stream.width, stream.height, stream.pix_fmt = w, h, "yuv420p"
        stream.codec_context.gop_size = max(1, round(fps))
        log.info(
            "stream_rtp: %s %dx%d at %.3g fps to rtp://%s:%d (payload type %d)",
            name,
            w,
            h,
            fps,
            host,
            port,
            payload_type,
        )
        clock = wall_clock if clock is None else clock
        t0 = clock.now()
        k0 = 0
        image: np.ndarray | None = first
        while image is not None:
            if stop is not None and stop.is_set():
                break
            image = np.asarray(image)
            if image.shape[:2] != (h, w):
                raise ValueError(
                    f"frames[{sent}]: size {image.shape[1]}x{image.shape[0]} px differs from {w}x{h}"
                )
            _, _, fmt = _frame_size(image)
            vf = av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format=fmt).reformat(
                format="yuv420p"
            )
            vf.pts = sent
            delay = t0 + (sent - k0) / fps - clock.now()
            if delay > 0:
                if stop is not None:
                    if stop.wait(delay):
                        break
                else:
                    clock.sleep(delay)
            elif delay < -1.0 / fps:
                t0, k0 = clock.now(), sent  # late: restart the schedule here rather than burst
            for packet in stream.encode(vf):
                out.mux(packet)
            if on_sent is not None:
                on_sent(sent, clock.now())
            sent += 1
            image = next(it, None)
        for packet in stream.encode(None):
            out.mux(packet)
    finally:
        out.close()
    return sent
