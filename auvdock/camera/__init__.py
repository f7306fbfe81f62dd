"""Fiducial-marker dock tracking from the vehicle's forward camera.

Modules
-------
layout
    Markers on the dock's back panel (:class:`Marker`, :class:`MarkerLayout`, :func:`default_layout`)
    and marker images.
print_sheet
    The printable true-scale marker sheet, tiled over A4 or Letter pages (:func:`write_sheet`).
model
    Camera intrinsics (:class:`CameraModel`, YAML :func:`load_camera` / :func:`save_camera`), the camera
    mount on the vehicle (:class:`CameraMount`) and the frame chain NED -> body -> camera <- dock
    (:func:`camera_from_dock`, :func:`project`, :func:`rotation_zyx`).
render
    Synthetic images of the markers (:func:`render_view`) and of checkerboards (:func:`render_checkerboard`)
    for rehearsal and tests.
pose
    Marker detection (:class:`MarkerDetector`) and fused dock pose with covariance
    (:func:`estimate_dock_pose`, :class:`DockPose`, :meth:`DockPose.in_body`).
video_in
    Frame sources: RTP/H.264 from BlueOS (``udp:5600``), V4L2, video files, image folders
    (:func:`open_source`), and :class:`LatestFrameGrabber` (newest frame only, in a thread).
video_out
    The RTP/H.264 sender (:func:`stream_rtp`), what BlueOS sends, for rehearsals.
video_common
    What both sides share (the RTP payload type, :class:`VideoSourceError`).
tracker
    ``fly`` with ``dock.source: camera``: the synthetic camera, the detection thread and the
    lost-tracking states (imported on its own: ``auvdock.fly.dock_tracker``).
calibration
    Checkerboard camera calibration (:func:`calibrate`, :func:`find_corners`) from image folders or videos
    (:func:`image_sources`).

Frames: {n} NED; {b} body (x forward, y starboard, z down); {d} dock (origin at the docking point, x along the
docked heading, z down); {c} camera (OpenCV: x right, y down, z optical axis). Poses are written
``x_c = R_cd x_d + t_cd``; lengths in m, angles in rad unless the name says ``_deg``, pixels in px.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from auvdock.camera.calibration import calibrate, find_corners
    from auvdock.camera.image_files import image_sources
    from auvdock.camera.layout import (
        DICTIONARIES,
        Marker,
        MarkerLayout,
        aruco_dictionary,
        default_layout,
        marker_image,
    )
    from auvdock.camera.model import (
        CameraModel,
        CameraMount,
        camera_from_dock,
        load_camera,
        project,
        rotation_zyx,
        save_camera,
    )
    from auvdock.camera.pose import (
        Detection,
        DockPose,
        MarkerDetector,
        estimate_dock_pose,
        relative_pose_truth,
        wrap_angle,
    )
    from auvdock.camera.print_sheet import sheet_size_in, write_sheet
    from auvdock.camera.render import render_checkerboard, render_view
    from auvdock.camera.video_in import Frame, FrameSource, LatestFrameGrabber, open_source
    from auvdock.camera.video_out import stream_rtp

__all__ = [
    "Frame",
    "FrameSource",
    "LatestFrameGrabber",
    "open_source",
    "stream_rtp",
    "DICTIONARIES",
    "CameraModel",
    "CameraMount",
    "Detection",
    "DockPose",
    "Marker",
    "MarkerDetector",
    "MarkerLayout",
    "aruco_dictionary",
    "calibrate",
    "camera_from_dock",
    "default_layout",
    "estimate_dock_pose",
    "find_corners",
    "image_sources",
    "load_camera",
    "marker_image",
    "project",
    "relative_pose_truth",
    "render_checkerboard",
    "render_view",
    "rotation_zyx",
    "save_camera",
    "sheet_size_in",
    "wrap_angle",
    "write_sheet",
]

#: Each name of the package and the module it is imported from, when first asked for (the
#: camera's modules load OpenCV and PyAV; reading a mission's marker layout needs neither).
_LAZY: dict[str, str] = {
    "calibrate": "auvdock.camera.calibration",
    "find_corners": "auvdock.camera.calibration",
    "image_sources": "auvdock.camera.image_files",
    "DICTIONARIES": "auvdock.camera.layout",
    "Marker": "auvdock.camera.layout",
    "MarkerLayout": "auvdock.camera.layout",
    "aruco_dictionary": "auvdock.camera.layout",
    "default_layout": "auvdock.camera.layout",
    "marker_image": "auvdock.camera.layout",
    "CameraModel": "auvdock.camera.model",
    "CameraMount": "auvdock.camera.model",
    "camera_from_dock": "auvdock.camera.model",
    "load_camera": "auvdock.camera.model",
    "project": "auvdock.camera.model",
    "rotation_zyx": "auvdock.camera.model",
    "save_camera": "auvdock.camera.model",
    "Detection": "auvdock.camera.pose",
    "DockPose": "auvdock.camera.pose",
    "MarkerDetector": "auvdock.camera.pose",
    "estimate_dock_pose": "auvdock.camera.pose",
    "relative_pose_truth": "auvdock.camera.pose",
    "wrap_angle": "auvdock.camera.pose",
    "sheet_size_in": "auvdock.camera.print_sheet",
    "write_sheet": "auvdock.camera.print_sheet",
    "render_checkerboard": "auvdock.camera.render",
    "render_view": "auvdock.camera.render",
    "Frame": "auvdock.camera.video_in",
    "FrameSource": "auvdock.camera.video_in",
    "LatestFrameGrabber": "auvdock.camera.video_in",
    "open_source": "auvdock.camera.video_in",
    "stream_rtp": "auvdock.camera.video_out",
}


def __getattr__(name: str) -> Any:
    """A name of :data:`__all__`, imported from its module when first asked for."""
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'auvdock.camera' has no attribute {name!r}")
