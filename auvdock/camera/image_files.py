"""Still images and video files as frames: a folder of images, one image, or a video file.

The source of the offline camera paths (``auvdock calibrate`` on saved views, ``camera.source`` set to a
folder of images); live sources are :mod:`auvdock.camera.video_in`'s.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from auvdock.camera.model import gray_image

__all__ = ["IMAGE_SUFFIXES", "image_sources"]

#: File suffixes read as images by :func:`image_sources` (case-insensitive).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


def image_sources(path: str | Path, *, every: int = 1) -> Iterator[np.ndarray]:
    """Grayscale uint8 frames from a directory of images, a single image, or a video file.

    Parameters
    ----------
    path : str or Path
        A directory (its files with a suffix in :data:`IMAGE_SUFFIXES`, sorted by name), an image file, or a
        video file readable by ``cv2.VideoCapture``.
    every : int
        Yield every ``every``-th frame / image (e.g. 15 for a 30 fps video: two frames per second).

    Returns
    -------
    iterator of ndarray, uint8, shape (h, w)
        Images are read lazily; the path is checked (and a video opened) at the call.

    Raises
    ------
    ValueError
        Missing path, a directory without images, an unreadable image, or a file OpenCV cannot open.
    """
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise ValueError(f"every: expected a positive integer, got {every!r}")
    path = Path(path)
    if not path.exists():
        raise ValueError(f"{path}: no such file or directory")
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
        if not files:
            raise ValueError(f"{path}: no images ({', '.join(IMAGE_SUFFIXES)}) in this directory")
        return (_read_image(p) for p in files[::every])
    if path.suffix.lower() in IMAGE_SUFFIXES:
        return iter([_read_image(path)])
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        cap.release()
        raise ValueError(f"{path}: cannot open as a video (not an image directory, image or video file)")
    return _video_frames(cap, every)


def _read_image(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise ValueError(f"{path}: cannot read image")
    return image


def _video_frames(cap: cv2.VideoCapture, every: int) -> Iterator[np.ndarray]:
    try:
        k = 0
        while True:
            ok, frame = cap.read()
            if not ok:
                break
            if k % every == 0:
                yield gray_image(frame)
            k += 1
    finally:
        cap.release()
