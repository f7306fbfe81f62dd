"""Thruster curves per vehicle (auvdock.vehicle.thrusters.ThrusterCurve) and the ardusub_sitl preset:
ArduPilot SITL's own vectored_6dof submarine written in this package's model."""

from __future__ import annotations

import numpy as np
import pytest

from auvdock.vehicle import load_vehicle
from auvdock.vehicle.ardusub import MOTOR_FACTORS, channels_for_wrench, thrust_from_channels
from auvdock.vehicle.params import VehicleParamsError, load_params
from auvdock.vehicle.thrusters import T200, ThrusterCurve, t200_force_to_pwm

# libraries/SITL/SIM_Submarine.cpp, vectored_6dof_thrusters: roll, pitch, yaw, throttle, forward, lateral
SITL_FACTORS = np.array(
    [
        [0, 0, 1, 0, -1, 1],
        [0, 0, -1, 0, -1, -1],
        [0, 0, -1, 0, 1, 1],
        [0, 0, 1, 0, 1, -1],
        [1, -1, 0, -1, 0, 0],
        [-1, -1, 0, -1, 0, 0],
        [1, 1, 0, -1, 0, 0],
        [-1, 1, 0, -1, 0, 0],
    ],
    dtype=float,
)


def test_sitls_table_is_ardusubs_mixer() -> None:
    """SITL's thruster table (transcribed from SIM_Submarine.cpp) is ArduSub's VECTORED_6DOF mixer
    (AP_Motors6DOF), column for column: the preset below is built on it."""
    np.testing.assert_array_equal(SITL_FACTORS[:, [1, 0, 3, 2, 4, 5]], MOTOR_FACTORS)


def test_quadratic_curve_is_sitls() -> None:
    c = ThrusterCurve("quadratic", (51.48,), 25.0)
    pwm = np.array([1100, 1300, 1474, 1476, 1500, 1524, 1526, 1700, 1900], dtype=float)
    q = (pwm - 1500) / 400
    want = np.where(np.abs(pwm - 1500) > 25, 51.48 * q * np.abs(q), 0.0)
    np.testing.assert_allclose(c.force(pwm), want)
    # the slope: the derivative outside the band, the band edge's inside it
    assert c.slope(np.array([1700.0]))[0] == pytest.approx(51.48 * 2 * 0.5 / 400)
    assert c.slope(np.array([1500.0]))[0] == pytest.approx(51.48 * 2 * (25 / 400) / 400)


def test_t200_is_the_default_and_unchanged() -> None:
    f = np.array([-30.0, -5.0, 2.0, 40.0])
    np.testing.assert_allclose(T200.force(2 * 1500 - (2 * 1500 - t200_force_to_pwm(f))), f, atol=0.01)
    assert load_vehicle("bluerov2_heavy").thruster_curve == T200


def test_sitl_preset_pushes_the_wrench_sitl_computes() -> None:
    """Each motor alone at a command m: the preset's B u equals SIM_Submarine's force
    (forward, lateral, -throttle) s and moment (roll, pitch, yaw) 0.25 s, s = 51.48 m|m|."""
    v = load_vehicle("ardusub_sitl")
    for m in (0.3, -0.6, 1.0):
        for i in range(8):
            pwm = np.full(8, 1500.0)
            pwm[i] = 1500 + 400 * m
            s = 51.48 * m * abs(m)
            ro, pi, ya, th, fw, la = SITL_FACTORS[i]
            sitl = np.r_[np.array([fw, la, -th]) * s, np.array([ro, pi, ya]) * 0.25 * s]
            u = v.thruster_curve.force(2 * 1500 - pwm)  # motor command m pushes along -e_i
            np.testing.assert_allclose(v.allocation @ u, sitl, atol=1e-3)


def test_sitl_preset_dynamics_constants() -> None:
    v = load_vehicle("ardusub_sitl")
    np.testing.assert_allclose(np.diag(v.model.M), [10.5] * 3 + [0.26808] * 3)
    p = v.params
    # net buoyancy: SIM_BUOYANCY 1 N over SITL's 16.755 kg, as an acceleration of the 10.5 kg body
    assert (p.buoyancy_N - p.weight_N) / p.mass_kg == pytest.approx(1.0 / 16.755, rel=1e-3)
    # righting moment 40 N at 0.15 m
    assert -p.r_b_m[2] * p.buoyancy_N == pytest.approx(6.0, rel=1e-3)


def test_channel_map_round_trips_through_the_quadratic_curve() -> None:
    v = load_vehicle("ardusub_sitl")
    B, curve = v.allocation, v.thruster_curve
    rng = np.random.default_rng(3)
    for _ in range(30):
        w = rng.normal(0, [8, 8, 8, 1, 1, 1])
        u = thrust_from_channels(channels_for_wrench(w, B, curve=curve), curve)
        np.testing.assert_allclose(B @ u, w, atol=0.6)


def test_bad_curve_is_one_clear_error(tmp_path) -> None:
    from importlib import resources

    import yaml

    d = yaml.safe_load(resources.files("auvdock.vehicle").joinpath("data/ardusub_sitl.yaml").read_text())
    path = tmp_path / "v.yaml"
    d["thrusters"]["model"] = "T300"
    path.write_text(yaml.safe_dump(d))
    with pytest.raises(VehicleParamsError, match="thrusters.model: must be T200 or quadratic, got 'T300'"):
        load_params(path)
    d["thrusters"]["model"] = "quadratic"
    d["thrusters"]["max_N"] = -1
    path.write_text(yaml.safe_dump(d))
    with pytest.raises(VehicleParamsError, match="thrusters.max_N"):
        load_params(path)
