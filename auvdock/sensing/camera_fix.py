"""The camera's fix of the dock, modelled fast: what a camera sees of the dock's markers in water, and
how well -- a model derived from the real pipeline on rendered underwater views.

Every constant below was measured with ``python benchmarks/camera_fix_errors.py`` (2026-12-02): the
synthetic camera (:func:`auvdock.camera.render.render_view`: ideal 640 x 480, 80 deg; image noise 2 grey
levels, blur 0.5 px) renders one 0.15 m marker over a grid of apparent sides (12-85 px), contrasts
(12-255 grey levels, set through the water) and obliquities (0, 30, 50 deg; and 0-80 deg at 60 px),
10 frames each at random sub-pixel offsets, and the real pipeline
(:class:`auvdock.camera.pose.MarkerDetector`, :func:`auvdock.camera.pose.refine_corners`,
:func:`auvdock.camera.pose.estimate_dock_pose`) decodes it; the benchmark prints the rates and the
errors and fits the constants (maximum likelihood for the rates, least squares for the errors).

Water
-----
Water of visibility ``V`` (m: the horizontal visibility of a black target) has the beam attenuation
coefficient ``c = 4.8 / V`` (1/m; Zaneveld and Pegau 2003, "Robust underwater visibility parameter",
Optics Express 11(23) 2997-3009).  A marker at range ``d`` (its centre) keeps the fraction ``exp(-c d)``
of its black-to-white contrast, the rest going to the veiling light (:class:`auvdock.camera.render.Water`)::

    C = C0 exp(-c d)     grey levels; C0 = marker_contrast_grey (255: black 0, white 255)

Which markers are seen
----------------------
A fix exists only when at least one marker of the layout is seen whole: its four corners in front of the
camera and inside the image, its face turned towards the camera by at most ``max_view_angle_deg`` (78 deg:
half the 60 px markers were decoded at 78.2 deg), and decodable::

    min_contrast_grey / C + (min_side_px / side)^size_power <= 1

with ``side`` its apparent side, px (the square root of its image area, which takes the obliquity into
account: the decoding rates at 0, 30 and 50 deg fall on one curve against it).  Fitted: 19.5 grey levels,
12.5 px, power 3 -- the boundary where half the markers were decoded; the rate falls from 90 % to 10 %
as ``u`` (the left-hand side) goes from 0.80 to 1.25 (``P = 1 / (1 + u^10)``,
:meth:`CameraFixModel.detection_probability`).  So a large marker is decoded while its contrast is
above 19.5 grey levels -- 10 times the synthetic camera's noise of 2 grey levels, but nearly an absolute
threshold (OpenCV's adaptive threshold wants the black cells 7 grey levels below the local mean) -- i.e.
out to ``d = V ln(C0 / 19.5) / 4.8 = 0.54 V``, and a marker of full contrast while it is 13 px wide.  Each
frame is lost with probability ``dropout``.

The fix's errors
----------------
Each seen marker's corners have an error of RMS ``sigma_c`` (px; bias included: the pipeline's corner
biases change with the pose, so along a trajectory they act as noise), a mixture of two regimes:

* **edge-refined corners** (:func:`auvdock.camera.pose.refine_corners`)::

      sigma_r^2 = (corner_px C0 / C)^2 + (small_px (16 px / s)^small_power)^2

  with ``s = side sqrt(cos(obliquity))`` the short side.  The first term is the image noise over the
  contrast: the refinement locates each edge by the area under its profile, whose noise is the image
  noise over the step height -- measured ``corner_px`` = 0.0071 px at full contrast (the error times
  ``C / C0`` was 0.0069-0.0078 px for every contrast from 22 to 160 grey levels: the law holds; it is
  0.9 times the image noise over the contrast).  The second is the bias of small markers, whose cells
  are 2-3 px: 0.13 px at 16 px, falling as the 3.3rd power of the side.
* **unrefined corners** (the detector's own, ``CORNER_REFINE_SUBPIX``): ``unrefined_corner_px`` = 0.92
  px.  The refinement gives up (it needs a 20 grey level step across each edge, measured half a cell
  from it) with probability ``u^20 / (1 + u^20)``, ``u = 17.5 / C + 9 px / s``: half the time below
  32 grey levels for a 20 px marker, below 21 for a 60 px one.  Oblique markers' corners are as bad as
  unrefined ones with probability ``1 / (1 + exp(-(a - 63 deg) / 2.2 deg))`` (measured: 0.04 px at
  50 deg, 0.46 px at 60, 0.73 at 65).
  ``sigma_c^2 = p_u unrefined_corner_px^2 + (1 - p_u) sigma_r^2`` with ``p_u`` the probability of either.

The biases are mostly scale errors: a displacement common to the four corners along their directions
from the marker's centre, which moves the fix along the view but does not tilt it -- 58 % of the unrefined
corners' error variance, 16 % of the small markers' extra error (the image noise has none: -0.06 measured).
The model splits ``sigma_c`` accordingly (:meth:`CameraFixModel.corner_error_parts`).

So the corner noise in water stays far below the 0.5 px this model assumed before the measurement --
0.007 px at full contrast, 0.05 px at 40 grey levels -- for as long as the edges are refined; near the
detection limit (contrasts of 19.5 to 21-32 grey levels: the last 3-20 % of the range the water allows)
the pipeline falls back to the detector's corners, which are twice as bad as that assumption.

The corner errors are propagated to the fix as the pipeline computes it: one rigid pose of the dock
fitted by unweighted least squares to the corners of the markers used (the pipeline's Levenberg-Marquardt
refinement), of covariance ``(J^T J)^-1 J^T S J (J^T J)^-1`` with ``J`` the Jacobian of the corners'
pixel coordinates with respect to the dock's position and attitude in the camera frame and ``S`` the
corners' error covariance (independent errors plus each marker's common radial one); the fix's
covariance is its position block.  As in the pipeline, markers narrower than ``fuse_min_side_px``
(32 px) are left out when a wider one is seen.  The docking point lies 0.35-0.39 m from the markers, so
the attitude error, magnified by this lever arm, dominates: a single marker's tilt is poorly measured
(its keystone distortion is ``f s^2 / (4 d^2)`` px per radian), and the error grows as ``d^2`` across the
view as well as along it.  Along approaches to the dock and a pass across it (the benchmark's tables,
``tests/test_camera_rendered.py``) the pipeline's errors divided by this model's standard deviations
have an RMS of 0.8-1.3 per axis.  Not modelled: the pipeline's occasional choice of the wrong one of
the two IPPE solutions of a small, faint or oblique marker (a tilt flip: errors of tens of standard
deviations in 0-7 % of the fixes along those trajectories); and forward scatter, which the renderer does
not draw (:mod:`auvdock.camera.render`): a blur of 1 px instead of 0.5 px raises the smallest decodable
side from 12.5 to 19.5 px and the small markers' corner bias eightfold (the benchmark with ``--blur 1``),
so in water that blurs far markers the size limit is optimistic.

The fix is what a camera measures: the dock's docking point in the camera frame (x right, y down, z along
the optical axis), m -- the measurement ``dock`` of :mod:`auvdock.sensing.measurements`, the same formula
(:func:`auvdock.vehicle.geometry.point_in_sensor_frame`) -- with its standard deviation per camera axis.
The navigation filter estimates the dock's position from it (relative navigation);
:attr:`CameraFix.position_ned_m` is the vehicle's position it implies for a dock whose position is known
(the paper's Assumption 2).  The real pipeline itself in the loop, for spot checks, is
:class:`auvdock.sensing.camera_rendered.RenderedCameraFix`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from auvdock.camera.layout import MarkerLayout
from auvdock.camera.model import CameraModel, CameraMount
from auvdock.camera.render import VISIBILITY_ATTENUATION
from auvdock.vehicle.geometry import point_in_sensor_frame, rotation_zyx
from auvdock.vehicle.state import POS

__all__ = ["CameraFixModel", "CameraFixSource", "MarkerView", "CameraFix"]

_SMALL_REF_PX = 16.0  # the side at which small_px is the small markers' extra corner error, px


@dataclass(frozen=True)
class MarkerView:
    """One marker as the camera sees it: id, range of its centre (m), obliquity (rad: the angle between
    its face normal and the line of sight), mean apparent side (px), whether it counts (``seen``) and if
    not, why; its contrast in the water (grey levels), its corners' RMS error (px; nan when not seen),
    its black square's corners in the camera frame ((4, 3), m) and the dock's docking point in the camera
    frame ((3,), m; both None when the marker is behind the camera)."""

    marker_id: int
    range_m: float
    view_angle_rad: float
    side_px: float
    seen: bool
    why: str
    contrast_grey: float = math.nan
    corner_px: float = math.nan
    corners_camera_m: np.ndarray | None = field(default=None, repr=False, compare=False)
    dock_camera_m: np.ndarray | None = field(default=None, repr=False, compare=False)


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


class CameraFixSource(Protocol):
    """What gives the camera's fixes: :class:`CameraFixModel` (fast) or
    :class:`auvdock.sensing.camera_rendered.RenderedCameraFix` (the real pipeline)."""

    def fix(
        self,
        x: np.ndarray,
        dock_position_ned: np.ndarray,
        dock_heading_rad: float,
        rng: np.random.Generator,
    ) -> CameraFix | None:
        """One frame's fix at the true state ``x`` (12,), or None."""
        ...


@dataclass(frozen=True)
class CameraFixModel:
    """The fast camera model (see the module docstring for the laws and the measurements).

    Parameters
    ----------
    camera : CameraModel
        Intrinsics and image size (distortion ignored: the field of view is the undistorted one).
    mount : CameraMount
        Where the camera sits on the vehicle.
    layout : MarkerLayout
        The dock's markers in the dock frame.
    visibility_m : float
        The water's visibility (horizontal, black target), m: ``c = 4.8 / visibility_m`` (1/m);
        ``math.inf`` for no water.  Default 8 m: assumed (clear coastal water; a turbid harbour is 1-3 m).
    min_side_px : float
        Apparent side (px: the square root of the marker's image area) below which no marker is decoded
        however high its contrast: 12.5 px fitted.
    max_view_angle_deg : float
        Largest obliquity decoded, deg: 78, where half the 60 px markers were decoded (78.2 deg).
    corner_px : float
        Edge-refined corner error at the full contrast ``marker_contrast_grey`` of a well-resolved marker,
        px; it grows as ``C0 / C`` with the contrast ``C``: 0.0071 px measured.
    dropout : float
        Probability that a frame gives no fix although markers are in view (assumed 0.02).
    marker_contrast_grey : float
        The markers' black-to-white step in the image without water, grey levels (``C0``): 255, the
        synthetic camera's (black 0, white 255).
    min_contrast_grey : float
        Contrast below which no marker is decoded however large, grey levels: 19.5 fitted.
    size_power : float
        How size and contrast combine in the decoding rule
        ``min_contrast_grey / C + (min_side_px / side)^size_power <= 1``: 3 fitted.
    detect_steepness : float
        The decoding rate is ``1 / (1 + u^detect_steepness)`` with ``u`` that rule's left-hand side:
        10 fitted (only :meth:`detection_probability` uses it; the model decodes where it is >= 1/2).
    unrefined_corner_px : float
        RMS error of the detector's own corners, used when the edge refinement gives up, px: 0.92.
    refine_contrast_grey, refine_side_px, refine_size_power, refine_steepness : float
        The edge refinement gives up on a decoded marker with probability ``u^k / (1 + u^k)``,
        ``u = refine_contrast_grey / C + (refine_side_px / short side)^refine_size_power``,
        ``k = refine_steepness``: 17.5 grey levels, 9 px, 1 and 20 fitted (the short side is the side
        times the square root of the cosine of the obliquity).
    refine_max_angle_deg, refine_angle_width_deg : float
        The corners are as bad as unrefined ones with probability
        ``1 / (1 + exp(-(a - refine_max_angle_deg) / refine_angle_width_deg))`` at obliquity ``a``:
        63 and 2.2 deg fitted.
    small_px, small_power : float
        Extra corner error (in quadrature) of small markers, ``small_px (16 px / short side)^small_power``:
        0.13 px and 3.3 fitted.
    unrefined_radial_share, small_radial_share : float
        The share of the unrefined corners' error variance, and of the small markers' extra one, that is a
        displacement common to the four corners along their directions from the marker's centre (a scale
        error, which moves the fix along the view rather than tilting it): 0.58 and 0.16 measured (the
        image noise has none).
    fuse_min_side_px : float
        Markers narrower than this are left out of the fix when a wider one is seen, px: 32, the
        pipeline's rule (``min_side_px`` of :func:`auvdock.camera.pose.estimate_dock_pose`).
    """

    camera: CameraModel
    mount: CameraMount
    layout: MarkerLayout
    visibility_m: float = 8.0
    min_side_px: float = 12.5
    max_view_angle_deg: float = 78.0
    corner_px: float = 0.0071
    dropout: float = 0.02
    marker_contrast_grey: float = 255.0
    min_contrast_grey: float = 19.5
    size_power: float = 3.0
    detect_steepness: float = 10.0
    unrefined_corner_px: float = 0.92
    refine_contrast_grey: float = 17.5
    refine_side_px: float = 9.0
    refine_size_power: float = 1.0
    refine_steepness: float = 20.0
    refine_max_angle_deg: float = 63.0
    refine_angle_width_deg: float = 2.2
    small_px: float = 0.13
    small_power: float = 3.3
    unrefined_radial_share: float = 0.58
    small_radial_share: float = 0.16
    fuse_min_side_px: float = 32.0

    def __post_init__(self) -> None:
        for name in (
            "visibility_m",
            "min_side_px",
            "corner_px",
            "marker_contrast_grey",
            "size_power",
            "detect_steepness",
            "unrefined_corner_px",
            "refine_size_power",
            "refine_steepness",
            "refine_angle_width_deg",
            "small_power",
        ):
            v = float(getattr(self, name))
            if not (v > 0 and (math.isfinite(v) or name == "visibility_m")):
                raise ValueError(f"{name}: must be positive, got {v}")
        for name in ("unrefined_radial_share", "small_radial_share"):
            v = float(getattr(self, name))
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"{name}: must be in [0, 1], got {v}")
        for name in (
            "min_contrast_grey",
            "refine_contrast_grey",
            "refine_side_px",
            "refine_max_angle_deg",
            "small_px",
            "fuse_min_side_px",
        ):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name}: must be >= 0, got {v}")
        if not 0.0 < self.max_view_angle_deg < 90.0:
            raise ValueError(f"max_view_angle_deg: must be in (0, 90), got {self.max_view_angle_deg}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"dropout: must be in [0, 1), got {self.dropout}")

    @property
    def focal_px(self) -> float:
        """Mean focal length, px."""
        K = self.camera.K
        return 0.5 * float(K[0, 0] + K[1, 1])

    @property
    def attenuation_per_m(self) -> float:
        """The water's beam attenuation coefficient ``c = 4.8 / visibility_m``, 1/m (0 without water)."""
        return VISIBILITY_ATTENUATION / self.visibility_m

    def contrast(self, range_m: float) -> float:
        """A marker's black-to-white contrast at range ``range_m`` (m): ``C0 exp(-c d)``, grey levels."""
        return self.marker_contrast_grey * math.exp(-self.attenuation_per_m * max(float(range_m), 0.0))

    @property
    def max_range_m(self) -> float:
        """Range beyond which the water leaves a marker less than ``min_contrast_grey``, m."""
        if self.min_contrast_grey <= 0 or self.attenuation_per_m == 0:
            return math.inf
        return math.log(self.marker_contrast_grey / self.min_contrast_grey) / self.attenuation_per_m

    def _decoding_u(self, contrast_grey: float, side_px: float) -> float:
        if contrast_grey <= 0 or side_px <= 0:
            return math.inf
        return self.min_contrast_grey / contrast_grey + (self.min_side_px / side_px) ** self.size_power

    def decodable(self, contrast_grey: float, side_px: float) -> bool:
        """Whether a marker of contrast ``contrast_grey`` (grey levels) and apparent side ``side_px`` (px)
        is decoded: ``min_contrast_grey / C + (min_side_px / side)^size_power <= 1``."""
        return self._decoding_u(contrast_grey, side_px) <= 1.0

    def detection_probability(self, contrast_grey: float, side_px: float) -> float:
        """The measured rate at which such a marker is decoded, ``1 / (1 + u^detect_steepness)`` (the
        model itself decodes it when this is >= 1/2)."""
        u = self._decoding_u(contrast_grey, side_px)
        if not math.isfinite(u):
            return 0.0
        return 1.0 / (1.0 + math.exp(min(self.detect_steepness * math.log(max(u, 1e-300)), 700.0)))

    def unrefined_probability(self, contrast_grey: float, side_px: float, view_angle_rad: float) -> float:
        """Probability that the edge refinement gives up on a decoded marker (contrast, grey levels;
        apparent side, px; obliquity, rad), or that its corners are as bad as if it had."""
        C = max(float(contrast_grey), 1e-9)
        short = max(float(side_px) * math.sqrt(max(math.cos(float(view_angle_rad)), 0.0)), 1e-9)
        u = self.refine_contrast_grey / C + (self.refine_side_px / short) ** self.refine_size_power
        p_size = 1.0 / (1.0 + u ** (-self.refine_steepness))
        z = (math.degrees(float(view_angle_rad)) - self.refine_max_angle_deg) / self.refine_angle_width_deg
        p_angle = 1.0 / (1.0 + math.exp(-min(max(z, -50.0), 50.0)))
        return 1.0 - (1.0 - p_size) * (1.0 - p_angle)

    def corner_error_parts(
        self, contrast_grey: float, side_px: float, view_angle_rad: float
    ) -> tuple[float, float]:
        """A decoded marker's corner error split into (independent std per corner coordinate, std of the
        displacement common to its four corners along their directions from its centre -- a scale
        error), px; see :meth:`corner_error_px`."""
        C = max(float(contrast_grey), 1e-9)
        short = max(float(side_px) * math.sqrt(max(math.cos(float(view_angle_rad)), 0.0)), 1e-9)
        noise2 = (self.corner_px * self.marker_contrast_grey / C) ** 2
        small2 = (self.small_px * (_SMALL_REF_PX / short) ** self.small_power) ** 2
        p_u = self.unrefined_probability(C, side_px, view_angle_rad)
        unrefined2 = p_u * self.unrefined_corner_px**2
        small2 *= 1.0 - p_u
        radial2 = self.unrefined_radial_share * unrefined2 + self.small_radial_share * small2
        independent2 = (1.0 - p_u) * noise2 + unrefined2 + small2 - radial2
        # a displacement common to the 4 corners along their radial directions puts half its variance
        # on each corner coordinate
        return math.sqrt(independent2), math.sqrt(2.0 * radial2)

    def corner_error_px(self, contrast_grey: float, side_px: float, view_angle_rad: float) -> float:
        """RMS corner error (px, per coordinate) of a decoded marker of contrast ``contrast_grey`` (grey
        levels), apparent side ``side_px`` (px) and obliquity ``view_angle_rad`` (rad): the mixture of
        edge-refined and unrefined corners of the module docstring."""
        independent, radial = self.corner_error_parts(contrast_grey, side_px, view_angle_rad)
        return math.sqrt(independent**2 + 0.5 * radial**2)

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
        """Every marker of the layout as the camera at pose ``eta`` (6,) sees it (seen or why not), for
        the dock at ``dock_position_ned`` (3,, m) with heading ``dock_heading_rad`` (rad)."""
        R_cd, t_cd, _ = self._dock_in_camera(eta, dock_position_ned, dock_heading_rad)
        corners_d, normals_d = self._marker_geometry()
        K = self.camera.K
        w, h = self.camera.image_size
        corners_c = corners_d @ R_cd.T + t_cd  # (markers, 4, 3)
        centres = corners_c.mean(axis=1)
        ranges = np.linalg.norm(centres, axis=1)
        cos_a = -np.einsum("ij,ij->i", normals_d @ R_cd.T, centres) / np.maximum(ranges, 1e-12)
        angles = np.arccos(np.clip(cos_a, -1.0, 1.0))
        contrasts = self.marker_contrast_grey * np.exp(-self.attenuation_per_m * ranges)
        z = np.maximum(corners_c[..., 2:3], 1e-12)
        uv = corners_c[..., :2] / z * np.array([K[0, 0], K[1, 1]]) + K[:2, 2]  # (markers, 4, 2)
        u, v = uv[..., 0], uv[..., 1]
        sides = np.sqrt(0.5 * np.abs(np.sum(u * np.roll(v, -1, axis=1) - np.roll(u, -1, axis=1) * v, axis=1)))
        behind = np.any(corners_c[..., 2] <= 0.02, axis=1)
        outside = np.any((u < 0) | (u > w - 1) | (v < 0) | (v > h - 1), axis=1)
        max_angle = math.radians(self.max_view_angle_deg)
        out = []
        for i, m in enumerate(self.layout.markers):
            rng, angle, contrast = float(ranges[i]), float(angles[i]), float(contrasts[i])
            side = 0.0 if behind[i] else float(sides[i])
            if behind[i]:
                why = "behind the camera"
            elif outside[i]:
                why = "outside the field of view"
            elif cos_a[i] <= 0:
                why = "seen from behind"
            elif angle > max_angle:
                why = f"too oblique ({math.degrees(angle):.0f} deg)"
            elif contrast < self.min_contrast_grey:
                why = (
                    f"too faint (contrast {contrast:.1f} < {self.min_contrast_grey:g} grey levels: "
                    f"{rng:.1f} m in {self.visibility_m:g} m visibility)"
                )
            elif side < self.min_side_px:
                why = f"too small ({side:.1f} px)"
            elif not self.decodable(contrast, side):
                why = f"too small for its contrast ({side:.1f} px, {contrast:.1f} grey levels)"
            else:
                why = ""
            sigma = self.corner_error_px(contrast, side, angle) if why == "" else math.nan
            out.append(
                MarkerView(m.id, rng, angle, side, why == "", why, contrast, sigma, corners_c[i], t_cd)
            )
        return out

    def _marker_geometry(self) -> tuple[np.ndarray, np.ndarray]:
        """The layout's black-square corners (markers, 4, 3) and face normals (markers, 3) in the dock
        frame, m (computed once)."""
        cached = self.__dict__.get("_geometry")
        if cached is None:
            corners = np.array([m.corners_dock() for m in self.layout.markers])
            normals = np.array([m.R_dm()[:, 2] for m in self.layout.markers])
            cached = (corners, normals)
            object.__setattr__(self, "_geometry", cached)
        return cached

    def fused(self, views: list[MarkerView]) -> list[MarkerView]:
        """The seen markers the fix uses: those at least ``fuse_min_side_px`` wide if any is, else all
        (the pipeline's rule, :func:`auvdock.camera.pose.estimate_dock_pose`)."""
        seen = [v for v in views if v.seen]
        wide = [v for v in seen if v.side_px >= self.fuse_min_side_px]
        return wide or seen

    def covariance_camera(self, views: list[MarkerView]) -> np.ndarray | None:
        """The fix's covariance in the camera frame (x right, y down, z along the axis), (3, 3) m^2: the
        position block of the covariance of the dock's pose fitted, unweighted, to the corners of the
        markers used (:meth:`fused`), each with its error ``corner_px`` (see the module docstring);
        None when none is seen."""
        used = self.fused(views)
        if not used:
            return None
        K = self.camera.K
        fx, fy = float(K[0, 0]), float(K[1, 1])
        X = np.array([v.corners_camera_m for v in used])  # (markers, 4, 3), camera frame
        P = X - np.array([v.dock_camera_m for v in used])[:, None, :]  # relative to the dock origin
        X, P = X.reshape(-1, 3), P.reshape(-1, 3)
        x, y, z = X[:, 0], X[:, 1], X[:, 2]
        zero = np.zeros_like(z)
        D = np.stack(  # d(u, v) / d(corner), (corners, 2, 3)
            [
                np.stack([fx / z, zero, -fx * x / z**2], axis=1),
                np.stack([zero, fy / z, -fy * y / z**2], axis=1),
            ],
            axis=1,
        )
        # a rotation dtheta of the dock about its origin moves a corner by dtheta x P = -[P]x dtheta
        skew = np.zeros((len(P), 3, 3))
        skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -P[:, 2], P[:, 1], -P[:, 0]
        skew[:, 1, 0], skew[:, 2, 0], skew[:, 2, 1] = P[:, 2], -P[:, 1], P[:, 0]
        J = np.concatenate([D, -D @ skew], axis=2).reshape(-1, 6)  # d(u, v) / d(t_cd, attitude)
        S = np.zeros((len(J), len(J)))
        uv = (X[:, :2] / X[:, 2:3] * np.array([fx, fy])).reshape(len(used), 4, 2)
        for i, v in enumerate(used):
            radial = uv[i] - uv[i].mean(axis=0)
            radial = (radial / np.linalg.norm(radial, axis=1, keepdims=True)).reshape(8)
            independent, common = self.corner_error_parts(v.contrast_grey, v.side_px, v.view_angle_rad)
            S[8 * i : 8 * i + 8, 8 * i : 8 * i + 8] = independent**2 * np.eye(8) + common**2 * np.outer(
                radial, radial
            )
        try:
            A = np.linalg.solve(J.T @ J, J.T)
        except np.linalg.LinAlgError:
            A = np.linalg.pinv(J)
        cov = A @ S @ A.T
        cov_t = cov[:3, :3]
        return 0.5 * (cov_t + cov_t.T)

    def fix(
        self,
        x: np.ndarray,
        dock_position_ned: np.ndarray,
        dock_heading_rad: float,
        rng: np.random.Generator,
    ) -> CameraFix | None:
        """One frame's fix at the true state ``x`` (12,), or None (no marker seen, or a dropout).

        The noise is drawn from the model's covariance (correlated across the camera axes); the draws
        come from ``rng`` in a fixed order (a dropout draw, then three normals when markers are seen)."""
        views = self.views(x[0:6], dock_position_ned, dock_heading_rad)
        cov_c = self.covariance_camera(views)
        drop = rng.uniform() < self.dropout
        if cov_c is None or drop:
            return None
        _, t_cd, R_nc = self._dock_in_camera(x[0:6], dock_position_ned, dock_heading_rad)
        std_c = np.sqrt(np.diag(cov_c))
        w, V = np.linalg.eigh(cov_c)
        noise_c = V @ (np.sqrt(np.clip(w, 0.0, None)) * rng.standard_normal(3))
        cov_n = R_nc @ cov_c @ R_nc.T
        # the dock measured noise_c away from where it is: the vehicle then seems -noise_c away
        pos = np.asarray(x[POS], dtype=float) - R_nc @ noise_c
        ids = tuple(v.marker_id for v in self.fused(views))
        return CameraFix(t_cd + noise_c, std_c, ids, pos, cov_n)
