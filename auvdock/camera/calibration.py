"""Checkerboard camera calibration (OpenCV pinhole + 5-term plumb-bob distortion).

Board convention (OpenCV): ``cols x rows`` INNER corners, i.e. (cols + 1) x (rows + 1) squares of side
``square_m``; object points ``(i square_m, j square_m, 0)`` in m, i along a row (fastest), j down the
columns. Print the board flat and rigid, and take views that tilt it (+-30 deg or more) and cover the whole
image, corners included.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import cv2
import numpy as np

from auvdock.camera.model import CameraModel, gray_image
from auvdock.runtime.clock import Clock, wall_clock

if TYPE_CHECKING:
    from auvdock.camera.video_in import FrameSource

__all__ = [
    "MIN_VIEWS",
    "NoVideoError",
    "board_points",
    "calibrate",
    "collect_views",
    "find_corners",
]

#: Fewest board views :func:`calibrate` accepts by default.
MIN_VIEWS = 5


def _check_pattern(cols: int, rows: int) -> None:
    for name, v in (("cols", cols), ("rows", rows)):
        if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 2:
            raise ValueError(f"{name}: expected an integer >= 2 (inner corners), got {v!r}")


def board_points(cols: int, rows: int, square_m: float) -> np.ndarray:
    """Inner-corner positions on the board, m, shape (cols * rows, 3), in OpenCV's detection order."""
    _check_pattern(cols, rows)
    if not (math.isfinite(square_m) and square_m > 0):
        raise ValueError(f"square_m: must be > 0, got {square_m}")
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2)
    return np.hstack([grid * float(square_m), np.zeros((cols * rows, 1))])


def find_corners(image: np.ndarray, cols: int, rows: int) -> np.ndarray | None:
    """Inner corners of a ``cols x rows`` checkerboard, refined to sub-pixel accuracy.

    Parameters
    ----------
    image : ndarray, uint8, shape (h, w) or (h, w, 3) (BGR)
    cols, rows : int
        Inner corners per row and per column.

    Returns
    -------
    ndarray, shape (cols * rows, 2), or None
        Corner pixel coordinates (row by row, OpenCV order); None when the whole board is not found.
    """
    _check_pattern(cols, rows)
    gray = gray_image(image)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
    found, corners = cv2.findChessboardCorners(gray, (cols, rows), flags=flags)
    if not found or corners is None:
        return None
    pts = corners.reshape(rows, cols, 2)
    spacing = min(
        np.linalg.norm(np.diff(pts, axis=1), axis=2).min(), np.linalg.norm(np.diff(pts, axis=0), axis=2).min()
    )
    win = int(np.clip(round(spacing / 3.0), 2, 11))  # half window, kept well inside one square
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    refined = cv2.cornerSubPix(gray, corners.astype(np.float32), (win, win), (-1, -1), criteria)
    return refined.reshape(-1, 2).astype(float)


def calibrate(
    images: Iterable[np.ndarray], cols: int, rows: int, square_m: float, *, min_views: int = MIN_VIEWS
) -> CameraModel:
    """Calibrate a camera from checkerboard images.

    Parameters
    ----------
    images : iterable of ndarray
        uint8 grayscale or BGR frames, all of one size (e.g. from
        :func:`auvdock.camera.image_files.image_sources`).
    cols, rows : int
        Inner corners per row and per column of the board.
    square_m : float
        Square side, m (sets the scale of the extrinsics only; intrinsics do not depend on it).
    min_views : int
        Minimum number of images in which the whole board must be found.

    Returns
    -------
    CameraModel
        ``K``, 5-term distortion, image size, RMS reprojection error (px), board and number of views used.

    Raises
    ------
    ValueError
        No images; images of different sizes; or too few views, e.g.
        ``"only 3 of 12 images show the 9x6 board (need 5)"``.
    """
    objp = board_points(cols, rows, square_m).astype(np.float32)
    if isinstance(min_views, bool) or not isinstance(min_views, int) or min_views < 1:
        raise ValueError(f"min_views: expected a positive integer, got {min_views!r}")
    size: tuple[int, int] | None = None
    object_points, image_points = [], []
    n_images = 0
    for k, image in enumerate(images):
        gray = gray_image(image)
        h, w = gray.shape
        if size is None:
            size = (w, h)
        elif size != (w, h):
            raise ValueError(
                f"images[{k}]: size {w}x{h} px differs from the first image's {size[0]}x{size[1]} px"
            )
        n_images += 1
        corners = find_corners(gray, cols, rows)
        if corners is not None:
            object_points.append(objp)
            image_points.append(corners.astype(np.float32).reshape(-1, 1, 2))
    if size is None:
        raise ValueError("images: no images given")
    n = len(image_points)
    if n < min_views:
        raise ValueError(f"only {n} of {n_images} images show the {cols}x{rows} board (need {min_views})")
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12)
    rms, K, dist, _, _ = cv2.calibrateCamera(object_points, image_points, size, None, None, criteria=criteria)
    return CameraModel(
        K=K,
        dist=np.asarray(dist, dtype=float).ravel()[:5],
        image_size=size,
        rms_px=float(rms),
        board=(int(cols), int(rows), float(square_m)),
        n_views=n,
    )


class NoVideoError(ValueError):
    """:func:`collect_views`: no frame came from the live source within the wait."""


def collect_views(
    source: FrameSource,
    cols: int,
    rows: int,
    *,
    views: int = 25,
    wait_s: float = 30.0,
    collect_s: float | None = None,
    spacing_s: float = 0.5,
    clock: Clock = wall_clock,
    what: str = "the camera",
    waiting_for: str | None = None,
    say: Callable[[str], None] | None = None,
    progress_every_s: float = 5.0,
    poll_s: float = 0.1,
) -> list[np.ndarray]:
    """Board views from a live camera or stream, for :func:`calibrate`; every wait is on ``clock``.

    Waits up to ``wait_s`` for the first frame, then keeps a frame that shows the whole board at most
    every ``spacing_s`` until it has ``views`` of them, ``collect_s`` have passed since the first frame,
    or no frame came for ``wait_s``. ``say`` gets a line when the wait starts, every ``progress_every_s``
    while it waits (for the video, then for board views), when the video arrives and at each view.

    Parameters
    ----------
    source : FrameSource
        E.g. from :func:`auvdock.camera.video_in.open_source`. It is read without blocking (``read(0)``); the
        waits between reads are ``clock.sleep`` of at most ``poll_s`` (so a
        :class:`auvdock.runtime.clock.SimClock`
        runs them in simulated time).
    cols, rows : int
        Inner corners of the board.
    views : int
        Views wanted.
    wait_s : float
        Longest wait for the first frame, and longest gap between frames once the video runs, s.
    collect_s : float, optional
        Time for collecting the views, from the first frame, s (default ``60 + views``).
    spacing_s : float
        Shortest time between two kept views, s.
    clock : Clock
    what : str
        The source in the messages, e.g. ``"UDP port 5600"``.
    waiting_for : str, optional
        What the progress lines wait for (default ``"video on <what>"``), e.g.
        ``"the RTP/H.264 stream on UDP port 5600"``.
    say : callable, optional
        Gets the progress lines (default: none).

    Returns
    -------
    list of ndarray
        At least :data:`MIN_VIEWS` grayscale views (fewer than ``views`` if the time ran out or the video
        stopped; ``say`` tells).

    Raises
    ------
    NoVideoError
        ``"no video arrived on <what> within <wait_s> s"``.
    ValueError
        Fewer than :data:`MIN_VIEWS` views, e.g. ``"only 2 board views (the whole 9x6 board in view) in
        85 s of video (need 5)"`` or ``"... before the video stopped (no frame from <what> for 30 s) ..."``.
    auvdock.camera.video_common.VideoSourceError
        The source failed (its reader thread stopped on an error).
    """
    _check_pattern(cols, rows)
    for name, v in (("wait_s", wait_s), ("spacing_s", spacing_s), ("poll_s", poll_s)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name}: must be > 0 s, got {v}")
    tell = say or (lambda _line: None)
    waiting_for = waiting_for or f"video on {what}"
    collect_s = 60.0 + views if collect_s is None else collect_s

    # 1. the first frame
    t0 = clock.now()
    deadline = t0 + wait_s
    note = t0 + progress_every_s
    tell(f"waiting up to {wait_s:g} s for {waiting_for}")
    while True:
        try:
            frame = source.read(0.0)
        except EOFError:
            raise NoVideoError(f"{what} ended before its first frame") from None
        if frame is not None:
            break
        now = clock.now()
        if now >= deadline:
            raise NoVideoError(f"no video arrived on {what} within {wait_s:g} s")
        if now >= note:
            tell(f"waiting for {waiting_for}: {now - t0:.0f} s of {wait_s:g} s")
            note += progress_every_s
        clock.sleep_until(min(now + poll_s, deadline, note))
    h, w = frame.image.shape[:2]
    tell(
        f"video from {what}: {w}x{h} px; show the {cols}x{rows} board, tilted and all over the image "
        f"({views} views, {spacing_s:g} s apart)"
    )

    # 2. the views
    t1 = last_frame = clock.now()
    deadline = t1 + collect_s
    note = t1 + progress_every_s
    images: list[np.ndarray] = []
    last_view = -math.inf
    stopped = ""
    while True:
        now = clock.now()
        if frame is not None:
            last_frame = now
            if now - last_view >= spacing_s and find_corners(frame.image, cols, rows) is not None:
                images.append(gray_image(frame.image))
                last_view = now
                note = now + progress_every_s
                tell(f"board view {len(images)}/{views}")
                if len(images) >= views:
                    break
        elif now >= last_frame + wait_s:
            stopped = f"before the video stopped (no frame from {what} for {wait_s:g} s)"
            break
        if now >= deadline:
            break
        if now >= note:
            tell(
                f"board views: {len(images)}/{views} after {now - t1:.0f} s (the whole board must be in view)"
            )
            note += progress_every_s
        if frame is None:
            clock.sleep_until(min(now + poll_s, deadline, note, last_frame + wait_s))
        try:
            frame = source.read(0.0)
        except EOFError:
            stopped = f"before the video from {what} ended"
            break
    n = len(images)
    if n < MIN_VIEWS:
        when = stopped or f"in {clock.now() - t1:.0f} s of video"
        raise ValueError(
            f"only {n} board view{'' if n == 1 else 's'} (the whole {cols}x{rows} board in view) {when} "
            f"(need {MIN_VIEWS})"
        )
    if n < views:
        tell(f"{n} of {views} views {stopped or f'in {collect_s:g} s'}: calibrating with these")
    return images
