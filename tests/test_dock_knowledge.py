"""The dock's telemetry (``sensors.dock_telemetry``) and what a deployable controller knows from it: the
telemetry's sampling, noise, latency and history; the forecast dock against an analytic sinusoid; Oracle
told the truth, every other controller the forecast, and the run's idealisations saying which."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auvdock.config.mission import load_mission
from auvdock.estimation.dock_knowledge import TelemetryDock
from auvdock.loop.assemble import build_autopilot, knows_dock_from_telemetry
from auvdock.loop.simulation import idealisations
from auvdock.sensing.settings import SensorSettings
from auvdock.sensing.simulated import SensorSuite
from auvdock.vehicle import load_vehicle
from auvdock.world.dock import HeaveDock

A, F = 0.0635, 0.6  # the tank trial's heave: 2.5 in at 0.6 Hz
W = 2 * math.pi * F
DOCK = HeaveDock((2.0, 1.0, 1.0), amplitude_m=A, angular_frequency_rad_s=W, phase_rad=0.4)


def _telemetry(seed: int = 0, steps: int = 200, dt: float = 0.05, **tel):
    settings = SensorSettings.model_validate({"dock_telemetry": {"enabled": True, **tel}})
    suite = SensorSuite(settings, load_vehicle("bluerov2_heavy"), seed, dock=DOCK)
    x = np.zeros(12)
    u = np.zeros(8)
    out = []
    for k in range(steps):
        out.append((k * dt, [r for r in suite.read(k * dt, x, u, np.zeros(3)) if r.kind == "dock_motion"]))
    return out


def test_the_telemetry_is_the_docks_displacement_with_the_stated_noise_and_history():
    # the white unit (the data sheet's 5 cm taken as white noise): tests/test_dock_motion.py has the mru's
    steps = _telemetry(
        motion_unit="white", std_m=0.05, dropout=0.0, history_s=300.0, rate_hz=10.0, latency_s=0.25
    )
    first = steps[0][1]
    # the record of the last 300 s at 10 Hz arrives at once, less the samples still in transit
    assert len(first) == 3001 - 3
    assert first[0].t == pytest.approx(-300.0)
    assert max(r.t for r in first) <= -0.25 + 1e-9
    every = [r for _, rs in steps for r in rs]
    times = np.array([r.t for r in every])
    assert np.allclose(np.diff(times), 0.1)  # in order, none lost, none twice
    resid = np.array([r.value - (DOCK.position(r.t) - np.asarray(DOCK.position_ned_m)) for r in every])
    assert np.all(np.abs(resid.mean(axis=0)) < 4 * 0.05 / math.sqrt(len(every)))
    assert np.allclose(resid.std(axis=0), 0.05, rtol=0.05)
    assert all(np.allclose(r.std, 0.05) for r in every)


def test_each_sample_arrives_after_its_latency_and_a_stated_share_is_lost():
    for t, rs in _telemetry(latency_s=0.3, history_s=0.0, dropout=0.0)[1:]:
        for r in rs:
            assert t - 0.05 < r.t + 0.3 <= t + 1e-9
    n = sum(len(rs) for _, rs in _telemetry(seed=3, dropout=0.2, history_s=300.0))
    expected = 3000 + 200 * 0.05 * 10
    assert abs(n / expected - 0.8) < 4 * math.sqrt(0.2 * 0.8 / expected)


def test_before_any_telemetry_the_forecast_dock_rests_at_its_charted_anchor():
    dock = TelemetryDock(DOCK)
    assert dock.position_ned_m == DOCK.position_ned_m
    assert np.allclose(dock.position(np.array([0.0, 1.0])), [DOCK.position_ned_m] * 2)
    assert np.allclose(dock.velocity(0.5), 0.0)
    assert np.all(np.isinf(dock.std(0.5)))


@pytest.mark.parametrize("ahead", [1.0, 3.0])
def test_the_forecast_dock_follows_a_sinusoid_it_only_hears_through_noise(ahead):
    """5 cm noise on a 6.35 cm heave at 0.6 Hz, 300 s of it: the forecast 1 and 3 s ahead errs under a
    third of the amplitude (holding the last sample would err 1.3 A), its velocity under a third of
    w A, and the truth lies within its +-2 std in most forecasts."""
    rng = np.random.default_rng(7)
    dock = TelemetryDock(DOCK)
    anchor = np.asarray(DOCK.position_ned_m)
    errors, verrors, inside = [], [], []
    for t in np.arange(-300.0, 60.0, 0.1):
        truth = DOCK.position(t) - anchor
        dock.update(t, truth + 0.05 * rng.standard_normal(3), np.full(3, 0.05))
        if t > 0 and abs(t / 2.0 - round(t / 2.0)) < 1e-6:
            p, std = dock.position(t + ahead), dock.std(t + ahead)
            errors.append(p[2] - DOCK.position(t + ahead)[2])
            verrors.append(dock.velocity(t + ahead)[2] - DOCK.velocity(t + ahead)[2])
            inside.append(abs(errors[-1]) <= 2 * std[2])
    assert math.sqrt(np.mean(np.square(errors))) < A / 3
    assert math.sqrt(np.mean(np.square(verrors))) < W * A / 3
    assert np.mean(inside) >= 0.8


def test_oracle_is_told_the_dock_and_every_other_controller_forecasts_it():
    m = load_mission("basin_regular").with_updates(sensors__dock_telemetry__enabled=True)
    vehicle = m.build_vehicle()
    dock = m.build_dock(m.build_sea())
    assert not knows_dock_from_telemetry(m, "oracle")
    assert knows_dock_from_telemetry(m, "ce") and knows_dock_from_telemetry(m, "sequential")
    assert build_autopilot(m, vehicle, dock, "oracle").dock is dock
    ce = build_autopilot(m, vehicle, dock, "ce")
    assert isinstance(ce.dock, TelemetryDock)
    assert ce.estimation.telemetry is ce.dock  # type: ignore[attr-defined]
    said = [s for s in idealisations(m, reads_true_flow=True) if s.startswith("Assumption 2")]
    assert said and "told the dock's true motion" in said[0]
    assert not any(s.startswith("Assumption 2") or "Assumption 2" in s for s in idealisations(m, False))


@pytest.mark.parametrize("seed", range(6))
def test_the_basin_mission_captures_forecasting_the_dock_from_its_telemetry(seed):
    """basin_regular as shipped (waves, the camera alone, the dock's motion forecast from its telemetry,
    the waves in the navigation filter): Certainty-equivalent MPC captures without collision, under
    0.15 m/s at contact, and the forecast of the dock's displacement 1 s ahead errs under 3 cm RMS (the
    heave: 6.35 cm amplitude).  Six seeds (ten until 2026-12-07: the suite's 8 minutes; the basin_capture
    campaign flies fifty)."""
    import auvdock

    o = auvdock.simulate("basin_regular", controller="ce", seed=seed).outcome
    assert o["reason"] == "captured", o
    assert not o["collided"] and o["contact_speed_m_s"] < 0.15
    assert o["dock_forecast_rmse_1s_m"] < 0.03


def test_with_the_waves_off_the_basin_mission_docks_as_before():
    """The basin mission without its waves: no wave model in the filter (the water is a current), the
    dock still heaving on its drive and forecast from its telemetry; CE captures without collision."""
    import auvdock
    from auvdock.loop.assemble import filter_wave_model

    calm = load_mission("basin_regular").with_updates(sea__waves=None)
    assert filter_wave_model(calm) is None
    run = auvdock.simulate(calm, controller="ce", seed=3)
    o = run.outcome
    assert o["reason"] == "captured" and not o["collided"], o
    assert "estimated_wave_velocity_ned_m_s" not in run.series
