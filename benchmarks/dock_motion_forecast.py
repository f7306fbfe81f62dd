"""The dock's heave forecast from its motion unit, against the best any linear forecaster can do.

For each mission's dock and ``--seeds`` seas, the dock's motion unit is simulated as the suite does
(:class:`auvdock.sensing.motion_unit.MotionUnit`, ``sensors.dock_telemetry``: 10 Hz, 0.25 s late, 2 % of the
samples lost, ``history_s`` of record at the start) for each ``--unit`` (``mru``: the data sheet's unit, a
slow 5 cm error, 1 cm white noise and the heave rate; ``white``: 5 cm of white noise, no rate).  In a 20 Hz
loop every ``--every`` s the heave 0.5, 1 and 2 s ahead is forecast by

* **bound**: the optimal linear predictor given the same readings of the last ``--past`` s, computed from
  the *true* covariance of the realised heave (the sea's components through the buoy's RAO) and of the
  unit's errors (the slow error's exponential covariance, the white noise): the conditional mean of a
  Gaussian process (kriging), which no linear forecaster of these readings beats;
* **modes**: the navigation filter's dock states (:class:`auvdock.estimation.dock_modes.ModeBank`:
  ``--modes`` oscillators fitted to the spectrum estimated from the record, the unit's slow error as a
  state, the readings applied ``latency`` late as the filter applies them);
* **kriging**: the shipped forecaster (:class:`auvdock.estimation.dock_forecast.DockForecaster`, with the
  unit's settings: :func:`auvdock.estimation.dock_knowledge.forecast_settings`): the heave readings, the
  rate readings and the unit's slow error as a known covariance;
* **estimated**: the optimal predictor's formula on the same readings with the spectrum the forecaster
  estimated in place of the true one (what the estimate costs).

Printed: RMS error (cm) per horizon, pooled over the seeds, each method's ratio to the bound, and the share
of the truth inside the modes' +-2 std (nominal 95.4 %).

    python benchmarks/dock_motion_forecast.py [--seeds 3] [--missions basin_regular pacwave_common_10m]
                                              [--unit mru white] [--modes 4] [--duration 120]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from dock_modes import ModeBank, fit_modes, scalar_update

from auvdock.config.mission import load_mission
from auvdock.estimation.dock_forecast import DockForecaster
from auvdock.estimation.dock_knowledge import forecast_settings
from auvdock.sensing.motion_unit import MotionUnit
from auvdock.sensing.settings import DockTelemetrySettings

MISSIONS = ("basin_regular", "pacwave_common_10m", "pacwave_energetic_10m")
HORIZONS_S = np.array([0.0, 0.5, 1.0, 2.0])
DT_S = 0.05
METHODS = ("bound", "estimated", "modes", "kriging")


def heave_covariance(dock: object) -> tuple[np.ndarray, np.ndarray]:
    """The true heave's components: angular frequencies (n,) rad/s and variances (n,) m^2 (a WEC dock's
    components through its RAO, or a sinusoid's one line)."""
    amp = getattr(dock, "_amp", None)
    if amp is not None:
        return np.asarray(dock._w, dtype=float), 0.5 * np.asarray(amp, dtype=float) ** 2  # type: ignore[attr-defined]
    a = float(dock.amplitude_m)  # type: ignore[attr-defined]
    return np.array([2.0 * math.pi * float(dock.frequency_hz)]), np.array([0.5 * a * a])  # type: ignore[attr-defined]


#: The lag grid of the true covariance's tables, s: the loop's step and the unit's sample period are
#: multiples of it.
LAG_S = 0.05
_TABLES: dict[tuple[int, int], np.ndarray] = {}


def _table(w: np.ndarray, var: np.ndarray, d: int, span_s: float = 120.0) -> np.ndarray:
    """c, -c' or c'' (per ``d``; with the sign of a positive lag) at lags ``k LAG_S``, k = 0..span/LAG_S."""
    key = (hash(w.tobytes() + var.tobytes()), d)
    if key not in _TABLES:
        lags = LAG_S * np.arange(int(span_s / LAG_S) + 1)
        ph = np.outer(lags, w)
        if d == 0:
            _TABLES[key] = np.cos(ph) @ var
        elif d == 1:
            _TABLES[key] = -(np.sin(ph) @ (var * w))
        else:
            _TABLES[key] = -(np.cos(ph) @ (var * w * w))
    return _TABLES[key]


def bound_forecast(
    w: np.ndarray,
    var: np.ndarray,
    tel: DockTelemetrySettings,
    t_h: np.ndarray,
    y_h: np.ndarray,
    t_v: np.ndarray,
    y_v: np.ndarray,
    targets: np.ndarray,
) -> np.ndarray:
    """The optimal linear predictor (kriging with the true covariances) of the heave (down) at ``targets``
    from heave readings (``t_h``, ``y_h``) and rate readings (``t_v``, ``y_v``)."""

    def c(tau: np.ndarray, d: int) -> np.ndarray:
        # d-th derivative of c(tau) = sum var cos(w tau), from exact tables on the lag grid of the samples
        # and the loop (multiples of LAG_S: every reading and every target sits on it)
        idx = np.rint(np.asarray(tau) / LAG_S).astype(np.int64)
        out = _table(w, var, d)[np.abs(idx)]
        return np.sign(idx) * out if d == 1 else out

    mru = tel.motion_unit == "mru"
    n_h, n_v = t_h.size, t_v.size
    K = np.empty((n_h + n_v, n_h + n_v))
    K[:n_h, :n_h] = c(t_h[:, None] - t_h[None, :], 0)
    if mru:
        K[:n_h, :n_h] += tel.heave_error_std_m**2 * np.exp(
            -np.abs(t_h[:, None] - t_h[None, :]) / tel.heave_error_tau_s
        )
        noise = tel.heave_noise_m
    else:
        noise = tel.std_m
    K[:n_h, :n_h] += noise**2 * np.eye(n_h)
    if n_v:
        # E[h(a) h'(b)] = -c'(a - b);  E[h'(a) h'(b)] = -c''(a - b)
        K[:n_h, n_h:] = -c(t_h[:, None] - t_v[None, :], 1)
        K[n_h:, :n_h] = K[:n_h, n_h:].T
        K[n_h:, n_h:] = -c(t_v[:, None] - t_v[None, :], 2) + tel.rate_noise_m_s**2 * np.eye(n_v)
    k = np.concatenate(
        [c(targets[:, None] - t_h[None, :], 0), -c(targets[:, None] - t_v[None, :], 1)], axis=1
    )
    y = np.concatenate([y_h, y_v])
    return k @ np.linalg.solve(K, y)


def run_one(
    mission: str,
    seed: int,
    unit: str,
    n_modes: int,
    duration: float,
    past: float,
    every: float,
    true_spectrum: bool = False,
) -> dict:
    m = load_mission(mission).with_updates({"seed": seed})
    dock = m.build_dock(m.build_sea())
    tel = m.sensors.dock_telemetry.model_copy(update={"motion_unit": unit})
    anchor = np.asarray(dock.position_ned_m, dtype=float)
    rng = np.random.default_rng([seed, 16])
    unit_sim = MotionUnit(tel, np.random.default_rng([seed, 17]))
    period = 1.0 / tel.rate_hz
    ts = np.arange(-tel.history_s, duration + 3.0, period)
    readings = []
    for t in ts:
        lost = rng.random() < tel.dropout
        rs = unit_sim.sample(float(t), dock.position(t) - anchor, dock.velocity(t))
        if not lost:
            readings.extend(rs)
    readings.sort(key=lambda r: r.t)
    w, var = heave_covariance(dock)
    # the kriging forecaster and the modes' spectrum: the record before the start
    kf = DockForecaster(forecast_settings(tel))
    bank = ModeBank(n_modes, tel.heave_error_std_m if unit == "mru" else 0.0, tel.heave_error_tau_s)
    i = 0
    lat = tel.latency_s
    while i < len(readings) and readings[i].t <= -lat:
        r = readings[i]
        if r.kind == "dock_motion":
            kf.update(r.t, r.value, r.std)
        else:
            kf.update_rate(r.t, r.value, r.std)
        i += 1
    spec = kf.spectrum
    assert spec is not None
    omega, spectrum = spec[0], spec[1][2]
    if true_spectrum:  # the realised heave's lines, binned on the estimate's grid
        d = float(omega[1] - omega[0])
        spectrum = (
            np.bincount(np.rint(w / d).astype(np.int64), weights=var, minlength=omega.size)[: omega.size] / d
        )
    modes = fit_modes(omega, spectrum, n_modes)
    assert modes is not None
    bank.set_modes(modes)
    # the modes' filter from the stationary prior over the last 60 s of the record, then the loop
    zm = np.zeros(bank.nm)
    Pm = bank.stationary_cov()
    t_f = None
    j0 = max(0, next((k for k, r in enumerate(readings) if r.t >= -lat - 60.0), 0))
    errs: dict[str, list[np.ndarray]] = {"bound": [], "modes": [], "kriging": [], "estimated": []}
    w_est, var_est = omega, spectrum * float(omega[1] - omega[0])
    inside = []
    cost = []
    j = j0
    steps = np.arange(0.0, duration, DT_S)
    k_every = int(round(every / DT_S))

    def advance(t_new: float) -> None:
        nonlocal zm, Pm, t_f
        if t_f is not None and t_new > t_f:
            F = bank.transition(t_new - t_f)
            zm = F @ zm
            Pm = F @ Pm @ F.T + bank.process_cov(t_new - t_f)
        t_f = t_new

    # the record's last minute, each reading at its own time (the history arrives at once)
    while j < len(readings) and readings[j].t <= -lat:
        r = readings[j]
        advance(r.t)
        row = bank.heave_row(0.0, rate=r.kind == "dock_motion_rate")
        scalar_update(zm, Pm, row, float(r.value[2]), float(r.std[2]) ** 2)
        j += 1
    for step, t0 in enumerate(steps):
        a = time.perf_counter()
        advance(float(t0))
        while j < len(readings) and readings[j].t <= t0 - lat:
            r = readings[j]
            rate = r.kind == "dock_motion_rate"
            tau = float(t0) - r.t
            row = bank.heave_row(tau, rate=rate)
            scalar_update(zm, Pm, row, float(r.value[2]), float(r.std[2]) ** 2 + bank.lag_variance(tau, rate))
            if r.kind == "dock_motion":
                kf.update(r.t, r.value, r.std)
            else:
                kf.update_rate(r.t, r.value, r.std)
            j += 1
        cost.append(time.perf_counter() - a)
        if step % k_every:
            continue
        truth = dock.position(t0 + HORIZONS_S)[:, 2] - anchor[2]
        h, _, sd = bank.forecast(zm, Pm, HORIZONS_S)
        errs["modes"].append(h - truth)
        inside.append(np.abs(h - truth) <= 2.0 * sd)
        errs["kriging"].append(kf.predict(t0 + HORIZONS_S).position_ned_m[:, 2] - truth)
        seen = [r for r in readings[:j] if r.t > t0 - lat - past]
        th = np.array([r.t for r in seen if r.kind == "dock_motion"])
        yh = np.array([r.value[2] for r in seen if r.kind == "dock_motion"])
        tv = np.array([r.t for r in seen if r.kind == "dock_motion_rate"])
        yv = np.array([r.value[2] for r in seen if r.kind == "dock_motion_rate"])
        errs["bound"].append(bound_forecast(w, var, tel, th, yh, tv, yv, t0 + HORIZONS_S) - truth)
        errs["estimated"].append(bound_forecast(w_est, var_est, tel, th, yh, tv, yv, t0 + HORIZONS_S) - truth)
    return {
        **{k: np.array(v) for k, v in errs.items()},
        "inside": np.array(inside),
        "std": math.sqrt(float(var.sum())),
        "cost": np.array(cost),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--missions", nargs="+", default=list(MISSIONS))
    ap.add_argument("--unit", nargs="+", default=["mru", "white"], choices=["mru", "white"])
    ap.add_argument("--modes", type=int, default=4, help="oscillators of the modes' filter")
    ap.add_argument("--duration", type=float, default=120.0, help="scored time per sea, s")
    ap.add_argument("--past", type=float, default=30.0, help="readings the bound is conditioned on, s")
    ap.add_argument("--every", type=float, default=1.0, help="time between scored forecasts, s")
    ap.add_argument(
        "--true-spectrum",
        action="store_true",
        help="fit the modes to the realised heave's spectrum, not the estimate",
    )
    args = ap.parse_args()
    print(
        f"heave forecast from the dock's motion unit: {args.seeds} seas each, {args.duration:g} s "
        f"scored every "
        f"{args.every:g} s; bound = the optimal linear predictor on the last {args.past:g} s; RMS error, cm"
    )
    for mission in args.missions:
        for unit in args.unit:
            runs = [
                run_one(
                    mission, s, unit, args.modes, args.duration, args.past, args.every, args.true_spectrum
                )
                for s in range(args.seeds)
            ]
            rms = {k: np.sqrt(np.mean(np.concatenate([r[k] for r in runs]) ** 2, axis=0)) for k in METHODS}
            cover = float(np.mean(np.concatenate([r["inside"] for r in runs])))
            cost = np.concatenate([r["cost"] for r in runs]) * 1e3
            sig = float(np.mean([r["std"] for r in runs]))
            print(f"\n{mission}, unit {unit} (heave std {100 * sig:.1f} cm)")
            print("  " + f"{'ahead':<10}" + "".join(f"{h:>9.1f} s" for h in HORIZONS_S))
            for k in METHODS:
                ratio = (
                    "" if k == "bound" else "   ratio " + " ".join(f"{v:.2f}" for v in rms[k] / rms["bound"])
                )
                print("  " + f"{k:<10}" + "".join(f"{100 * v:>11.2f}" for v in rms[k]) + ratio)
            print(
                f"  modes: truth inside +-2 std {100 * cover:.1f} % (nominal 95.4); filter step median "
                f"{np.median(cost):.3f} ms, p99 {np.percentile(cost, 99):.3f} ms"
            )


if __name__ == "__main__":
    main()
