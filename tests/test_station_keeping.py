"""Holding station in a sea (auvdock.world.station_keeping) against analytic facts: the thrusters'
utilisation of a pure surge force from the allocation's geometry, the wrench a small regular wave asks
for from linear theory and the added-mass, Froude-Krylov and linear-damping terms, and the still-water
wrench the buoyancy asks for."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auvdock.vehicle import load_vehicle
from auvdock.world.spectra import regular_wave
from auvdock.world.station_keeping import station_keeping, utilisation


@pytest.fixture(scope="module")
def vehicle():
    return load_vehicle("bluerov2_heavy")


def test_a_pure_surge_force_is_shared_by_the_horizontal_thrusters(vehicle):
    """Minimum-norm allocation of F along x: u_i = F d_ix / sum d_jx^2 (the other rows cancel by the
    frame's symmetry); the utilisation is the largest |u_i| over its limit in its direction."""
    F = 10.0
    d = vehicle.allocation[0]
    u = F * d / float(d @ d)
    limits = np.where(u >= 0, vehicle.thrust_max, -np.asarray(vehicle.thrust_min))
    expected = float(np.max(np.abs(u) / limits))
    assert utilisation(vehicle, np.array([F, 0, 0, 0, 0, 0]))[0] == pytest.approx(expected, rel=1e-9)
    assert expected == pytest.approx(F / (2 * math.sqrt(2)) / 39.9, rel=1e-3)


def test_a_small_regular_wave_asks_for_its_inertia_and_linear_drag(vehicle):
    """A 2 mm, 3 s wave travelling north in deep water, the vehicle 2 m down, heading north: the surge
    wrench's oscillation has the amplitude sqrt(((rho V + X_udot) w U)^2 + (X_u U)^2) of linear theory
    (U = a w e^{-kd}; the quadratic drag is 1e-4 of it at this amplitude), and the still-water heave
    wrench is the net buoyancy."""
    H, T, depth = 0.002, 3.0, 2.0
    sea = regular_wave(H, T, direction_rad=0.0)
    w = 2 * math.pi / T
    k = float(sea.wavenumber_rad_m[0])
    U = H / 2 * w * math.exp(-k * depth)
    m = vehicle.model
    s = station_keeping(vehicle, sea, depth, duration_s=T, dt_s=T / 400)
    expected = U * math.hypot((m.displaced_mass_kg + m.M_A[0, 0]) * w, m.D_lin[0])
    assert s.wrench_p99_N[0] == pytest.approx(expected, rel=0.01)
    net_buoyancy = vehicle.params.buoyancy_N - vehicle.params.weight_N
    calm = station_keeping(vehicle, regular_wave(1e-9, T), depth, duration_s=1.0, dt_s=0.5)
    assert calm.wrench_p99_N[2] == pytest.approx(net_buoyancy, rel=1e-6)
    assert calm.holds and calm.utilisation_p99 == pytest.approx(net_buoyancy / 4 / 39.9, rel=1e-3)


def test_the_sweep_report_puts_each_sea_state_beside_its_station_keeping(vehicle):
    """A sweep's rows over two wave heights: one table row per sea state, its utilisation the one
    station_keeping computes for that sea, the captures counted per controller; none without waves."""
    from auvdock.config.mission import load_mission
    from auvdock.sweep.station import station_keeping_report

    base = load_mission("basin_regular")
    runs = [(0.127, "ce", True), (0.127, "ce", False), (0.127, "oracle", True), (0.4, "ce", False)]
    rows = [{"sea.waves.height_m": h, "controller": c, "docked": d, "status": "done"} for h, c, d in runs]
    header, body = station_keeping_report(rows, base.to_yaml(), ["sea.waves.height_m"])
    assert header[0] == "sea.waves.height_m" and header[-2:] == ["ce", "oracle"]
    assert [r[0] for r in body] == ["0.127", "0.4"]
    assert body[0][-2:] == ["1/2", "1/1"] and body[1][-2:] == ["0/1", "0/0"]
    sea = base.with_updates({"sea.waves.height_m": 0.4}).build_sea()
    direct = station_keeping(vehicle, sea, base.dock.position_ned_m[2])
    assert body[1][1] == f"{direct.utilisation_p99:.2f}" and body[1][3] == ("yes" if direct.holds else "no")
    calm = load_mission("tank_0p6hz")
    assert station_keeping_report(rows, calm.to_yaml(), ["sea.waves.height_m"]) == ([], [])
