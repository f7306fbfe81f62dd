"""The water a prediction meets over its horizon (:mod:`auvdock.estimation.water_ahead`): the wave
oscillators run forward against the solution of their ODE, the true sea ahead against Airy's deep-water
formulas, and the MPC given the water held as before."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from auvdock.estimation.water_ahead import WaterAhead
from auvdock.estimation.wave_model import WaveModel
from auvdock.vehicle.constants import GRAVITY_M_S2
from auvdock.world.waves import WaveComponents


@pytest.mark.parametrize("zeta", [0.05, 0.1, 0.5])
def test_the_oscillators_run_forward_as_their_differential_equation_says(zeta):
    model = WaveModel(1.3, zeta, (0.2, 0.2, 0.1))
    w0, a0 = np.array([0.12, -0.05, 0.03]), np.array([0.04, 0.2, -0.1])
    tau = np.linspace(0.0, 4.0, 9)
    w, a = model.propagate(w0, a0, tau)

    def f(_t, y):
        return np.concatenate([y[3:], -(1.3**2) * y[:3] - 2 * zeta * 1.3 * y[3:]])

    sol = solve_ivp(f, (0.0, 4.0), np.concatenate([w0, a0]), t_eval=tau, rtol=1e-11, atol=1e-13)
    assert np.allclose(w, sol.y[:3].T, atol=1e-9)
    assert np.allclose(a, sol.y[3:].T, atol=1e-9)


def test_a_lightly_damped_oscillator_carries_a_regular_waves_velocity_a_quarter_period_on():
    """From a crest's velocity (w = U, w' = 0) a quarter period later the velocity is ~0 and the rate
    -U omega; half a period later -U (times the decay exp(-zeta omega tau))."""
    omega, zeta, U = 2 * math.pi / 8.5, 0.01, 0.5
    w, a = WaveModel(omega, zeta, (0.3, 0.0, 0.3)).propagate([U, 0, 0], [0, 0, 0], [8.5 / 4, 8.5 / 2])
    assert abs(w[0, 0]) < 0.02 * U
    assert a[0, 0] == pytest.approx(-U * omega, rel=0.03)
    assert w[1, 0] == pytest.approx(-U * math.exp(-zeta * omega * 8.5 / 2), rel=1e-3)


def test_the_true_sea_ahead_is_airys_deep_water_orbital_motion():
    a, T, d, phase = 0.4, 6.0, 3.0, 0.7
    omega = 2 * math.pi / T
    k = omega**2 / GRAVITY_M_S2
    sea = WaveComponents([a], [omega], [0.0], [phase])  # deep water, travelling north
    p = np.array([5.0, -2.0, d])
    water = WaterAhead.from_sea(np.array([0.2, 0.1, 0.0]), sea, p, 10.0, 0.25 * np.arange(6))
    t = 10.0 + 0.25 * np.arange(6)
    th = k * p[0] + phase - omega * t
    amp = a * omega * math.exp(-k * d)
    assert np.allclose(water.velocity_ned[:, 0], 0.2 + amp * np.cos(th), atol=1e-12)
    assert np.allclose(water.velocity_ned[:, 1], 0.1, atol=1e-12)
    assert np.allclose(water.velocity_ned[:, 2], -amp * np.sin(th), atol=1e-12)
    assert np.allclose(water.accel_ned[:, 0], amp * omega * np.sin(th), atol=1e-12)
    assert np.allclose(water.accel_ned[:, 2], amp * omega * np.cos(th), atol=1e-12)


def test_water_held_is_the_flow_at_every_step_and_no_acceleration():
    w = WaterAhead.held(np.array([0.3, -0.1, 0.0]), 4)
    assert w.steps == 4 and np.allclose(w.velocity_ned, [0.3, -0.1, 0.0]) and not np.any(w.accel_ned)
    with pytest.raises(ValueError, match="must both be"):
        WaterAhead(np.zeros((3, 3)), np.zeros((2, 3)))


def test_the_mpc_given_the_water_held_plans_as_with_the_flow_alone():
    from auvdock.controllers.mpc import DockingMPC
    from auvdock.controllers.settings import DEFAULT_Q
    from auvdock.vehicle import load_vehicle
    from auvdock.world.dock import HeaveDock

    v = load_vehicle("bluerov2_heavy")
    dock = HeaveDock((2.0, 0.0, 1.0), amplitude_m=0.05, angular_frequency_rad_s=2.0)
    mpc = DockingMPC(v, dock, Q=DEFAULT_Q, R=[1e-3] * 8, P=DEFAULT_Q, solver="rti")
    x = np.zeros(12)
    x[2] = 1.0
    flow = np.array([0.2, 0.1, 0.0])
    r1 = mpc.solve(0.0, x, np.zeros(8), flow)
    mpc.reset()
    r2 = mpc.solve(0.0, x, np.zeros(8), water=WaterAhead.held(flow, mpc.N))
    assert np.allclose(r1.plan_thrust, r2.plan_thrust, atol=1e-9)
    mpc.reset()
    with pytest.raises(ValueError, match="water: 3 steps for a horizon of 10"):
        mpc.solve(0.0, x, np.zeros(8), water=WaterAhead.held(flow, 3))
