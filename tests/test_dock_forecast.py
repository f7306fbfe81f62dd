"""The dock forecaster (auvdock.estimation.dock_forecast) against seas it has not been told about.

Every test feeds the forecaster what the camera would give -- fixes of the dock's position at 15 Hz,
0.1 s late, with noise and lost frames -- and compares its forecasts with the true dock.  Errors are
RMS over many forecast origins, as a fraction of the heave's standard deviation.  The bounds come
from what the method achieves and from two baselines measured on the same samples
(``python benchmarks/dock_forecast.py`` prints them for the missions' docks):

* persistence (the last fix held) -- for a 9 s swell about 0.9 of the heave's std at 1 s ahead and
  1.7 at 3 s;
* the best linear predictor given the *true* covariance of the realised sea (what no forecaster that
  learns the sea can beat): about 0.21 at 1 s and 0.38 at 3 s on this sea.

Seeded and deterministic; the whole file takes a few seconds.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from auvdock.estimation.dock_forecast import DockForecaster, DockForecastSettings, ForecastDock
from auvdock.world.dock import DockMotion, HeaveDock
from auvdock.world.spectra import jonswap, realise
from auvdock.world.wec_dock import WecDock

RATE_HZ = 15.0  # the camera's frame rate
LATENCY_S = 0.1  # a fix is known this long after its image


def narrow_sea_dock(seed: int = 0) -> WecDock:
    """A dock riding the surface (RAO 1) of a narrow-band sea: JONSWAP Hs 1.5 m, Tp 9 s, gamma 7,
    120 frequencies over 0.5-3 peak frequencies (std of the heave about 0.37 m)."""
    wp = 2.0 * math.pi / 9.0
    sea = realise(
        functools.partial(jonswap, hs_m=1.5, tp_s=9.0, gamma=7.0),
        0.5 * wp,
        3.0 * wp,
        120,
        np.random.default_rng(seed),
        label="narrow JONSWAP",
    )
    return WecDock(sea, (0.0, 0.0, 10.0), 0.0, np.ones(sea.n_components))


def paper_dock() -> HeaveDock:
    """The paper's dock: 0.0635 m heave at 0.6 Hz, 1 m deep."""
    return HeaveDock((2.0, 0.0, 1.0), 0.0, 0.0635, 2.0 * math.pi * 0.6, 0.0)


def camera_fixes(
    dock: DockMotion,
    t_end: float,
    rng: np.random.Generator,
    *,
    noise_m: float,
    lost: float = 0.05,
    bursts: tuple[tuple[float, float], ...] = (),
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fixes at 15 Hz up to t_end: times (n,), positions (n, 3) with white noise of ``noise_m`` per
    axis, stds (n, 3); each frame lost with probability ``lost``, none inside the (start, length)
    ``bursts``."""
    t = np.arange(0.0, t_end, 1.0 / RATE_HZ)
    keep = rng.uniform(size=t.size) >= lost
    for start, length in bursts:
        keep &= ~((t >= start) & (t < start + length))
    t = t[keep]
    p = dock.position(t) + noise_m * rng.standard_normal((t.size, 3))
    return t, p, np.full((t.size, 3), noise_m)


def run(
    dock: DockMotion,
    fixes: tuple[np.ndarray, np.ndarray, np.ndarray],
    origins: np.ndarray,
    horizons: np.ndarray,
    settings: DockForecastSettings | None = None,
) -> dict[str, np.ndarray]:
    """Feed the fixes (each LATENCY_S after its image) and forecast the heave from each origin:
    errors (n_origins, n_horizons) m of the forecast and of persistence, and the forecast's std."""
    t, p, s = fixes
    f = DockForecaster(settings)
    err, pers, std = [], [], []
    i = 0
    for t0 in origins:
        while i < t.size and t[i] <= t0 - LATENCY_S:
            f.update(t[i], p[i], s[i])
            i += 1
        assert f.ready
        mean, sd = f.forecast(t0, t0 + horizons)
        truth = dock.position(t0 + horizons)[:, 2]
        err.append(mean[:, 2] - truth)
        std.append(sd[:, 2])
        pers.append(p[i - 1, 2] - truth)
    return {"err": np.array(err), "pers": np.array(pers), "std": np.array(std)}


def rms(e: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(e**2, axis=0))


@pytest.fixture(scope="module")
def narrow_run() -> tuple[dict[str, np.ndarray], float]:
    """Two seas (seeds 0 and 1), 180 s of training, then forecasts every second for 120 s at 0.5, 1 and
    3 s ahead; 2 cm noise, 5 % frames lost and a 3 s burst lost during the test."""
    out: dict[str, list[np.ndarray]] = {"err": [], "pers": [], "std": []}
    sig2 = []
    horizons = np.array([0.5, 1.0, 3.0])
    for seed in (0, 1):
        dock = narrow_sea_dock(seed)
        rng = np.random.default_rng(100 + seed)
        fixes = camera_fixes(dock, 305.0, rng, noise_m=0.02, bursts=((60.0, 4.0), (230.0, 3.0)))
        r = run(dock, fixes, np.arange(180.0, 300.0, 1.0), horizons)
        for k in out:
            out[k].append(r[k])
        sig2.append(float(np.var(dock.position(np.arange(0.0, 305.0, 0.1))[:, 2])))
    return {k: np.concatenate(v) for k, v in out.items()}, math.sqrt(float(np.mean(sig2)))


def test_narrow_sea_beats_persistence(narrow_run: tuple[dict[str, np.ndarray], float]) -> None:
    """After 180 s of fixes, 1 s ahead within 0.35 and 3 s ahead within 0.65 of the heave's std, and
    under half of persistence's error at both.  Measured here 0.22 and 0.41 (persistence 0.98 and 2.0);
    over other seas and seeds 0.20-0.30 and 0.40-0.60 (benchmarks/dock_forecast.py), and the predictor
    given the sea's true covariance 0.18-0.25 and 0.34-0.47: the bounds leave room for a harder sea,
    not for a forecaster that does no better than persistence."""
    r, sig = narrow_run
    f, p = rms(r["err"]) / sig, rms(r["pers"]) / sig
    assert f[1] < 0.35 and f[2] < 0.65, f"forecast RMS / std at 0.5, 1, 3 s: {np.round(f, 3)}"
    assert np.all(f[1:] < 0.5 * p[1:]), f"forecast {np.round(f, 3)} vs persistence {np.round(p, 3)}"
    assert p[1] > 0.6 and p[2] > 1.2, f"persistence {np.round(p, 3)}: the sea is not the one assumed"


def test_narrow_sea_std_is_calibrated(narrow_run: tuple[dict[str, np.ndarray], float]) -> None:
    """The truth lies within +-2 std in 85-100 % of the forecasts at each horizon (nominal 95.4 %; the
    240 origins are correlated over a wave period or so, hence the margin), and the std is not
    padded: the RMS of error / std is 0.7-1.3."""
    r, _ = narrow_run
    z = r["err"] / r["std"]
    coverage = np.mean(np.abs(z) <= 2.0, axis=0)
    z_rms = rms(z)
    assert np.all((coverage >= 0.85) & (coverage <= 1.0)), f"coverage at 0.5, 1, 3 s: {coverage}"
    assert np.all((z_rms > 0.7) & (z_rms < 1.3)), f"RMS of error / std at 0.5, 1, 3 s: {z_rms}"


def test_std_grows_with_horizon() -> None:
    """From one origin the std rises with the horizon towards the heave's std (climatology)."""
    dock = narrow_sea_dock(2)
    t, p, s = camera_fixes(dock, 120.0, np.random.default_rng(7), noise_m=0.02)
    f = DockForecaster()
    for i in range(t.size):
        f.update(t[i], p[i], s[i])
    assert f.ready
    horizons = np.array([0.0, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 30.0, 200.0])
    _, sd = f.forecast(t[-1], t[-1] + horizons)
    assert np.all(np.diff(sd[:6, 2]) > 0), sd[:, 2]
    sig = f.signal_std_m[2]
    assert sd[0, 2] < 0.1 * sig
    assert sd[-1, 2] == pytest.approx(sig, rel=0.02)  # beyond the covariance span: the climatology


def test_pure_sinusoid_is_forecast_almost_exactly() -> None:
    """The paper's dock (6.35 cm at 0.6 Hz), 2 mm noise (the camera close up), 5 % frames lost: after
    180 s, 1 s and 3 s ahead within 0.05 of its std (2 mm of 45 mm; measured about 0.025 and 0.03),
    where persistence errs by 1.7 and 0.7 of it."""
    dock = paper_dock()
    fixes = camera_fixes(dock, 245.0, np.random.default_rng(3), noise_m=0.002)
    r = run(dock, fixes, np.arange(180.0, 240.0, 0.5), np.array([1.0, 3.0]))
    sig = dock.amplitude_m / math.sqrt(2.0)
    f = rms(r["err"]) / sig
    assert np.all(f < 0.05), f"forecast RMS / std at 1, 3 s: {np.round(f, 4)}"
    assert np.all(rms(r["pers"]) / sig > 0.5)


def test_gap_forecast_runs_on_and_recovers() -> None:
    """6 s without a fix: the forecaster stays ready, its std grows through the gap and keeps covering
    the truth; 1 s after fixes return the 1 s-ahead error is back to its usual size."""
    dock = narrow_sea_dock(3)
    gap0, gap_len = 150.0, 6.0
    t, p, s = camera_fixes(dock, 175.0, np.random.default_rng(11), noise_m=0.02, bursts=((gap0, gap_len),))
    f = DockForecaster()
    i = 0
    sig = float(np.std(dock.position(np.arange(0.0, 175.0, 0.1))[:, 2]))
    stds, errs = [], []
    for t0 in np.arange(140.0, 170.0, 0.25):
        while i < t.size and t[i] <= t0 - LATENCY_S:
            f.update(t[i], p[i], s[i])
            i += 1
        mean, sd = f.forecast(t0, np.array([t0, t0 + 1.0]))
        truth = dock.position(np.array([t0, t0 + 1.0]))[:, 2]
        stds.append(sd[:, 2])
        errs.append(mean[:, 2] - truth)
    assert f.ready
    tt = np.arange(140.0, 170.0, 0.25)
    stds_a, errs_a = np.array(stds), np.array(errs)
    in_gap = (tt > gap0 + 0.5) & (tt < gap0 + gap_len)
    now_std = stds_a[in_gap, 0]
    # it grows through the gap (not strictly: with ten seconds of a narrow-band past, the error of
    # predicting half a period ahead can exceed that of a whole period)
    assert now_std[-1] > 3.0 * stds_a[tt < gap0, 0].mean()
    assert np.all(np.diff(now_std) > -0.05 * now_std[:-1]), now_std
    assert np.all(np.abs(errs_a[in_gap, 0]) <= 3.0 * now_std), "the grown std still covers the truth"
    back = tt > gap0 + gap_len + 1.0
    assert rms(errs_a[back, 1]) / sig < 0.35, "1 s ahead after the gap"


def test_outlier_is_rejected_and_changes_nothing() -> None:
    """A fix 1 m off, 7 s before the forecast, is rejected: the forecast stays within 1 mm of the one
    without it (the older fixes are thinned a little differently), where accepting it (no gate) moves it
    by centimetres.  A run of such fixes at a new level (the dock moved) restarts the forecaster."""
    dock = narrow_sea_dock(4)
    t, p, s = camera_fixes(dock, 100.0, np.random.default_rng(5), noise_m=0.02)
    clean, dirty = DockForecaster(), DockForecaster()
    naive = DockForecaster(DockForecastSettings(outlier_gate=1e6))
    k = int(np.searchsorted(t, 93.3))  # not a refit's time (every 10 s from 60 s): the refit would wait
    for i in range(t.size):
        clean.update(t[i], p[i], s[i])
        q = p[i] + np.array([0.0, 0.0, 1.0]) if i == k else p[i]
        accepted = dirty.update(t[i], q, s[i])
        assert accepted == (i != k)
        naive.update(t[i], q, s[i])
    assert dirty.rejected == 1 and dirty.restarts == 0 and naive.rejected == 0
    times = t[-1] + np.array([0.1, 1.0, 3.0])
    ref = clean.forecast(t[-1], times)[0]
    np.testing.assert_allclose(dirty.forecast(t[-1], times)[0], ref, atol=1e-3)
    assert np.abs(naive.forecast(t[-1], times)[0] - ref).max() > 0.02
    # the dock (or the frame it is measured in) jumps 2 m north: rejected, then a restart
    n = dirty.settings.max_rejections
    t_next = t[-1] + np.arange(1, n + 1) / RATE_HZ
    for i in range(n):
        dirty.update(t_next[i], dock.position(t_next[i]) + np.array([2.0, 0.0, 0.0]), s[0])
    assert dirty.restarts == 1 and not dirty.ready and dirty.n_measurements == n
    assert dirty.level(t_next[-1])[0] == pytest.approx(2.0, abs=0.05)


def test_out_of_order_and_nonfinite_fixes_are_refused() -> None:
    f = DockForecaster()
    assert f.update(1.0, np.zeros(3), np.full(3, 0.01))
    assert not f.update(1.0, np.ones(3), np.full(3, 0.01))
    assert not f.update(0.5, np.ones(3), np.full(3, 0.01))
    assert not f.update(2.0, np.array([0.0, math.nan, 0.0]), np.full(3, 0.01))
    assert f.n_measurements == 1 and f.rejected == 3
    with pytest.raises(ValueError, match="precedes the latest fix"):
        f.forecast(0.5, np.array([1.0]))


def test_cold_start_is_the_climatology() -> None:
    """Before min_history_s: not ready, the forecast is the mean of the fixes with their spread, and
    no velocity; before any fix a forecast is an error."""
    f = DockForecaster()
    with pytest.raises(RuntimeError, match="no dock fix"):
        f.forecast(0.0, np.array([1.0]))
    dock = narrow_sea_dock(5)
    t, p, s = camera_fixes(dock, 30.0, np.random.default_rng(9), noise_m=0.02)
    for i in range(t.size):
        f.update(t[i], p[i], s[i])
    assert not f.ready
    pred = f.predict(np.array([31.0, 35.0]))
    assert not pred.ready
    np.testing.assert_allclose(pred.position_ned_m[0], p.mean(axis=0))
    np.testing.assert_allclose(pred.std_m[0], np.sqrt(p.var(axis=0) + 0.02**2))
    np.testing.assert_array_equal(pred.velocity_ned_m_s, 0.0)


def test_drift_of_the_level_is_followed() -> None:
    """The same fixes, drifting 1 cm/s (the vehicle's navigation under them): 1 s ahead errs at most 10 %
    more than without the drift (measured 1 %; 0.30 of the heave's std, persistence 1.1).  Without the
    level's trend the drifting fixes leave the gate and the forecaster keeps starting again."""
    dock = narrow_sea_dock(6)
    t, p, s = camera_fixes(dock, 250.0, np.random.default_rng(13), noise_m=0.02)
    drift = np.array([0.0, 0.0, 0.01])

    class Drifting(WecDock):
        def position(self, tt: float | np.ndarray) -> np.ndarray:
            return super().position(tt) + np.multiply.outer(np.asarray(tt, dtype=float), drift)

    truth = Drifting(dock.sea, dock.position_ned_m, 0.0, dock.heave_rao)
    origins, horizon = np.arange(180.0, 245.0, 1.0), np.array([1.0])
    still = rms(run(dock, (t, p, s), origins, horizon)["err"])[0]
    drifting = rms(run(truth, (t, p + np.outer(t, drift), s), origins, horizon)["err"])[0]
    sig = float(np.std(dock.position(np.arange(0.0, 250.0, 0.1))[:, 2]))
    assert drifting < 1.1 * still and drifting < 0.4 * sig, (drifting / sig, still / sig)


@pytest.fixture(scope="module")
def trained() -> tuple[DockForecaster, WecDock]:
    dock = narrow_sea_dock(8)
    t, p, s = camera_fixes(dock, 100.0, np.random.default_rng(17), noise_m=0.02)
    f = DockForecaster()
    for i in range(t.size):
        f.update(t[i], p[i], s[i])
    assert f.ready
    return f, dock


def test_forecast_dock_is_a_dock_motion_consistent_with_the_forecast(
    trained: tuple[DockForecaster, WecDock],
) -> None:
    """position = forecast, velocity = d position / dt (central differences, 1 ms), shapes of
    DockMotion (scalar -> (3,), (n,) -> (n, 3), (2, 4) -> (2, 4, 3)), trajectory and reference_state."""
    f, dock = trained
    motion: DockMotion = ForecastDock(f, heading_rad=0.3)
    t_now = f.last_time_s + LATENCY_S
    times = t_now + np.linspace(-2.0, 5.0, 29)
    np.testing.assert_allclose(motion.position(times), f.forecast(t_now, times)[0], atol=1e-12)
    h = 1e-3
    fd = (motion.position(times + h) - motion.position(times - h)) / (2.0 * h)
    vel = motion.velocity(times)
    v_scale = float(np.std(dock.velocity(np.arange(0.0, 100.0, 0.1))[:, 2]))
    np.testing.assert_allclose(vel, fd, atol=0.01 * v_scale)
    assert np.abs(vel[:, 2]).max() > 0.2 * v_scale  # it does move
    assert motion.position(t_now).shape == (3,)
    assert motion.velocity(t_now).shape == (3,)
    assert motion.position(times.reshape(29, 1)[:8].reshape(2, 4)).shape == (2, 4, 3)
    tt, pos, v = motion.trajectory(t_now, 0.05, 20)
    assert tt.shape == (21,) and pos.shape == (21, 3) and v.shape == (21, 3)
    np.testing.assert_allclose(pos, motion.position(tt), atol=1e-12)
    np.testing.assert_allclose(v, motion.velocity(tt), atol=1e-12)
    ref = motion.reference_state(tt)
    assert ref.shape == (21, 12)
    np.testing.assert_allclose(ref[:, 5], 0.3)
    assert motion.heading_rad == 0.3
    anchor = np.asarray(motion.position_ned_m)
    np.testing.assert_allclose(anchor, dock.position_ned_m, atol=0.05)
    assert isinstance(motion, ForecastDock) and ForecastDock(f).std(t_now).shape == (3,)


def test_forecast_follows_the_dock(trained: tuple[DockForecaster, WecDock]) -> None:
    """The adapter's position and velocity near now are close to the true dock's (the camera's 2 cm
    noise and the sea's unpredictability allowing)."""
    f, dock = trained
    motion = ForecastDock(f)
    times = f.last_time_s + LATENCY_S + np.arange(0.0, 1.0, 0.05)
    sig = float(np.std(dock.position(np.arange(0.0, 100.0, 0.1))[:, 2]))
    v_sig = float(np.std(dock.velocity(np.arange(0.0, 100.0, 0.1))[:, 2]))
    assert rms(motion.position(times)[:, 2] - dock.position(times)[:, 2]) < 0.3 * sig
    assert rms(motion.velocity(times)[:, 2] - dock.velocity(times)[:, 2]) < 0.4 * v_sig


def test_settings_are_strict() -> None:
    with pytest.raises(ValueError, match="segment_s"):
        DockForecastSettings(segment_s=400.0)
    with pytest.raises(ValueError, match="covariance_span_s"):
        DockForecastSettings(covariance_span_s=200.0)
    with pytest.raises(ValueError):
        DockForecastSettings(unknown=1.0)  # type: ignore[call-arg]
    s = DockForecastSettings()
    for name, field in type(s).model_fields.items():
        assert field.description, f"{name} has no description"
