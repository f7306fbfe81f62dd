"""Tests of the navigation filter (auvdock.estimation.navigation_filter), all in simulated time.

Truth: ``Vehicle.stepper(DT, 4, ConstantCurrent(...))`` driven by a thrust profile that surges,
sways and turns; readings from :func:`auvdock.sensing.measurements.measure` plus Gaussian noise
(attitude, gyro, accel, depth every step, position at 2 Hz, DVL optional).
"""

from __future__ import annotations

import numpy as np
import pytest

from auvdock.camera.model import CameraMount
from auvdock.estimation.flow_filter import chi2_quantile
from auvdock.estimation.navigation_filter import (
    BIAS_A,
    BIAS_G,
    DOCK,
    NZ,
    NavEstimate,
    NavigationFilter,
    process_density,
)
from auvdock.estimation.settings import NavigationSettings
from auvdock.runtime.fastcall import BufferedFunction
from auvdock.sensing import measurements as ms
from auvdock.sensing.readings import Reading
from auvdock.sensing.settings import SensorSettings
from auvdock.vehicle import load_vehicle
from auvdock.vehicle.geometry import point_in_sensor_frame, rotation_zyx
from auvdock.vehicle.state import NX, YAW
from auvdock.world.flow import ConstantCurrent

DT = 0.05
CURRENT = (0.3, -0.2)
STD = {"attitude": 0.01, "gyro": 0.005, "accel": 0.05, "depth": 0.02, "position": 0.05, "dvl": 0.02}
X0_STD = np.array([0.05] * 3 + [0.01] * 3 + [0.1] * 3 + [0.01] * 3)  # first guess from first readings


@pytest.fixture(scope="module")
def vehicle():
    return load_vehicle("bluerov2_heavy")


ZERO3 = np.zeros(3)


class Measure:
    """``ms.measure(kind, vehicle, x, u, flow_ned)``, the same functions on preallocated buffers
    (:class:`~auvdock.runtime.fastcall.BufferedFunction`): the same values, bit for bit, without
    converting every argument to a CasADi matrix at each of a run's thousands of readings."""

    def __init__(self, vehicle) -> None:
        self.vehicle = vehicle
        self._fns: dict[str, BufferedFunction] = {}

    def __call__(self, kind: str, x: np.ndarray, u: np.ndarray, flow_ned: np.ndarray) -> np.ndarray:
        fn = self._fns.get(kind)
        if fn is None:
            h = ms.h(kind, self.vehicle)
            assert h.nnz_out(0) == h.numel_out(0)  # dense: the buffer is the whole reading
            fn = self._fns[kind] = BufferedFunction(h)
        return fn(x, u, flow_ned)[0].copy()


def buffered_step(step):
    """A truth step ``(x, u, a) -> x_next`` (a CasADi Function) on preallocated buffers: same values."""
    fn = BufferedFunction(step)
    return lambda x, u, a: fn(x, u, a)[0].copy()


# (id(vehicle), t) -> (vehicle, thrust): the vehicle kept so that its id() stays its own
_THRUST: dict[tuple[int, float], tuple[object, np.ndarray]] = {}


def thrust(vehicle, t):
    """Surge, sway, depth-holding heave and a slow yaw moment: the vehicle moves and turns.

    The profile depends on the time only: solved once per vehicle and instant, not again for
    every seed of a run over seeds."""
    key = (id(vehicle), t)
    if key not in _THRUST:
        surge, sway, heave = 12 + 6 * np.sin(0.3 * t), 4 * np.cos(0.2 * t), 2.0 + np.sin(0.5 * t)
        tau = np.array([surge, sway, heave, 0, 0, 0.6 * np.sin(0.15 * t)])
        u, *_ = np.linalg.lstsq(vehicle.allocation, tau, rcond=None)
        _THRUST[key] = (vehicle, np.clip(u, vehicle.thrust_min, vehicle.thrust_max))
    return _THRUST[key][1].copy()


def run(seed, truth, model, settings, T=30.0, dvl=False, current=CURRENT, bias_a=ZERO3, bias_g=ZERO3):
    """Simulate; rows (t, error z_true - z_hat (NZ,), NEES, estimate); IMU biases in the readings."""
    rng = np.random.default_rng(seed)
    flow = ConstantCurrent(*current)
    step = buffered_step(truth.stepper(DT, 4, flow))
    measure = Measure(truth)
    vc = np.array([current[0], current[1], 0.0])
    x = np.zeros(NX)
    x[2] = 5.0
    nav = NavigationFilter(settings, model, DT)
    nav.reset(x + rng.normal(size=NX) * X0_STD, X0_STD)
    u = np.zeros(model.n_thrusters)
    rows = []
    for k in range(int(round(T / DT)) + 1):
        t = k * DT
        if k > 0:
            x = step(x, u, t - DT)
        kinds = ["attitude", "gyro", "accel", "depth"] + (["position"] if k % 10 == 0 else [])
        kinds += ["dvl"] if dvl else []
        readings = []
        for kind in kinds:
            y = measure(kind, x, u, vc)
            noisy = y + rng.normal(size=y.shape) * STD[kind]
            noisy = noisy + (bias_a if kind == "accel" else bias_g if kind == "gyro" else 0.0)
            readings.append(Reading(kind, t, noisy, np.full(y.shape, STD[kind])))
        est = nav.step(t, readings, u)
        e = np.concatenate([x - est.state, vc[0:2] - est.flow_ned[0:2], bias_a - nav.z[BIAS_A]])
        e = np.concatenate([e, bias_g - nav.z[BIAS_G], -nav.z[DOCK]])
        e[YAW] = (e[YAW] + np.pi) % (2 * np.pi) - np.pi
        rows.append((t, e, float(e @ np.linalg.solve(nav.P, e)), est))
        u = thrust(model, t)
    return rows


def test_estimate_shape_and_api(vehicle):
    nav = NavigationFilter(NavigationSettings(), vehicle, DT)
    nav.reset(np.zeros(NX))
    est = nav.step(0.0, [Reading("depth", 0.0, np.array([0.1]), np.array([0.02]))], np.zeros(8))
    assert isinstance(est, NavEstimate)
    assert est.state.shape == (12,) and est.state_cov.shape == (12, 12)
    assert est.flow_ned.shape == (3,) and est.flow_ned[2] == 0 and est.flow_cov.shape == (3, 3)
    assert est.nis > 0 and est.n_meas == 1
    est = nav.step(0.12, [], np.zeros(8))  # a gap longer than dt: split into steps
    assert est.t == pytest.approx(0.12) and est.nis == 0 and np.all(np.isfinite(est.state))


@pytest.mark.parametrize("dvl", [False, True])
def test_current_converges(vehicle, dvl):
    rows = run(0, vehicle, vehicle, NavigationSettings(), T=30.0, dvl=dvl)
    late = [r for r in rows if r[0] >= 20.0]
    cur_err = max(np.linalg.norm(r[1][NX : NX + 2]) for r in late)
    pos_err = max(np.linalg.norm(r[1][0:3]) for r in late)
    att_err = max(np.abs(r[1][3:6]).max() for r in late)
    vel_err = max(np.linalg.norm(r[1][6:9]) for r in late)
    print(
        f"dvl={dvl}: current {cur_err:.4f} m/s, position {pos_err:.3f} m, attitude {att_err:.4f} rad, "
        f"velocity {vel_err:.4f} m/s"
    )
    assert cur_err < 0.05
    assert pos_err < 0.15 and att_err < 0.02 and vel_err < 0.05


DOCK_STD = np.array([0.003, 0.003, 0.02])  # a camera fix about 2 m away: lateral 3 mm, range 2 cm


def _dock_heave(t: float) -> tuple[np.ndarray, np.ndarray]:
    """The test dock's known motion about its anchor: 0.3 m heave at 0.1 Hz (NED m, m/s)."""
    w = 2 * np.pi * 0.1
    return np.array([0.0, 0.0, 0.3 * np.sin(w * t)]), np.array([0.0, 0.0, 0.3 * w * np.cos(w * t)])


def _suite_std() -> dict[str, np.ndarray]:
    """The default sensor suite's white-noise std per reading kind (the truth runs' readings)."""
    suite = SensorSettings()
    return {
        "attitude": np.array([suite.ahrs.roll_pitch_std_rad] * 2 + [suite.ahrs.yaw_std_rad]),
        "gyro": np.full(3, suite.imu.gyro_noise_rad_s),
        "accel": np.full(3, suite.imu.accel_noise_m_s2),
        "depth": np.array([suite.depth.std_m]),
        "position": np.full(3, suite.position.figures()[2]),
    }


def _process_truth_run(vehicle, truth_step, seed, settings, T, every, dock_from_t=None):
    """One run whose truth is the process the filter assumes (Bar-Shalom's consistency test).

    The truth z (NZ) starts drawn from the filter's prior and moves by the filter's model (RK4
    of the vehicle model with the current held) plus the filter's process noise, the current,
    the IMU biases and the dock's anchor as random walks of its densities; the readings are the
    measurement definitions at the true z, biases included, plus white noise of the sensor
    suite's default figures (no latency).  With ``dock_from_t`` (s) there are no position fixes:
    the filter dead-reckons, and from that time on the camera fixes the dock (kind ``dock``, 15
    Hz, :data:`DOCK_STD`), the dock heaving about its anchor (:func:`_dock_heave`).  Returns the
    NEES and the NEES of the position relative to the dock (one every ``every`` steps), and the
    normalised errors.
    """
    rng = np.random.default_rng(seed)
    std = _suite_std()
    measure = Measure(vehicle)
    mount = CameraMount()
    nav = NavigationFilter(settings, vehicle, DT, (mount.R_bc(), mount.t_bc()), _dock_heave)
    x0 = np.zeros(NX)
    x0[2] = 5.0
    nav.reset(x0, dock_anchor=np.array([2.0, 0.0, 5.0]))
    z = nav.z + np.linalg.cholesky(nav.P) @ rng.standard_normal(NZ)
    w_std = np.sqrt(process_density(settings) * DT)
    u = np.zeros(vehicle.n_thrusters)
    nees, rel_nees, normed, rel_std = [], [], [], []
    for k in range(int(round(T / DT)) + 1):
        t = k * DT
        if k > 0:
            z[0:NX] = truth_step(z[0:NX], u, z[NX : NX + 2])
            z += w_std * rng.standard_normal(NZ)
        vc = np.array([z[NX], z[NX + 1], 0.0])
        readings = []
        if dock_from_t is None:
            kinds = ["attitude", "gyro", "accel", "depth"] + (["position"] if k % 3 == 0 else [])
        else:
            kinds = ["attitude", "gyro", "accel", "depth"] + (["dock"] if t >= dock_from_t and k % 4 else [])
        for kind in kinds:
            if kind == "dock":  # the docking point in the camera frame
                p_dock = z[DOCK] + _dock_heave(t)[0]
                y = point_in_sensor_frame(rotation_zyx(*z[3:6]), z[0:3], p_dock, mount.R_bc(), mount.t_bc())
                readings.append(Reading(kind, t, y + DOCK_STD * rng.standard_normal(3), DOCK_STD))
                continue
            y = measure(kind, z[0:NX], u, vc)
            y = y + (z[BIAS_A] if kind == "accel" else z[BIAS_G] if kind == "gyro" else 0.0)
            readings.append(Reading(kind, t, y + std[kind] * rng.standard_normal(y.shape), std[kind]))
        est = nav.step(t, readings, u)
        e = z - nav.z
        e[YAW] = (e[YAW] + np.pi) % (2 * np.pi) - np.pi
        if k % every == 0:
            nees.append(float(e @ np.linalg.solve(nav.P, e)))
            e_rel = e[0:3] - e[DOCK]
            rel_nees.append(float(e_rel @ np.linalg.solve(est.relative_cov, e_rel)))
            rel_std.append(float(np.sqrt(np.max(np.linalg.eigvalsh(est.relative_cov)))))
            normed.append(e / np.sqrt(np.diag(nav.P)))
        u = thrust(vehicle, t)
    return np.array(nees), np.array(rel_nees), np.array(normed), np.array(rel_std)


@pytest.fixture(scope="module")
def truth_step(vehicle):
    """The filter's own process model as a truth integrator: (x, u, v_c north/east) -> x after DT."""
    import casadi as ca

    from auvdock.vehicle.model import rk4

    x, u, vc = ca.SX.sym("x", NX), ca.SX.sym("u", vehicle.n_thrusters), ca.SX.sym("vc", 2)
    f = lambda xx: vehicle.model.dynamics(xx, u, ca.vertcat(vc, 0), ca.DM.zeros(3))  # noqa: E731
    return buffered_step(ca.Function("truth", [x, u, vc], [rk4(f, x, DT, 4)]))


@pytest.mark.slow
def test_nees_is_consistent_over_seeds(vehicle, truth_step):
    """Bar-Shalom's test: over N = 30 seeds (0..29, none left out) of a truth generated by the
    process the filter assumes, the ensemble-average NEES at each sampled time (every 0.5 s,
    0-40 s) lies inside the two-sided 95 % bounds chi2(N NZ) / N at most times (a consistent
    filter: about 95 %).  Before the second-order terms the gyro bias took the model's
    mispredicted rates in the first half second and the fraction was 0 %."""
    settings = NavigationSettings()
    n_seeds = 30
    runs = [_process_truth_run(vehicle, truth_step, s, settings, T=40.0, every=10) for s in range(n_seeds)]
    nees = np.array([r[0] for r in runs])  # (seeds, times)
    assert np.all(np.isfinite(nees))
    avg = nees.mean(axis=0)
    # chi-square quantiles by Wilson-Hilferty (at 600 degrees of freedom within 1e-4 of exact)
    lo, hi = (chi2_quantile(p, n_seeds * NZ) / n_seeds for p in (0.025, 0.975))
    inside = float(np.mean((avg >= lo) & (avg <= hi)))
    per_seed = nees.mean(axis=1)
    comp = np.mean(np.concatenate([r[2] for r in runs]) ** 2, axis=0)
    print(
        f"ensemble NEES inside [{lo:.2f}, {hi:.2f}] at {100 * inside:.0f} % of {avg.size} times "
        f"(below {100 * np.mean(avg < lo):.0f} %, above {100 * np.mean(avg > hi):.0f} %); "
        f"per-seed time-averaged NEES min {per_seed.min():.1f} median {np.median(per_seed):.1f} "
        f"max {per_seed.max():.1f}; per-state mean (e/sigma)^2 {np.round(comp, 2).tolist()}"
    )
    assert inside >= 0.85
    assert np.all(comp < 2.0)  # no state's error is more than sqrt(2) times what the filter claims


@pytest.mark.slow
def test_nees_is_consistent_before_and_after_the_camera_sees_the_dock(vehicle, truth_step):
    """Relative navigation, Bar-Shalom's test in both phases: no position fixes; for 15 s the
    filter dead-reckons (the vehicle's position and the dock's anchor drift apart in its
    covariance), then the camera fixes the dock at 15 Hz (kind ``dock``).  Over 30 seeds of a
    truth generated by the process the filter assumes (the dock's anchor drawn from its prior,
    2 m ahead, 0.5 m std), the ensemble NEES of the whole state, and of the position relative
    to the dock (3 degrees of freedom), lie inside their two-sided 95 % bounds at most times of
    each phase, and the relative position, a metre uncertain before the hand-over, is known to
    centimetres after it.

    The vehicle starts at rest in water whose current is known to 0.1 m/s (a tank, a tide table).
    With the default prior (1 m/s) the dead-reckoning phase is over-confident: measured with
    ``python benchmarks/navigation_consistency.py --relative``, docs/sensing-estimation.md."""
    settings = NavigationSettings(prior_current_std_m_s=0.1, prior_velocity_std_m_s=0.05)
    n_seeds, t_cam, T = 30, 15.0, 30.0
    runs = [
        _process_truth_run(vehicle, truth_step, s, settings, T=T, every=10, dock_from_t=t_cam)
        for s in range(n_seeds)
    ]
    times = np.arange(0.0, T + 1e-9, 10 * DT)
    nees, rel = np.array([r[0] for r in runs]), np.array([r[1] for r in runs])
    assert np.all(np.isfinite(nees)) and np.all(np.isfinite(rel))
    for name, values, dof in (("state", nees, NZ), ("relative position", rel, 3)):
        lo, hi = (chi2_quantile(p, n_seeds * dof) / n_seeds for p in (0.025, 0.975))
        avg = values.mean(axis=0)
        for phase, sel in (("dead reckoning", times < t_cam), ("camera", times >= t_cam + 0.5)):
            inside = float(np.mean((avg[sel] >= lo) & (avg[sel] <= hi)))
            print(
                f"{name}, {phase}: ensemble NEES inside [{lo:.2f}, {hi:.2f}] at {100 * inside:.0f} % of times"
            )
            assert inside >= 0.85, (name, phase)
    # what the hand-over buys: the relative position's uncertainty (largest std), before and after
    before = np.median([r[3][(times > t_cam - 1.0) & (times < t_cam)] for r in runs])
    after = np.median([r[3][times > t_cam + 2.0] for r in runs])
    print(f"relative position std: {before:.2f} m before the first fix, {100 * after:.1f} cm after")
    assert before > 0.5 and after < 0.03


def test_imu_biases_are_estimated(vehicle):
    """Constant IMU biases (as the sensor suite draws them) are learnt: the velocity estimate is
    not biased by the accelerometer's offset, and the current still converges."""
    b_a, b_g = np.array([0.02, -0.015, 0.03]), np.array([1e-3, -2e-3, 1.5e-3])
    rows = run(1, vehicle, vehicle, NavigationSettings(), T=40.0, bias_a=b_a, bias_g=b_g)
    late = [r for r in rows if r[0] >= 30.0]
    vel_bias = np.abs(np.mean([r[1][6:9] for r in late], axis=0))
    acc_err = np.linalg.norm(late[-1][1][NX + 2 : NX + 5])
    print(f"biases: mean velocity error {vel_bias}, accel bias error {acc_err:.4f} m/s^2")
    assert np.all(vel_bias < 0.01)
    assert acc_err < 0.01
    assert max(np.linalg.norm(r[1][NX : NX + 2]) for r in late) < 0.05


def test_model_error_stays_bounded(vehicle):
    base = vehicle.params
    truth = load_vehicle(
        "bluerov2_heavy",
        overrides={
            "linear_damping": (1.2 * base.linear_damping).tolist(),
            "quadratic_damping": (1.2 * base.quadratic_damping).tolist(),
            "buoyancy_N": base.buoyancy_N - 1.0,
        },
    )
    rows = run(0, truth, vehicle, NavigationSettings(), T=30.0)
    assert all(np.all(np.isfinite(r[3].state)) and np.all(np.isfinite(r[3].state_cov)) for r in rows)
    late = [r for r in rows if r[0] >= 20.0]
    cur_err = max(np.linalg.norm(r[1][NX : NX + 2]) for r in late)
    print(f"model error: current error after 20 s <= {cur_err:.3f} m/s")
    assert cur_err < 0.2


def _link_truth_run(vehicle, seed, settings, timing_known, T=10.0, every=5, delay=0.11, jitter=0.03):
    """One run of the process the filter assumes, its commands delivered over a link: each command
    (a dock-heave-tracking thrust: 15 N of heave at 0.6 Hz, 4 N of surge) is sent at a step and takes
    effect ``delay`` later give or take a normal ``jitter`` (the one arriving last acts, as ArduSub's
    RC override does).  The truth integrates through each arrival;
    the filter is given the :class:`~auvdock.estimation.delay.ThrustSchedule` of
    :class:`~auvdock.estimation.delay.DelayCompensation` (the commands at send time + delay), with the
    link's jitter (``timing_known``) or without it.  Returns the NEES (every ``every`` steps) and the
    normalised errors."""
    import casadi as ca

    from auvdock.estimation.delay import DelayCompensation
    from auvdock.vehicle.model import rk4

    rng = np.random.default_rng(seed)
    x, u_s = ca.SX.sym("x", NX), ca.SX.sym("u", vehicle.n_thrusters)
    vc, h = ca.SX.sym("vc", 2), ca.SX.sym("h")
    f = lambda xx: vehicle.model.dynamics(xx, u_s, ca.vertcat(vc, 0), ca.DM.zeros(3))  # noqa: E731
    step = BufferedFunction(ca.Function("truth_h", [x, u_s, vc, h], [rk4(f, x, h, 2)]))
    std = _suite_std()
    measure = Measure(vehicle)
    nav = NavigationFilter(settings, vehicle, DT)
    x0 = np.zeros(NX)
    x0[2] = 5.0
    nav.reset(x0)
    z = nav.z + np.linalg.cholesky(nav.P) @ rng.standard_normal(NZ)
    w_std = np.sqrt(process_density(settings) * DT)
    comp = DelayCompensation(vehicle)
    comp.command_delay_s = delay
    comp.jitter_s = jitter if timing_known else 0.0
    arrivals: list[tuple[float, np.ndarray]] = []  # (instant it takes effect, thrust)

    def acting(s: float) -> np.ndarray:
        arrived = [a for a in arrivals if a[0] <= s + 1e-12]
        return max(arrived, key=lambda a: a[0])[1] if arrived else np.zeros(vehicle.n_thrusters)

    nees, normed = [], []
    for k in range(int(round(T / DT)) + 1):
        t = k * DT
        if k > 0:
            t0 = t - DT
            cuts = sorted({t0, t, *(a for a, _ in arrivals if t0 < a < t)})
            for a, b in zip(cuts[:-1], cuts[1:], strict=True):
                z[0:NX] = step(z[0:NX], acting(a), z[NX : NX + 2], b - a)[0]
            z += w_std * rng.standard_normal(NZ)
        vc = np.array([z[NX], z[NX + 1], 0.0])
        u_now = acting(t - 1e-9)  # the accelerometer reads the thrust of the step that ends at t
        readings = []
        for kind in ["attitude", "gyro", "accel", "depth"] + (["position"] if k % 3 == 0 else []):
            y = measure(kind, z[0:NX], u_now, vc)
            y = y + (z[BIAS_A] if kind == "accel" else z[BIAS_G] if kind == "gyro" else 0.0)
            readings.append(Reading(kind, t, y + std[kind] * rng.standard_normal(y.shape), std[kind]))
        nav.step(t, readings, comp.acted(t - DT, t) if k > 0 else np.zeros(vehicle.n_thrusters))
        e = z - nav.z
        e[YAW] = (e[YAW] + np.pi) % (2 * np.pi) - np.pi
        if k % every == 0:
            nees.append(float(e @ np.linalg.solve(nav.P, e)))
            normed.append(e / np.sqrt(np.diag(nav.P)))
        tau = np.array([4.0, 0.0, 15.0 * np.sin(2 * np.pi * 0.6 * t), 0.0, 0.0, 0.0])
        u_cmd, *_ = np.linalg.lstsq(vehicle.allocation, tau, rcond=None)
        u_cmd = np.clip(u_cmd, vehicle.thrust_min, vehicle.thrust_max)
        comp.history.sent(t, u_cmd)
        arrivals.append((t + delay + jitter * float(rng.standard_normal()), u_cmd))
    return np.array(nees), np.array(normed)


@pytest.mark.slow
def test_nees_is_consistent_when_the_link_makes_the_thrust_late_by_an_uncertain_time(vehicle):
    """Bar-Shalom's test over 12 seeds, the commands over a 110 ms +- 30 ms link: the filter given the
    link's jitter (each change of thrust widens the velocity covariance by its impulse, and the
    accelerometer's noise near it) is consistent; the same filter told the instants are exact is not
    (measured: inside the bounds at 97 % and 0 % of the times, mean NEES 22.2 and 347 for NZ = 23).
    Commands with 0.5 or 1 N of white noise per thruster and step on top (a jittery controller) left the
    jitter-aware filter over-confident (mean NEES 36 and 75 over 10 seeds): its one-change-at-a-time
    model of the timing misses what overtaken commands and the roll they kick do.  Through a real relay
    (fly, vehicle-sim, 100 ms +- 30 ms, 5 % loss) its position's NEES averaged 3.0 for 3 degrees of
    freedom (docs/commands/fly.md).
    """
    settings = NavigationSettings()
    n_seeds = 12
    lo, hi = (chi2_quantile(p, n_seeds * NZ) / n_seeds for p in (0.025, 0.975))
    inside = {}
    for known in (True, False):
        runs = [_link_truth_run(vehicle, s, settings, known) for s in range(n_seeds)]
        nees = np.array([r[0] for r in runs])
        avg = nees[:, 2:].mean(axis=0)  # from 0.5 s on (the first update's transient)
        inside[known] = float(np.mean((avg >= lo) & (avg <= hi)))
        print(
            f"timing {'known' if known else 'taken as exact'}: ensemble NEES inside [{lo:.2f}, {hi:.2f}] at "
            f"{100 * inside[known]:.0f} % of {avg.size} times; mean NEES {avg.mean():.1f}"
        )
    assert inside[True] >= 0.85
    assert inside[False] < 0.25
