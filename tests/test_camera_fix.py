"""The fast camera model against geometry and the water: field of view, contrast, size, obliquity,
and its noise (the laws of :mod:`auvdock.sensing.camera_fix`, measured on rendered views by
benchmarks/camera_fix_errors.py, 2026-12-02)."""

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


def test_no_fix_outside_the_field_of_view_behind_too_faint_in_the_water_or_too_small():
    """The water's visibility is no hard range any more: a marker is decoded while its contrast
    255 exp(-4.8 d / V) and its size satisfy 19.5 / C + (12.5 px / side)^3 <= 1 (the benchmark's fit;
    before, it was seen out to d = V and down to 16 px whatever the contrast)."""
    m = _model()
    half_fov = math.degrees(math.atan(320 / m.focal_px))  # 40 deg for the ideal 80 deg camera
    assert half_fov == pytest.approx(40.0, abs=1e-9)
    # turned away by more than half the field of view (plus the marker's own half-width): out of view
    assert m.views(_eta(-1.0, 0.0, 45.0), np.zeros(3), 0.0)[0].why == "outside the field of view"
    assert m.views(_eta(-1.0, 0.0, 30.0), np.zeros(3), 0.0)[0].seen
    assert m.views(_eta(1.0, 0.0, 0.0), np.zeros(3), 0.0)[0].why == "behind the camera"
    # 2 m visibility: c = 2.4 /m, the contrast falls to 19.5 grey levels at d = ln(255 / 19.5) / 2.4
    murky = _model(visibility_m=2.0)
    assert murky.max_range_m == pytest.approx(math.log(255 / 19.5) / 2.4, rel=1e-12)  # 1.07 m
    near = murky.views(_eta(-(1.0 - 0.15)), np.zeros(3), 0.0)[0]  # 1.0 m away, 57 px wide
    assert near.seen and near.contrast_grey == pytest.approx(255 * math.exp(-2.4), rel=1e-9)
    far = murky.views(_eta(-(1.1 - 0.15)), np.zeros(3), 0.0)[0]
    assert far.why == "too faint (contrast 18.2 < 19.5 grey levels: 1.1 m in 2 m visibility)"
    # no water: too small below 12.5 px; between 12.5 px and the side where 19.5 / 255 uses up the rest
    # of the rule, too small for its (full) contrast
    clear = _model(visibility_m=math.inf)
    s_min = 12.5 / (1 - 19.5 / 255) ** (1 / 3)  # 12.84 px
    d_min = clear.focal_px * 0.15 / s_min
    assert clear.views(_eta(-(d_min - 0.15 - 0.05)), np.zeros(3), 0.0)[0].seen
    edge = clear.views(_eta(-(d_min - 0.15 + 0.05)), np.zeros(3), 0.0)[0]
    assert not edge.seen and edge.why.startswith("too small for its contrast")
    tiny = clear.views(_eta(-(clear.focal_px * 0.15 / 12.0 - 0.15)), np.zeros(3), 0.0)[0]
    assert tiny.why == "too small (12.0 px)"
    rng = np.random.default_rng(0)
    x = np.zeros(12)
    x[0] = 1.0
    assert m.fix(x, np.zeros(3), 0.0, rng) is None


def test_an_oblique_marker_is_not_decoded():
    """Beyond 78 deg (half the 60 px markers decoded at 78.2 deg in the benchmark; 70 deg assumed
    before the measurement)."""
    tilted = MarkerLayout(
        dictionary="apriltag_36h11", markers=(Marker(0, 0.15, (0.35, 0.0, 0.0), (0.0, 0.0, 80.0)),)
    )
    v = _model(layout=tilted).views(_eta(-1.0), np.zeros(3), 0.0)[0]
    assert v.view_angle_rad == pytest.approx(math.radians(80.0), abs=1e-9)
    assert v.why == "too oblique (80 deg)"
    # the apparent side is the square root of the image area: foreshortened by sqrt(cos(obliquity))
    less = MarkerLayout(
        dictionary="apriltag_36h11", markers=(Marker(0, 0.15, (0.35, 0.0, 0.0), (0.0, 0.0, 60.0)),)
    )
    w = _model(layout=less).views(_eta(-1.0), np.zeros(3), 0.0)[0]
    assert w.seen
    assert w.side_px == pytest.approx(_model().focal_px * 0.15 / 1.15 * math.sqrt(0.5), rel=0.02)


def test_the_corner_error_follows_the_measured_laws():
    """Edge-refined corners: the image noise over the contrast, corner_px C0 / C (0.0071 px at full
    contrast), plus the bias of small markers; near the decoding limit, or very oblique, the detector's
    own corners (0.92 px)."""
    m = _model()
    assert m.corner_error_px(255.0, 200.0, 0.0) == pytest.approx(0.0071, rel=1e-3)
    assert m.corner_error_px(51.0, 200.0, 0.0) == pytest.approx(0.0071 * 5, rel=1e-3)
    small = m.corner_error_px(255.0, 16.0, 0.0)
    assert small == pytest.approx(math.hypot(0.0071, 0.13), rel=0.01)
    assert m.corner_error_px(20.0, 20.0, 0.0) == pytest.approx(0.92, rel=0.01)  # refinement gave up
    assert m.corner_error_px(255.0, 60.0, math.radians(75.0)) == pytest.approx(0.92, rel=0.01)
    assert m.corner_error_px(255.0, 60.0, math.radians(63.0)) == pytest.approx(
        math.sqrt(0.5) * 0.92, rel=0.01
    )
    # the bias is mostly a scale error: a displacement common to the four corners along their radii
    ind, radial = m.corner_error_parts(20.0, 20.0, 0.0)
    assert math.hypot(ind, radial / math.sqrt(2)) == pytest.approx(m.corner_error_px(20.0, 20.0, 0.0))
    assert radial**2 / 2 / (ind**2 + radial**2 / 2) == pytest.approx(0.58, abs=0.01)
    assert m.corner_error_parts(255.0, 200.0, 0.0)[1] < 1e-4  # noise only (0.0071 px): independent


def test_the_fix_covariance_is_the_pipelines_first_order_covariance_at_the_corner_noise():
    """With independent corner noise (a large, high-contrast marker: no small-marker bias), the fix's
    covariance is the position block of sigma^2 (J^T J)^-1, as the pipeline computes its own
    (auvdock.camera.pose._covariance), and on the axis its range std is sigma d^2 / (sqrt(2) f s) --
    the formula the model used before; across the view the docking point, 0.35 m behind the marker,
    moves with the marker's poorly measured tilt, so its error grows as d^2 too."""
    import cv2

    from auvdock.camera.pose import _covariance

    m = _model(visibility_m=math.inf, small_px=0.0)
    for n, e, yaw in ((-1.0, 0.0, 0.0), (-1.5, 0.2, 10.0), (-0.8, -0.1, -20.0)):
        eta = _eta(n, e, yaw)
        views = m.views(eta, np.zeros(3), 0.0)
        cov = m.covariance_camera(views)
        sigma = views[0].corner_px
        assert sigma == pytest.approx(0.0071, rel=1e-3)
        R_cd, t_cd = camera_from_dock(eta, np.zeros(3), 0.0, CameraMount())
        rvec, _ = cv2.Rodrigues(R_cd)
        expected = _covariance(ONE.markers[0].corners_dock(), rvec.ravel(), t_cd, CameraModel.ideal(), sigma)
        # equal but for the unrefined corners' tail (probability < 1e-9 here), which is a scale error
        np.testing.assert_allclose(cov, expected[:3, :3], rtol=1e-4, atol=1e-6 * np.max(np.diag(cov)))
    c1 = m.covariance_camera(m.views(_eta(-1.0), np.zeros(3), 0.0))
    c2 = m.covariance_camera(m.views(_eta(-2.15), np.zeros(3), 0.0))  # twice the range (1.15 -> 2.3 m)
    assert c1 is not None and c2 is not None
    f, d = m.focal_px, 1.15
    assert math.sqrt(c1[2, 2]) == pytest.approx(0.0071 * d**2 / (math.sqrt(2) * f * 0.15), rel=1e-4)
    np.testing.assert_allclose(np.sqrt(np.diag(c2) / np.diag(c1)), 4.0, rtol=0.01)  # ~ d^2
    # in water the same marker's noise grows as 1 / contrast = exp(c d)
    wet = _model(visibility_m=8.0, small_px=0.0)
    c_wet = wet.covariance_camera(wet.views(_eta(-1.0), np.zeros(3), 0.0))
    assert c_wet is not None
    np.testing.assert_allclose(np.sqrt(np.diag(c_wet) / np.diag(c1)), math.exp(0.6 * d), rtol=1e-3)


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


def test_the_fix_uses_the_markers_the_pipeline_uses_and_more_are_better():
    """As the pipeline (estimate_dock_pose), markers narrower than 32 px are left out when a wider one
    is seen (before, the model fused every seen marker); among the ones used, more give a better fix."""
    m = _model(layout=default_layout())
    views = m.views(_eta(-0.5), np.zeros(3), 0.0)
    assert {v.marker_id for v in views if v.seen} == {0, 1, 2, 3, 4}
    assert [v.marker_id for v in m.fused(views)] == [0]  # the small ones are 23.5 px
    np.testing.assert_array_equal(
        m.covariance_camera(views), m.covariance_camera([v for v in views if v.marker_id == 0])
    )
    x = np.zeros(12)
    x[0] = -0.5
    fix = m.fix(x, np.zeros(3), 0.0, np.random.default_rng(0))
    assert fix is not None and fix.marker_ids == (0,)
    close = m.views(_eta(-0.2), np.zeros(3), 0.0)  # the big marker out of view, the small ones 44 px
    assert [v.marker_id for v in m.fused(close)] == [1, 2, 3, 4]
    all_four = m.covariance_camera(close)
    only_one = m.covariance_camera([v for v in close if v.marker_id == 1])
    assert all_four is not None and only_one is not None
    assert np.all(np.diag(all_four) < np.diag(only_one))


def test_the_fast_model_sees_the_markers_the_rendering_pipeline_decodes():
    """On the same poses, the markers the fast model counts as seen are the ones the detector
    decodes in rendered views (image noise 2 grey levels, blur 0.5 px, as the synthetic camera) in
    the model's water (8 m visibility; before, the views were rendered without water); the poses are
    away from the decoding boundary (3.0 m ahead is now 2.5 m: the big marker, 18 px and 35 grey levels
    there, is decoded only 3 times in 4)."""
    from auvdock.camera.pose import MarkerDetector
    from auvdock.camera.render import Water, render_view

    camera, mount, layout = CameraModel.ideal(), CameraMount(), default_layout()
    model = CameraFixModel(camera, mount, layout)
    detector = MarkerDetector(layout, camera)
    rng = np.random.default_rng(1)
    poses = [(-0.6, 0.0, 0.0), (-1.5, 0.0, 0.0), (-2.5, 0.0, 0.0), (-6.0, 0.0, 0.0), (-1.0, 0.0, 55.0),
             (-1.0, 0.3, 20.0), (-2.0, 0.8, -15.0)]  # fmt: skip
    for n, e, yaw in poses:
        eta = _eta(n, e, yaw)
        expected = {v.marker_id for v in model.views(eta, np.zeros(3), 0.0) if v.seen}
        R_cd, t_cd = camera_from_dock(eta, np.zeros(3), 0.0, mount)
        for _ in range(3):
            image = render_view(
                camera, layout, R_cd, t_cd, noise_std=2.0, blur_px=0.5, rng=rng, water=Water(8.0)
            )
            assert {d.id for d in detector.detect(image)} == expected, (n, e, yaw)


def test_the_sensor_suite_gives_dock_fixes_only_while_the_camera_sees_the_dock():
    """sensors.dock_camera: fixes at the camera's rate while the markers are in view, none when the
    vehicle looks away, each the dock in the camera frame with the model's standard deviation (the
    model's own covariance at the pose: no closed form any more, the corner noise being the measured
    one and the fix the docking point 0.35 m behind the markers)."""
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
    camera_fix = m.build_camera_fix()
    for r in facing:  # across the view (image x, y) the lateral error, along it (z) the range one
        views = camera_fix.views(x[0:6], dock.position(r.t), dock.heading_rad)
        assert [v.marker_id for v in views if v.seen] == [0]
        cov = camera_fix.covariance_camera(views)
        assert cov is not None
        np.testing.assert_allclose(r.std, np.sqrt(np.diag(cov)), rtol=1e-9)
        np.testing.assert_allclose(r.value, [0.0, -dock.position(r.t)[2] + 1.0, 1.8], atol=0.2)
    away = x.copy()
    away[5] = math.pi  # turned round
    later = [
        r for k in range(60, 120) for r in suite.read(k * 0.05, away, u, np.zeros(3)) if r.kind == "dock"
    ]
    assert all(r.t < 3.0 for r in later)  # only the fixes taken before it turned, delivered late
