"""Camera frame sources (auvdock.camera.video_in): video files, RTP/H.264 loopback, V4L2 (faked),
image folders, the latest-frame grabber and spec errors.

Images: the default dock layout rendered by an ideal 320x240 camera (80 deg field of view) approaching the
panel, or a bright square moving on a dark background. Networking only on 127.0.0.1.

Pacing and waiting are checked in simulated time (:class:`auvdock.runtime.clock.SimClock`): exact, at
any machine
load. RTP and V4L2 are real devices on the wall clock; nothing here asserts a wall-clock duration.
"""

from __future__ import annotations

import itertools
import os
import re
import socket
import struct
import threading
from pathlib import Path

import cv2
import numpy as np
import pytest

av = pytest.importorskip("av")

from helpers.loopback import free_udp_pair  # noqa: E402

from auvdock.camera import video_in as video  # noqa: E402
from auvdock.camera.layout import default_layout  # noqa: E402
from auvdock.camera.model import R_BC_DEFAULT, CameraModel  # noqa: E402
from auvdock.camera.pose import MarkerDetector  # noqa: E402
from auvdock.camera.render import render_view  # noqa: E402
from auvdock.camera.video_common import VideoSourceError  # noqa: E402
from auvdock.camera.video_in import (  # noqa: E402
    SOURCE_FORMS,
    Frame,
    FrameSource,
    ImageFolderSource,
    LatestFrameGrabber,
    RtpSource,
    V4l2Source,
    VideoFileSource,
    open_source,
)
from auvdock.camera.video_out import h264_encoder, stream_rtp  # noqa: E402
from auvdock.runtime.clock import SimClock  # noqa: E402

CAM = CameraModel.ideal(320, 240)
LAYOUT = default_layout()


def _approach(n: int) -> list[np.ndarray]:
    """Frames of the camera moving from 1.2 m to 0.5 m in front of the panel (docking axis, 5 cm to port)."""
    R_cd = R_BC_DEFAULT.T  # camera axes along the dock's (dock x = optical axis)
    return [render_view(CAM, LAYOUT, R_cd, [0.0, 0.05, r - 0.35]) for r in np.linspace(1.2, 0.5, n)]


def _square(n: int, w: int = 320, h: int = 240) -> list[np.ndarray]:
    frames = []
    for k in range(n):
        image = np.full((h, w), 40, np.uint8)
        x = 10 + 5 * k
        image[100:140, x : x + 40] = 220
        frames.append(image)
    return frames


def _write_video(path: Path, frames: list[np.ndarray], fps: int) -> Path:
    encoder = h264_encoder()
    with av.open(str(path), "w") as out:
        stream = out.add_stream(encoder, rate=fps, options={"crf": "18"} if encoder == "libx264" else {})
        stream.height, stream.width = frames[0].shape
        stream.pix_fmt = "yuv420p"
        for k, image in enumerate(frames):
            vf = av.VideoFrame.from_ndarray(image, format="gray").reformat(format="yuv420p")
            vf.pts = k
            out.mux(stream.encode(vf))
        out.mux(stream.encode(None))
    return path


def _mad(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.mean(np.abs(a.astype(np.int16) - b.astype(np.int16))))




def _read_all(source: FrameSource, timeout_s: float = 1.0) -> list[Frame]:
    frames = []
    while True:
        try:
            frame = source.read(timeout_s)
        except EOFError:
            return frames
        assert frame is not None, "timeout before the end of the file"
        frames.append(frame)


# --- video files ------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def approach_video(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[np.ndarray]]:
    frames = _approach(30)
    return _write_video(tmp_path_factory.mktemp("video") / "approach.mp4", frames, 30), frames


def test_file_read_back_as_fast_as_decoded(approach_video: tuple[Path, list[np.ndarray]]) -> None:
    path, written = approach_video
    with SimClock() as clock, open_source(str(path), realtime=False, clock=clock) as source:
        assert isinstance(source, VideoFileSource) and isinstance(source, FrameSource)
        assert source.fps == pytest.approx(30.0)
        frames = _read_all(source)
        with pytest.raises(EOFError):
            source.read(0.1)
        elapsed = clock.now()
    assert len(frames) == 30
    assert [f.index for f in frames] == list(range(30))
    assert all(f.image.shape == (240, 320) and f.image.dtype == np.uint8 for f in frames)
    t = np.array([f.t_capture for f in frames])
    assert np.all(np.diff(t) >= 0.0)
    pts = np.array([f.pts_s for f in frames], dtype=float)
    np.testing.assert_allclose(np.diff(pts), 1 / 30, atol=1e-3)
    mad = [_mad(f.image, w) for f, w in zip(frames, written, strict=True)]
    assert max(mad) < 2.0, mad
    assert elapsed == 0.0  # not paced: no waiting at all (30 frames would take 1 s)
    detector = MarkerDetector(LAYOUT, CAM)
    assert all(0 in [d.id for d in detector.detect(f.image)] for f in frames)


def test_file_realtime_is_paced_at_the_frame_rate(approach_video: tuple[Path, list[np.ndarray]]) -> None:
    path, _ = approach_video
    with SimClock() as clock, open_source(str(path), realtime=True, clock=clock) as source:
        first = source.read(1.0)
        assert first is not None and first.index == 0
        assert source.read(0.0) is None  # frame 1 is due 33 ms after frame 0: not within 0 s
        frames = [first]
        while len(frames) < 15:
            frame = source.read(0.02)
            if frame is not None:
                frames.append(frame)
    assert [f.index for f in frames] == list(range(15))
    t = np.array([f.t_capture for f in frames])
    np.testing.assert_allclose(t - t[0], np.arange(15) / 30, atol=1e-3)  # released at the file's timing


def test_missing_and_undecodable_files(tmp_path: Path) -> None:
    missing = str(tmp_path / "dive.mp4")
    with pytest.raises(ValueError) as exc:
        open_source(missing)
    assert str(exc.value) == f"video source {missing!r}: no such file or directory (accepted: {SOURCE_FORMS})"
    notes = tmp_path / "notes.txt"
    notes.write_text("not a video\n")
    with pytest.raises(VideoSourceError, match=re.escape(f"{notes}: cannot open as a video")):
        open_source(str(notes))


def test_image_folder(tmp_path: Path) -> None:
    images = _square(3, 64, 48)
    for k, image in enumerate(images):
        cv2.imwrite(str(tmp_path / f"frame_{k:03d}.png"), image)
    with open_source(str(tmp_path), realtime=False) as source:
        assert isinstance(source, ImageFolderSource)
        frames = _read_all(source)
    assert [f.index for f in frames] == [0, 1, 2]
    assert all(np.array_equal(f.image, i) and f.pts_s is None for f, i in zip(frames, images, strict=True))
    with (
        SimClock() as clock,
        open_source(str(tmp_path), realtime=True, image_fps=50.0, clock=clock) as source,
    ):
        frames = _read_all(source)
    assert frames[-1].t_capture - frames[0].t_capture == pytest.approx(0.04)  # 2 intervals of 20 ms
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="no images"):
        open_source(str(empty))


# --- RTP / H.264 over UDP ----------------------------------------------------------------------------------


def test_rtp_loopback_receives_decodes_and_keeps_content() -> None:
    port = free_udp_pair()
    fps = 30.0
    sent_frames = _approach(60)
    sent_t: dict[int, float] = {}
    result: dict[str, object] = {}
    with open_source(f"udp:{port}") as source:  # listening before the sender starts
        assert isinstance(source, RtpSource)
        assert source.description == f"rtp://0.0.0.0:{port} (H.264, payload type 96)"

        def send() -> None:
            try:
                result["sent"] = stream_rtp(
                    sent_frames, port, fps=fps, on_sent=lambda k, t: sent_t.__setitem__(k, t)
                )
            except Exception as exc:  # noqa: BLE001 - reported by the assertion below
                result["error"] = exc

        sender = threading.Thread(target=send, daemon=True)
        sender.start()
        received: list[Frame] = []
        while len(received) < len(sent_frames):
            frame = source.read(0.5)
            if frame is None and not sender.is_alive():
                break
            if frame is not None:
                received.append(frame)
        sender.join(5.0)
        stats = (source.frames_produced, source.frames_dropped, source.frames_corrupt, source.decode_errors)
    assert "error" not in result, result
    assert result["sent"] == 60
    assert len(received) >= 15, f"only {len(received)} of 60 frames received"  # UDP, a busy machine: not all
    assert all(f.image.shape == (240, 320) and f.image.dtype == np.uint8 for f in received)
    assert [f.index for f in received] == list(range(len(received)))
    assert np.all(np.diff([f.t_capture for f in received]) >= 0.0)
    # Each received frame is one sent frame (best match), in order, and its RTP time says which.
    matches = []
    for f in received:
        mads = [_mad(f.image, s) for s in sent_frames]
        k = int(np.argmin(mads))
        assert mads[k] < 3.0, mads[k]
        matches.append(k)
        if f.pts_s is not None:
            assert round(f.pts_s * fps) == k
    assert np.all(np.diff(matches) > 0)
    latency = np.array([f.t_capture - sent_t[k] for f, k in zip(received, matches, strict=True)])
    assert np.all(
        latency > 0.0
    )  # received after sent (its size is a wall-clock figure: printed, not asserted)
    detector = MarkerDetector(LAYOUT, CAM)
    assert sum(0 in [d.id for d in detector.detect(f.image)] for f in received) >= 0.9 * len(received)
    print(
        f"\nRTP loopback: {len(received)}/60 frames, latency median {1e3 * np.median(latency):.1f} ms "
        f"max {1e3 * latency.max():.1f} ms; produced/dropped/corrupt/decode errors {stats}"
    )


def test_stream_rtp_wire_format_is_blueos_like() -> None:
    """RTP version 2, payload type 96, 90 kHz clock, H.264 with in-band SPS/PPS and an IDR first."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        sock.settimeout(2.0)
        port = sock.getsockname()[1]
        assert stream_rtp(_square(3), port, fps=50.0) == 3
        packets = []
        sock.settimeout(0.2)
        try:
            while True:
                packets.append(sock.recv(65536))
        except TimeoutError:
            pass
    assert packets
    nal_types, stamps, markers = [], [], []
    for p in packets:
        b0, b1, _seq, stamp = struct.unpack("!BBHI", p[:8])
        assert b0 >> 6 == 2 and b1 & 0x7F == 96
        stamps.append(stamp)
        markers.append(bool(b1 & 0x80))
        payload = p[12 + 4 * (b0 & 0x0F) :]
        nal = payload[0] & 0x1F
        if nal == 24:  # STAP-A: 16-bit sizes then NAL units
            i = 1
            while i + 2 < len(payload):
                size = int.from_bytes(payload[i : i + 2], "big")
                nal_types.append(payload[i + 2] & 0x1F)
                i += 2 + size
        elif nal == 28:  # FU-A
            nal_types.append(payload[1] & 0x1F)
        else:
            nal_types.append(nal)
    assert {7, 8, 5} <= set(nal_types)  # SPS, PPS, IDR slice
    assert nal_types.index(7) < nal_types.index(5)
    frame_stamps = sorted(set(stamps))
    assert len(frame_stamps) == 3 and set(np.diff(frame_stamps)) == {90000 // 50}
    assert sum(markers) == 3  # the marker bit ends each frame


def test_rtp_source_without_sender_times_out_and_closes_quickly() -> None:
    port = free_udp_pair()
    source = open_source(f"rtp://127.0.0.1:{port}")
    assert source.read(0.2) is None
    source.close()  # returns (its thread polls for close every 0.1 s)
    assert source.closed
    source.close()  # idempotent
    with pytest.raises(VideoSourceError, match="source is closed"):
        source.read(0.1)


def test_rtp_port_in_use_is_a_clear_error() -> None:
    port = free_udp_pair()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", port))
        with pytest.raises(VideoSourceError) as exc:
            open_source(f"udp:127.0.0.1:{port}")
    assert str(exc.value).startswith(f"cannot receive RTP on udp://127.0.0.1:{port}: RTP port {port}: ")
    assert "already in use" in str(exc.value)


def test_stream_rtp_checks_frames() -> None:
    assert stream_rtp([], 5600) == 0
    with pytest.raises(ValueError, match="even sizes"):
        stream_rtp([np.zeros((240, 321), np.uint8)], 5600)
    with pytest.raises(ValueError, match="uint8"):
        stream_rtp([np.zeros((240, 320), np.float32)], 5600)
    with pytest.raises(ValueError, match="UDP port must be 1-65534"):
        stream_rtp(_square(1), 65535)


# --- V4L2 (no camera here: OpenCV faked) -------------------------------------------------------------------


class _FakeCapture:
    """A camera that captures a frame each time the test presses its shutter (no clock at all),
    until it is set free-running."""

    instances: list[_FakeCapture] = []
    opens = True

    def __init__(self, index: int, api: int) -> None:
        self.args = (index, api)
        self.k = 0
        self.released = False
        self.shutter = threading.Semaphore(0)
        self.free_running = False
        _FakeCapture.instances.append(self)

    def isOpened(self) -> bool:
        return self.opens

    def read(self) -> tuple[bool, np.ndarray]:
        if not self.free_running:
            self.shutter.acquire()
        self.k += 1
        return True, np.full((48, 64, 3), (10 * self.k) % 200, np.uint8)

    def run_free(self) -> None:
        self.free_running = True
        self.shutter.release()

    def release(self) -> None:
        self.released = True


def test_v4l2_source_with_a_faked_camera(monkeypatch: pytest.MonkeyPatch) -> None:
    real_exists = os.path.exists
    monkeypatch.setattr(os.path, "exists", lambda p: p == "/dev/video7" or real_exists(p))
    monkeypatch.setattr(video.cv2, "VideoCapture", _FakeCapture)
    _FakeCapture.instances.clear()
    with open_source("/dev/video7") as source:
        assert isinstance(source, V4l2Source) and source.description == "V4L2 device /dev/video7"
        cap = _FakeCapture.instances[-1]
        frames = []
        for _ in range(3):  # one frame captured at a time, each read before the next is captured
            cap.shutter.release()
            frames.append(source.read(30.0))  # returns as soon as it is there
        cap.run_free()  # so that its reader thread sees the stop when the source closes
    assert cap.args == (7, cv2.CAP_V4L2) and cap.released
    assert all(f is not None and f.image.shape == (48, 64) and f.pts_s is None for f in frames)
    assert [f.index for f in frames] == [0, 1, 2]  # none dropped from the 2-frame queue
    assert [int(f.image[0, 0]) for f in frames] == [10, 20, 30]
    monkeypatch.setattr(_FakeCapture, "opens", False)
    with pytest.raises(VideoSourceError, match=r"^cannot open V4L2 device /dev/video7: "):
        open_source("v4l2:7")


def test_v4l2_missing_device() -> None:
    if os.path.exists("/dev/video63"):
        pytest.skip("/dev/video63 exists here")
    with pytest.raises(VideoSourceError) as exc:
        open_source("v4l2:63")
    assert str(exc.value) == "cannot open V4L2 device /dev/video63: no such device"


# --- LatestFrameGrabber -------------------------------------------------------------------------------------


class _CountingSource:
    """A frame every ``period_s`` (simulated); EOFError after ``n``, RuntimeError after ``fail_after``."""

    description = "counting source"

    def __init__(
        self, clock: SimClock, period_s: float = 0.002, n: int | None = None, fail_after: int | None = None
    ) -> None:
        self.clock = clock
        self.period_s, self.n, self.fail_after = period_s, n, fail_after
        self.k = 0
        self.closed = False

    def read(self, timeout_s: float) -> Frame | None:
        self.clock.sleep(self.period_s)
        if self.fail_after is not None and self.k >= self.fail_after:
            raise RuntimeError("camera unplugged")
        if self.n is not None and self.k >= self.n:
            raise EOFError("end")
        frame = Frame(np.full((4, 4), self.k % 256, np.uint8), self.clock.now(), self.k)
        self.k += 1
        return frame

    def close(self) -> None:
        self.closed = True


def _wait_until(clock: SimClock, condition, timeout_s: float = 3.0) -> None:  # noqa: ANN001
    t_end = clock.now() + timeout_s
    while not condition():
        assert clock.now() < t_end, "condition not met within the simulated timeout"
        clock.sleep(0.005)


def test_grabber_slow_consumer_drops_frames_instead_of_lagging() -> None:
    with SimClock() as clock:
        _slow_consumer(clock)


def _slow_consumer(clock: SimClock) -> None:
    source = _CountingSource(clock, period_s=0.002)
    grabber = LatestFrameGrabber(source, clock=clock)
    assert grabber.latest() is None or grabber.latest().index >= 0
    taken = []
    last = -1
    for _ in range(8):
        frame = grabber.wait_new(last, timeout_s=2.0)
        assert frame is not None and frame.index > last
        taken.append(frame.index)
        last = frame.index
        clock.sleep(0.03)  # slow consumer: 15 frames arrive meanwhile
        assert grabber.latest().index - last in (14, 15)  # the newest, not the next in line
    assert grabber.frames_dropped > 0
    assert np.all(np.diff(taken) > 1)
    grabber.stop()
    assert not grabber.running and source.closed
    assert grabber.error is None
    assert grabber.frames_read - grabber.frames_dropped <= len(taken) + 8 + 1  # taken via wait_new / latest
    grabber.stop()  # idempotent


def test_grabber_keeps_the_source_error_and_never_raises() -> None:
    with SimClock() as clock:
        source = _CountingSource(clock, fail_after=3)
        with LatestFrameGrabber(source, clock=clock) as grabber:
            _wait_until(clock, lambda: not grabber.running)
            assert isinstance(grabber.error, RuntimeError) and str(grabber.error) == "camera unplugged"
            assert grabber.frames_read == 3 and grabber.latest().index == 2
            t0 = clock.now()
            assert grabber.wait_new(2, timeout_s=5.0) is None  # returns at once: the reader has stopped
            assert clock.now() == t0
        assert source.closed


def test_grabber_over_a_file_ends_with_eof(approach_video: tuple[Path, list[np.ndarray]]) -> None:
    path, _ = approach_video
    with SimClock() as clock:
        grabber = LatestFrameGrabber(open_source(str(path), realtime=False, clock=clock), clock=clock)
        _wait_until(clock, lambda: not grabber.running)
        assert isinstance(grabber.error, EOFError)
        assert grabber.frames_read == 30 and grabber.latest().index == 29
        grabber.stop()
        assert grabber.source.closed


def test_grabber_over_rtp_stops_cleanly() -> None:
    port = free_udp_pair()
    stop = threading.Event()
    sender = threading.Thread(
        target=stream_rtp, args=(itertools.repeat(_square(1)[0]), port), kwargs={"fps": 50.0, "stop": stop}
    )
    grabber = LatestFrameGrabber(open_source(f"udp:{port}"))
    sender.start()
    try:
        frame = grabber.wait_new(-1, timeout_s=3.0)
        assert frame is not None and frame.image.shape == (240, 320)
    finally:
        stop.set()
        sender.join(3.0)
        grabber.stop()
    assert not grabber.running and grabber.error is None and grabber.source.closed


# --- specs and frames ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("spec", ["camera", "udp:", "udp:abc", "rtsp://192.168.2.2:8554/video", "v4l2:x", ""])
def test_bad_specs(spec: str) -> None:
    with pytest.raises(ValueError) as exc:
        open_source(spec)
    assert str(exc.value) == f"video source {spec!r} not recognised; accepted: {SOURCE_FORMS}"


def test_bad_ports_and_hosts() -> None:
    with pytest.raises(ValueError) as exc:
        open_source("udp:70000")
    assert (
        str(exc.value) == "video source 'udp:70000': UDP port must be 1-65534 (RTCP uses port + 1), got 70000"
    )
    with pytest.raises(ValueError) as exc:
        open_source("udp:300.1.1.1:5600")
    assert (
        str(exc.value) == "video source 'udp:300.1.1.1:5600': HOST must be an IPv4 address, got '300.1.1.1'"
    )
    with pytest.raises(ValueError, match="HOST must be an IPv4 address"):
        open_source("rtp://topside:5600")


def test_frame_checks_its_image() -> None:
    frame = Frame(np.zeros((3, 4), np.uint8), 1.0, 0)
    assert frame.shape == (3, 4) and frame.pts_s is None and frame.age_s(now=1.5) == 0.5
    with pytest.raises(ValueError, match=r"expected a \(h, w\) uint8 grayscale array"):
        Frame(np.zeros((3, 4, 3), np.uint8), 0.0, 0)
