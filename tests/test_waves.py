"""Linear waves against analytic facts: dispersion, kinematics, spectra, Doppler, the wave forces.

Reference values: capytaine 3.0's ``airy_waves_velocity`` (a = 1 m, T = 8 s, h = 30 m, z = -5 m:
|u| = 0.600 m/s, |w| = 0.556 m/s) and mhkit's ``wave_number`` (T = 8 s, h = 30 m: k = 0.06543 rad/m),
both computed with the packages' own functions; the Doppler wavelengths from the closed form
(T = 8 s, deep water, U = +-0.5 m/s: 107.8 / 91.7 m).
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from auvdock.vehicle import load_vehicle
from auvdock.vehicle.constants import GRAVITY_M_S2 as G
from auvdock.world.plant import TruthPlant
from auvdock.world.spectra import (
    SpectrumFileError,
    jonswap,
    load_spectrum,
    realise,
    regular_wave,
    spreading_weights,
)
from auvdock.world.waves import WaveComponents, dispersion_residual, group_speed, wavenumber

W8 = 2 * math.pi / 8.0


def test_dispersion_residual_and_wavelength_at_8_s_in_30_m():
    w = np.linspace(0.2, 6.0, 200)
    for h in (2.0, 30.0, 70.0, math.inf):
        k = wavenumber(w, h)
        assert np.max(np.abs(dispersion_residual(k, w, h))) < 1e-12
    k = wavenumber(W8, 30.0)[0]
    assert k == pytest.approx(0.06543, rel=2e-4)  # mhkit's wave_number
    assert 2 * math.pi / k == pytest.approx(96.0, abs=0.1)
    assert 2 * math.pi / wavenumber(W8)[0] == pytest.approx(
        G * 64 / (2 * math.pi), rel=1e-12
    )  # L = g T^2 / 2 pi


def test_group_speed_deep_water_is_gT_over_4pi():
    k = wavenumber(W8)
    assert group_speed(k)[0] == pytest.approx(G * 8.0 / (4 * math.pi), rel=1e-12)
    # shallow water: c_g -> sqrt(g h)
    assert group_speed(wavenumber(0.05, 2.0), 2.0)[0] == pytest.approx(math.sqrt(G * 2.0), rel=1e-3)


def test_doppler_shifted_wavelengths_following_and_opposing():
    assert 2 * math.pi / wavenumber(W8, math.inf, 0.5)[0] == pytest.approx(107.8, abs=0.1)
    assert 2 * math.pi / wavenumber(W8, math.inf, -0.5)[0] == pytest.approx(91.7, abs=0.1)
    for U in (0.5, -0.5, 1.3):
        k = wavenumber(W8, 30.0, U)
        assert abs(dispersion_residual(k, W8, 30.0, U)[0]) < 1e-12
    # the sea object applies the current along each direction: a current across the waves changes nothing
    across = WaveComponents([1.0], [W8], [0.0], [0.0], current_ned_m_s=(0.0, 0.8))
    assert across.wavenumber_rad_m[0] == pytest.approx(W8**2 / G, rel=1e-12)
    with pytest.raises(ValueError, match="blocked by the opposing current"):
        wavenumber(W8, math.inf, -3.5)  # blocking at U = -g / 4w = -3.1 m/s


def test_orbital_velocity_amplitudes_and_phases_at_depth_against_closed_form():
    sea = regular_wave(2.0, 8.0, water_depth_m=30.0)
    t = np.linspace(0.0, 8.0, 801)
    p = np.tile([0.0, 0.0, 5.0], (t.size, 1))
    kin = sea.kinematics(p, t)
    assert np.max(np.abs(kin.velocity_ned_m_s[:, 0])) == pytest.approx(0.600, abs=1e-3)  # capytaine
    assert np.max(np.abs(kin.velocity_ned_m_s[:, 2])) == pytest.approx(0.556, abs=1e-3)
    k = sea.wavenumber_rad_m[0]
    h, d = 30.0, 5.0
    u = W8 * math.cosh(k * (h - d)) / math.sinh(k * h) * np.cos(-W8 * t)
    w_up = W8 * math.sinh(k * (h - d)) / math.sinh(k * h) * np.sin(-W8 * t)
    np.testing.assert_allclose(kin.velocity_ned_m_s[:, 0], u, atol=1e-12)
    np.testing.assert_allclose(-kin.velocity_ned_m_s[:, 2], w_up, atol=1e-12)
    np.testing.assert_allclose(
        kin.acceleration_ned_m_s2[:, 0],
        W8 * W8 * math.cosh(k * (h - d)) / math.sinh(k * h) * np.sin(-W8 * t),
        atol=1e-12,
    )
    # deep water: every depth factor is e^{-k d}
    deep = regular_wave(2.0, 8.0)
    v = deep.velocity(np.array([[0.0, 0.0, 10.0]]), 0.0)
    assert v[0, 0] == pytest.approx(W8 * math.exp(-deep.wavenumber_rad_m[0] * 10.0), rel=1e-12)


def _irregular(seed: int, **kw) -> WaveComponents:
    return realise(
        lambda w: jonswap(w, 1.5, 8.0),
        0.3,
        4.0,
        120,
        np.random.default_rng(seed),
        water_depth_m=40.0,
        spread_deg=25.0,
        n_directions=5,
        mean_direction_rad=0.4,
        **kw,
    )


def test_field_is_divergence_free_and_gradient_matches_finite_differences():
    sea = _irregular(3, current_ned_m_s=(0.2, -0.1))
    rng = np.random.default_rng(0)
    for _ in range(5):
        p = rng.uniform([-30, -30, 0.5], [30, 30, 20])
        t = rng.uniform(0, 100)
        kin = sea.kinematics(p, t)
        J = kin.gradient_ned_1_s
        assert abs(np.trace(J)) < 1e-12 * max(1.0, np.max(np.abs(J)))
        eps = 1e-5
        for j in range(3):
            dp = np.zeros(3)
            dp[j] = eps
            fd = (sea.velocity(p + dp, t) - sea.velocity(p - dp, t)) / (2 * eps)
            np.testing.assert_allclose(J[:, j], fd, atol=1e-8)
        fd_t = (sea.velocity(p, t + eps) - sea.velocity(p, t - eps)) / (2 * eps)
        np.testing.assert_allclose(kin.acceleration_ned_m_s2, fd_t, atol=1e-8)


def test_vertical_velocity_at_the_surface_is_the_elevation_rate():
    sea = _irregular(5)
    t = np.linspace(0, 60, 300)
    n, e = 3.0, -7.0
    w_up = -sea.velocity(np.tile([n, e, 0.0], (t.size, 1)), t)[:, 2]
    np.testing.assert_allclose(w_up, sea.elevation_rate(n, e, t), atol=1e-12)


def test_casadi_velocity_is_the_numpy_one():
    sea = _irregular(7, current_ned_m_s=(0.3, 0.0))
    p = ca.SX.sym("p", 3)
    t = ca.SX.sym("t")
    f = ca.Function("v", [p, t], [sea.symbolic_velocity(p, t)])
    for q, tt in (([1.0, 2.0, 3.0], 4.0), ([-20.0, 5.0, 12.0], 33.3), ([0.0, 0.0, -0.2], 1.0)):
        np.testing.assert_allclose(np.asarray(f(q, tt)).ravel(), sea.velocity(np.array(q), tt), atol=1e-12)


def test_jonswap_m0_gives_hs():
    w = np.linspace(0.01, 30.0, 300_001)
    for hs, tp, gamma in ((1.0, 8.0, 3.3), (2.75, 11.7, 3.3), (1.75, 9.4, 1.0), (0.1, 2.5, 5.0)):
        m0 = np.trapezoid(jonswap(w, hs, tp, gamma), w)
        assert 4 * math.sqrt(m0) == pytest.approx(hs, rel=0.005)


def test_sampled_record_4_sd_and_welch_spectrum_tend_to_the_input():
    from scipy.signal import welch  # (imported here: a second of every worker's collection)

    hs, tp = 1.5, 8.0
    fs, dur = 4.0, 3600.0
    t = np.arange(0, dur, 1 / fs)
    ratios = []
    for seed in range(4):
        sea = realise(lambda w: jonswap(w, hs, tp), 0.25, 5.0, 400, np.random.default_rng(seed))
        eta = sea.elevation(0.0, 0.0, t)
        ratios.append(4 * np.std(eta) / hs)
        f, P = welch(eta, fs=fs, nperseg=2048)
        w = 2 * math.pi * f
        S = P / (2 * math.pi)
        band = (w > 0.6) & (w < 1.6)  # around the peak (0.785 rad/s)
        rel = np.trapezoid(S[band], w[band]) / np.trapezoid(jonswap(w[band], hs, tp), w[band])
        assert rel == pytest.approx(1.0, abs=0.15)
    assert np.mean(ratios) == pytest.approx(1.0, abs=0.05)
    assert all(abs(r - 1) < 0.1 for r in ratios)


def test_same_seed_same_sea_other_seed_other_sea():
    a, b, c = _irregular(11), _irregular(11), _irregular(12)
    np.testing.assert_array_equal(a.phase_rad, b.phase_rad)
    np.testing.assert_array_equal(a.omega_rad_s, b.omega_rad_s)
    assert not np.array_equal(a.phase_rad, c.phase_rad)


def test_spreading_weights_and_exponent():
    dirs, wts = spreading_weights(9, 30.0, 0.5)
    assert wts.sum() == pytest.approx(1.0)
    assert dirs[np.argmax(wts)] == pytest.approx(0.5)
    # the circular spread of the discretised distribution is the requested one
    sd = math.sqrt(2 * (1 - np.sum(wts * np.cos(dirs - 0.5))))
    assert math.degrees(sd) == pytest.approx(30.0, rel=0.05)


def test_the_realised_sea_round_trips_through_its_arrays():
    sea = _irregular(2, current_ned_m_s=(0.1, 0.2))
    back = WaveComponents.from_arrays(sea.to_arrays(), sea.attributes())
    p, t = np.array([4.0, 1.0, 6.0]), 12.5
    np.testing.assert_array_equal(back.velocity(p, t), sea.velocity(p, t))
    np.testing.assert_array_equal(back.wavenumber_rad_m, sea.wavenumber_rad_m)


def test_spectrum_file_columns_and_errors(tmp_path):
    good = tmp_path / "s.csv"
    w = np.linspace(0.3, 3.0, 50)
    good.write_text(
        "# a measured spectrum\nomega_rad_s,S_m2_s_rad\n"
        + "\n".join(f"{a},{b}" for a, b in zip(w, jonswap(w, 1.0, 8.0), strict=True))
    )
    s = load_spectrum(good)
    assert s.hm0_m == pytest.approx(1.0, rel=0.02)
    hz = tmp_path / "hz.csv"
    f = w / (2 * math.pi)
    hz.write_text(
        "frequency_hz,S_m2_hz\n"
        + "\n".join(f"{a},{b}" for a, b in zip(f, 2 * math.pi * jonswap(w, 1.0, 8.0), strict=True))
    )
    assert load_spectrum(hz).hm0_m == pytest.approx(s.hm0_m, rel=1e-9)
    bad = tmp_path / "bad.csv"
    bad.write_text("freq,S\n0.1,1\n0.2,2\n0.3,1\n")
    with pytest.raises(SpectrumFileError) as e:
        load_spectrum(bad)
    assert str(e.value) == f"{bad}: columns freq, S; expected omega_rad_s,S_m2_s_rad or frequency_hz,S_m2_hz"
    dec = tmp_path / "dec.csv"
    dec.write_text("omega_rad_s,S_m2_s_rad\n0.3,1\n0.2,2\n0.4,1\n")
    with pytest.raises(SpectrumFileError, match=r"omega_rad_s must be positive and strictly increasing$"):
        load_spectrum(dec)


def test_a_body_without_drag_or_thrust_follows_the_water_in_the_ratio_of_its_masses():
    """(rho V + A) / (m + A) per axis, rho V = B / g (Morison inertia; Fossen 2021 section 10.3).

    The BlueROV2 Heavy with no drag and weight = buoyancy, in a small regular wave (a = 1 cm, so
    that the quadratic Munk moments are negligible) travelling north, then east: started at rest
    in moving water, its velocity is ``ratio (u_water(p(t), t) - u_water(p(0), 0))`` on each axis.
    """
    v = load_vehicle(
        overrides={"linear_damping": [0.0] * 6, "quadratic_damping": [0.0] * 6, "weight_N": 114.8}
    )
    m, A = 13.5, np.array([5.5, 12.7, 14.6])
    expected = (114.8 / G + A) / (m + A)
    assert np.all((expected > 0.89) & (expected < 0.95))  # 0.906, 0.932, 0.936
    dt = 0.05
    for direction, axis in ((0.0, 0), (math.pi / 2, 1)):
        sea = WaveComponents([0.01], [2 * math.pi / 6.0], [direction], [0.3])
        plant = TruthPlant(v, None, [0, 0, 3.0, 0, 0, 0, 0, 0, 0, 0, 0, 0], dt=dt, sea=sea)
        u0 = sea.velocity(plant.state[0:3], 0.0)
        body, water = [], []
        for k in range(241):
            x = plant.state
            body.append(TruthPlant.rotation(x) @ x[6:9])
            water.append(sea.velocity(x[0:3], k * dt) - u0)
            plant.step(np.zeros(v.n_thrusters), k * dt)
        vb, vw = np.array(body), np.array(water)
        for ax in (axis, 2):
            np.testing.assert_allclose(
                vb[:, ax], expected[ax] * vw[:, ax], atol=5e-3 * np.max(np.abs(vw[:, ax]))
            )


def test_waves_off_is_the_integrator_without_a_sea():
    v = load_vehicle()
    u = np.linspace(-5, 5, v.n_thrusters)
    a = TruthPlant(v, None, [0, 0, 2.0, 0, 0, 0.3, 0.1, 0, 0, 0, 0, 0], dt=0.1)
    b = TruthPlant(
        v, None, [0, 0, 2.0, 0, 0, 0.3, 0.1, 0, 0, 0, 0, 0], dt=0.1, sea=WaveComponents([], [], [], [])
    )
    c = TruthPlant(v, None, [0, 0, 2.0, 0, 0, 0.3, 0.1, 0, 0, 0, 0, 0], dt=0.1, sea=regular_wave(0.0, 8.0))
    for k in range(20):
        xa, xb, xc = a.step(u, k * 0.1).copy(), b.step(u, k * 0.1).copy(), c.step(u, k * 0.1).copy()
        np.testing.assert_array_equal(xa, xb)
        np.testing.assert_allclose(xc, xa, atol=1e-12)  # zero-height waves: the same motion (numpy RK4)


def test_the_one_point_kinematics_are_the_vectorised_ones():
    for depth in (30.0, math.inf):
        rng = np.random.default_rng(1)
        sea = realise(
            lambda w: jonswap(w, 2.0, 9.0), 0.3, 4.0, 50, rng,
            water_depth_m=depth, spread_deg=20.0, n_directions=3, current_ned_m_s=(0.2, 0.1),
        )  # fmt: skip
        for p, t in (([3.0, -4.0, 6.0], 7.7), ([0.0, 0.0, -0.3], 1.0), ([10.0, 2.0, 0.0], 0.0)):
            kin = sea.kinematics(np.array(p), t)
            v, a, J = sea.kinematics_at(np.array(p), t)
            np.testing.assert_allclose(v, kin.velocity_ned_m_s, rtol=1e-12, atol=1e-15)
            np.testing.assert_allclose(a, kin.acceleration_ned_m_s2, rtol=1e-12, atol=1e-15)
            np.testing.assert_allclose(J, kin.gradient_ned_1_s, rtol=1e-12, atol=1e-15)
