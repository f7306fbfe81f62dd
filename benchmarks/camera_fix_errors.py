"""The camera pipeline's fix errors on rendered views, beside the fast camera model's.

The default camera (640 x 480, 80 deg, 0.2 m ahead of the body origin) on the dock's axis at
several ranges, facing the dock, and at an angle: each view rendered ``--frames`` times with the
synthetic camera's image noise (2 grey levels) and blur (0.5 px), the markers detected and the
dock's pose estimated (:mod:`auvdock.camera.render`, :mod:`auvdock.camera.pose`); the error of the
dock's position in the camera frame (lateral x, y and range z) against the truth, beside the fast
model's (:class:`auvdock.sensing.camera_fix.CameraFixModel`) markers and standard deviations
with the corner noise ``--corner-px``.  The last line fits the corner noise that makes the fast
model's range std match the pipeline's (least squares over the views where both see markers).

    python benchmarks/camera_fix_errors.py [--frames 30] [--corner-px 0.5]
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from auvdock.camera.layout import default_layout
from auvdock.camera.model import CameraModel, CameraMount, camera_from_dock
from auvdock.camera.pose import MarkerDetector, estimate_dock_pose
from auvdock.camera.render import render_view
from auvdock.sensing.camera_fix import CameraFixModel

VIEWS = [  # (vehicle north offset from the dock m, east m, yaw deg)
    (-0.6, 0.0, 0.0), (-1.0, 0.0, 0.0), (-1.5, 0.0, 0.0), (-2.0, 0.0, 0.0), (-3.0, 0.0, 0.0),
    (-4.0, 0.0, 0.0), (-6.0, 0.0, 0.0), (-2.0, 0.8, -15.0), (-1.0, 0.3, 20.0),
]  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--corner-px", type=float, default=0.5)
    args = ap.parse_args()
    camera, mount, layout = CameraModel.ideal(), CameraMount(), default_layout()
    model = CameraFixModel(camera, mount, layout, corner_px=args.corner_px, dropout=0.0)
    detector = MarkerDetector(layout, camera)
    rng = np.random.default_rng(0)
    dock = np.zeros(3)
    print(
        f"{'view (n, e, yaw)':<22} {'seen':>5} {'pipeline sd x/y/z mm':>24} {'model sd x/y/z mm':>22} "
        f"{'pipe ids':>12} {'model ids':>12}"
    )
    fit_pipe, fit_unit = [], []
    for n, e, yaw in VIEWS:
        eta = np.array([n, e, 0.0, 0.0, 0.0, math.radians(yaw)])
        R_cd, t_cd = camera_from_dock(eta, dock, 0.0, mount)
        errors, ids = [], set()
        for _ in range(args.frames):
            image = render_view(camera, layout, R_cd, t_cd, noise_std=2.0, blur_px=0.5, rng=rng)
            pose = estimate_dock_pose(detector.detect(image), layout, camera)
            if pose is not None:
                errors.append(pose.t_cd - t_cd)
                ids.update(pose.markers_used)
        views = model.views(eta, dock, 0.0)
        cov = model.covariance_camera(views)
        model_ids = sorted(v.marker_id for v in views if v.seen)
        sd_model = np.sqrt(np.diag(cov)) * 1e3 if cov is not None else np.full(3, np.nan)
        if errors:
            sd_pipe = np.std(np.array(errors), axis=0) * 1e3
        else:
            sd_pipe = np.full(3, np.nan)
        label = f"({n:g}, {e:g}, {yaw:g})"
        pipe = "/".join(f"{v:.2f}" for v in sd_pipe)
        mod = "/".join(f"{v:.2f}" for v in sd_model)
        print(
            f"{label:<22} {len(errors):>3}/{args.frames} {pipe:>24} {mod:>22} "
            f"{str(sorted(ids)):>12} {str(model_ids):>12}"
        )
        if errors and cov is not None:
            fit_pipe.append(sd_pipe[2])
            fit_unit.append(sd_model[2] / args.corner_px)
    if fit_pipe:
        p, u = np.array(fit_pipe), np.array(fit_unit)
        print(
            "corner noise that fits the pipeline's range errors (least squares): "
            f"{float(p @ u / (u @ u)):.3f} px"
        )


if __name__ == "__main__":
    main()
