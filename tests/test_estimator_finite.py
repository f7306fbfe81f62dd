"""The FSE flow estimator never hands on a non-finite value (issue 16): property tests over the
sweeps' noise and model-error ranges, and beyond them (spikes, NaN and inf readings)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from auvdock.config.mission import load_mission
from auvdock.estimation.flow_filter import FlowEstimator
from auvdock.estimation.settings import EstimatorSettings

ROOT = Path(__file__).resolve().parents[1]
_VEHICLE = load_mission(ROOT / "missions" / "diagonal.yaml").build_vehicle()

finite = st.floats(-1e3, 1e3, allow_nan=False)
anything = st.one_of(finite, st.just(np.nan), st.just(np.inf), st.just(-np.inf), st.floats(-1e12, 1e12))


def _estimator() -> FlowEstimator:
    e = EstimatorSettings()
    return FlowEstimator(
        _VEHICLE, 0.05, np.zeros(3), e.prior_std_m_s, e.process_noise_m2_s2, e.accel_noise_var,
        e.depth_rate_noise_var, e.forgetting_factor, gyro_std=1e-3, attitude_std=2e-3,
        relative_velocity_std=1e-3,
    )  # fmt: skip


def _run(steps: list[tuple[list[float], float | None]], seed: int) -> FlowEstimator:
    rng = np.random.default_rng(seed)
    est = _estimator()
    eta = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0])
    nu_r = np.zeros(6)
    for values, depth_rate in steps:
        eta = eta + rng.normal(0, 0.01, 6)
        nu_r = np.clip(nu_r + rng.normal(0, 0.05, 6), -2, 2)
        nu_r[3:6] = np.clip(nu_r[3:6], -0.5, 0.5)
        accel = np.asarray(values[0:3], dtype=float)
        u = np.asarray(values[3:11], dtype=float)
        r = est.step(eta, nu_r, accel, depth_rate, np.clip(np.nan_to_num(u), -40, 40))
        for a in (r.flow_body, r.flow_ned, r.covariance, np.asarray(r.information)):
            assert np.all(np.isfinite(a)), (values, depth_rate)
    return est


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.lists(anything, min_size=11, max_size=11), st.one_of(st.none(), anything)),
             min_size=1, max_size=30),
    st.integers(0, 2**16),
)  # fmt: skip
def test_any_readings_leave_the_estimate_finite(steps, seed) -> None:
    _run(steps, seed)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**16), st.floats(0.0, 0.05), st.floats(0.7, 1.3))
def test_sweep_noise_and_model_error_ranges(seed, accel_noise, model_scale) -> None:
    """Accelerometer noise up to ten times the default and thrust off by +-30 %: finite, and the
    estimate stays within the physically possible (far below 100 m/s)."""
    rng = np.random.default_rng(seed)
    steps = []
    for _ in range(60):
        accel = rng.normal(0, accel_noise, 3)
        u = model_scale * rng.uniform(-30, 30, 8)
        steps.append(([*accel, *u], float(rng.normal(0, 0.002))))
    est = _run(steps, seed)
    assert np.linalg.norm(est.estimate()) < 100.0
