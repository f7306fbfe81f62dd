"""The lost-camera hold (auvdock.controllers.hold) against analytic facts and the truth model."""

from __future__ import annotations

import numpy as np
import pytest
from helpers.loopback import TANK

from auvdock.config.mission import load_mission
from auvdock.controllers.hold import DepthAttitudeHold
from auvdock.vehicle.ardusub import channels_for_wrench, thrust_from_channels


@pytest.fixture(scope="module")
def vehicle():
    return load_mission(TANK).build_vehicle()


def test_at_the_target_and_at_rest_it_cancels_buoyancy_only(vehicle) -> None:
    """Level, at rest, on target: the wrench is g(eta) = [0, 0, -(W - B), 0, 0, 0] (Fossen eq. 4.6)."""
    p = vehicle.params
    hold = DepthAttitudeHold(vehicle)
    x = np.zeros(12)
    x[2] = 1.0
    hold.start(x)
    w = hold.wrench(x)
    assert w == pytest.approx([0.0, 0.0, p.buoyancy_N - p.weight_N, 0.0, 0.0, 0.0], abs=1e-9)
    assert w[2] > 0  # the buoyant vehicle is pushed down


def test_pd_terms_point_back_to_the_target(vehicle) -> None:
    hold = DepthAttitudeHold(vehicle, bandwidth_rad_s=1.0)
    x0 = np.zeros(12)
    x0[2] = 1.0
    hold.start(x0)
    g = hold.wrench(x0)
    above = x0.copy()
    above[2] = 0.9  # 0.1 m too shallow: push down by M_33 w^2 0.1
    assert hold.wrench(above)[2] - g[2] == pytest.approx(vehicle.model.M[2, 2] * 0.1, rel=1e-9)
    yawed = x0.copy()
    yawed[5] = 0.2  # heading 0.2 rad right of the target: yaw moment to the left
    assert hold.wrench(yawed)[5] < 0
    drifting = x0.copy()
    drifting[6] = 0.3  # moving forward: braked
    assert hold.wrench(drifting)[0] < 0


def test_it_holds_depth_and_attitude_on_the_truth_model(vehicle) -> None:
    """Closed loop through ArduSub's channel map on the truth model: 10 s from rest at 1 m."""
    hold = DepthAttitudeHold(vehicle)
    B = vehicle.allocation
    dt = 0.05
    step = vehicle.stepper(dt, 4)
    x = np.zeros(12)
    x[2] = 1.0
    x[3] = 0.1  # rolled 6 deg at the start
    hold.start(x)
    for k in range(200):
        u = thrust_from_channels(channels_for_wrench(hold.wrench(x), B))
        x = np.asarray(step(x, u, k * dt)).ravel()
    assert abs(x[2] - 1.0) < 0.02
    assert np.max(np.abs(x[3:6])) < np.radians(2.0)
    assert np.linalg.norm(x[6:12]) < 0.02
