"""Synthetic camera images of the dock markers and of calibration checkerboards (rehearsal and tests).

Each planar target (a marker with its white quiet zone, or a checkerboard with a one-square white margin)
is a texture mapped into the image by the exact pinhole homography of its four outer corners and
composited with its coverage mask. Targets are drawn supersampled (up to 8 x 8 samples per pixel, fewer
for targets covering much of the image) and box-averaged, i.e. area-sampled like a real sensor: on
distortion-free cameras, marker corners measured by :class:`auvdock.camera.pose.MarkerDetector` land within
~0.005 px of their projections. Lens distortion is rendered by drawing the undistorted image on a canvas
that covers the distorted field of view and remapping it (bilinear) through the distortion model; the
remap softens edges slightly (measured corner errors ~0.1 px for k1 = -0.28), so pose accuracy tests use
distortion-free cameras. Blur (Gaussian, sigma px) and then additive Gaussian noise (grey levels) are
applied last.

Water (optional, :class:`Water`; off by default, and then the images are the same as without it): the
simplified Jaffe-McGlamery image formation with Koschmieder's veiling light. A target at range ``d``
(m) of radiance ``J`` (its texture's grey level) appears as

    I = J exp(-c d) + B_inf (1 - exp(-c d))

-- its light attenuated along the line of sight, plus the light the water scatters into it
(backscatter, veiling light), which tends to the radiance of water seen to infinity ``B_inf`` -- with
the beam attenuation coefficient ``c = 4.8 / V`` (1/m) from the water's visibility ``V`` (m): the
horizontal visibility of a black target, Zaneveld and Pegau (2003), "Robust underwater visibility
parameter", Optics Express 11(23), 2997-3009. ``B_inf`` is the view's ``background`` grey: everything but
the markers is open water. The black/white contrast of a marker thus falls from 255 grey levels by
``exp(-c d)``, towards the background grey. Each target (a marker with its quiet zone) is attenuated
with the range of its centre, the markers being small against the attenuation length ``1 / c``: across
a 0.15 m marker (0.19 m with its quiet zone) turned by ``a`` from the line of sight the range varies by
+-0.09 sin(a) m, so ``exp(-c d)`` by +-0.09 c sin(a) -- +-4 % at 45 deg in 8 m visibility, +-16 % in 2 m
(facing the camera 1 m away, by 2 % at most in 2 m): the detector sees the marker's mean contrast, and
the fast camera model (:mod:`auvdock.sensing.camera_fix`) uses the same centre range.

Forward scatter (the small-angle blur of the direct light, growing with range) is not rendered: the
visibility fixes ``c`` only, while the forward-scatter spread function needs the scattering coefficient and
the width of the scattering phase function, which it does not give, so any blur law would be a guess; and
backscatter (the veiling light), not forward-scatter blur, is the main degradation of underwater images
(Schechner and Karpel 2005, "Recovery of underwater visibility and structure by polarization analysis",
IEEE J. Oceanic Eng. 30(3), 570-587).  The camera's own blur (``blur_px``) stands for it, uniformly; how
much it matters is measured by ``python benchmarks/camera_fix_errors.py --blur 1.0`` (2026-12-02): twice
the synthetic camera's 0.5 px blur leaves the contrast needed to decode a marker nearly unchanged (20.5
against 19.5 grey levels) but raises the smallest decodable side from 12.5 to 19.5 px and the corner bias
of small markers eightfold, so where forward scatter blurs far markers the fast model's size limit is
optimistic.

Pixel convention: OpenCV's (pixel centres at integer coordinates), the same as ``cv2.projectPoints``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from auvdock.camera.layout import MarkerLayout, marker_image
from auvdock.camera.model import CameraModel

__all__ = ["Water", "render_checkerboard", "render_view"]

_Z_MIN_M = 0.02  # targets with a corner closer to the camera plane than this are not drawn
_MAX_TEXEL_PER_CELL = 128
_MAX_SUPERSAMPLE = 8
_MAX_SUBPIXELS = 2.5e6  # per drawn target, sets the supersampling of large targets
_MAX_CANVAS_SCALE = 3.0  # canvas of a distorted camera at most this many times the image size


#: Beam attenuation times black-target visibility, c V (Zaneveld and Pegau 2003): c = 4.8 / V.
VISIBILITY_ATTENUATION = 4.8


@dataclass(frozen=True)
class Water:
    """The water between the camera and the targets (see the module docstring).

    Parameters
    ----------
    visibility_m : float
        Horizontal visibility of a black target, m (Zaneveld and Pegau 2003); it sets the beam
        attenuation coefficient ``c = 4.8 / visibility_m`` (1/m).
    """

    visibility_m: float

    def __post_init__(self) -> None:
        v = float(self.visibility_m)
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"visibility_m: must be > 0 m, got {self.visibility_m}")
        object.__setattr__(self, "visibility_m", v)

    @property
    def attenuation_per_m(self) -> float:
        """Beam attenuation coefficient ``c = 4.8 / V``, 1/m."""
        return VISIBILITY_ATTENUATION / self.visibility_m

    def transmittance(self, range_m: float) -> float:
        """``exp(-c d)``: the fraction of a target's radiance (and contrast) left at range ``d`` (m)."""
        return math.exp(-self.attenuation_per_m * max(float(range_m), 0.0))


def _homography(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """3x3 homography mapping 4 source points (4, 2) to 4 destination points (4, 2), in double precision."""
    A = np.zeros((8, 8))
    b = np.zeros(8)
    for i, ((x, y), (u, v)) in enumerate(zip(src, dst, strict=True)):
        A[2 * i] = [x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y]
        A[2 * i + 1] = [0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y]
        b[2 * i], b[2 * i + 1] = u, v
    h = np.linalg.solve(A, b)
    return np.append(h, 1.0).reshape(3, 3)


class _Canvas:
    """Float image plus the pinhole matrix used to draw on it (undistorted)."""

    def __init__(self, camera: CameraModel, background: float) -> None:
        w, h = camera.image_size
        self.K = np.array(camera.K, dtype=float)
        self.maps: tuple[np.ndarray, np.ndarray] | None = None
        if camera.has_distortion:
            (x0, y0, cw, ch), self.maps = _distortion_maps(camera)
            self.K[0, 2] -= x0
            self.K[1, 2] -= y0
            w, h = cw, ch
        self.background = float(background)
        self.image: np.ndarray = np.full((h, w), self.background, dtype=np.float32)

    def draw(
        self,
        corners_c: np.ndarray,
        make_texture: Callable[[int], np.ndarray],
        cells: int,
        transmittance: float = 1.0,
    ) -> None:
        """Composite a planar texture.

        ``corners_c`` (4, 3) are the texture's outer corners (top-left, top-right, bottom-right,
        bottom-left of the texture image) in the camera frame, m; ``make_texture(q)`` returns the texture
        with ``q`` texels per cell, ``cells`` cells across. Not drawn if a corner is closer than
        ``z_c = 0.02 m`` or the back side faces the camera. The patch is rendered supersampled (S x S per
        pixel, S <= 8, from a texture of about one texel per sub-pixel) and box-averaged, so edges are
        area-sampled to ~0.01 px. With ``transmittance`` ``t < 1`` (water) the texture's grey levels ``J``
        become ``t J + (1 - t) B_inf`` with ``B_inf`` the canvas background (the veiling light).
        """
        if np.any(corners_c[:, 2] < _Z_MIN_M):
            return
        uvw = corners_c @ self.K.T
        dst = uvw[:, :2] / uvw[:, 2:3]
        x, y = dst[:, 0], dst[:, 1]
        signed_area = np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)  # > 0: front side (image y down)
        if signed_area <= 0.0:
            return
        h_img, w_img = self.image.shape
        x0, y0 = max(int(math.floor(x.min())) - 1, 0), max(int(math.floor(y.min())) - 1, 0)
        x1, y1 = min(int(math.ceil(x.max())) + 2, w_img), min(int(math.ceil(y.max())) + 2, h_img)
        if x1 <= x0 or y1 <= y0:
            return
        bw, bh = x1 - x0, y1 - y0
        S = int(np.clip(math.floor(math.sqrt(_MAX_SUBPIXELS / (bw * bh))), 1, _MAX_SUPERSAMPLE))
        side = float(np.max(np.linalg.norm(dst - np.roll(dst, -1, axis=0), axis=1)))
        q = int(np.clip(math.ceil(side * S / cells), 1, _MAX_TEXEL_PER_CELL))
        tex = make_texture(q).astype(np.float32)
        th, tw = tex.shape
        src = np.array([[-0.5, -0.5], [tw - 0.5, -0.5], [tw - 0.5, th - 0.5], [-0.5, th - 0.5]])
        to_sub = np.array([[S, 0.0, S * (0.5 - x0) - 0.5], [0.0, S, S * (0.5 - y0) - 0.5], [0.0, 0.0, 1.0]])
        H = to_sub @ _homography(src, dst)
        size = (S * bw, S * bh)
        kw: dict[str, Any] = {"flags": cv2.INTER_LINEAR, "borderMode": cv2.BORDER_CONSTANT, "borderValue": 0}
        warped = cv2.warpPerspective(tex, H, size, **kw)
        cover = cv2.warpPerspective(np.ones_like(tex), H, size, **kw)
        if S > 1:
            warped = cv2.resize(warped, (bw, bh), interpolation=cv2.INTER_AREA)
            cover = cv2.resize(cover, (bw, bh), interpolation=cv2.INTER_AREA)
        if transmittance < 1.0:  # I = J t + B_inf (1 - t), where the target covers the pixel
            veil = np.float32((1.0 - transmittance) * self.background)
            warped = np.float32(transmittance) * warped + veil * cover
        patch = self.image[y0:y1, x0:x1]
        patch *= 1.0 - cover
        patch += warped

    def finish(self, noise_std: float, blur_px: float, rng: np.random.Generator | int | None) -> np.ndarray:
        """Distort (remap), blur, add noise and quantise: uint8 image (height, width)."""
        img = self.image
        if self.maps is not None:
            img = cv2.remap(
                img, *self.maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=self.background
            )
        if blur_px > 0.0:
            img = cv2.GaussianBlur(
                img, (0, 0), sigmaX=blur_px, sigmaY=blur_px, borderType=cv2.BORDER_REPLICATE
            )
        if noise_std > 0.0:
            img = img + np.random.default_rng(rng).normal(0.0, noise_std, img.shape).astype(np.float32)
        return np.clip(np.rint(img), 0, 255).astype(np.uint8)


_MAP_CACHE: dict[bytes, tuple[tuple[int, int, int, int], tuple[np.ndarray, np.ndarray]]] = {}


def _distortion_maps(camera: CameraModel) -> tuple[tuple[int, int, int, int], tuple[np.ndarray, np.ndarray]]:
    """Canvas (x0, y0, width, height) in undistorted px and remap tables (float32, (height, width)) that
    take each distorted image pixel to its undistorted position on the canvas."""
    key = camera.K.tobytes() + camera.dist.tobytes() + np.array(camera.image_size).tobytes()
    if key not in _MAP_CACHE:
        w, h = camera.image_size
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
        pix = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10)
        if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4.x
            und = cv2.undistortPointsIter(pix, camera.K, camera.dist, None, camera.K, criteria)
        else:  # OpenCV >= 5: undistortPoints takes the criteria
            und = cv2.undistortPoints(pix, camera.K, camera.dist, R=None, P=camera.K, criteria=criteria)
        und = und.reshape(h, w, 2)
        finite = np.isfinite(und).all(axis=2)
        lo = np.array([-_MAX_CANVAS_SCALE / 2 + 0.5, -_MAX_CANVAS_SCALE / 2 + 0.5]) * np.array([w, h])
        hi = np.array([w, h]) - lo
        ux = np.clip(und[..., 0][finite], lo[0], hi[0])
        uy = np.clip(und[..., 1][finite], lo[1], hi[1])
        x0, y0 = int(math.floor(ux.min())) - 2, int(math.floor(uy.min())) - 2
        x1, y1 = int(math.ceil(ux.max())) + 3, int(math.ceil(uy.max())) + 3
        mx = np.where(finite, und[..., 0] - x0, -1e6).astype(np.float32)
        my = np.where(finite, und[..., 1] - y0, -1e6).astype(np.float32)
        if len(_MAP_CACHE) >= 4:
            _MAP_CACHE.clear()
        _MAP_CACHE[key] = ((x0, y0, x1 - x0, y1 - y0), (mx, my))
    return _MAP_CACHE[key]


def _check_common(camera: CameraModel, noise_std: float, blur_px: float, background: float) -> None:
    if not isinstance(camera, CameraModel):
        raise ValueError(f"camera: expected a CameraModel, got {type(camera).__name__}")
    if not (math.isfinite(noise_std) and noise_std >= 0):
        raise ValueError(f"noise_std: must be >= 0 grey levels, got {noise_std}")
    if not (math.isfinite(blur_px) and blur_px >= 0):
        raise ValueError(f"blur_px: must be >= 0 px, got {blur_px}")
    if not 0 <= background <= 255:
        raise ValueError(f"background: must be a grey level in [0, 255], got {background}")


def _pose(R: Any, t: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float).reshape(-1)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise ValueError(f"R_c{name}: expected a 3x3 rotation matrix")
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise ValueError(f"t_c{name}: expected 3 finite numbers (m)")
    return R, t


def render_view(
    camera: CameraModel,
    layout: MarkerLayout,
    R_cd: Any,
    t_cd: Any,
    *,
    noise_std: float = 0.0,
    blur_px: float = 0.0,
    background: float = 110,
    rng: np.random.Generator | int | None = None,
    water: Water | None = None,
) -> np.ndarray:
    """Render the dock markers as seen by the camera.

    Parameters
    ----------
    camera : CameraModel
        Intrinsics and image size; distortion is rendered by remapping (see module doc).
    layout : MarkerLayout
        Markers, each drawn with its white quiet zone on a uniform ``background``.
    R_cd : array_like, shape (3, 3)
    t_cd : array_like, shape (3,)
        Pose of the dock frame in the camera frame: ``x_c = R_cd x_d + t_cd`` (m), e.g. from
        :func:`auvdock.camera.model.camera_from_dock`.
    noise_std : float
        Standard deviation of additive Gaussian noise, grey levels.
    blur_px : float
        Gaussian blur sigma, px (applied before the noise).
    background : float
        Grey level of everything but the markers; with ``water``, also the veiling light ``B_inf``.
    rng : numpy Generator, int seed or None
        Noise source (seed it for reproducible images).
    water : Water, optional
        The water (see the module docstring): each marker attenuated by ``exp(-c d)`` with ``d`` the
        range of its centre, towards ``background``. None (default): no water, as in air.

    Returns
    -------
    ndarray, uint8, shape (height, width)
        Markers partly outside the image are clipped; markers with a corner within 0.02 m of the camera
        plane (or behind it) or seen from the back are not drawn; farther markers are drawn first.
    """
    _check_common(camera, noise_std, blur_px, background)
    if water is not None and not isinstance(water, Water):
        raise ValueError(f"water: expected a Water or None, got {type(water).__name__}")
    R_cd, t_cd = _pose(R_cd, t_cd, "d")
    canvas = _Canvas(camera, background)
    cells = layout.cells + 2
    targets = []
    for m in layout.markers:
        half = layout.quiet_zone_side_m(m) / 2.0
        outer_m = np.array([[-half, half, 0.0], [half, half, 0.0], [half, -half, 0.0], [-half, -half, 0.0]])
        corners_c = (outer_m @ m.R_dm().T + m.t_dm()) @ R_cd.T + t_cd
        targets.append((float(np.linalg.norm(corners_c.mean(axis=0))), m.id, corners_c))
    for range_m, marker_id, corners_c in sorted(targets, key=lambda item: -item[0]):
        t = 1.0 if water is None else water.transmittance(range_m)
        canvas.draw(corners_c, _marker_texture(layout, marker_id, cells), cells, t)
    return canvas.finish(noise_std, blur_px, rng)


def _marker_texture(layout: MarkerLayout, marker_id: int, cells: int) -> Callable[[int], np.ndarray]:
    """``make_texture`` of :meth:`_Canvas.draw` for one marker: ``q`` texels per cell."""
    return lambda q: marker_image(layout, marker_id, q * cells)


def checkerboard_texture(cols: int, rows: int, texels_per_square: int) -> np.ndarray:
    """Checkerboard with ``cols x rows`` INNER corners ((cols + 1) x (rows + 1) squares, the top-left one
    black) and a one-square white margin; uint8, shape ((rows + 3) q, (cols + 3) q) with q texels/square."""
    q = int(texels_per_square)
    i, j = np.meshgrid(np.arange(cols + 3), np.arange(rows + 3))
    inside = (i >= 1) & (i <= cols + 1) & (j >= 1) & (j <= rows + 1)
    black = inside & ((i + j) % 2 == 0)
    squares = np.where(black, 0, 255).astype(np.uint8)
    return np.kron(squares, np.ones((q, q), dtype=np.uint8))


def render_checkerboard(
    camera: CameraModel,
    cols: int,
    rows: int,
    square_m: float,
    R_cb: Any,
    t_cb: Any,
    *,
    noise_std: float = 0.0,
    blur_px: float = 0.0,
    background: float = 110,
    rng: np.random.Generator | int | None = None,
) -> np.ndarray:
    """Render a checkerboard calibration target.

    Parameters
    ----------
    camera : CameraModel
    cols, rows : int
        INNER corners per row and per column (the OpenCV ``patternSize = (cols, rows)`` convention).
    square_m : float
        Square side, m.
    R_cb : array_like, shape (3, 3)
    t_cb : array_like, shape (3,)
        Pose of the board frame in the camera frame, ``x_c = R_cb x_board + t_cb`` (m). Board frame (the
        ``cv2.calibrateCamera`` object-point convention): origin at the first inner corner, x along a row of
        inner corners, y down the columns, z into the board; inner corner (i, j) is at
        ``(i square_m, j square_m, 0)``. The printed side faces -z; a board seen from the back is not drawn.
    noise_std, blur_px, background, rng
        As in :func:`render_view`.

    Returns
    -------
    ndarray, uint8, shape (height, width)
    """
    _check_common(camera, noise_std, blur_px, background)
    for name, v in (("cols", cols), ("rows", rows)):
        if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 2:
            raise ValueError(f"{name}: expected an integer >= 2 (inner corners), got {v!r}")
    if not (math.isfinite(square_m) and square_m > 0):
        raise ValueError(f"square_m: must be > 0, got {square_m}")
    R_cb, t_cb = _pose(R_cb, t_cb, "b")
    s = float(square_m)
    x0, x1, y0, y1 = -2 * s, (cols + 1) * s, -2 * s, (rows + 1) * s
    outer_b = np.array([[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]])
    corners_c = outer_b @ R_cb.T + t_cb
    canvas = _Canvas(camera, background)
    canvas.draw(corners_c, lambda q: checkerboard_texture(cols, rows, q), max(cols, rows) + 3)
    return canvas.finish(noise_std, blur_px, rng)
