"""The camera's fix of the dock by the real pipeline in the simulation loop, for spot checks.

:class:`RenderedCameraFix` has the interface of the fast model
(:meth:`auvdock.sensing.camera_fix.CameraFixModel.fix`): at the true state it renders the camera's view
of the dock's markers with the water (:func:`auvdock.camera.render.render_view`, :class:`Water`: each
marker's contrast attenuated by ``exp(-c d)``, ``c = 4.8 / visibility_m``), detects them
(:class:`auvdock.camera.pose.MarkerDetector`) and estimates the dock's pose
(:func:`auvdock.camera.pose.estimate_dock_pose`), and returns the docking point in the camera frame
with the pipeline's own standard deviations (the position block of its covariance; rotated to NED for
:attr:`CameraFix.covariance_ned_m2`), or None when nothing is decoded.  It is what the fast model was
derived from (``benchmarks/camera_fix_errors.py``) and what ``tests/test_camera_rendered.py`` checks it
against.

Slow: 10-50 ms a frame on the 2-core machine (640 x 480; the more of the image the markers fill, the
slower), so a 15 Hz camera costs 0.2-0.7 s per simulated second.  The pipeline's covariance uses the
corner noise ``max(reprojection RMS, sigma_floor_px)`` with the pipeline's floor of 0.5 px, so its
standard deviations overstate the errors 8-70 times where the edges are refined (the measured corner
noise is 0.007-0.06 px there, :mod:`auvdock.sensing.camera_fix`); pass ``sigma_floor_px`` to change the
floor.

The rendered markers have the synthetic camera's full contrast (black 0, white 255 on a background of
110 grey levels, which is also the veiling light); ``settings.marker_contrast_grey``,
``min_contrast_grey``, ``min_side_px``, ``max_view_angle_deg`` and ``corner_px`` are the fast model's and
are not used here: what is decoded, and how well, is the pipeline's.
"""

from __future__ import annotations

import numpy as np

from auvdock.camera.layout import MarkerLayout
from auvdock.camera.model import CameraModel, CameraMount, camera_from_dock
from auvdock.camera.pose import MarkerDetector, estimate_dock_pose
from auvdock.camera.render import Water, render_view
from auvdock.sensing.camera_fix import CameraFix
from auvdock.sensing.settings import DockCameraSettings
from auvdock.vehicle.geometry import rotation_zyx
from auvdock.vehicle.state import POS

__all__ = ["RenderedCameraFix"]


class RenderedCameraFix:
    """The real rendering + detection + pose pipeline as the dock camera's fix (see the module docstring).

    Parameters
    ----------
    camera : CameraModel
        Intrinsics, image size and distortion (rendered).
    mount : CameraMount
        Where the camera sits on the vehicle.
    layout : MarkerLayout
        The dock's markers in the dock frame.
    settings : DockCameraSettings
        ``visibility_m`` (the water, m) and ``dropout`` (probability that a frame gives no fix) are used.
    noise_std : float
        Image noise std, grey levels (the synthetic camera's: 2).
    blur_px : float
        Gaussian blur sigma, px (the synthetic camera's: 0.5).
    sigma_floor_px : float
        Floor of the corner noise in the pipeline's covariance, px (the pipeline's default: 0.5).

    Draws from the ``rng`` of :meth:`fix`, in a fixed order: one uniform (the dropout), then, unless the
    frame is dropped, one integer that seeds the image noise -- so the other sensors' draws do not depend
    on the image size.
    """

    def __init__(
        self,
        camera: CameraModel,
        mount: CameraMount,
        layout: MarkerLayout,
        settings: DockCameraSettings,
        noise_std: float = 2.0,
        blur_px: float = 0.5,
        *,
        sigma_floor_px: float = 0.5,
    ) -> None:
        if not (np.isfinite(noise_std) and noise_std >= 0):
            raise ValueError(f"noise_std: must be >= 0 grey levels, got {noise_std}")
        if not (np.isfinite(blur_px) and blur_px >= 0):
            raise ValueError(f"blur_px: must be >= 0 px, got {blur_px}")
        if not (np.isfinite(sigma_floor_px) and sigma_floor_px > 0):
            raise ValueError(f"sigma_floor_px: must be > 0 px, got {sigma_floor_px}")
        self.camera = camera
        self.mount = mount
        self.layout = layout
        self.settings = settings
        self.noise_std = float(noise_std)
        self.blur_px = float(blur_px)
        self.sigma_floor_px = float(sigma_floor_px)
        self.dropout = float(settings.dropout)
        self.water = Water(float(settings.visibility_m))
        self.detector = MarkerDetector(layout, camera)

    def image(
        self, x: np.ndarray, dock_position_ned: np.ndarray, dock_heading_rad: float, seed: int | None
    ) -> np.ndarray:
        """The camera's view at the true state ``x`` (12,) of the dock at ``dock_position_ned`` (3,, m)
        with heading ``dock_heading_rad`` (rad): uint8 (height, width), image noise seeded by ``seed``."""
        eta = np.asarray(x[0:6], dtype=float)
        R_cd, t_cd = camera_from_dock(eta, dock_position_ned, dock_heading_rad, self.mount)
        return render_view(
            self.camera,
            self.layout,
            R_cd,
            t_cd,
            noise_std=self.noise_std,
            blur_px=self.blur_px,
            rng=seed,
            water=self.water,
        )

    def fix(
        self,
        x: np.ndarray,
        dock_position_ned: np.ndarray,
        dock_heading_rad: float,
        rng: np.random.Generator,
    ) -> CameraFix | None:
        """One frame's fix at the true state ``x`` (12,), or None (a dropout, or nothing decoded).

        ``dock_camera_m`` is the pipeline's docking point in the camera frame (3,, m), ``std_camera_m``
        the square roots of the diagonal of its position covariance (3,, m), ``marker_ids`` the markers
        it used; ``position_ned_m`` is the vehicle's position (NED, m) the fix implies for the dock where
        it truly is, with ``covariance_ned_m2`` the pipeline's position covariance rotated to NED."""
        if rng.uniform() < self.dropout:
            return None
        seed = int(rng.integers(0, 2**63 - 1))
        x = np.asarray(x, dtype=float)
        image = self.image(x, dock_position_ned, dock_heading_rad, seed)
        pose = estimate_dock_pose(
            self.detector.detect(image), self.layout, self.camera, sigma_floor_px=self.sigma_floor_px
        )
        if pose is None:
            return None
        _, t_cd = camera_from_dock(x[0:6], dock_position_ned, dock_heading_rad, self.mount)
        R_nc = rotation_zyx(float(x[3]), float(x[4]), float(x[5])) @ self.mount.R_bc()
        cov_c = pose.covariance[:3, :3]
        cov_c = 0.5 * (cov_c + cov_c.T)
        error_c = pose.t_cd - t_cd
        # the dock measured error_c away from where it is: the vehicle then seems -error_c away
        pos = x[POS] - R_nc @ error_c
        return CameraFix(
            dock_camera_m=np.array(pose.t_cd, dtype=float),
            std_camera_m=np.sqrt(np.diag(cov_c)),
            marker_ids=tuple(pose.markers_used),
            position_ned_m=pos,
            covariance_ned_m2=R_nc @ cov_c @ R_nc.T,
        )
