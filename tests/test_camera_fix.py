"""The fast camera model against geometry: field of view, range, size, obliquity, and its noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auvdock.camera.layout import Marker, MarkerLayout, default_layout
from auvdock.camera.model import CameraModel, CameraMount, camera_from_dock
from auvdock.sensing.camera_fix import CameraFixModel

ONE = MarkerLayout(dictionary="apriltag_36h11", markers=(Marker(0, 0.15, (0.35, 0.0, 0.0)),))


def _model(**kw) -> CameraFixModel:
    return CameraFixModel(CameraModel.ideal(), CameraMount(), kw.pop("layout", ONE), **kw)


def _eta(n: float, e: float = 0.0, yaw_deg: float = 0.0) -> np.ndarray:
    return np.array([n, e, 0.0, 0.0, 0.0, math.radians(yaw_deg)])


def test_a_marker_ahead_is_seen_with_its_range_and_pixel_size():
    m = _model()
    (v,) = m.views(_eta(-1.0), np.zeros(3), 0.0)
    assert v.seen and v.why == ""
    rng = 1.0 + 0.35 - 0.2  # the camera is 0.2 m ahead of the body origin, the marker 0.35 m past the dock
    assert v.range_m == pytest.approx(rng, abs=1e-12)
    assert v.side_px == pytest.approx(m.focal_px * 0.15 / rng, rel=1e-9)  # pinhole: f s / d
    assert v.view_angle_rad == pytest.approx(0.0, abs=1e-9)


def test_no_fix_outside_the_field_of_view_behind_beyond_the_water_or_too_small():
    m = _model()
    half_fov = math.degrees(math.atan(320 / m.focal_px))  # 40 deg for the ideal 80 deg camera
    assert half_fov == pytest.approx(40.0, abs=1e-9)
    # turned away by more than half the field of view (plus the marker's own half-width): out of view
    assert m.views(_eta(-1.0, 0.0, 45.0), np.zeros(3), 0.0)[0].why == "outside the field of view"
    assert m.views(_eta(-1.0, 0.0, 30.0), np.zeros(3), 0.0)[0].seen
    assert m.views(_eta(1.0, 0.0, 0.0), np.zeros(3), 0.0)[0].why == "behind the camera"
    murky = _model(visibility_m=2.0)
    assert murky.views(_eta(-1.7), np.zeros(3), 0.0)[0].seen  # 1.85 m away
    assert murky.views(_eta(-2.0), np.zeros(3), 0.0)[0].why == "beyond the visibility (2.1 m > 2 m)"
    # too small: f s / d < 16 px beyond d = f 0.15 / 16 = 3.57 m
    d_max = _model().focal_px * 0.15 / 16.0
    assert _model(visibility_m=20).views(_eta(-(d_max - 0.15 - 0.05)), np.zeros(3), 0.0)[0].seen
    far = _model(visibility_m=20).views(_eta(-(d_max - 0.15 + 0.05)), np.zeros(3), 0.0)[0]
    assert not far.seen and far.why.startswith("too small")
    rng = np.random.default_rng(0)
    x = np.zeros(12)
    x[0] = 1.0
    assert m.fix(x, np.zeros(3), 0.0, rng) is None


def test_an_oblique_marker_is_not_decoded():
    tilted = MarkerLayout(
        dictionary="apriltag_36h11", markers=(Marker(0, 0.15, (0.35, 0.0, 0.0), (0.0, 0.0, 75.0)),)
    )
    v = _model(layout=tilted).views(_eta(-1.0), np.zeros(3), 0.0)[0]
    assert v.view_angle_rad == pytest.approx(math.radians(75.0), abs=1e-9)
    assert v.why == "too oblique (75 deg)"


def test_the_noise_grows_with_range_and_obliquity_as_stated():
    m = _model(visibility_m=20)
    c1 = m.covariance_camera(m.views(_eta(-1.0), np.zeros(3), 0.0))
    c2 = m.covariance_camera(m.views(_eta(-2.15), np.zeros(3), 0.0))  # twice the range (1.15 -> 2.3 m)
    assert c1 is not None and c2 is not None
    assert math.sqrt(c2[0, 0] / c1[0, 0]) == pytest.approx(2.0, rel=1e-9)  # lateral: ~ d
    assert math.sqrt(c2[2, 2] / c1[2, 2]) == pytest.approx(4.0, rel=1e-9)  # range: ~ d^2
    f, d = m.focal_px, 1.15
    assert math.sqrt(c1[2, 2]) == pytest.approx(0.5 * d**2 / (math.sqrt(2) * f * 0.15), rel=1e-12)


def test_fix_noise_statistics_match_the_model_over_many_draws():
    m = _model(dropout=0.1)
    x = np.zeros(12)
    x[0], x[1], x[5] = -1.5, 0.2, math.radians(10.0)
    rng = np.random.default_rng(4)
    fixes = [m.fix(x, np.zeros(3), 0.0, rng) for _ in range(8000)]
    got = [f for f in fixes if f is not None]
    assert len(got) / len(fixes) == pytest.approx(0.9, abs=0.01)  # the dropouts
    err = np.array([f.position_ned_m - x[0:3] for f in got])
    cov = got[0].covariance_ned_m2
    assert np.all(np.abs(err.mean(axis=0)) < 4 * np.sqrt(np.diag(cov) / len(got)))  # unbiased
    # within 5 standard errors of a variance estimated from 8000 draws (sqrt(2 / 8000) = 1.6 %)
    np.testing.assert_allclose(np.cov(err.T), cov, rtol=0.08, atol=0.08 * np.max(np.diag(cov)))
    # what the camera measures: the dock in its frame, with the model's std per camera axis
    _, t_cd = camera_from_dock(x[0:6], np.zeros(3), 0.0, CameraMount())
    err_c = np.array([f.dock_camera_m - t_cd for f in got])
    np.testing.assert_allclose(err_c.std(axis=0), got[0].std_camera_m, rtol=0.05)


def test_more_markers_seen_give_a_better_fix():
    m = _model(layout=default_layout())
    views = m.views(_eta(-0.5), np.zeros(3), 0.0)
    assert {v.marker_id for v in views if v.seen} == {0, 1, 2, 3, 4}
    all_five = m.covariance_camera(views)
    only_big = m.covariance_camera([v for v in views if v.marker_id == 0])
    assert all_five is not None and only_big is not None
    assert np.all(np.diag(all_five) < np.diag(only_big))


def test_the_fast_model_sees_the_markers_the_rendering_pipeline_decodes():
    """On the same poses, the markers the fast model counts as seen are the ones the detector
    decodes in rendered views (image noise 2 grey levels, blur 0.5 px, as the synthetic camera)."""
    from auvdock.camera.model import camera_from_dock
    from auvdock.camera.pose import MarkerDetector
    from auvdock.camera.render import render_view

    camera, mount, layout = CameraModel.ideal(), CameraMount(), default_layout()
    model = CameraFixModel(camera, mount, layout)
    detector = MarkerDetector(layout, camera)
    rng = np.random.default_rng(1)
    poses = [(-0.6, 0.0, 0.0), (-1.5, 0.0, 0.0), (-3.0, 0.0, 0.0), (-6.0, 0.0, 0.0), (-1.0, 0.0, 55.0),
             (-1.0, 0.3, 20.0), (-2.0, 0.8, -15.0)]  # fmt: skip
    for n, e, yaw in poses:
        eta = _eta(n, e, yaw)
        expected = {v.marker_id for v in model.views(eta, np.zeros(3), 0.0) if v.seen}
        R_cd, t_cd = camera_from_dock(eta, np.zeros(3), 0.0, mount)
        for _ in range(3):
            image = render_view(camera, layout, R_cd, t_cd, noise_std=2.0, blur_px=0.5, rng=rng)
            assert {d.id for d in detector.detect(image)} == expected, (n, e, yaw)


def test_the_sensor_suite_gives_dock_fixes_only_while_the_camera_sees_the_dock():
    """sensors.dock_camera: fixes at the camera's rate while the markers are in view, none when the
    vehicle looks away, each the dock in the camera frame with the model's standard deviation."""
    from auvdock.config.mission import load_mission
    from auvdock.sensing.simulated import SensorSuite

    m = load_mission("tank_0p6hz").with_updates(
        estimation="filter", sensors__position__source="none", sensors__dock_camera__enabled=True
    )
    dock = m.build_dock()
    suite = SensorSuite(m.sensors, m.build_vehicle(), 0, camera_fix=m.build_camera_fix(), dock=dock)
    x = m.start_state()
    u = np.zeros(8)
    facing = [r for k in range(60) for r in suite.read(k * 0.05, x, u, np.zeros(3)) if r.kind == "dock"]
    assert not [r for k in range(60) for r in suite.read(k * 0.05, x, u, np.zeros(3)) if r.kind == "position"]
    assert 40 <= len(facing) <= 45  # 15 Hz for 3 s, 2 % dropouts; each 0.1 s late
    # 2 m in front of the dock, looking at it: the 0.15 m marker 2.15 m ahead (and 0.17 m up) alone
    d, f = 2.0 + 0.35 - 0.2, CameraModel.ideal().K[0, 0]
    for r in facing:  # across the view (image x, y) the lateral error, along it (z) the range one
        np.testing.assert_allclose(
            r.std, [0.5 * d / (2 * f), 0.5 * d / (2 * f), 0.5 * d**2 / (math.sqrt(2) * f * 0.15)], rtol=0.02
        )
        np.testing.assert_allclose(r.value, [0.0, -dock.position(r.t)[2] + 1.0, 1.8], atol=0.2)
    away = x.copy()
    away[5] = math.pi  # turned round
    later = [
        r for k in range(60, 120) for r in suite.read(k * 0.05, away, u, np.zeros(3)) if r.kind == "dock"
    ]
    assert all(r.t < 3.0 for r in later)  # only the fixes taken before it turned, delivered late
