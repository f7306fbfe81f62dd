"""Tests of the heaving dock (auvdock.world.dock): paper eq. (7), z(t) = z0 + A sin(w t + phase)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auvdock.world.dock import HeaveDock

# docs/parameter-sources.md section 3: dock at (2, 3) m around z = 5 m, A = 0.5 m, w = 0.1 rad/s
PAPER = HeaveDock(
    position_ned_m=(2.0, 3.0, 5.0), heading_rad=0.0, amplitude_m=0.5, angular_frequency_rad_s=0.1
)
PHASED = HeaveDock(
    position_ned_m=(-1.0, 4.0, 2.0),
    heading_rad=0.4,
    amplitude_m=0.0762,
    angular_frequency_rad_s=2 * math.pi * 0.8,
    phase_rad=0.9,
)


def test_position_hand_values():
    np.testing.assert_allclose(PAPER.position(0.0), [2.0, 3.0, 5.0], atol=1e-15)
    # w t = pi/2: crest (deepest, z down), w t = 3 pi / 2: trough
    np.testing.assert_allclose(PAPER.position(5 * math.pi), [2.0, 3.0, 5.5], atol=1e-14)
    np.testing.assert_allclose(PAPER.position(15 * math.pi), [2.0, 3.0, 4.5], atol=1e-14)
    np.testing.assert_allclose(PAPER.position(10 * math.pi), [2.0, 3.0, 5.0], atol=1e-14)
    t = 1.3
    np.testing.assert_allclose(
        PHASED.position(t), [-1.0, 4.0, 2.0 + 0.0762 * math.sin(2 * math.pi * 0.8 * t + 0.9)], atol=1e-15
    )


def test_velocity_hand_values():
    np.testing.assert_allclose(PAPER.velocity(0.0), [0.0, 0.0, 0.05], atol=1e-15)  # w A
    np.testing.assert_allclose(PAPER.velocity(5 * math.pi), [0.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(PAPER.velocity(10 * math.pi), [0.0, 0.0, -0.05], atol=1e-15)
    assert PHASED.frequency_hz == pytest.approx(0.8, rel=1e-15)
    assert PAPER.frequency_hz == pytest.approx(0.1 / (2 * math.pi), rel=1e-15)


@pytest.mark.parametrize("dock", [PAPER, PHASED])
def test_velocity_is_derivative_of_position(dock):
    t = np.linspace(0.0, 40.0, 57)
    h = 1e-5
    fd = (dock.position(t + h) - dock.position(t - h)) / (2 * h)
    v = dock.velocity(t)
    w, A = dock.angular_frequency_rad_s, dock.amplitude_m
    np.testing.assert_allclose(v, fd, atol=1e-9 * max(1.0, w**3 * A))
    np.testing.assert_array_equal(v[:, :2], 0.0)
    assert np.abs(v[:, 2]).max() <= w * A * (1 + 1e-12)


def test_still_dock():
    d = HeaveDock(position_ned_m=(1.0, 2.0, 3.0))
    t = np.linspace(0, 10, 11)
    np.testing.assert_array_equal(d.position(t), np.tile([1.0, 2.0, 3.0], (11, 1)))
    np.testing.assert_array_equal(d.velocity(t), 0.0)


def test_shapes():
    assert PAPER.position(0.0).shape == (3,)
    assert PAPER.velocity(0.0).shape == (3,)
    assert PAPER.position(np.zeros((2, 5))).shape == (2, 5, 3)
    assert PAPER.velocity(np.zeros((2, 5))).shape == (2, 5, 3)
    assert PAPER.reference_state(0.0).shape == (12,)
    assert PAPER.reference_state(np.zeros((4,))).shape == (4, 12)


@pytest.mark.parametrize("n_steps", [0, 1, 10])
def test_trajectory(n_steps):
    t0, dt = 2.0, 0.05
    t, p, v = PHASED.trajectory(t0, dt, n_steps)
    assert t.shape == (n_steps + 1,)
    assert p.shape == (n_steps + 1, 3)
    assert v.shape == (n_steps + 1, 3)
    np.testing.assert_allclose(t, t0 + dt * np.arange(n_steps + 1), atol=1e-15)
    for k in range(n_steps + 1):
        np.testing.assert_allclose(p[k], PHASED.position(t0 + k * dt), atol=1e-15)
        np.testing.assert_allclose(v[k], PHASED.velocity(t0 + k * dt), atol=1e-15)


def test_reference_state_layout():
    t = np.array([0.0, 1.0, 7.5])
    x = PHASED.reference_state(t)
    p, v = PHASED.position(t), PHASED.velocity(t)
    np.testing.assert_array_equal(x[:, 0:3], p)
    np.testing.assert_array_equal(x[:, 3:5], 0.0)  # level
    np.testing.assert_array_equal(x[:, 5], 0.4)  # fixed heading
    np.testing.assert_array_equal(x[:, 6:9], v)
    np.testing.assert_array_equal(x[:, 9:12], 0.0)  # no rotation
    # pure heave: the NED velocity is also the body velocity of the level dock at any heading
    c, s = math.cos(0.4), math.sin(0.4)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    np.testing.assert_allclose(x[:, 6:9] @ Rz, v, atol=1e-15)  # rows: R^T v
    xs = PAPER.reference_state(5 * math.pi)
    np.testing.assert_allclose(xs, [2, 3, 5.5, 0, 0, 0, 0, 0, 0, 0, 0, 0], atol=1e-14)
