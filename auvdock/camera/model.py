"""Camera intrinsics, camera mount on the vehicle, and the frame chain NED -> body -> camera <- dock.

Frames
------
{n}
    NED world frame.
{b}
    vehicle body: x forward, y starboard, z down. Vehicle pose
    ``eta = [north, east, down, roll, pitch, yaw]`` (m, rad); ``R_nb = Rz(yaw) Ry(pitch) Rx(roll)``
    maps body vectors to NED.
{d}
    dock: origin at the docking point, x along the docked vehicle's heading (``R_nd = Rz(dock_heading)``),
    y starboard, z down; the dock heaves but does not roll or pitch.
{c}
    camera, OpenCV convention: x right, y down, z along the optical axis.

A pose "of frame {a} in frame {c}" is written ``(R_ca, t_ca)`` with ``x_c = R_ca x_a + t_ca``.

Intrinsics follow OpenCV: pixel centres at integer coordinates, ``K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]``
(px) and the 5-term plumb-bob distortion ``[k1, k2, p1, p2, k3]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml

from auvdock.schema.yamlio import load_yaml_strict
from auvdock.vehicle.geometry import point_in_sensor_frame, rotation_zyx
from auvdock.vehicle.state import POS

__all__ = [
    "gray_image",
    "R_BC_DEFAULT",
    "CameraModel",
    "CameraMount",
    "camera_from_dock",
    "load_camera",
    "project",
    "rotation_zyx",
    "save_camera",
]

#: Rotation body <- camera of the default forward-looking camera (columns: camera x, y, z in body axes):
#: optical axis = body +x, image right = body +y, image down = body +z.
R_BC_DEFAULT = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
R_BC_DEFAULT.flags.writeable = False


def gray_image(image: Any) -> np.ndarray:
    """A camera image as grayscale uint8 (h, w): (h, w, 1), BGR (h, w, 3) and BGRA (h, w, 4) are
    converted; anything else is a ValueError."""
    image = np.asarray(image)
    if image.ndim == 3 and image.shape[2] == 1:
        image = image[:, :, 0]
    elif image.ndim == 3 and image.shape[2] == 3:
        image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    elif image.ndim == 3 and image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2GRAY)
    if image.ndim != 2:
        raise ValueError(
            f"image: expected a grayscale (h, w) or BGR (h, w, 3) array, got shape {image.shape}"
        )
    if image.dtype != np.uint8:
        raise ValueError(f"image: expected dtype uint8, got {image.dtype}")
    return image


def _float_array(value: Any, shape: tuple[int, ...], name: str) -> np.ndarray:
    """``value`` as a finite float array of ``shape``; ValueError naming ``name`` otherwise."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected numbers of shape {shape}, got {value!r}") from None
    if arr.shape != shape:
        raise ValueError(f"{name}: expected shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: values must be finite, got {arr.tolist()}")
    return arr


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, dtype=float)
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True, eq=False)
class CameraModel:
    """Pinhole camera with OpenCV plumb-bob distortion.

    Parameters
    ----------
    K : array_like, shape (3, 3)
        Camera matrix ``[[fx, 0, cx], [0, fy, cy], [0, 0, 1]]`` in px.
    dist : array_like, shape (5,)
        Distortion ``[k1, k2, p1, p2, k3]`` (dimensionless), OpenCV plumb-bob model.
    image_size : (int, int)
        Image (width, height) in px.
    rms_px : float
        RMS reprojection error of the calibration in px; ``nan`` when not calibrated.
    board : (int, int, float) or None
        Calibration board (inner-corner columns, inner-corner rows, square side in m), if calibrated.
    n_views : int or None
        Number of views used by the calibration, if calibrated.

    Equality compares all fields exactly (two ``nan`` RMS values are equal).
    """

    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))
    image_size: tuple[int, int] = (640, 480)
    rms_px: float = math.nan
    board: tuple[int, int, float] | None = None
    n_views: int | None = None

    def __post_init__(self) -> None:
        K = _float_array(self.K, (3, 3), "camera_matrix")
        if K[0, 0] <= 0 or K[1, 1] <= 0:
            raise ValueError(f"camera_matrix: focal lengths must be > 0, got fx={K[0, 0]}, fy={K[1, 1]}")
        if not np.allclose(K[2], [0.0, 0.0, 1.0]) or K[1, 0] != 0.0:
            raise ValueError(
                f"camera_matrix: expected [[fx, s, cx], [0, fy, cy], [0, 0, 1]], got {K.tolist()}"
            )
        dist = _float_array(self.dist, (5,), "distortion")
        size = self.image_size
        if (
            not isinstance(size, tuple | list)
            or len(size) != 2
            or not all(isinstance(v, int | np.integer) and not isinstance(v, bool) and v > 0 for v in size)
        ):
            raise ValueError(f"image_size: expected (width, height) positive integers, got {size!r}")
        rms = float(self.rms_px)
        if not (math.isnan(rms) or rms >= 0.0):
            raise ValueError(f"rms_reprojection_error_px: must be >= 0 or nan, got {rms}")
        board = self.board
        if board is not None:
            board = _check_board(board)
        if self.n_views is not None and (
            not isinstance(self.n_views, int | np.integer)
            or isinstance(self.n_views, bool)
            or self.n_views < 1
        ):
            raise ValueError(f"n_views: expected a positive integer, got {self.n_views!r}")
        object.__setattr__(self, "K", _readonly(K))
        object.__setattr__(self, "dist", _readonly(dist))
        object.__setattr__(self, "image_size", (int(size[0]), int(size[1])))
        object.__setattr__(self, "rms_px", rms)
        object.__setattr__(self, "board", board)
        object.__setattr__(self, "n_views", None if self.n_views is None else int(self.n_views))

    @classmethod
    def ideal(cls, width: int = 640, height: int = 480, hfov_deg: float = 80.0) -> CameraModel:
        """Distortion-free pinhole with square pixels and the principal point at the image centre.

        ``fx = fy = (width / 2) / tan(hfov / 2)``, ``cx = (width - 1) / 2``, ``cy = (height - 1) / 2`` (px).
        The BlueROV2 low-light camera has a horizontal field of view of about 80 deg.
        """
        if not 0.0 < hfov_deg < 180.0:
            raise ValueError(f"hfov_deg: must be in (0, 180), got {hfov_deg}")
        f = 0.5 * width / math.tan(math.radians(hfov_deg) / 2.0)
        K = np.array([[f, 0.0, (width - 1) / 2.0], [0.0, f, (height - 1) / 2.0], [0.0, 0.0, 1.0]])
        return cls(K=K, dist=np.zeros(5), image_size=(int(width), int(height)))

    @property
    def width(self) -> int:
        """Image width in px."""
        return self.image_size[0]

    @property
    def height(self) -> int:
        """Image height in px."""
        return self.image_size[1]

    @property
    def has_distortion(self) -> bool:
        """True when any distortion coefficient is non-zero."""
        return bool(np.any(self.dist != 0.0))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, CameraModel):
            return NotImplemented
        same_rms = self.rms_px == other.rms_px or (math.isnan(self.rms_px) and math.isnan(other.rms_px))
        return (
            np.array_equal(self.K, other.K)
            and np.array_equal(self.dist, other.dist)
            and self.image_size == other.image_size
            and same_rms
            and self.board == other.board
            and self.n_views == other.n_views
        )

    __hash__ = None  # type: ignore[assignment]


def _check_board(board: Any) -> tuple[int, int, float]:
    """``board`` as (cols, rows, square_m); ValueError otherwise."""
    if isinstance(board, dict):
        missing = [k for k in ("cols", "rows", "square_m") if k not in board]
        if missing:
            raise ValueError(f"board: missing key {missing[0]!r}")
        board = (board["cols"], board["rows"], board["square_m"])
    if not isinstance(board, tuple | list) or len(board) != 3:
        raise ValueError(f"board: expected (cols, rows, square_m), got {board!r}")
    cols, rows, square = board
    for name, v in (("cols", cols), ("rows", rows)):
        if not isinstance(v, int | np.integer) or isinstance(v, bool) or v < 2:
            raise ValueError(f"board.{name}: expected an integer >= 2, got {v!r}")
    if isinstance(square, bool) or not isinstance(square, int | float) or not square > 0:
        raise ValueError(f"board.square_m: expected a positive number, got {square!r}")
    return int(cols), int(rows), float(square)


# ---------------------------------------------------------------------------------------------------------
# YAML file
# ---------------------------------------------------------------------------------------------------------

_REQUIRED_KEYS = ("camera_matrix", "distortion", "image_size", "rms_reprojection_error_px")
_OPTIONAL_KEYS = ("board", "n_views")


def save_camera(model: CameraModel, path: str | Path) -> Path:
    """Write ``model`` to a YAML file; returns the path.

    Keys: ``camera_matrix`` (3x3 nested list, px), ``distortion`` ([k1, k2, p1, p2, k3]), ``image_size``
    ([width, height] px), ``rms_reprojection_error_px`` (float, ``.nan`` if unknown), and when known
    ``board`` ({cols, rows, square_m}) and ``n_views``.
    """
    data: dict[str, Any] = {
        "camera_matrix": [[float(v) for v in row] for row in model.K],
        "distortion": [float(v) for v in model.dist],
        "image_size": [int(model.image_size[0]), int(model.image_size[1])],
        "rms_reprojection_error_px": float(model.rms_px),
    }
    if model.board is not None:
        cols, rows, square = model.board
        data["board"] = {"cols": cols, "rows": rows, "square_m": square}
    if model.n_views is not None:
        data["n_views"] = model.n_views
    path = Path(path)
    path.write_text(yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
    return path


def load_camera(path: str | Path) -> CameraModel:
    """Read a camera YAML written by :func:`save_camera`.

    Raises
    ------
    ValueError
        If the file is missing, is not a YAML mapping, lacks a required key, has an unknown key or a value
        of the wrong shape; the message names the file and the key, e.g.
        ``"cam.yaml: missing key 'distortion'"``.
    """
    path = Path(path)
    try:
        data = load_yaml_strict(path.read_text())
    except OSError as exc:
        raise ValueError(f"{path}: cannot read camera file ({exc.strerror})") from None
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping with keys {', '.join(_REQUIRED_KEYS)}")
    for key in _REQUIRED_KEYS:
        if key not in data:
            raise ValueError(f"{path}: missing key {key!r}")
    unknown = sorted(set(data) - set(_REQUIRED_KEYS) - set(_OPTIONAL_KEYS))
    if unknown:
        raise ValueError(f"{path}: unknown key {unknown[0]!r}")
    size = data["image_size"]
    if isinstance(size, list):
        size = tuple(size)
    rms = data["rms_reprojection_error_px"]
    if isinstance(rms, bool) or not isinstance(rms, int | float):
        raise ValueError(f"{path}: rms_reprojection_error_px: expected a number, got {rms!r}")
    try:
        return CameraModel(
            K=data["camera_matrix"],
            dist=data["distortion"],
            image_size=size,
            rms_px=float(rms),
            board=data.get("board"),
            n_views=data.get("n_views"),
        )
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


# ---------------------------------------------------------------------------------------------------------
# Mount and frame chain
# ---------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CameraMount:
    """Camera extrinsics in the vehicle body frame.

    Parameters
    ----------
    position_body_m : (float, float, float)
        Camera optical centre in {b} (x forward, y starboard, z down), m. Default: 0.2 m ahead of the body
        origin.
    rpy_deg : (float, float, float)
        Roll, pitch, yaw (deg, ZYX, about body axes) of the camera relative to the default forward-looking
        camera (optical axis = body +x, image right = body +y, image down = body +z):
        ``R_bc = rotation_zyx(roll, pitch, yaw) @ R_BC_DEFAULT``. Positive pitch tilts the camera up.
    """

    position_body_m: tuple[float, float, float] = (0.2, 0.0, 0.0)
    rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        pos = _float_array(self.position_body_m, (3,), "position_body_m")
        rpy = _float_array(self.rpy_deg, (3,), "rpy_deg")
        object.__setattr__(self, "position_body_m", tuple(float(v) for v in pos))
        object.__setattr__(self, "rpy_deg", tuple(float(v) for v in rpy))

    def R_bc(self) -> np.ndarray:
        """Rotation camera -> body, shape (3, 3); its columns are the camera axes in body coordinates."""
        roll, pitch, yaw = np.radians(self.rpy_deg)
        return rotation_zyx(roll, pitch, yaw) @ R_BC_DEFAULT

    def t_bc(self) -> np.ndarray:
        """Camera optical centre in the body frame, m, shape (3,)."""
        return np.array(self.position_body_m, dtype=float)


def camera_from_dock(
    eta: Any, dock_position_ned: Any, dock_heading_rad: float, mount: CameraMount | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Pose of the dock frame {d} in the camera frame {c}.

    Parameters
    ----------
    eta : array_like, shape (6,)
        Vehicle pose [north, east, down (m), roll, pitch, yaw (rad)].
    dock_position_ned : array_like, shape (3,)
        Dock origin (docking point) in NED, m.
    dock_heading_rad : float
        Dock heading (rad): ``R_nd = Rz(dock_heading)``.
    mount : CameraMount, optional
        Camera extrinsics; default :class:`CameraMount()`.

    Returns
    -------
    R_cd : ndarray, shape (3, 3)
    t_cd : ndarray, shape (3,)
        ``x_c = R_cd x_d + t_cd``; ``t_cd`` is the dock origin in the camera frame, m.
    """
    mount = CameraMount() if mount is None else mount
    eta = _float_array(eta, (6,), "eta")
    p_nd = _float_array(dock_position_ned, (3,), "dock_position_ned")
    R_nb = rotation_zyx(*eta[3:])
    R_nd = rotation_zyx(0.0, 0.0, float(dock_heading_rad))
    R_bc = mount.R_bc()
    R_cd = R_bc.T @ R_nb.T @ R_nd
    t_cd = point_in_sensor_frame(R_nb, eta[POS], p_nd, R_bc, mount.t_bc())
    return R_cd, t_cd


def project(model: CameraModel, points_c: Any) -> np.ndarray:
    """Pixel coordinates of points given in the camera frame, with the model's distortion.

    Parameters
    ----------
    model : CameraModel
    points_c : array_like, shape (n, 3)
        Points in {c}, m; they must lie in front of the camera (z > 0).

    Returns
    -------
    ndarray, shape (n, 2)
        (u, v) in px.
    """
    pts = np.asarray(points_c, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points_c: expected shape (n, 3), got {pts.shape}")
    if len(pts) == 0:
        return np.zeros((0, 2))
    uv, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), model.K, model.dist)
    return uv.reshape(-1, 2)
