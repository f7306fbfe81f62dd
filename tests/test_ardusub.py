"""ArduSub's manual thrust path (auvdock.vehicle.ardusub): mixer facts, force -> channel round trip."""

from __future__ import annotations

import numpy as np
import pytest

from auvdock.vehicle import load_vehicle
from auvdock.vehicle.ardusub import (
    CHANNELS,
    MOTOR_FACTORS,
    NEUTRAL_CHANNELS,
    channels_for_thrust,
    channels_for_wrench,
    mix,
    motor_pwm,
    t200_pwm_to_force,
    thrust_from_channels,
)
from auvdock.vehicle.thrusters import t200_force_to_pwm


@pytest.fixture(scope="module")
def B():
    return load_vehicle().allocation


def test_channel_order_and_factor_signs(B) -> None:
    assert CHANNELS == ("pitch", "roll", "throttle", "yaw", "forward", "lateral")
    # horizontal thrusters: forward, lateral and yaw factors have the signs of -B (docs/parameter-sources.md)
    for col, row in ((4, 0), (5, 1), (3, 5)):
        for i in range(4):
            assert MOTOR_FACTORS[i, col] == np.sign(-B[row, i])
    # throttle up (positive) drives the vertical motors negative: up is -Z in {b}
    assert np.all(MOTOR_FACTORS[4:, 2] == -1)


def test_neutral_is_zero_thrust() -> None:
    assert np.all(mix(np.zeros(6)) == 0)
    assert np.all(motor_pwm(np.zeros(8)) == 1500)
    assert np.all(thrust_from_channels(NEUTRAL_CHANNELS) == 0)


def test_mixer_normalises_only_when_saturated() -> None:
    c = np.zeros(6)
    c[3:] = [0.3, 0.3, 0.3]  # yaw + forward + lateral = 0.9: no normalisation
    assert np.max(np.abs(mix(c))) == pytest.approx(0.9)
    c[3:] = [1.0, 1.0, 1.0]  # 3: divided by 3
    assert np.max(np.abs(mix(c))) == pytest.approx(1.0)


def test_t200_inverse_round_trips() -> None:
    f = np.linspace(-39.0, 51.0, 181)
    f = f[np.abs(f) > 0.05]
    assert np.allclose(t200_pwm_to_force(t200_force_to_pwm(f)), f, atol=0.01)
    assert t200_pwm_to_force(1500.0) == 0.0
    assert t200_pwm_to_force(1510.0) == 0.0  # dead band


def test_forward_channel_pushes_forward(B) -> None:
    ch = NEUTRAL_CHANNELS.copy()
    ch[4] = 1700
    w = B @ thrust_from_channels(ch)
    assert w[0] > 20.0
    assert np.allclose(w[[1, 2, 3, 5]], 0.0, atol=1e-9)
    # the horizontal thrusters sit 0.085 m below the origin: surge thrust pitches the nose up
    assert w[4] == pytest.approx(0.085 * w[0])


def test_round_trip_random_wrenches(B) -> None:
    """forces -> channels -> ArduSub mixer -> PWM -> T200 reproduces the wrench B u.

    Six channels cannot set eight thrusts, only their wrench.  Bound: 1 N / 1 N m (the T200
    dead band of +-33 us and the rounding of channels to whole microseconds); typically 0.1.
    """
    rng = np.random.default_rng(0)
    errs = []
    for _ in range(300):
        u = rng.uniform(-15.0, 15.0, 8)
        ch = channels_for_thrust(u, B)
        assert np.all((ch >= 1100) & (ch <= 1900)) and np.all(ch == np.rint(ch))
        errs.append(np.max(np.abs(B @ thrust_from_channels(ch) - B @ u)))
    errs = np.asarray(errs)
    assert errs.max() < 1.0
    assert np.median(errs) < 0.2


def test_zero_wrench_gives_neutral(B) -> None:
    assert np.array_equal(channels_for_wrench(np.zeros(6), B), NEUTRAL_CHANNELS)
