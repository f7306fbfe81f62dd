"""The camera's fix of the dock, modelled fast: what a camera sees of the dock's markers, and how well.

A fix exists only when at least one of the dock's markers (the mission's marker layout, in the
dock frame) is seen whole: all four corners in front of the camera and inside the image
(the camera's intrinsics: field of view and image size), the marker nearer than the water's
visibility (turbidity), its face turned towards the camera by less than ``max_view_angle_deg``,
and its apparent side at least ``min_side_px`` pixels (smaller markers are not decoded).  Each
frame is lost with probability ``dropout``.

The fix's noise is first-order propagation of the corner localisation noise ``corner_px`` (px)
through the pinhole geometry, per marker seen, fused by inverse variance: for a marker of side
``s`` (m) at range ``d`` (m) seen by a camera of focal length ``f`` (px), with its face turned by
``a`` from the line of sight::

    lateral std (each image axis) = corner_px d / (2 f)          (4 corners average the centroid)
    range std                     = corner_px d^2 / (sqrt(2) f s cos a)   (from the apparent size)

so the error grows linearly across the view and with the square of the range along it, and with
the obliquity.  The default ``corner_px`` (0.5 px) is an assumption for real water, not a
measurement: on this project's rendered views (no water, no motion blur) the pipeline's errors are
far smaller -- ``python benchmarks/camera_fix_errors.py`` prints them beside the model's, and the
corner noise that would match them (0.02 px for the range, 2026-12-02) -- so the model is the
cautious one, and stays so until a measurement in water replaces the figure.

The fix is what a camera measures: the dock's docking point in the camera frame (x right, y down,
z along the optical axis), m -- the measurement ``dock`` of :mod:`auvdock.sensing.measurements`,
the same formula (:func:`auvdock.vehicle.geometry.point_in_sensor_frame`) -- with its standard
deviation per camera axis.  The navigation filter estimates the dock's position from it
(relative navigation); :attr:`CameraFix.position_ned_m` is the vehicle's position it implies for a
dock whose position is known (the paper's Assumption 2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from auvdock.camera.layout import MarkerLayout
from auvdock.camera.model import CameraModel, CameraMount
from auvdock.vehicle.geometry import point_in_sensor_frame, rotation_zyx
from auvdock.vehicle.state import POS

__all__ = ["CameraFixModel", "MarkerView", "CameraFix"]


@dataclass(frozen=True)
class MarkerView:
    """One marker as the camera sees it: id, range (m), obliquity (rad), apparent side (px), whether
    it counts (``seen``) and if not, why."""

    marker_id: int
    range_m: float
    view_angle_rad: float
    side_px: float
    seen: bool
    why: str


@dataclass(frozen=True)
class CameraFix:
    """A fix: the dock's docking point measured in the camera frame (3,, m; x right, y down, z
    along the optical axis), its standard deviation per camera axis (3,, m), the markers it used,
    and the vehicle's position (NED, m) with its covariance (3x3, m^2) that it implies for the dock
    where it truly is (what a dock known to the vehicle, the paper's Assumption 2, makes of it)."""

    dock_camera_m: np.ndarray
    std_camera_m: np.ndarray
    marker_ids: tuple[int, ...]
    position_ned_m: np.ndarray
    covariance_ned_m2: np.ndarray

    @property
    def std_ned_m(self) -> np.ndarray:
        """Per-axis standard deviation of the implied position (3,), m."""
        return np.sqrt(np.diag(self.covariance_ned_m2))


@dataclass(frozen=True)
class CameraFixModel:
    """The fast camera model (see the module docstring).

    Parameters
    ----------
    camera : CameraModel
        Intrinsics and image size (distortion ignored: the field of view is the undistorted one).
    mount : CameraMount
        Where the camera sits on the vehicle.
    layout : MarkerLayout
        The dock's markers in the dock frame.
    visibility_m : float
        Range beyond which the water hides a marker (turbidity), m.
    min_side_px : float
        Smallest apparent marker side that is decoded, px: 16, between the sides the pipeline
        decoded (17.9 px: the 0.15 m marker 3.2 m away) and did not (13.6 px, 4.2 m) on rendered
        views (``python benchmarks/camera_fix_errors.py``).
    max_view_angle_deg : float
        Largest angle between a marker's face normal and the line of sight, degrees.
    corner_px : float
        Corner localisation noise std, px.
    dropout : float
        Probability that a frame gives no fix although markers are in view.
    """

    camera: CameraModel
    mount: CameraMount
    layout: MarkerLayout
    visibility_m: float = 8.0
    min_side_px: float = 16.0
    max_view_angle_deg: float = 70.0
    corner_px: float = 0.5
    dropout: float = 0.02

    def __post_init__(self) -> None:
        for name in ("visibility_m", "min_side_px", "corner_px"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: must be positive, got {v}")
        if not 0.0 < self.max_view_angle_deg < 90.0:
            raise ValueError(f"max_view_angle_deg: must be in (0, 90), got {self.max_view_angle_deg}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"dropout: must be in [0, 1), got {self.dropout}")

    @property
    def focal_px(self) -> float:
        """Mean focal length, px."""
        K = self.camera.K
        return 0.5 * float(K[0, 0] + K[1, 1])

    def _dock_in_camera(
        self, eta: np.ndarray, dock_position_ned: np.ndarray, dock_heading_rad: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        R_nb = rotation_zyx(float(eta[3]), float(eta[4]), float(eta[5]))
        R_nd = rotation_zyx(0.0, 0.0, float(dock_heading_rad))
        R_bc = self.mount.R_bc()
        R_nc = R_nb @ R_bc
        R_cd = R_nc.T @ R_nd
        t_cd = point_in_sensor_frame(
            R_nb, np.asarray(eta[POS], float), np.asarray(dock_position_ned, float), R_bc, self.mount.t_bc()
        )
        return R_cd, t_cd, R_nc

    def views(
        self, eta: np.ndarray, dock_position_ned: np.ndarray, dock_heading_rad: float
    ) -> list[MarkerView]:
        """Every marker of the layout as the camera at pose ``eta`` (6,) sees it (seen or why not)."""
        R_cd, t_cd, _ = self._dock_in_camera(eta, dock_position_ned, dock_heading_rad)
        K = self.camera.K
        w, h = self.camera.image_size
        out = []
        for m in self.layout.markers:
            corners_c = m.corners_dock() @ R_cd.T + t_cd  # (4, 3)
            centre = corners_c.mean(axis=0)
            rng = float(np.linalg.norm(centre))
            normal_c = R_cd @ m.R_dm()[:, 2]  # the marker's face normal (+z of the marker frame)
            cos_a = float(-normal_c @ centre) / max(rng, 1e-12)
            angle = math.acos(max(-1.0, min(1.0, cos_a)))
            if np.any(corners_c[:, 2] <= 0.02):
                out.append(MarkerView(m.id, rng, angle, 0.0, False, "behind the camera"))
                continue
            uv = (corners_c[:, :2] / corners_c[:, 2:3]) @ np.diag([K[0, 0], K[1, 1]]) + K[:2, 2]
            side = float(np.mean(np.linalg.norm(uv - np.roll(uv, 1, axis=0), axis=1)))
            if (
                np.any(uv[:, 0] < 0)
                or np.any(uv[:, 0] > w - 1)
                or np.any(uv[:, 1] < 0)
                or np.any(uv[:, 1] > h - 1)
            ):
                why = "outside the field of view"
            elif cos_a <= 0:
                why = "seen from behind"
            elif angle > math.radians(self.max_view_angle_deg):
                why = f"too oblique ({math.degrees(angle):.0f} deg)"
            elif rng > self.visibility_m:
                why = f"beyond the visibility ({rng:.1f} m > {self.visibility_m:g} m)"
            elif side < self.min_side_px:
                why = f"too small ({side:.1f} px)"
            else:
                why = ""
            out.append(MarkerView(m.id, rng, angle, side, why == "", why))
        return out

    def covariance_camera(self, views: list[MarkerView]) -> np.ndarray | None:
        """The fix's covariance in the camera frame (x right, y down, z along the axis), m^2, from
        the markers seen (inverse-variance fusion); None when none is seen."""
        f = self.focal_px
        info = np.zeros(3)
        for v in views:
            if not v.seen:
                continue
            marker = self.layout.marker(v.marker_id)
            lat = self.corner_px * v.range_m / (2.0 * f)
            rng = (
                self.corner_px
                * v.range_m**2
                / (math.sqrt(2.0) * f * marker.size_m * max(math.cos(v.view_angle_rad), 1e-3))
            )
            info += 1.0 / np.array([lat, lat, rng]) ** 2
        if not np.any(info):
            return None
        return np.diag(1.0 / info)

    def fix(
        self,
        x: np.ndarray,
        dock_position_ned: np.ndarray,
        dock_heading_rad: float,
        rng: np.random.Generator,
    ) -> CameraFix | None:
        """One frame's fix at the true state ``x`` (12,), or None (no marker seen, or a dropout).

        The noise is drawn from the model's covariance; the draws come from ``rng`` in a fixed
        order (a dropout draw, then three normals when markers are seen)."""
        views = self.views(x[0:6], dock_position_ned, dock_heading_rad)
        cov_c = self.covariance_camera(views)
        drop = rng.uniform() < self.dropout
        if cov_c is None or drop:
            return None
        _, t_cd, R_nc = self._dock_in_camera(x[0:6], dock_position_ned, dock_heading_rad)
        std_c = np.sqrt(np.diag(cov_c))
        noise_c = std_c * rng.standard_normal(3)
        cov_n = R_nc @ cov_c @ R_nc.T
        # the dock measured noise_c away from where it is: the vehicle then seems -noise_c away
        pos = np.asarray(x[POS], dtype=float) - R_nc @ noise_c
        ids = tuple(v.marker_id for v in views if v.seen)
        return CameraFix(t_cd + noise_c, std_c, ids, pos, cov_n)
