"""The dock's motion as the vehicle learns it (issue 40): the motion unit as its data sheet states it, the
navigation filter's heave error of the dock, the forecaster's use of the unit's rate and slow error, the
oscillator bank ``benchmarks/dock_motion_forecast.py`` measures, the entry timed to the sea and the search."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from auvdock.config.guidance import GuidanceSettings
from auvdock.controllers.entry import EntryCorridor
from auvdock.estimation.dock_heave_error import DockErrorModel
from auvdock.estimation.estimate import Estimate
from auvdock.loop.guidance import Guidance
from auvdock.sensing.motion_unit import MotionUnit
from auvdock.sensing.settings import DockTelemetrySettings
from auvdock.world.dock import HeaveDock

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from dock_modes import DockModes, ModeBank, expm, fit_modes, mode_matrices, scalar_update  # noqa: E402


# --- the motion unit ----------------------------------------------------------------------------
def test_the_data_sheet_unit_has_a_slow_heave_error_of_its_stated_size_and_time():
    s = DockTelemetrySettings(enabled=True)  # mru: 5 cm, 20 s, 1 cm white, 1 cm/s rate
    unit = MotionUnit(s, np.random.default_rng(3))
    t = np.arange(0.0, 20000.0, 0.5)
    err = np.array([unit.heave_error(float(ti)) for ti in t])
    assert float(np.std(err)) == pytest.approx(0.05, rel=0.15)
    # a first-order Gauss-Markov process: correlation exp(-lag / 20 s)
    for lag_s in (2.0, 20.0):
        k = int(lag_s / 0.5)
        rho = float(np.corrcoef(err[:-k], err[k:])[0, 1])
        assert rho == pytest.approx(math.exp(-lag_s / 20.0), abs=0.08)
    r = unit.sample(1e5, np.zeros(3), np.array([0.0, 0.0, 0.3]))
    assert [x.kind for x in r] == ["dock_motion", "dock_motion_rate"]
    np.testing.assert_allclose(r[0].std, 0.01)
    np.testing.assert_allclose(r[1].std, 0.01)


def test_the_white_unit_is_white_noise_of_std_m_and_sends_no_rate():
    s = DockTelemetrySettings(enabled=True, motion_unit="white", std_m=0.05)
    unit = MotionUnit(s, np.random.default_rng(4))
    vals = np.array([unit.sample(0.1 * i, np.zeros(3), np.zeros(3))[0].value for i in range(20000)])
    assert float(np.std(vals[:, 2])) == pytest.approx(0.05, rel=0.05)
    # white: no correlation between neighbours
    assert abs(float(np.corrcoef(vals[:-1, 2], vals[1:, 2])[0, 1])) < 0.03
    assert len(unit.sample(0.0, np.zeros(3), np.zeros(3))) == 1


# --- the heave error's oscillator ----------------------------------------------------------------
def _rk4_oscillator(w: float, z: float, x0: np.ndarray, tau: float, n: int = 4000) -> np.ndarray:
    def f(x: np.ndarray) -> np.ndarray:
        return np.array([x[1], -w * w * x[0] - 2.0 * z * w * x[1]])

    h, x = tau / n, x0.copy()
    for _ in range(n):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


@pytest.mark.parametrize("tau", [0.05, 0.7, 3.0, -0.25])
def test_the_heave_errors_transition_solves_its_equation(tau):
    m = DockErrorModel(0.8, 0.5, 0.1)
    x0 = np.array([0.07, -0.2])
    np.testing.assert_allclose(m.transition(tau) @ x0, _rk4_oscillator(0.8, 0.5, x0, tau), atol=1e-10)
    np.testing.assert_allclose(m.transition(tau) @ m.transition(-tau), np.eye(2), atol=1e-12)


def test_a_scalar_update_is_the_kalman_update():
    rng = np.random.default_rng(0)
    M = rng.standard_normal((5, 5))
    P = M @ M.T
    z = rng.standard_normal(5)
    c = rng.standard_normal(5)
    P0, z0 = P.copy(), z.copy()
    scalar_update(z, P, c, 1.3, 0.2)
    S = float(c @ P0 @ c) + 0.2
    K = P0 @ c / S
    np.testing.assert_allclose(z, z0 + K * (1.3 - c @ z0), atol=1e-12)
    np.testing.assert_allclose(P, P0 - np.outer(K, K) * S, atol=1e-12)


# --- the oscillator bank (benchmarks/dock_motion_forecast.py) ---------------------------------------
def test_the_bank_is_stationary_and_its_matrix_exponential_exact():
    A, S = mode_matrices(0.7, 0.1, 2.0)
    np.testing.assert_allclose(A @ S + S @ A.T + np.diag([0.0, 0.0, 1.0]), 0.0, atol=1e-12)
    # the 2 x 2 oscillator inside: its exponential in closed form
    A2 = A[:2, :2]
    np.testing.assert_allclose(expm(A2 * 1.7), DockErrorModel(0.7, 0.1, 1.0).transition(1.7), atol=1e-12)
    bank = ModeBank(2, bias_std_m=0.05, bias_tau_s=20.0)
    bank.set_modes(DockModes(np.array([0.6, 1.1]), np.array([0.1, 0.2]), np.array([0.04, 0.01])))
    S = bank.stationary_cov()
    F, Q = bank.transition(0.3), bank.process_cov(0.3)
    np.testing.assert_allclose(F @ S @ F.T + Q, S, atol=1e-14)
    assert S[bank.p_index[0], bank.p_index[0]] == pytest.approx(0.04)
    assert np.all(np.linalg.eigvalsh(Q) > -1e-14)


def test_a_line_spectrum_is_fitted_at_its_frequency():
    omega = np.linspace(0.0, 4.0, 401)
    spectrum = np.where(np.abs(omega - 1.3) < 1e-9, 1.0 / 0.01, 0.0)  # one bin of variance 1
    modes = fit_modes(omega, spectrum, 3)
    assert modes is not None
    assert float(np.sum(modes.variance_m2)) == pytest.approx(1.0)
    np.testing.assert_allclose(modes.omega_rad_s, 1.3, rtol=1e-9)
    assert fit_modes(omega, np.zeros_like(omega), 3) is None


# --- the entry timed to the sea -------------------------------------------------------------------
CORRIDOR = EntryCorridor(
    cradle_x_m=-0.18,
    face_x_m=-0.78,
    side_radius_m=1.5,
    cradle_radius_m=0.086,
    taper=0.833,
    contact_speed_m_s=0.1,
    deceleration_1_s=0.5,
    heading_margin_rad=0.087,
    heading_slope_rad_m=1.05,
    weights=(500.0, 200.0, 200.0),
)


def _est(t: float, p: np.ndarray, v_ned: np.ndarray, fix: float) -> Estimate:
    x = np.zeros(12)
    x[0:3] = p
    x[6:9] = v_ned  # level attitude, heading 0: {b} = {n}
    return Estimate(t, x, dock_offset_ned=np.zeros(3), dock_fix_t=fix, relative_cov=np.eye(3) * 1e-4)


def test_the_window_opens_where_the_heave_says_and_the_entry_waits_for_it():
    """The vehicle sits still on the dock's axis, 1 m out, while the dock heaves ``A cos(w t)``: its
    offset from the axis is ``|A cos(w t)|`` and its speed across it ``|A w sin(w t)|`` (<= 0.04 m/s, inside
    the gate's 0.05): the window is open where ``|cos(w t)| <= 0.04 / A``, and the guidance goes in
    ``gate_hold_s`` after the first such window opens, not before."""
    A, w = 0.1, 0.4
    dock = HeaveDock(
        position_ned_m=(2.0, 0.0, 1.0),
        heading_rad=0.0,
        amplitude_m=A,
        angular_frequency_rad_s=w,
        phase_rad=math.pi / 2,
    )
    s = GuidanceSettings(entry_gate=True)
    g = Guidance(s, dock, camera=True, corridor=CORRIDOR)
    p = np.array([1.0, 0.0, 1.0])
    dt = 0.05
    t_go = None
    t = 1.0
    g.update(_est(0.0, p, np.zeros(3), fix=0.0))
    while t < 20.0:
        g.update(_est(t, p, np.zeros(3), fix=t - 0.05))
        if g.phase == "approach":
            t_go = t
            break
        assert g.phase in ("hold", "align")
        t += dt
    # the offset first falls within 0.04 m at w t = acos(0.4)
    t_open = math.acos(s.gate_offset_m / A) / w
    assert t_go is not None
    assert t_open + s.gate_hold_s - 1e-9 <= t_go <= t_open + s.gate_hold_s + dt + 1e-9


def test_an_entry_whose_offset_will_leave_the_cone_aborts_to_the_hold():
    s = GuidanceSettings(entry_gate=True)
    dock = HeaveDock(position_ned_m=(2.0, 0.0, 1.0), heading_rad=0.0)
    g = Guidance(s, dock, camera=True, corridor=CORRIDOR)
    g.phase = "approach"
    # 0.3 m from the docking point along the axis (the nose 0.12 m short of the cradle): the cone there is
    # 0.086 + 0.833 * 0.12 = 0.186 m; 0.1 m off and drifting away at 0.2 m/s: 0.2 m in 0.5 s
    g.update(_est(1.0, np.array([1.7, 0.1, 1.0]), np.array([0.0, 0.2, 0.0]), fix=0.95))
    assert g.phase == "hold" and g.aborts == 1 and g.target.standoff_m == s.gate_m
    g.phase = "approach"
    g.update(_est(1.1, np.array([1.7, 0.1, 1.0]), np.array([0.0, 0.1, 0.0]), fix=1.05))  # 0.15 m: inside
    assert g.phase == "approach" and g.aborts == 1


def test_without_a_gate_the_entry_tube_is_the_approach_as_before():
    g = Guidance(
        GuidanceSettings(), HeaveDock(position_ned_m=(2.0, 0.0, 1.0)), camera=True, corridor=CORRIDOR
    )
    g.update(_est(3.0, np.array([0.6, 0.1, 1.0]), np.zeros(3), fix=2.95))
    assert g.phase == "approach" and g.corridor is None


# --- the filter's heave error, the forecaster's rate, the search ---------------------------------------
def test_the_heave_error_states_keep_their_stationary_spread_in_the_filter():
    """Predicted with nothing measured, the filter's heave error (an oscillator driven to a stationary std of
    ``std_m``) and its slow part (Gauss-Markov, ``slow_std_m``) keep their stationary variances: the CasADi
    step's dynamics and the process noise are one model."""
    from auvdock.estimation.navigation_filter import NavigationFilter, NavigationSettings
    from auvdock.vehicle import load_vehicle

    model = DockErrorModel(0.7, 0.5, 0.12, slow_std_m=0.05, slow_tau_s=20.0)
    f = NavigationFilter(NavigationSettings(), load_vehicle("bluerov2_heavy"), 0.05, dock_error=model)
    i = f.dock_error_index
    assert i is not None and f.nz == i + 3
    f.step(0.0, [], np.zeros(8))
    for k in range(1, 1201):  # 60 s
        f.step(0.05 * k, [], np.zeros(8))
    P = f.P[i : i + 3, i : i + 3]
    assert math.sqrt(P[0, 0]) == pytest.approx(0.12, rel=0.03)
    assert math.sqrt(P[1, 1]) == pytest.approx(0.7 * 0.12, rel=0.03)
    assert math.sqrt(P[2, 2]) == pytest.approx(0.05, rel=0.03)
    assert np.allclose(f.z[i : i + 3], 0.0)


def test_the_forecasters_rate_covariance_is_the_spectrums_second_derivative():
    """For a sinusoid the covariance is ``A^2/2 cos(w tau)``: the tabled ``c''`` the rate fixes are
    conditioned
    with is ``-w^2 c``, and with the rate and the unit's slow error known the nowcast is centimetres."""
    from auvdock.estimation.dock_forecast import DockForecaster, DockForecastSettings

    w, A = 0.7, 0.4
    tel = DockTelemetrySettings(enabled=True)  # mru
    unit = MotionUnit(tel, np.random.default_rng(1))
    kf = DockForecaster(DockForecastSettings(slow_error_std_m=0.05, slow_error_tau_s=20.0))
    errs = []
    for k in range(4000):
        t = -300.0 + 0.1 * k
        rs = unit.sample(
            t, np.array([0.0, 0.0, A * math.sin(w * t)]), np.array([0.0, 0.0, A * w * math.cos(w * t)])
        )
        kf.update(rs[0].t, rs[0].value, rs[0].std)
        kf.update_rate(rs[1].t, rs[1].value, rs[1].std)
        if t > 0 and k % 10 == 0:
            errs.append(kf.predict(np.array([t + 0.5])).position_ned_m[0, 2] - A * math.sin(w * (t + 0.5)))
    fit = kf._fit
    assert fit is not None
    tau = np.linspace(0.0, 8.0, 33)
    c, c2 = fit.lookup(tau)[2], fit.lookup2(tau)[2]
    np.testing.assert_allclose(c2, -w * w * c, atol=0.05 * w * w * c[0])
    assert float(np.sqrt(np.mean(np.square(errs)))) < 0.03  # 0.5 s ahead; the slow error alone is 5 cm


def test_the_search_covers_three_sigma_along_and_across_before_giving_up():
    s = GuidanceSettings()
    g = Guidance(s, HeaveDock(position_ned_m=(2.0, 0.0, 1.0), heading_rad=0.0), camera=True)
    cov = np.diag(
        [0.6**2, 0.5**2, 0.1**2]
    )  # the vehicle relative to the dock: 3 sigma 1.8 m along, 1.5 m across
    p = np.array([2.0 - s.standoff_m, 0.0, 1.0])  # at the standoff point: search starts
    x = np.zeros(12)
    x[0:3] = p
    shifts = []
    t = 0.0
    while True:
        g.update(Estimate(t, x.copy(), dock_offset_ned=np.zeros(3), relative_cov=cov))
        if g.phase == "given_up":
            break
        shifts.append(g.target.search_shift.copy())
        t += 0.1
    shifts_a = np.array(shifts)
    assert shifts_a[:, 0].max() == pytest.approx(1.8, rel=0.01)  # forward along the axis (north), and back
    assert shifts_a[:, 0].min() >= -1e-9
    assert shifts_a[:, 1].max() == pytest.approx(1.5, rel=0.01) and shifts_a[:, 1].min() == pytest.approx(
        -1.5, rel=0.01
    )
    # it gave up only once the pattern was done (two sweeps after the search began), not at give_up_s
    assert t >= max(s.give_up_s, 2 * s.search_period_s) - 1e-9
