"""A vehicle's docking verdict with a margin (:mod:`auvdock.loop.verdict`), against the chi-square facts."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from auvdock.estimation.estimate import Estimate
from auvdock.loop.verdict import BOUND_95_3D, MarginVerdict, bound_95
from auvdock.world.dock import ClockedDock, HeaveDock

DOCK = HeaveDock((2.0, 0.0, 1.0), 0.0, 0.0635, 2 * np.pi * 0.6)


def _estimate(t: float, rel: np.ndarray, cov: np.ndarray | None, fix: bool = True) -> Estimate:
    x = np.zeros(12)
    x[0:3] = DOCK.position(t) + rel
    state_cov = None if cov is None else np.eye(12) * 1e-6
    if cov is not None:
        state_cov[0:3, 0:3] = cov
    return Estimate(t, x, state_cov, relative_cov=cov, dock_fix_t=t if fix else None)


def test_the_95_bound_is_the_chi_square_quantile() -> None:
    assert BOUND_95_3D == pytest.approx(np.sqrt(chi2.ppf(0.95, 3)), rel=1e-12)
    cov = np.diag([0.01, 0.02, 0.005]) ** 2
    assert bound_95(0.03, cov) == pytest.approx(0.03 + BOUND_95_3D * 0.02)


@pytest.mark.parametrize("seed", range(5))
def test_the_bound_covers_the_true_distance_at_least_95_percent(seed: int) -> None:
    """Sampled relative positions about an estimate (a random covariance): the true distance is within
    the bound in at least 95 % of them (the bound contains the whole 95 % ellipsoid)."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3)) * 0.01
    cov = A @ A.T + np.eye(3) * 1e-6
    mean = rng.normal(size=3) * 0.02
    bound = bound_95(float(np.linalg.norm(mean)), cov)
    samples = rng.multivariate_normal(mean, cov, size=20000)
    covered = np.mean(np.linalg.norm(samples, axis=1) <= bound)
    assert covered >= 0.95


def test_the_verdict_refuses_a_docked_claim_when_the_uncertainty_is_too_large() -> None:
    """Right on the dock, but 2 cm std per axis: the bound 0.056 m is beyond the 5 cm tolerance.
    With 5 mm: docked."""
    v = MarginVerdict(0.05, DOCK, position_std_m=0.01)
    unsure = v.judge(_estimate(3.0, np.zeros(3), np.eye(3) * 0.02**2))
    assert unsure is not None and not unsure.docked
    assert unsure.bound_m == pytest.approx(BOUND_95_3D * 0.02)
    assert "95 % bound 0.056 m > 0.05 m" in unsure.describe()
    sure = v.judge(_estimate(3.1, np.array([0.01, 0.0, 0.0]), np.eye(3) * 0.005**2))
    assert sure is not None and sure.docked and sure.basis == "navigation filter's estimate"
    assert v.closest is sure


def test_what_is_judged_without_a_dock_fix_or_a_covariance() -> None:
    v = MarginVerdict(0.05, DOCK, position_std_m=0.01)
    # the filter before any fix of the dock: the dock as charted, the position's own covariance
    est = _estimate(1.0, np.array([0.0, 0.02, 0.0]), np.eye(3) * 0.003**2, fix=False)
    est.relative_cov = np.eye(3) * 0.5**2  # the dock's prior: not what the charted dock is judged on
    j = v.judge(est)
    assert j is not None and j.basis == "navigation filter's position" and j.docked
    # estimation: truth: the telemetry with the position source's stated noise
    j = v.judge(_estimate(1.0, np.array([0.0, 0.025, 0.0]), None))
    assert j is not None and j.basis == "position telemetry"
    assert j.bound_m == pytest.approx(0.025 + BOUND_95_3D * 0.01) and not j.docked
    assert v.judge(None) is None


def test_a_clocked_dock_is_the_dock_on_the_other_clock() -> None:
    d = ClockedDock(DOCK, offset_s=1.94)
    t = np.array([0.0, 0.3, 7.0])
    assert np.allclose(d.position(t), DOCK.position(t + 1.94))
    assert np.allclose(d.velocity(2.0), DOCK.velocity(3.94))
    _, p, v = d.trajectory(0.5, 0.05, 4)
    assert np.allclose(p, DOCK.position(2.44 + 0.05 * np.arange(5)))
    assert d.position_ned_m == DOCK.position_ned_m and d.heading_rad == DOCK.heading_rad


def test_the_frame_s_own_error_widens_the_bound_where_the_frame_places_the_vehicle() -> None:
    """fly's mission frame is the mean of n positions and m headings: at a dock 2 m ahead its heading
    error (2 deg / sqrt(m)) moves the vehicle sideways by 2 m times that; the origin's error is the
    position noise / sqrt(n).  The verdict adds it, except on a position relative to a camera-fixed dock."""
    from pymavlink.dialects.v20 import ardupilotmega as mav2

    from auvdock.config.mission import load_mission
    from auvdock.fly.telemetry import TelemetrySensors

    m = load_mission("missions/tank_positioned.yaml")
    tel = TelemetrySensors(m.sensors, "truth")
    msgs = []
    for i in range(50):
        stamp = i * 40_000
        msgs.append((stamp, mav2.MAVLink_attitude_message(i * 40, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))
        msgs.append((stamp, mav2.MAVLink_local_position_ned_message(i * 40, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)))
    tel.feed(msgs)
    tel.set_frame(m.start_state(), window_s=2.0)
    n_pos, n_att = tel.frame_readings
    assert (n_pos, n_att) == (50, 50)
    cov = tel.frame_cov(np.array([2.0, 0.0, 1.0]))
    yaw_std = m.sensors.ahrs.yaw_std_rad
    pos_std = m.sensors.position.figures()[2]
    assert cov[1, 1] == pytest.approx(pos_std**2 / 50 + (2.0 * yaw_std) ** 2 / 50)
    assert cov[0, 0] == pytest.approx(pos_std**2 / 50) and cov[0, 1] == pytest.approx(0.0)
    v = MarginVerdict(0.05, DOCK, 0.01, frame_cov=tel.frame_cov)
    plain = MarginVerdict(0.05, DOCK, 0.01)
    est = _estimate(1.0, np.array([0.01, 0.0, 0.0]), None)
    assert v.judge(est).bound_m > plain.judge(est).bound_m
    fixed = _estimate(1.0, np.array([0.01, 0.0, 0.0]), np.eye(3) * 0.004**2)
    assert v.judge(fixed).bound_m == pytest.approx(plain.judge(fixed).bound_m)


def test_a_slowly_varying_position_error_is_not_averaged_away() -> None:
    """The mean of five readings divides the white noise's variance by five, not a wandering error's:
    1 cm white and 1.5 cm of wander (ArduSub SITL's EKF on its GPS) bound the mean at
    2.7955 sqrt(0.01^2 / 5 + 0.015^2) beyond its distance, where white alone gives 2.7955 * 0.01 / sqrt 5."""
    white = MarginVerdict(0.05, DOCK, position_std_m=0.01)
    wander = MarginVerdict(0.05, DOCK, position_std_m=0.01, position_bias_std_m=0.015)
    for i in range(5):  # five distinct readings at rest on the dock's motion, 0.04 s apart
        t = 1.0 + 0.04 * i
        est = _estimate(t, np.array([0.0, 0.01 + 0.001 * i, 0.0]), None)
        est.state[6:9] = 0.0
        a, b = white.judge(est), wander.judge(est)
    assert a is not None and b is not None and a.basis == "position telemetry, the mean of 5"
    assert b.bound_m - b.distance_m == pytest.approx(BOUND_95_3D * np.sqrt(0.01**2 / 5 + 0.015**2))
    assert a.bound_m - a.distance_m == pytest.approx(BOUND_95_3D * 0.01 / np.sqrt(5))
    assert a.docked and not b.docked
