"""Fiducial markers on the dock's back panel: their layout and geometry, as the pose pipeline uses them.

A :class:`MarkerLayout` is the marker family (:data:`DICTIONARIES`) and every :class:`Marker`'s id, size
(m) and pose in the dock frame {d}; :func:`marker_image` draws one marker as it must be printed, and
:func:`default_layout` is the dock's five-marker panel. The true-scale print of a layout (pages, crop
marks, PDF / PNG / JPEG) is :mod:`auvdock.camera.print_sheet`.

Frames
------
Dock frame {d}: origin at the docking point, x along the docked vehicle's heading, y starboard, z down.
Marker frame {m} (the OpenCV ArUco / ``SOLVEPNP_IPPE_SQUARE`` convention): origin at the marker centre,
x toward the marker image's right, y toward its top, z out of the marker toward the viewer.

A marker's pose in {d} is its centre ``position_dock_m`` and ``rpy_deg`` relative to the DEFAULT orientation,
in which the marker faces the approaching vehicle (its normal points to -x_d), its image "up" is -z_d (up)
and its image "right" is +y_d (starboard) as seen by a vehicle looking along +x_d:
``R_dm = rotation_zyx(roll, pitch, yaw) @ R_DM_DEFAULT`` (rotation about the dock axes).

``size_m`` is the side of the marker's BLACK square (outer border included). Every marker also needs a
white quiet zone one cell wide around the black square (a cell is ``size_m / (bits + 2)``); the images
from :func:`marker_image` and the printed sheets and pages include it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.vehicle.geometry import rotation_zyx

if TYPE_CHECKING:
    import cv2

__all__ = [
    "DICTIONARIES",
    "R_DM_DEFAULT",
    "Marker",
    "MarkerLayout",
    "aruco_dictionary",
    "default_layout",
    "marker_image",
]

#: Supported dictionary names -> (OpenCV's predefined dictionary, bits per side, number of ids).
#: The sizes are OpenCV's own (tests/test_camera.py compares them), written here so that a layout
#: is checked -- when a mission is read -- without loading OpenCV.
DICTIONARIES: dict[str, tuple[str, int, int]] = {
    "apriltag_36h11": ("DICT_APRILTAG_36h11", 6, 587),
    "aruco_4x4_50": ("DICT_4X4_50", 4, 50),
    "aruco_5x5_100": ("DICT_5X5_100", 5, 100),
    "aruco_6x6_250": ("DICT_6X6_250", 6, 250),
    "aruco_original": ("DICT_ARUCO_ORIGINAL", 5, 1024),
}

#: Rotation dock <- marker of the default marker orientation (columns: marker x, y, z in dock axes):
#: image right = +y_d, image up = -z_d, normal (toward the viewer) = -x_d.
R_DM_DEFAULT = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
R_DM_DEFAULT.flags.writeable = False


def _vec3(value: Any, name: str) -> tuple[float, float, float]:
    """``value`` as 3 finite floats; ValueError naming ``name`` otherwise."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected 3 numbers, got {value!r}") from None
    if arr.shape != (3,) or isinstance(value, str) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected 3 finite numbers, got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


@dataclass(frozen=True)
class Marker:
    """One square fiducial marker on the dock.

    Parameters
    ----------
    id : int
        Marker id in the layout's dictionary.
    size_m : float
        Side of the black square in m (the white quiet zone is extra).
    position_dock_m : (float, float, float)
        Marker centre in the dock frame {d}, m.
    rpy_deg : (float, float, float)
        Roll, pitch, yaw (deg, ZYX about the dock axes) relative to the default orientation (see module doc).
    """

    id: int
    size_m: float
    position_dock_m: tuple[float, float, float]
    rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if isinstance(self.id, bool) or not isinstance(self.id, int | np.integer):
            raise ValueError(f"id: expected an integer, got {self.id!r}")
        if self.id < 0:
            raise ValueError(f"id: must be >= 0, got {self.id}")
        size = self.size_m
        if isinstance(size, bool) or not isinstance(size, int | float | np.floating | np.integer):
            raise ValueError(f"size_m: expected a positive number, got {size!r}")
        if not (math.isfinite(size) and size > 0):
            raise ValueError(f"size_m: must be > 0, got {size}")
        object.__setattr__(self, "id", int(self.id))
        object.__setattr__(self, "size_m", float(size))
        object.__setattr__(self, "position_dock_m", _vec3(self.position_dock_m, "position_dock_m"))
        object.__setattr__(self, "rpy_deg", _vec3(self.rpy_deg, "rpy_deg"))

    def R_dm(self) -> np.ndarray:
        """Rotation marker -> dock, shape (3, 3): ``x_d = R_dm x_m + position_dock_m``."""
        roll, pitch, yaw = np.radians(self.rpy_deg)
        return rotation_zyx(roll, pitch, yaw) @ R_DM_DEFAULT

    def t_dm(self) -> np.ndarray:
        """Marker centre in the dock frame, m, shape (3,)."""
        return np.array(self.position_dock_m)

    def corners_marker(self) -> np.ndarray:
        """Black-square corners in the marker frame, m, shape (4, 3).

        Order top-left, top-right, bottom-right, bottom-left (as seen looking at the marker), i.e. the
        ArUco corner order and the object points ``SOLVEPNP_IPPE_SQUARE`` requires:
        ``[-s/2, s/2, 0], [s/2, s/2, 0], [s/2, -s/2, 0], [-s/2, -s/2, 0]``.
        """
        h = self.size_m / 2.0
        return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])

    def corners_dock(self) -> np.ndarray:
        """Black-square corners in the dock frame, m, shape (4, 3), in ArUco order (see corners_marker)."""
        return self.corners_marker() @ self.R_dm().T + self.t_dm()


def _check_dictionary(name: str) -> None:
    if name not in DICTIONARIES:
        raise ValueError(f"dictionary: {name!r} is not supported; choose from {', '.join(DICTIONARIES)}")


def aruco_dictionary(name: str) -> cv2.aruco.Dictionary:
    """The OpenCV dictionary for a supported name (see :data:`DICTIONARIES`)."""
    import cv2

    _check_dictionary(name)
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARIES[name][0]))


def _dictionary_info(name: str) -> tuple[int, int]:
    """(bits per side, number of ids) of a supported dictionary."""
    _check_dictionary(name)
    _, bits, n_ids = DICTIONARIES[name]
    return bits, n_ids


@dataclass(frozen=True)
class MarkerLayout:
    """The set of markers on the dock.

    Parameters
    ----------
    dictionary : str
        Marker family, one of :data:`DICTIONARIES` (default ``"apriltag_36h11"``).
    markers : tuple of Marker
        At least one marker; ids unique and valid for the dictionary.
    """

    dictionary: str = "apriltag_36h11"
    markers: tuple[Marker, ...] = ()

    def __post_init__(self) -> None:
        _, n_ids = _dictionary_info(self.dictionary)
        markers = tuple(self.markers)
        if not markers:
            raise ValueError("markers: at least one marker is required")
        seen: set[int] = set()
        for i, m in enumerate(markers):
            if not isinstance(m, Marker):
                raise ValueError(f"markers[{i}]: expected a Marker, got {type(m).__name__}")
            if m.id >= n_ids:
                raise ValueError(f"markers[{i}].id: {m.id} is not in {self.dictionary} (ids 0..{n_ids - 1})")
            if m.id in seen:
                raise ValueError(f"markers[{i}].id: {m.id} appears twice")
            seen.add(m.id)
        object.__setattr__(self, "markers", markers)

    @property
    def ids(self) -> tuple[int, ...]:
        """Marker ids in layout order."""
        return tuple(m.id for m in self.markers)

    @property
    def cells(self) -> int:
        """Cells across a marker's black square (data bits + 2 border cells)."""
        return _dictionary_info(self.dictionary)[0] + 2

    def marker(self, marker_id: int) -> Marker:
        """The marker with id ``marker_id``; KeyError if absent."""
        for m in self.markers:
            if m.id == marker_id:
                return m
        raise KeyError(f"marker id {marker_id} is not in the layout (ids {list(self.ids)})")

    def quiet_zone_side_m(self, marker: Marker) -> float:
        """Side of a marker's outer white quiet zone square in m: ``size_m (cells + 2) / cells``."""
        return marker.size_m * (self.cells + 2) / self.cells

    def to_dict(self) -> dict[str, Any]:
        """Plain (YAML-able) dict: ``{dictionary, markers: [{id, size_m, position_dock_m, rpy_deg}]}``."""
        return {
            "dictionary": self.dictionary,
            "markers": [
                {
                    "id": m.id,
                    "size_m": m.size_m,
                    "position_dock_m": list(m.position_dock_m),
                    "rpy_deg": list(m.rpy_deg),
                }
                for m in self.markers
            ],
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MarkerLayout:
        """Build and validate a layout from :meth:`to_dict`'s format (``rpy_deg`` optional, default 0).

        Raises ValueError naming the offending field, e.g. ``"markers[2].id: 7 appears twice"``.
        """
        if not isinstance(data, Mapping):
            raise ValueError(
                f"layout: expected a mapping with keys dictionary, markers; got {type(data).__name__}"
            )
        unknown = sorted(set(data) - {"dictionary", "markers"})
        if unknown:
            raise ValueError(f"layout: unknown key {unknown[0]!r} (expected dictionary, markers)")
        dictionary = data.get("dictionary", "apriltag_36h11")
        if not isinstance(dictionary, str):
            raise ValueError(f"dictionary: expected a name, got {dictionary!r}")
        _check_dictionary(dictionary)
        items = data.get("markers")
        if not isinstance(items, list | tuple):
            raise ValueError(f"markers: expected a list of markers, got {items!r}")
        markers = tuple(_marker_from_dict(item, f"markers[{i}]") for i, item in enumerate(items))
        return cls(dictionary=dictionary, markers=markers)


_MARKER_KEYS = ("id", "size_m", "position_dock_m", "rpy_deg")


def _marker_from_dict(item: Any, where: str) -> Marker:
    if not isinstance(item, Mapping):
        raise ValueError(f"{where}: expected a mapping with keys {', '.join(_MARKER_KEYS)}, got {item!r}")
    for key in _MARKER_KEYS[:3]:
        if key not in item:
            raise ValueError(f"{where}: missing key {key!r}")
    unknown = sorted(set(item) - set(_MARKER_KEYS))
    if unknown:
        raise ValueError(f"{where}: unknown key {unknown[0]!r} (expected {', '.join(_MARKER_KEYS)})")
    try:
        return Marker(
            id=item["id"],
            size_m=item["size_m"],
            position_dock_m=item["position_dock_m"],
            rpy_deg=item.get("rpy_deg", (0.0, 0.0, 0.0)),
        )
    except ValueError as exc:
        raise ValueError(f"{where}.{exc}") from None


def default_layout() -> MarkerLayout:
    """Five AprilTag 36h11 markers on the back panel (x_d = 0.35 m), sized for far range down to contact.

    * id 0: 0.15 m, centre (0.35, 0, -0.17): the far-range marker, above the docking axis.
    * ids 1-4: 0.04 m, centres (0.35, +-0.045, +-0.035) (1 upper port, 2 upper starboard,
      3 lower starboard, 4 lower port): a cluster on the docking axis for the last metre.

    At contact the default camera (0.2 m ahead of the body origin, ~80 deg x 64 deg field of view) is
    0.15 m from the panel and sees about +-0.126 m (y) x +-0.094 m (z) of it: the 0.15 m marker (with its
    quiet zone ~0.19 m) would fill the whole view, so the small markers sit on the axis (all four in view at
    contact, at least one for misalignments up to ~3 cm) and the large one above them. Black squares are
    >= 0.03 m apart and the quiet zones do not overlap.
    """
    x = 0.35
    small = 0.04
    return MarkerLayout(
        dictionary="apriltag_36h11",
        markers=(
            Marker(0, 0.15, (x, 0.0, -0.17)),
            Marker(1, small, (x, -0.045, -0.035)),
            Marker(2, small, (x, 0.045, -0.035)),
            Marker(3, small, (x, 0.045, 0.035)),
            Marker(4, small, (x, -0.045, 0.035)),
        ),
    )


def marker_image(layout: MarkerLayout, marker_id: int, pixels: int) -> np.ndarray:
    """Image of one marker including its one-cell white quiet zone, uint8, shape (pixels, pixels).

    The black square (side ``size_m`` in the world) spans ``cells`` of the ``cells + 2`` cells across the
    image (``cells = layout.cells``). Choose ``pixels`` as a multiple of ``cells + 2`` for equal cells;
    other sizes are resampled (nearest).
    """
    marker = layout.marker(marker_id)
    cells = layout.cells
    if isinstance(pixels, bool) or not isinstance(pixels, int | np.integer) or pixels < cells + 2:
        raise ValueError(f"pixels: expected an integer >= {cells + 2}, got {pixels!r}")
    import cv2

    core = cv2.aruco.generateImageMarker(aruco_dictionary(layout.dictionary), marker.id, cells, borderBits=1)
    img = cv2.copyMakeBorder(core, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=255)
    # nearest resampling by pixel centres, exact for multiples (cv2.resize INTER_NEAREST can be off by one)
    idx = ((np.arange(int(pixels)) + 0.5) * (cells + 2) // int(pixels)).astype(int)
    return np.ascontiguousarray(img[np.ix_(idx, idx)])
