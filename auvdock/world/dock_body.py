"""The dock's body: an entry funnel, a cradle and a back plate, so that docking means contact.

The point-mass view of docking (the vehicle's body origin reaching the docking point) says
nothing about whether the vehicle fits, strikes the structure or arrives too fast.  This
module gives the dock a body and the vehicle a hull, and classifies each instant as
``"free"``, ``"captured"`` or ``"collided"`` (:func:`classify_contact`).

Frames and units (metres, seconds, radians unless a name says ``_deg``):

* {n}: NED inertial frame.
* {b}: the vehicle's body frame, x forward (the nose), y starboard, z down; the vehicle
  state ``x = [north, east, down, roll, pitch, yaw, u, v, w, p, q, r]`` (see
  :mod:`auvdock.vehicle.state`), ``R_nb = rotation_zyx(roll, pitch, yaw)``.
* {d}: the dock frame, origin at the docking point ``p_d(t)`` (the dock position of
  :class:`auvdock.world.dock.HeaveDock`), x_d along the docked heading, z_d down.  A level
  dock has ``R_nd = rotation_zyx(0, 0, heading_rad)``; a dock attitude (roll, pitch, yaw)
  may be given instead, so pitch motion can be added later.

The geometry in {d}, along -x_d -> +x_d: the mouth of a conical entry funnel, the funnel,
a cylindrical cradle, and the back plate.  The solid structure is everything inside an
outer box around them that is not free entry space, the back plate included.  A WEC
buoy may sit above the dock (:class:`WecBuoy`).  All dimensions are assumptions (no
drawing of a real BlueROV2 dock was available); they are stated at each class.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Literal

import numpy as np

from auvdock.vehicle.geometry import rotation_of, rotation_zyx, zyx_entries
from auvdock.vehicle.state import NX

__all__ = [
    "HullBox",
    "WecBuoy",
    "DockBody",
    "CaptureLimits",
    "Contact",
    "ContactStatus",
    "classify_contact",
    "dock_rotation",
    "points_in_dock_frame",
]

#: The three outcomes of :func:`classify_contact`.
ContactStatus = Literal["free", "captured", "collided"]

# labels of the solid's bounding surfaces, in the row order of DockBody._surface_depths
_SURFACE_LABELS = (
    "structure face",  # front face of the frame (the mouth plane)
    "structure face",  # rear face of the frame (behind the back plate)
    "structure face",  # the frame's side faces, |y_d| = half-width
    "structure face",  # the frame's top and bottom faces, |z_d| = half-width
    "funnel wall",
    "cradle wall",
    "back plate",
    "buoy",  # not a bounding surface of the structure: the index DockBody._surfaces gives the buoy
)


def _finite(name: str, value: float) -> float:
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name}: must be a finite number, got {value}")
    return v


def _positive(name: str, value: float) -> float:
    v = _finite(name, value)
    if v <= 0.0:
        raise ValueError(f"{name}: must be positive, got {value}")
    return v


def _vector3(name: str, value: object) -> tuple[float, float, float]:
    a = np.asarray(value, dtype=float)
    if a.shape != (3,):
        raise ValueError(f"{name}: must have 3 components, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: must be finite, got {a.tolist()}")
    return (float(a[0]), float(a[1]), float(a[2]))


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


# --------------------------------------------------------------------------------------------
# the vehicle's hull
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class HullBox:
    """The vehicle's hull as a box in the body frame {b}.

    Defaults: the BlueROV2 Heavy's published outer dimensions, 457 mm long (x_b), 575 mm
    wide (y_b) and 254 mm high (z_b), its centre taken at the body origin (an assumption:
    the origin of the vehicle model is near the geometric centre).

    Parameters
    ----------
    length_m : float
        Extent along x_b (forward), m.
    width_m : float
        Extent along y_b (starboard), m.
    height_m : float
        Extent along z_b (down), m.
    centre_b_m : tuple of 3 floats
        Offset of the box centre from the body origin, in {b}, m.
    sample_spacing_m : float
        Largest spacing of the contact sample points on the box's surface, m.

    Notes
    -----
    Contact is tested at sample points on the hull's surface (:attr:`sample_points_b_m`):
    a regular grid on each face with an even number of intervals along each edge, so the
    8 corners, the 12 edge midpoints and the 6 face centres are all among them.  With the
    default spacing of 0.05 m the BlueROV2 box has 10 x 12 x 6 intervals (0.046, 0.048,
    0.042 m) and 506 points.  Why 0.05 m: a convex edge of the dock (the frame's 90 deg
    edges; the funnel lip is blunter, about 130 deg) can press into a hull face between
    samples by at most half the spacing, 0.025 m for a 90 deg edge, before a sample is
    inside it.  That is below the hull's travel in one control step at the fastest speed
    of interest (0.6 m/s x 0.05 s = 0.03 m), so a finer grid would not detect contact
    earlier.  A free-standing plate thinner than the spacing could slip between samples;
    the dock has none (its back plate is backed by the frame and met face on).
    """

    length_m: float = 0.457
    width_m: float = 0.575
    height_m: float = 0.254
    centre_b_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    sample_spacing_m: float = 0.05

    def __post_init__(self) -> None:
        for name in ("length_m", "width_m", "height_m", "sample_spacing_m"):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))
        object.__setattr__(self, "centre_b_m", _vector3("centre_b_m", self.centre_b_m))

    @property
    def half_extents_m(self) -> np.ndarray:
        """Half the box's length, width and height, shape (3,), m."""
        return 0.5 * np.array([self.length_m, self.width_m, self.height_m])

    @property
    def nose_b_m(self) -> np.ndarray:
        """The nose: the centre of the box's front face, in {b}, shape (3,), m."""
        c = self.centre_b_m
        return np.array([c[0] + 0.5 * self.length_m, c[1], c[2]])

    @property
    def half_cross_diagonal_m(self) -> float:
        """Half the diagonal of the box's cross-section (y_b, z_b), m.

        The radius of the smallest circle about the nose's axis that holds the hull's
        cross-section; 0.314 m for the BlueROV2 Heavy.
        """
        return math.hypot(0.5 * self.width_m, 0.5 * self.height_m)

    @property
    def bounding_radius_m(self) -> float:
        """Half the box's space diagonal: the radius of its bounding sphere about its centre, m."""
        return 0.5 * math.sqrt(self.length_m**2 + self.width_m**2 + self.height_m**2)

    @cached_property
    def corners_b_m(self) -> np.ndarray:
        """The 8 corners of the box in {b}, shape (8, 3), m (read-only)."""
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
        return _readonly(np.asarray(self.centre_b_m) + signs * self.half_extents_m)

    @cached_property
    def sample_intervals(self) -> tuple[int, int, int]:
        """Number of sample intervals along the box's length, width and height (each even)."""
        h = self.sample_spacing_m
        n = [
            2 * max(1, math.ceil(extent / (2.0 * h)))
            for extent in (self.length_m, self.width_m, self.height_m)
        ]
        return (n[0], n[1], n[2])

    @cached_property
    def sample_points_b_m(self) -> np.ndarray:
        """Contact sample points on the box's surface, in {b}, shape (N, 3), m (read-only).

        See the class notes for the resolution.
        """
        nx, ny, nz = self.sample_intervals
        i, j, k = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij")
        on_surface = (i == 0) | (i == nx) | (j == 0) | (j == ny) | (k == 0) | (k == nz)
        frac = np.stack([i[on_surface] / nx, j[on_surface] / ny, k[on_surface] / nz], axis=1)
        lo = np.asarray(self.centre_b_m) - self.half_extents_m
        return _readonly(lo + frac * (2.0 * self.half_extents_m))

    @cached_property
    def _samples_h(self) -> np.ndarray:
        # homogeneous (4, N), C-contiguous: [R | o] @ _samples_h gives contiguous coordinate rows
        s = self.sample_points_b_m
        return _readonly(np.ascontiguousarray(np.vstack([s.T, np.ones(len(s))])))

    @cached_property
    def _nose_t(self) -> tuple[float, float, float]:
        c = self.centre_b_m
        return (c[0] + 0.5 * self.length_m, c[1], c[2])

    @cached_property
    def _centre_t(self) -> tuple[float, float, float]:
        return self.centre_b_m

    @cached_property
    def _half_t(self) -> tuple[float, float, float]:
        return (0.5 * self.length_m, 0.5 * self.width_m, 0.5 * self.height_m)


# --------------------------------------------------------------------------------------------
# the dock
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WecBuoy:
    """The wave-energy converter's buoy: a vertical cylinder above the dock, rigid in {d}.

    Parameters
    ----------
    radius_m : float
        Radius of the buoy, m.
    draft_m : float
        Submerged height of the buoy (waterline to bottom), m; only the submerged part
        is solid to the vehicle.
    centre_d_m : tuple of 3 floats
        Centre of the submerged cylinder in the dock frame {d}, m; negative z_d is
        above the docking point.

    Notes
    -----
    The axis of the cylinder is z_d (vertical for a level dock).  The buoy moves with the
    dock frame; for a WEC whose dock hangs below its float this is a rigid link.
    """

    radius_m: float
    draft_m: float
    centre_d_m: tuple[float, float, float]

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius_m", _positive("radius_m", self.radius_m))
        object.__setattr__(self, "draft_m", _positive("draft_m", self.draft_m))
        object.__setattr__(self, "centre_d_m", _vector3("centre_d_m", self.centre_d_m))

    @classmethod
    def above(
        cls,
        dock_depth_m: float,
        radius_m: float,
        draft_m: float,
        offset_d_m: tuple[float, float] = (0.0, 0.0),
    ) -> WecBuoy:
        """A buoy floating at the surface with the docking point ``dock_depth_m`` below its waterline.

        Parameters
        ----------
        dock_depth_m : float
            Depth of the docking point below the buoy's waterline, m (> ``draft_m``).
        radius_m, draft_m : float
            As in the class, m.
        offset_d_m : tuple of 2 floats
            Horizontal offset (x_d, y_d) of the buoy's axis from the docking point, m.
        """
        if not dock_depth_m > draft_m:
            raise ValueError(
                f"dock_depth_m: must be larger than draft_m ({draft_m:.2f} m), got {dock_depth_m}"
            )
        return cls(radius_m, draft_m, (offset_d_m[0], offset_d_m[1], -(dock_depth_m - 0.5 * draft_m)))

    def contains(self, points_d: np.ndarray) -> np.ndarray:
        """Whether points (in {d}, shape (..., 3), m) are strictly inside the buoy; bool (...)."""
        p = np.asarray(points_d, dtype=float)
        cx, cy, cz = self.centre_d_m
        rho2 = (p[..., 0] - cx) ** 2 + (p[..., 1] - cy) ** 2
        return (rho2 < self.radius_m**2) & (np.abs(p[..., 2] - cz) < 0.5 * self.draft_m)


#: Nose of the default hull at the docking point (x_d), plus the 0.05 m clearance to the back plate.
_DEFAULT_BACK_X_M = 0.5 * 0.457 + 0.05


@dataclass(frozen=True)
class DockBody:
    """The docking station's body in the dock frame {d}: funnel, cradle, back plate, frame.

    Along +x_d: the funnel's mouth (radius :attr:`mouth_radius_m`) at :attr:`mouth_x_m`;
    a cone narrowing to the cradle's radius at the cradle entrance :attr:`cradle_entrance_x_m`;
    the cradle, a cylinder of radius :attr:`cradle_radius_m`, up to the back plate at
    ``back_x_m``.  The solid structure is everything strictly inside the outer box
    ``mouth_x_m < x_d < back_x_m + back_plate_thickness_m``,
    ``|y_d|, |z_d| < structure_half_width_m`` that is not inside the cone or the cylinder
    (the back plate is the box's part behind ``back_x_m``), and the buoy if there is one.

    Defaults (assumptions, for a BlueROV2 Heavy docked with its body origin at the
    docking point, heading along x_d): the nose then is at x_d = 0.2285 m, and the back
    plate 0.05 m ahead of it (``back_x_m`` = 0.2785 m) so position control can hold the
    origin at the docking point without pressing on the plate.  A cradle radius of 0.40 m
    leaves 0.086 m around the hull's half cross-section diagonal (0.314 m), enough for
    centimetre-level tracking errors; its depth of 0.30 m holds the front 0.25 m of the
    hull when docked.  The 0.6 m funnel opens to a 0.9 m mouth (a half-angle of 39.8 deg),
    so a hull whose nose is up to 0.59 m (0.9 - 0.314) off the axis passes the mouth's
    lip.  Touching the funnel is reported as a collision (with its impact speed), not as
    guidance: a caller may treat a slow funnel contact as a guided entry.  The frame is
    2.4 m square (half-width 1.2 m), and the back plate with its backing 0.05 m thick,
    more than a hull's travel in one 0.05 s step at up to 1 m/s, so that a per-step
    classification cannot step through it.  With the 0.05 m clearance, a hull turned by
    more than 10.8 deg about the docking point puts a front corner into the back plate.

    Parameters
    ----------
    back_x_m : float
        x_d of the back plate's front face, m.
    cradle_radius_m : float
        Radius of the cylindrical cradle, m.
    cradle_depth_m : float
        Length of the cradle along x_d, m.
    funnel_length_m : float
        Length of the conical funnel along x_d, m.
    mouth_radius_m : float
        Radius of the funnel's mouth, m (> ``cradle_radius_m``).
    structure_half_width_m : float
        Half-size of the outer box in y_d and z_d, m (> ``mouth_radius_m``).
    back_plate_thickness_m : float
        Thickness of the back plate along x_d, m.
    buoy : WecBuoy or None
        The WEC buoy, or None for no buoy.
    """

    back_x_m: float = _DEFAULT_BACK_X_M
    cradle_radius_m: float = 0.40
    cradle_depth_m: float = 0.30
    funnel_length_m: float = 0.60
    mouth_radius_m: float = 0.90
    structure_half_width_m: float = 1.20
    back_plate_thickness_m: float = 0.05
    buoy: WecBuoy | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "back_x_m", _finite("back_x_m", self.back_x_m))
        for name in (
            "cradle_radius_m",
            "cradle_depth_m",
            "funnel_length_m",
            "mouth_radius_m",
            "structure_half_width_m",
            "back_plate_thickness_m",
        ):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))
        if not self.mouth_radius_m > self.cradle_radius_m:
            raise ValueError(
                f"mouth_radius_m: must be larger than cradle_radius_m ({self.cradle_radius_m:.2f} m), "
                f"got {self.mouth_radius_m}"
            )
        if not self.structure_half_width_m > self.mouth_radius_m:
            raise ValueError(
                f"structure_half_width_m: must be larger than mouth_radius_m ({self.mouth_radius_m:.2f} m), "
                f"got {self.structure_half_width_m}"
            )
        if self.buoy is not None and not isinstance(self.buoy, WecBuoy):
            raise ValueError(f"buoy: must be a WecBuoy or None, got {type(self.buoy).__name__}")

    @classmethod
    def for_hull(cls, hull: HullBox, clearance_m: float = 0.05, **kwargs: Any) -> DockBody:
        """A dock whose back plate is ``clearance_m`` ahead of ``hull``'s nose when docked.

        Parameters
        ----------
        hull : HullBox
            The vehicle's hull; docked, its body origin is at the docking point.
        clearance_m : float
            Gap between the docked nose and the back plate, m (>= 0).
        **kwargs
            Any other :class:`DockBody` field.
        """
        if not clearance_m >= 0.0:
            raise ValueError(f"clearance_m: must be non-negative, got {clearance_m}")
        return cls(back_x_m=float(hull.nose_b_m[0]) + clearance_m, **kwargs)

    # ---- derived geometry ---------------------------------------------------------------

    @property
    def cradle_entrance_x_m(self) -> float:
        """x_d of the cradle's entrance (the funnel's narrow end), m."""
        return self.back_x_m - self.cradle_depth_m

    @property
    def mouth_x_m(self) -> float:
        """x_d of the funnel's mouth (the front face of the structure), m."""
        return self.back_x_m - self.cradle_depth_m - self.funnel_length_m

    @property
    def back_end_x_m(self) -> float:
        """x_d of the structure's rear face (behind the back plate), m."""
        return self.back_x_m + self.back_plate_thickness_m

    @property
    def half_angle_rad(self) -> float:
        """Half-angle of the funnel's cone, ``atan((mouth - cradle radius) / funnel length)``, rad."""
        return math.atan((self.mouth_radius_m - self.cradle_radius_m) / self.funnel_length_m)

    @property
    def half_angle_deg(self) -> float:
        """Half-angle of the funnel's cone, degrees."""
        return math.degrees(self.half_angle_rad)

    @cached_property
    def _taper(self) -> float:
        # radius gained per metre towards the mouth, tan(half-angle)
        return (self.mouth_radius_m - self.cradle_radius_m) / self.funnel_length_m

    def free_radius(self, x_d: np.ndarray | float) -> np.ndarray:
        """Radius of the free entry space at x_d (m), for x_d in [mouth_x_m, back_x_m]; m.

        The funnel's radius ahead of the cradle entrance, the cradle's radius behind it.
        """
        x = np.asarray(x_d, dtype=float)
        return self.cradle_radius_m + np.maximum(self.cradle_entrance_x_m - x, 0.0) * self._taper

    def in_structure(self, points_d: np.ndarray) -> np.ndarray:
        """Whether points (in {d}, shape (..., 3), m) are strictly inside the solid structure.

        The buoy is not included (see :meth:`in_solid`).  Points on a surface are not inside.

        Returns
        -------
        ndarray of bool, shape (...)
        """
        p = np.asarray(points_d, dtype=float)
        return _structure_mask(self, p[..., 0], p[..., 1], p[..., 2])

    def in_solid(self, points_d: np.ndarray) -> np.ndarray:
        """Whether points (in {d}, shape (..., 3), m) are strictly inside the structure or the buoy.

        Returns
        -------
        ndarray of bool, shape (...)
        """
        inside = self.in_structure(points_d)
        if self.buoy is not None:
            inside = inside | self.buoy.contains(points_d)
        return inside

    def _surface_depths(self, X: np.ndarray, Y: np.ndarray, Z: np.ndarray) -> np.ndarray:
        """Distances (m) of points (X, Y, Z in {d}) to each bounding surface, shape (7, M).

        Rows in the order of ``_SURFACE_LABELS``; for a point inside the structure, the
        smallest is its penetration depth and names the surface it came through.  The
        funnel, cradle and back plate are surfaces of revolution: their distances are
        taken in the meridian half-plane (x_d, r), which is exact for a body of revolution.
        """
        r = np.sqrt(Y * Y + Z * Z)
        w = self.structure_half_width_m
        xm, xc, xb = self.mouth_x_m, self.cradle_entrance_x_m, self.back_x_m
        rc, rm = self.cradle_radius_m, self.mouth_radius_m
        d = np.empty((7, X.size))
        np.subtract(X, xm, out=d[0])
        np.subtract(self.back_end_x_m, X, out=d[1])
        np.subtract(w, np.abs(Y), out=d[2])
        np.subtract(w, np.abs(Z), out=d[3])
        d[4] = _segment_distance(X, r, (xm, rm), (xc, rc))
        ex = np.maximum(X, xc)  # the cradle's wall: r = rc for xc <= x <= xb
        np.minimum(ex, xb, out=ex)
        ex -= X
        er = r - rc
        d[5] = np.sqrt(ex * ex + er * er)
        np.maximum(er, 0.0, out=er)  # the back plate's face: x = xb for 0 <= r <= rc
        ex = X - xb
        d[6] = np.sqrt(ex * ex + er * er)
        return d

    def _surfaces(self, X: np.ndarray, Y: np.ndarray, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Surface index (into ``_SURFACE_LABELS``, 7 the buoy) and penetration depth (m) of points.

        For points (X, Y, Z in {d}) inside the solid; the depth is -inf for a point that is not.
        """
        d = self._surface_depths(X, Y, Z)
        idx = np.argmin(d, axis=0)
        depth = d[idx, np.arange(X.size)]
        if self.buoy is None:
            return idx, depth
        depth[~_structure_mask(self, X, Y, Z)] = -np.inf
        b = self.buoy
        cx, cy, cz = b.centre_d_m
        rho = np.sqrt((X - cx) ** 2 + (Y - cy) ** 2)
        buoy_depth = np.minimum(b.radius_m - rho, 0.5 * b.draft_m - np.abs(Z - cz))
        buoy_depth[buoy_depth <= 0.0] = -np.inf
        in_buoy = buoy_depth > depth
        idx[in_buoy] = len(_SURFACE_LABELS) - 1
        return idx, np.maximum(depth, buoy_depth)

    def surface_of(self, points_d: np.ndarray) -> tuple[list[str], np.ndarray]:
        """The surface each point inside the solid is nearest to, and its penetration depth.

        Parameters
        ----------
        points_d : array_like, shape (M, 3)
            Points in {d}, m, each strictly inside the structure or the buoy.

        Returns
        -------
        labels : list of str
            ``"structure face"``, ``"funnel wall"``, ``"cradle wall"``, ``"back plate"``
            or ``"buoy"``, one a point.
        depth : ndarray, shape (M,)
            Distance to that surface, m.
        """
        p = np.atleast_2d(np.asarray(points_d, dtype=float))
        idx, depth = self._surfaces(p[:, 0], p[:, 1], p[:, 2])
        return [_SURFACE_LABELS[i] for i in idx], depth


def _segment_distance(
    x: np.ndarray, r: np.ndarray, a: tuple[float, float], b: tuple[float, float]
) -> np.ndarray:
    """Distance (m) of points (x, r) to the segment a-b in the meridian half-plane."""
    ax, ar = a
    dx, dr = b[0] - ax, b[1] - ar
    ex = x - ax
    er = r - ar
    t = (ex * dx + er * dr) * (1.0 / (dx * dx + dr * dr))
    np.maximum(t, 0.0, out=t)
    np.minimum(t, 1.0, out=t)
    ex -= t * dx
    er -= t * dr
    return np.sqrt(ex * ex + er * er)


# --------------------------------------------------------------------------------------------
# capture
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CaptureLimits:
    """What counts as captured: pose and speed limits of a vehicle in the cradle.

    All are assumptions (no capture criteria of a real BlueROV2 dock were available).

    Parameters
    ----------
    max_heading_error_deg : float
        Largest heading (yaw) error relative to the dock, degrees, in (0, 180).
    max_pitch_roll_error_deg : float
        Largest pitch and roll errors relative to the dock, degrees, in (0, 90).
    max_relative_speed_m_s : float
        Largest speed of the vehicle's body origin relative to the dock, m/s.  The issue
        asks for "relative speed below a stated limit": 0.3 m/s is assumed (a latch or
        a soft stop is assumed to absorb an arrival at that speed).
    nose_inside_depth_m : float
        How far past the cradle's entrance the nose must be, m (>= 0).
    max_radial_offset_m : float or None
        Largest distance of the nose from the cradle's axis, m.  None (the default):
        derived per dock and hull by :meth:`radial_offset_limit_m`.
    """

    max_heading_error_deg: float = 15.0
    max_pitch_roll_error_deg: float = 15.0
    max_relative_speed_m_s: float = 0.3
    nose_inside_depth_m: float = 0.10
    max_radial_offset_m: float | None = None

    def __post_init__(self) -> None:
        h = _finite("max_heading_error_deg", self.max_heading_error_deg)
        if not 0.0 < h < 180.0:
            raise ValueError(f"max_heading_error_deg: must be in (0, 180), got {self.max_heading_error_deg}")
        pr = _finite("max_pitch_roll_error_deg", self.max_pitch_roll_error_deg)
        if not 0.0 < pr < 90.0:
            raise ValueError(
                f"max_pitch_roll_error_deg: must be in (0, 90), got {self.max_pitch_roll_error_deg}"
            )
        v = _positive("max_relative_speed_m_s", self.max_relative_speed_m_s)
        d = _finite("nose_inside_depth_m", self.nose_inside_depth_m)
        if d < 0.0:
            raise ValueError(f"nose_inside_depth_m: must be non-negative, got {self.nose_inside_depth_m}")
        object.__setattr__(self, "max_heading_error_deg", h)
        object.__setattr__(self, "max_pitch_roll_error_deg", pr)
        object.__setattr__(self, "max_relative_speed_m_s", v)
        object.__setattr__(self, "nose_inside_depth_m", d)
        if self.max_radial_offset_m is not None:
            object.__setattr__(
                self, "max_radial_offset_m", _positive("max_radial_offset_m", self.max_radial_offset_m)
            )

    def radial_offset_limit_m(self, body: DockBody, hull: HullBox) -> float:
        """The nose's largest distance from the cradle's axis, m.

        ``max_radial_offset_m`` if given; otherwise the cradle's radius less the hull's half
        cross-section diagonal, the offset at which an aligned hull's front face just fits
        the cradle: 0.40 - 0.314 = 0.086 m for the defaults.  Never below zero.
        """
        if self.max_radial_offset_m is not None:
            return self.max_radial_offset_m
        return max(0.0, body.cradle_radius_m - hull.half_cross_diagonal_m)

    def check(self, body: DockBody, hull: HullBox) -> None:
        """Raise ValueError if a vehicle with ``hull`` could never be captured in ``body``."""
        if not self.nose_inside_depth_m < body.cradle_depth_m:
            raise ValueError(
                f"nose_inside_depth_m: must be less than cradle_depth_m ({body.cradle_depth_m:.2f} m), "
                f"got {self.nose_inside_depth_m}"
            )
        if not hull.half_cross_diagonal_m < body.cradle_radius_m:
            raise ValueError(
                f"cradle_radius_m: must be larger than the hull's half cross-section diagonal "
                f"({hull.half_cross_diagonal_m:.3f} m), got {body.cradle_radius_m}"
            )


@dataclass(frozen=True, eq=False)
class Contact:
    """The dock contact state of the vehicle at one instant (:func:`classify_contact`).

    Parameters
    ----------
    status : {"free", "captured", "collided"}
        The outcome.
    relative_speed_m_s : float
        Speed of the vehicle's body origin relative to the dock (NED), m/s.
    impact_speed_m_s : float
        For ``"collided"``: speed of the colliding hull point relative to the dock, m/s;
        NaN otherwise.
    contact_point_ned : ndarray, shape (3,)
        For ``"collided"``: the colliding hull point (the deepest inside the solid), NED, m;
        NaN otherwise.
    what : str
        For ``"collided"``: the surface struck, ``"back plate"``, ``"funnel wall"``,
        ``"cradle wall"``, ``"structure face"`` or ``"buoy"``; ``""`` otherwise.
    nose_dock_m : ndarray, shape (3,)
        The nose in the dock frame {d}, m.
    heading_error_rad : float
        Vehicle heading relative to the dock, wrapped to [-pi, pi], rad.
    pitch_error_rad, roll_error_rad : float
        Vehicle pitch and roll relative to the dock frame, rad.
    nose_depth_m : float
        How far the nose is past the cradle's entrance along x_d, m (negative: short of it).
    radial_offset_m : float
        Distance of the nose from the cradle's axis, m.
    reason : str
        For ``"free"``: the first capture condition not met; for ``"collided"``: how many
        hull sample points are inside the solid and how deep the deepest is; ``""`` when
        captured.
    """

    status: ContactStatus
    relative_speed_m_s: float
    impact_speed_m_s: float
    contact_point_ned: np.ndarray
    what: str
    nose_dock_m: np.ndarray
    heading_error_rad: float
    pitch_error_rad: float
    roll_error_rad: float
    nose_depth_m: float
    radial_offset_m: float
    reason: str

    def describe(self) -> str:
        """One line for messages: the status and its key numbers.

        For example ``captured: nose 0.12 m inside the cradle, heading error 3.1 deg,
        relative speed 0.08 m/s`` or ``collided with the funnel wall at 0.42 m/s``.
        """
        if self.status == "captured":
            heading_deg = math.degrees(self.heading_error_rad)
            return (
                f"captured: nose {self.nose_depth_m:.2f} m inside the cradle, heading error "
                f"{heading_deg:.1f} deg, relative speed {self.relative_speed_m_s:.2f} m/s"
            )
        if self.status == "collided":
            return f"collided with the {self.what} at {self.impact_speed_m_s:.2f} m/s"
        if "relative speed" in self.reason:
            return f"free: {self.reason}"
        return f"free: {self.reason}, relative speed {self.relative_speed_m_s:.2f} m/s"


def dock_rotation(
    dock_heading_rad: float | None = None, dock_attitude_rad: np.ndarray | None = None
) -> np.ndarray:
    """The dock frame's rotation ``R_nd`` ({d} -> NED), shape (3, 3).

    Parameters
    ----------
    dock_heading_rad : float, optional
        Heading of a level dock, rad (the ``heading_rad`` of the dock's motion).
    dock_attitude_rad : array_like, shape (3,), optional
        Dock roll, pitch, yaw (ZYX Euler angles), rad.  Exactly one of the two is given.
    """
    if dock_attitude_rad is None:
        if dock_heading_rad is None:
            raise ValueError("give dock_heading_rad (a level dock) or dock_attitude_rad (roll, pitch, yaw)")
        return rotation_zyx(0.0, 0.0, float(dock_heading_rad))
    if dock_heading_rad is not None:
        raise ValueError("give dock_heading_rad or dock_attitude_rad, not both")
    a = np.asarray(dock_attitude_rad, dtype=float)
    if a.shape != (3,):
        raise ValueError(f"dock_attitude_rad: must have 3 components (roll, pitch, yaw), got shape {a.shape}")
    return rotation_of(a)


def points_in_dock_frame(
    points_ned: np.ndarray,
    dock_position_ned: np.ndarray,
    dock_heading_rad: float | None = None,
    dock_attitude_rad: np.ndarray | None = None,
) -> np.ndarray:
    """NED points (shape (..., 3), m) in the dock frame {d}, shape (..., 3), m.

    ``p_d = R_nd^T (p_n - p_dock)``; the dock's rotation as in :func:`dock_rotation`.
    """
    R_nd = dock_rotation(dock_heading_rad, dock_attitude_rad)
    return (np.asarray(points_ned, dtype=float) - np.asarray(dock_position_ned, dtype=float)) @ R_nd


def classify_contact(
    x_vehicle: np.ndarray,
    dock_position_ned: np.ndarray,
    dock_velocity_ned: np.ndarray,
    body: DockBody,
    hull: HullBox,
    limits: CaptureLimits,
    dock_attitude_rad: np.ndarray | None = None,
    *,
    dock_heading_rad: float | None = None,
) -> Contact:
    """Classify the vehicle's contact with the dock at one instant: free, captured or collided.

    Captured: the nose is past the cradle's entrance by ``limits.nose_inside_depth_m`` and
    not beyond the back plate, within the radial offset limit of the cradle's axis, the
    vehicle's heading, pitch and roll relative to the dock are within their limits, its
    relative speed is within ``limits.max_relative_speed_m_s``, and no hull sample point
    is inside the solid.  Otherwise collided if any hull sample point is strictly inside
    the structure or the buoy; otherwise free.  A vehicle in the capture pose but with a
    hull point inside the solid (possible near the radial and angular limits) is collided:
    a hull inside the structure is contact, whatever the nose's pose.  An instant is
    judged alone: a vehicle arriving too fast is free while its nose is in the cradle and
    collided once it reaches the back plate.

    Parameters
    ----------
    x_vehicle : array_like, shape (12,)
        Vehicle state ``[north, east, down, roll, pitch, yaw, u, v, w, p, q, r]``: NED
        position of the body origin (m), ZYX Euler angles (rad), body-frame velocity over
        ground (m/s) and body rates (rad/s).
    dock_position_ned : array_like, shape (3,)
        The docking point p_d (the origin of {d}), NED, m.
    dock_velocity_ned : array_like, shape (3,)
        The dock's velocity, NED, m/s.  The dock's rotation rate is taken as zero.
    body : DockBody
        The dock's geometry in {d}.
    hull : HullBox
        The vehicle's hull in {b}.
    limits : CaptureLimits
        The capture criteria.
    dock_attitude_rad : array_like, shape (3,), optional
        Dock roll, pitch, yaw (rad); give this or ``dock_heading_rad``.
    dock_heading_rad : float, optional
        Heading of a level dock (rad), e.g. ``HeaveDock.heading_rad``.

    Returns
    -------
    Contact

    Notes
    -----
    The vehicle's velocity in NED is ``R_nb @ [u, v, w]``; a hull point's velocity is
    ``R_nb @ ([u, v, w] + [p, q, r] x r_b)``.  The 3-vectors are handled as Python floats
    (faster than numpy at that size); the hull's sample points all at once with numpy,
    and only when the hull's axis-aligned bounding box in {d} reaches the structure or the
    buoy (not when it lies wholly outside the frame's box, or wholly inside the entry
    space, as on most of an approach along the axis and when docked).

    Timing (default hull of 506 sample points): about 11 to 13 us when the bounding box
    settles it (far from the dock, inside the funnel or cradle clear of the walls,
    docked), 35 to 45 us when every sample point is tested without a hit (the hull
    near a wall), and 100 to 170 us for a collided result (finding the deepest point and
    its surface; once per run).  Measured with ``timeit.repeat(..., number=20000,
    repeat=10, timer=time.process_time)``, best and median of the repeats, on the 2-core
    development machine (Python 3.11, numpy 2.4) while it was shared with other work
    (load 1.5 to 3.7): the free and captured cases meet the 50 us target.
    """
    x = np.asarray(x_vehicle, dtype=float)
    if x.shape != (NX,):
        raise ValueError(f"x_vehicle: must have shape ({NX},), got {x.shape}")
    (n, e, dn, roll, pitch, yaw, u, v, w, pr, qr, rr) = x.tolist()
    pdn, pde, pdd = np.asarray(dock_position_ned, dtype=float).tolist()
    vdn, vde, vdd = np.asarray(dock_velocity_ned, dtype=float).tolist()

    R_nb = _rzyx(roll, pitch, yaw)
    if dock_attitude_rad is None:
        if dock_heading_rad is None:
            raise ValueError("give dock_heading_rad (a level dock) or dock_attitude_rad (roll, pitch, yaw)")
        psi = float(dock_heading_rad)
        R_db = _rzyx(roll, pitch, yaw - psi)  # Rz(-psi) Rz(yaw) Ry Rx
        c, s = math.cos(psi), math.sin(psi)
        R_dn = (c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0)
    else:
        R_dn = _transpose(dock_rotation(dock_heading_rad, dock_attitude_rad).ravel().tolist())
        R_db = _matmul(R_dn, R_nb)

    # relative pose and speed
    o_d = _mv(R_dn, (n - pdn, e - pde, dn - pdd))  # body origin in {d}
    vn, ve, vd = _mv(R_nb, (u, v, w))
    rel_speed = math.sqrt((vn - vdn) ** 2 + (ve - vde) ** 2 + (vd - vdd) ** 2)
    heading_err = math.atan2(R_db[3], R_db[0])
    pitch_err = -math.asin(max(-1.0, min(1.0, R_db[6])))
    roll_err = math.atan2(R_db[7], R_db[8])
    nb = _mv(R_db, hull._nose_t)
    nose_d = np.array([o_d[0] + nb[0], o_d[1] + nb[1], o_d[2] + nb[2]])
    nose_depth = o_d[0] + nb[0] - body.cradle_entrance_x_m
    radial = math.hypot(o_d[1] + nb[1], o_d[2] + nb[2])

    found = _solid_hits(body, hull, R_db, o_d)
    if found is None:
        reason = _capture_failure(
            limits, body, hull, nose_depth, radial, heading_err, pitch_err, roll_err, rel_speed
        )
        status: ContactStatus = "captured" if reason == "" else "free"
        return Contact(
            status, rel_speed, math.nan, _NAN3, "", nose_d, heading_err, pitch_err, roll_err,
            nose_depth, radial, reason,
        )  # fmt: skip

    hits, P_d = found
    idx, depth = body._surfaces(P_d[0, hits], P_d[1, hits], P_d[2, hits])
    k = int(np.argmax(depth))
    sx, sy, sz = hull.sample_points_b_m[hits[k]].tolist()
    # hull point velocity in {b}: nu_1 + omega x r_b
    vp = _mv(R_nb, (u + qr * sz - rr * sy, v + rr * sx - pr * sz, w + pr * sy - qr * sx))
    impact = math.sqrt((vp[0] - vdn) ** 2 + (vp[1] - vde) ** 2 + (vp[2] - vdd) ** 2)
    sn = _mv(R_nb, (sx, sy, sz))
    point_ned = np.array([n + sn[0], e + sn[1], dn + sn[2]])
    what = _SURFACE_LABELS[idx[k]]
    return Contact(
        "collided", rel_speed, impact, point_ned, what, nose_d, heading_err, pitch_err, roll_err,
        nose_depth, radial, f"{hits.size} hull sample point(s) inside the solid, deepest {depth[k]:.3f} m",
    )  # fmt: skip


_NAN3 = _readonly(np.full(3, np.nan))
# a point within this distance (m) of the free space's walls or the back plate is on them, not
# inside: two computations of one point (rounding) then agree on which side it is
_ON_SURFACE_M = 1e-9
# bounding boxes are widened by this much (m) before deciding a test can be skipped
_AABB_MARGIN_M = 1e-9

_Mat3 = tuple[float, float, float, float, float, float, float, float, float]
_Vec3 = tuple[float, float, float]


def _rzyx(roll: float, pitch: float, yaw: float) -> _Mat3:
    """``rotation_zyx`` as 9 Python floats, row-major."""
    return zyx_entries(roll, pitch, yaw)


def _transpose(a: list[float] | _Mat3) -> _Mat3:
    return (a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8])


def _matmul(a: _Mat3, b: _Mat3) -> _Mat3:
    return (
        a[0] * b[0] + a[1] * b[3] + a[2] * b[6],
        a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
        a[0] * b[2] + a[1] * b[5] + a[2] * b[8],
        a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
        a[3] * b[1] + a[4] * b[4] + a[5] * b[7],
        a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
        a[6] * b[0] + a[7] * b[3] + a[8] * b[6],
        a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
        a[6] * b[2] + a[7] * b[5] + a[8] * b[8],
    )


def _mv(a: _Mat3, b: _Vec3) -> _Vec3:
    return (
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2],
        a[3] * b[0] + a[4] * b[1] + a[5] * b[2],
        a[6] * b[0] + a[7] * b[1] + a[8] * b[2],
    )


def _solid_hits(
    body: DockBody, hull: HullBox, R_db: _Mat3, o_d: _Vec3
) -> tuple[np.ndarray, np.ndarray] | None:
    """Indices of the hull sample points inside the solid, and all points in {d} (3, N).

    None when there are none.  Tests that the hull's axis-aligned bounding box in {d}
    shows to be decided for every point are skipped; the result is that of
    :meth:`DockBody.in_solid` on the sample points.
    """
    cx, cy, cz = _mv(R_db, hull._centre_t)
    cx, cy, cz = cx + o_d[0], cy + o_d[1], cz + o_d[2]
    hx, hy, hz = hull._half_t
    m = _AABB_MARGIN_M
    ex = abs(R_db[0]) * hx + abs(R_db[1]) * hy + abs(R_db[2]) * hz + m
    ey = abs(R_db[3]) * hx + abs(R_db[4]) * hy + abs(R_db[5]) * hz + m
    ez = abs(R_db[6]) * hx + abs(R_db[7]) * hy + abs(R_db[8]) * hz + m
    w = body.structure_half_width_m
    xm, xe = body.mouth_x_m, body.back_end_x_m
    near_structure = cx - ex < xe and cx + ex > xm and abs(cy) - ey < w and abs(cz) - ez < w
    if near_structure and cx + ex <= body.back_x_m:
        # wholly inside the entry space?  The free radius shrinks along +x_d, so its least
        # over the box is at the box's front; ahead of the mouth nothing is solid anyway
        rf = body.cradle_radius_m + max(body.cradle_entrance_x_m - (cx + ex), 0.0) * body._taper
        ry, rz = abs(cy) + ey, abs(cz) + ez
        near_structure = ry * ry + rz * rz > rf * rf
    b = body.buoy
    near_buoy = False
    if b is not None:
        bx, by, bz = b.centre_d_m
        near_buoy = (
            abs(cx - bx) - ex < b.radius_m
            and abs(cy - by) - ey < b.radius_m
            and abs(cz - bz) - ez < 0.5 * b.draft_m
        )
    if not (near_structure or near_buoy):
        return None
    M = np.array(
        [
            R_db[0],
            R_db[1],
            R_db[2],
            o_d[0],
            R_db[3],
            R_db[4],
            R_db[5],
            o_d[1],
            R_db[6],
            R_db[7],
            R_db[8],
            o_d[2],
        ]
    ).reshape(3, 4)
    P = M @ hull._samples_h  # (3, N) in {d}
    X, Y, Z = P[0], P[1], P[2]
    mask: np.ndarray | None = None
    if near_structure:
        box = (cx - ex <= xm, cx + ex >= xe, abs(cy) + ey >= w, abs(cz) + ez >= w)
        mask = _structure_mask(body, X, Y, Z, check_plate=cx + ex > body.back_x_m, check_box=box)
    if near_buoy:
        in_buoy = body.buoy.contains(P.T)  # type: ignore[union-attr]
        mask = in_buoy if mask is None else mask | in_buoy
    assert mask is not None
    hits = mask.nonzero()[0]
    return (hits, P) if hits.size else None


def _structure_mask(
    body: DockBody,
    X: np.ndarray,
    Y: np.ndarray,
    Z: np.ndarray,
    check_plate: bool = True,
    check_box: tuple[bool, bool, bool, bool] = (True, True, True, True),
) -> np.ndarray:
    """Whether points (coordinates X, Y, Z in {d}, m) are strictly inside the structure.

    Outside the free space: ``x > back_x`` or ``r^2 > free_radius(x)^2``, with
    ``free_radius(x) = max(R_c + (x_c - x) tan(a), R_c)``; and inside the outer box.
    ``check_plate=False`` skips the back-plate test when the caller knows every point is
    ahead of the back plate; ``check_box`` flags which of the outer box's limits (front,
    rear, y, z) some point may be beyond.  Written for few numpy operations: their call
    overhead dominates at a few hundred points.
    """
    t = body._taper
    rc = body.cradle_radius_m
    rf2 = (rc + _ON_SURFACE_M + t * body.cradle_entrance_x_m) - t * X
    np.maximum(rf2, rc + _ON_SURFACE_M, out=rf2)
    rf2 *= rf2
    r2 = Y * Y
    r2 += Z * Z
    out = r2 > rf2
    if check_plate:
        out |= X > body.back_x_m + _ON_SURFACE_M
    front, rear, side, top = check_box
    w = body.structure_half_width_m
    if front:
        out &= X > body.mouth_x_m
    if rear:
        out &= X < body.back_end_x_m
    if side:
        out &= np.abs(Y) < w
    if top:
        out &= np.abs(Z) < w
    return out


def _capture_failure(
    limits: CaptureLimits,
    body: DockBody,
    hull: HullBox,
    nose_depth: float,
    radial: float,
    heading_err: float,
    pitch_err: float,
    roll_err: float,
    rel_speed: float,
) -> str:
    """The first capture condition not met, as a phrase; "" when all are met."""
    need = limits.nose_inside_depth_m
    if nose_depth < 0.0:
        return f"nose {-nose_depth:.2f} m short of the cradle entrance"
    if nose_depth < need:
        return f"nose {nose_depth:.2f} m inside the cradle, short of {need:.2f} m"
    if nose_depth > body.cradle_depth_m:
        return "nose beyond the back plate"
    r_max = limits.radial_offset_limit_m(body, hull)
    if radial > r_max:
        return f"nose {radial:.3f} m off the cradle axis, over the {r_max:.3f} m limit"
    h = math.degrees(abs(heading_err))
    if h > limits.max_heading_error_deg:
        return f"heading error {h:.1f} deg over the {limits.max_heading_error_deg:.1f} deg limit"
    pr = math.degrees(max(abs(pitch_err), abs(roll_err)))
    if pr > limits.max_pitch_roll_error_deg:
        return f"pitch/roll error {pr:.1f} deg over the {limits.max_pitch_roll_error_deg:.1f} deg limit"
    if rel_speed > limits.max_relative_speed_m_s:
        return f"relative speed {rel_speed:.2f} m/s over the {limits.max_relative_speed_m_s:.2f} m/s limit"
    return ""
