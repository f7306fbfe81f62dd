"""``auvdock calibrate`` on a live source (issue 19): it says what it waits for every 5 s, stops after
``--wait`` with one line naming the port (exit 2), and collects board views as the video comes; all in
simulated time (a SimClock as the command's clock), so nothing here waits for real."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.loopback import free_udp_pair
from test_camera import COLS, ROWS, _board_views
from typer.testing import CliRunner

from auvdock.camera.calibration import NoVideoError, collect_views
from auvdock.camera.video_in import Frame
from auvdock.cli import app
from auvdock.cli.app import Runtime
from auvdock.runtime.clock import SimClock

runner = CliRunner()


@pytest.fixture
def sim_clock():
    with SimClock() as clock:
        yield clock


@pytest.mark.parametrize("wait", [None, 12.5])
def test_no_stream_on_the_port_ends_with_one_line_after_the_wait(
    sim_clock: SimClock, wait: float | None
) -> None:
    port = free_udp_pair()
    spec = f"udp:127.0.0.1:{port}"
    args = ["calibrate", spec, "--board", "9x6", "--square", "0.025"]
    res = runner.invoke(app, args + ([] if wait is None else ["--wait", str(wait)]), obj=Runtime(sim_clock))
    limit = 30.0 if wait is None else wait
    assert res.exit_code == 2, res.output + res.stderr
    assert res.stderr == (
        f"error: {spec}: no video arrived on UDP 127.0.0.1:{port} within {limit:g} s (--wait {limit:g}); "
        f"is the camera streaming RTP/H.264 to this computer's port {port}?\n"
    )
    assert "Traceback" not in res.output + res.stderr and "images" not in res.stderr
    what = f"the RTP/H.264 stream on UDP 127.0.0.1:{port}"
    notes = [f"waiting for {what}: {t} s of {limit:g} s" for t in range(5, int(limit) + 1, 5) if t < limit]
    assert res.stdout.splitlines() == [f"waiting up to {limit:g} s for {what}", *notes]
    assert sim_clock.now() == pytest.approx(limit)  # simulated seconds


class FakeCamera:
    """A live source in simulated time: ``images[k]`` at ``start + k / fps`` (None in between), then
    nothing (or EOFError with ``eof``)."""

    def __init__(self, clock: SimClock, images: list[np.ndarray], start: float, fps: float = 10.0, eof=False):
        self.clock, self.images, self.start, self.fps, self.eof = clock, images, start, fps, eof
        self.k = 0
        self.t_last = None

    def read(self, timeout_s: float) -> Frame | None:
        assert timeout_s == 0.0  # never blocks: the waits are the clock's
        if self.k >= len(self.images):
            if self.eof:
                raise EOFError("end of stream")
            return None
        if self.clock.now() < self.start + self.k / self.fps:
            return None
        self.k += 1
        self.t_last = self.clock.now()
        return Frame(self.images[self.k - 1], self.clock.now(), self.k - 1, None)


def _collect(clock: SimClock, camera: FakeCamera, lines: list[str], **kw):
    return collect_views(camera, COLS, ROWS, clock=clock, what="fake", say=lines.append, **kw)


def test_views_once_the_video_arrives() -> None:
    views = _board_views(6, seed=2)
    with SimClock() as clock:
        lines: list[str] = []
        images = _collect(
            clock, FakeCamera(clock, [v for v in views for _ in range(8)], start=12.0), lines, views=5
        )
    assert len(images) == 5 and images[0].shape == (480, 640)
    assert lines[:3] == [
        "waiting up to 30 s for video on fake",
        "waiting for video on fake: 5 s of 30 s",
        "waiting for video on fake: 10 s of 30 s",
    ]
    assert lines[3].startswith("video from fake: 640x480 px; show the 9x6 board")
    assert lines[4:] == [f"board view {k}/5" for k in range(1, 6)]


def test_too_few_views_when_the_video_stops() -> None:
    views = _board_views(2, seed=4)
    with SimClock() as clock:
        lines: list[str] = []
        camera = FakeCamera(clock, views, start=0.0, fps=1.0)
        with pytest.raises(ValueError) as exc:
            _collect(clock, camera, lines, views=5, wait_s=8.0)
        assert clock.now() == pytest.approx(camera.t_last + 8.0)  # the last frame, then the wait
    assert str(exc.value) == (
        "only 2 board views (the whole 9x6 board in view) before the video stopped "
        "(no frame from fake for 8 s) (need 5)"
    )


def test_too_few_views_when_the_board_is_not_seen() -> None:
    blank = np.full((240, 320), 128, np.uint8)
    with SimClock() as clock:
        lines: list[str] = []
        with pytest.raises(ValueError) as exc:
            _collect(clock, FakeCamera(clock, [blank] * 1000, start=0.0), lines, views=5, collect_s=20.0)
    assert str(exc.value) == "only 0 board views (the whole 9x6 board in view) in 20 s of video (need 5)"
    assert "board views: 0/5 after 5 s (the whole board must be in view)" in lines


def test_a_source_that_ends_before_any_frame() -> None:
    with SimClock() as clock:
        with pytest.raises(NoVideoError, match="^fake ended before its first frame$"):
            _collect(clock, FakeCamera(clock, [], start=0.0, eof=True), [])
        assert clock.now() == 0.0
