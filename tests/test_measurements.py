"""Tests of the measurement functions (auvdock.sensing.measurements) against analytic facts."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from auvdock.sensing import measurements as ms
from auvdock.vehicle import load_vehicle
from auvdock.vehicle.state import ANG, ATT, LIN, NX, POS

G = ms.GRAVITY


@pytest.fixture(scope="module")
def vehicle():
    return load_vehicle("bluerov2_heavy")


def holding_thrust(vehicle, x, flow=np.zeros(3)):
    """Thrust (n,) that makes nu_dot = 0 at state x (least squares; exact: B has rank 6)."""
    acc = vehicle.model.function("accel")
    nu_dot0 = np.asarray(acc(x, np.zeros(vehicle.n_thrusters), flow, np.zeros(3))[0]).ravel()
    tau = -vehicle.model.M @ nu_dot0  # nu_dot = M^-1 (tau - n(x)) = 0
    u, *_ = np.linalg.lstsq(vehicle.allocation, tau, rcond=None)
    return u


def test_kinds_and_dimensions(vehicle):
    assert ms.KINDS == {"attitude": 3, "gyro": 3, "accel": 3, "depth": 1, "position": 3, "dvl": 3, "dock": 3}
    x = np.arange(1.0, 13.0) / 10
    for kind, n in ms.KINDS.items():
        if kind == "dock":  # needs the dock and the camera mount: its expression only
            with pytest.raises(ValueError, match="needs the dock's position and the camera mount"):
                ms.measure(kind, vehicle, x)
            continue
        assert ms.measure(kind, vehicle, x).shape == (n,)
        assert ms.h(kind, vehicle) is ms.h(kind, vehicle)  # cached
    with pytest.raises(KeyError, match="unknown measurement kind"):
        ms.measure("sonar", vehicle, x)


@pytest.mark.parametrize(
    "yaw_deg, dock, expected",
    [
        (0.0, (2.0, 0.0, 5.0), (0.0, 0.0, 1.8)),  # 2 m ahead: 1.8 m along the axis of a camera 0.2 m forward
        (90.0, (0.0, 2.0, 5.0), (0.0, 0.0, 1.8)),  # facing east, the dock 2 m east
        (0.0, (0.0, 1.0, 5.0), (1.0, 0.0, -0.2)),  # abeam to starboard: image right, behind the lens
        (0.0, (2.0, 0.0, 5.5), (0.0, 0.5, 1.8)),  # 0.5 m deeper: image down
    ],
)
def test_the_dock_in_the_camera_frame(vehicle, yaw_deg, dock, expected):
    """Kind ``dock``: the docking point in the frame of the default camera (0.2 m ahead of the
    body origin, optical axis along body x, image x to starboard, y down)."""
    from auvdock.camera.model import CameraMount

    mount = CameraMount()
    x_sym, d_sym = ca.SX.sym("x", NX), ca.SX.sym("d", 3)
    y = ms.expression(
        "dock", vehicle.model, x_sym, ca.SX.zeros(8), ca.SX.zeros(3), (d_sym, mount.R_bc(), mount.t_bc())
    )
    f = ca.Function("h_dock", [x_sym, d_sym], [y])
    x = np.zeros(NX)
    x[2], x[5] = 5.0, math.radians(yaw_deg)
    np.testing.assert_allclose(np.asarray(f(x, np.array(dock))).ravel(), expected, atol=1e-12)


def test_slices_of_the_state(vehicle):
    x = np.random.default_rng(1).normal(size=NX)
    u = np.full(vehicle.n_thrusters, 3.0)
    np.testing.assert_array_equal(ms.measure("attitude", vehicle, x, u), x[ATT])
    np.testing.assert_array_equal(ms.measure("gyro", vehicle, x, u), x[ANG])
    np.testing.assert_array_equal(ms.measure("position", vehicle, x, u), x[POS])
    np.testing.assert_array_equal(ms.measure("dvl", vehicle, x, u), x[LIN])
    np.testing.assert_array_equal(ms.measure("depth", vehicle, x, u), x[POS][2:3])


def test_specific_force_at_rest_level(vehicle):
    x = np.zeros(NX)
    x[2] = 5.0
    u = holding_thrust(vehicle, x)
    np.testing.assert_allclose(ms.measure("accel", vehicle, x, u), [0.0, 0.0, -G], atol=1e-9)


def test_specific_force_rolled_90_deg(vehicle):
    """Rolled right by 90 deg, the body y axis points down: the reaction to gravity is f_y = -g."""
    x = np.zeros(NX)
    x[3] = math.pi / 2
    u = holding_thrust(vehicle, x)
    np.testing.assert_allclose(ms.measure("accel", vehicle, x, u), [0.0, -G, 0.0], atol=1e-9)


def test_specific_force_pitched_up(vehicle):
    """Nose up by theta: f = (g sin(theta), 0, -g cos(theta))."""
    th = 0.3
    x = np.zeros(NX)
    x[4] = th
    u = holding_thrust(vehicle, x)
    f = ms.measure("accel", vehicle, x, u)
    np.testing.assert_allclose(f, [G * math.sin(th), 0.0, -G * math.cos(th)], atol=1e-9)


def test_specific_force_in_a_steady_turn(vehicle):
    """Level steady turn (surge U, yaw rate r, thrust holding nu constant): f = (0, U r, -g)."""
    U, r = 0.5, 0.2
    x = np.zeros(NX)
    x[LIN] = [U, 0.0, 0.0]
    x[ANG] = [0.0, 0.0, r]
    x[5] = 1.0  # any heading
    u = holding_thrust(vehicle, x)
    f = ms.measure("accel", vehicle, x, u)
    np.testing.assert_allclose(f, [0.0, U * r, -G], atol=1e-9)


def test_specific_force_under_thrust_and_current(vehicle):
    """nu1_dot comes from the one model: with thrust and a current the model's acceleration appears."""
    rng = np.random.default_rng(3)
    x = rng.normal(scale=0.3, size=NX)
    u = rng.normal(scale=5.0, size=vehicle.n_thrusters)
    vc = np.array([0.3, -0.2, 0.0])
    nu_dot = np.asarray(vehicle.model.function("accel")(x, u, vc, np.zeros(3))[0]).ravel()
    R = vehicle.model.function("rotation")(x[ATT]).full()
    expected = nu_dot[0:3] + np.cross(x[ANG], x[LIN]) - R.T @ [0.0, 0.0, G]
    np.testing.assert_allclose(ms.measure("accel", vehicle, x, u, vc), expected, atol=1e-12)
    # the current matters (through the damping of the relative velocity)
    assert np.linalg.norm(ms.measure("accel", vehicle, x, u, vc) - ms.measure("accel", vehicle, x, u)) > 1e-3


def test_casadi_and_numpy_agree(vehicle):
    """The symbolic expression (SX and MX) gives what measure() gives, and its Jacobian is right."""
    rng = np.random.default_rng(7)
    x0 = rng.normal(scale=0.3, size=NX)
    u0 = rng.normal(scale=5.0, size=vehicle.n_thrusters)
    vc0 = np.array([0.3, -0.2, 0.0])
    for sym in (ca.SX, ca.MX):
        x = sym.sym("x", NX)
        u = sym.sym("u", vehicle.n_thrusters)
        vc = sym.sym("vc", 3)
        for kind in ms.KINDS:
            if kind == "dock":  # test_the_dock_in_the_camera_frame
                continue
            y = ms.expression(kind, vehicle.model, x, u, vc)
            f = ca.Function("f", [x, u, vc], [y, ca.jacobian(y, x)])
            y0, J = (np.asarray(v) for v in f(x0, u0, vc0))
            np.testing.assert_allclose(y0.ravel(), ms.measure(kind, vehicle, x0, u0, vc0), atol=1e-12)
            # finite-difference check of the Jacobian
            eps = 1e-6
            for i in range(NX):
                dx = np.zeros(NX)
                dx[i] = eps
                fd = (
                    ms.measure(kind, vehicle, x0 + dx, u0, vc0) - ms.measure(kind, vehicle, x0 - dx, u0, vc0)
                ) / (2 * eps)
                np.testing.assert_allclose(J[:, i], fd, atol=1e-6)
