"""How well the dock's motion is forecast from the camera's fixes alone (auvdock.estimation.dock_forecast).

For each mission's true dock (``--seeds`` seas each) the camera's fixes are simulated -- 15 Hz, 0.1 s
late, white noise (``--noise``; by default 5 mm in the basin, the dock 2 m away in clear water, and 2 cm
at PacWave, 3 m away in coastal water: the camera's "few mm to few cm"), 2 % of the frames lost at
random (``CameraFixModel.dropout``) and bursts of 2-6 s lost about once a minute (the dock out of view;
an assumption) -- and fed to a :class:`DockForecaster` in a 20 Hz control loop: at each 50 ms step
the fixes that have arrived are added (``update``) and the dock is forecast over a 10-step horizon
(``forecast``: the MPC's 0.5 s), both timed.  Every 0.5 s after ``--train`` seconds the forecast at 0.5,
1, 2, 3 and 5 s ahead is compared with the true dock, beside

* persistence: the latest fix held;
* climatology: the mean of the fixes of the last 5 min (the dock's anchor);

as the RMS error (m) and as a fraction of the heave's standard deviation, pooled over the seeds, with
the share of the true positions inside the forecast's +-2 std (nominal 95.4 %).  Origins in a burst
of lost frames count: a forecaster has to forecast on.

With ``--source telemetry`` the positions are the dock's own telemetry instead (what the deployable
controllers forecast from: ``sensors.dock_telemetry``'s defaults, 10 Hz, 0.25 s late, 5 cm, 2 % lost,
no bursts: the dock's motion unit never loses sight of the dock).

    python benchmarks/dock_forecast.py [--seeds 3] [--missions basin_regular ...] [--train 180]
                                       [--duration 300] [--noise 0.02] [--outliers 0.002]
                                       [--source camera|telemetry]
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass

import numpy as np

from auvdock.config.mission import load_mission
from auvdock.estimation.dock_forecast import DockForecaster
from auvdock.sensing.settings import DockTelemetrySettings
from auvdock.world.dock import DockMotion

MISSIONS = ("basin_regular", "pacwave_common_10m", "pacwave_energetic_10m")
HORIZONS_S = np.array([0.5, 1.0, 2.0, 3.0, 5.0])
RATE_HZ = 15.0
LATENCY_S = 0.1
CONTROL_DT_S = 0.05
MPC_STEPS = 10
LOST = 0.02
BURST_EVERY_S = 60.0
BURST_S = (2.0, 6.0)
#: the camera's noise per mission when --noise is not given, m
NOISE_M = {"basin_regular": 0.005}
DEFAULT_NOISE_M = 0.02


@dataclass(frozen=True)
class Source:
    """Where the dock's positions come from: rate (Hz), latency (s), share lost, bursts lost or not."""

    name: str
    rate_hz: float
    latency_s: float
    lost: float
    bursts: bool


CAMERA = Source("camera fixes", RATE_HZ, LATENCY_S, LOST, True)
_TEL = DockTelemetrySettings()
#: the dock's own telemetry (sensors.dock_telemetry's defaults): never out of view
TELEMETRY = Source("the dock's telemetry", _TEL.rate_hz, _TEL.latency_s, _TEL.dropout, False)


def camera_fixes(
    dock: DockMotion,
    t_end: float,
    noise_m: float,
    outliers: float,
    rng: np.random.Generator,
    source: Source = CAMERA,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fix times (n,), positions (n, 3) NED m and stds (n, 3) m, as the source would give them."""
    t = np.arange(0.0, t_end, 1.0 / source.rate_hz)
    keep = rng.uniform(size=t.size) >= source.lost
    start = rng.exponential(BURST_EVERY_S)
    while source.bursts and start < t_end:
        keep &= ~((t >= start) & (t < start + rng.uniform(*BURST_S)))
        start += rng.exponential(BURST_EVERY_S)
    t = t[keep]
    p = dock.position(t) + noise_m * rng.standard_normal((t.size, 3))
    bad = rng.uniform(size=t.size) < outliers  # wrong decodes: 0.3-1 m off on every axis
    p[bad] += rng.choice([-1.0, 1.0], size=(int(bad.sum()), 3)) * rng.uniform(0.3, 1.0, (int(bad.sum()), 3))
    return t, p, np.full((t.size, 3), noise_m)


def run_one(
    dock: DockMotion,
    train_s: float,
    duration_s: float,
    noise_m: float,
    outliers: float,
    seed: int,
    source: Source = CAMERA,
) -> dict[str, np.ndarray | list[float] | float]:
    """One sea: errors (n_origins, n_horizons) of the forecast, persistence and climatology (heave, m),
    the forecast's std, the heave's std, and the times of each update and 10-step forecast call (s)."""
    rng = np.random.default_rng([seed, 0xD0C])
    t_end = train_s + duration_s + HORIZONS_S[-1] + 1.0
    t, p, s = camera_fixes(dock, t_end, noise_m, outliers, rng, source)
    latency = source.latency_s
    f = DockForecaster()
    err, pers, clim, std = [], [], [], []
    t_update: list[float] = []
    t_forecast: list[float] = []
    i = 0
    steps = np.arange(0.0, train_s + duration_s, CONTROL_DT_S)
    every = int(round(0.5 / CONTROL_DT_S))
    mpc = CONTROL_DT_S * np.arange(1, MPC_STEPS + 1)
    for k, t0 in enumerate(steps):
        while i < t.size and t[i] <= t0 - latency:
            a = time.perf_counter()
            f.update(t[i], p[i], s[i])
            t_update.append(time.perf_counter() - a)
            i += 1
        if i == 0:
            continue
        a = time.perf_counter()
        f.forecast(t0, t0 + mpc)
        if t0 >= train_s:
            t_forecast.append(time.perf_counter() - a)
        if t0 < train_s or k % every:
            continue
        mean, sd = f.forecast(t0, t0 + HORIZONS_S)
        truth = dock.position(t0 + HORIZONS_S)[:, 2]
        recent = (t > t0 - latency - 300.0) & (t <= t0 - latency)
        err.append(mean[:, 2] - truth)
        std.append(sd[:, 2])
        pers.append(p[i - 1, 2] - truth)
        clim.append(p[recent, 2].mean() - truth)
    heave = dock.position(np.arange(0.0, t_end, 0.1))[:, 2]
    return {
        "err": np.array(err),
        "pers": np.array(pers),
        "clim": np.array(clim),
        "std": np.array(std),
        "var": float(np.var(heave)),
        "t_update": t_update,
        "t_forecast": t_forecast,
    }


def _row(label: str, values: np.ndarray, fmt: str) -> str:
    return f"  {label:<22}" + "".join(f"{v:>8{fmt}}" for v in values)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=3, help="seas per mission (seeds 0..n-1)")
    ap.add_argument("--missions", nargs="+", default=list(MISSIONS))
    ap.add_argument("--train", type=float, default=180.0, help="fixes before the first scored forecast, s")
    ap.add_argument("--duration", type=float, default=300.0, help="scored time per sea, s")
    ap.add_argument("--noise", type=float, default=None, help="the camera's noise per axis, m")
    ap.add_argument("--outliers", type=float, default=0.0, help="share of fixes 0.3-1 m off (wrong decodes)")
    ap.add_argument(
        "--source",
        choices=("camera", "telemetry"),
        default="camera",
        help="camera: the camera's fixes (15 Hz, 0.1 s, bursts lost); telemetry: the dock's own "
        "(sensors.dock_telemetry's defaults: 10 Hz, 0.25 s, 5 cm, 2 %% lost, never out of view)",
    )
    args = ap.parse_args()
    source = CAMERA if args.source == "camera" else TELEMETRY
    t_start = time.perf_counter()
    all_update: list[float] = []
    all_forecast: list[float] = []
    bursts = ""
    if source.bursts:
        bursts = f" and {BURST_S[0]:g}-{BURST_S[1]:g} s bursts about every {BURST_EVERY_S:g} s"
    print(
        f"dock forecast from {source.name}: {source.rate_hz:g} Hz, {source.latency_s:g} s late, "
        f"{source.lost:.0%} lost{bursts}; trained "
        f"{args.train:g} s, scored every 0.5 s for {args.duration:g} s; heave (down) errors"
    )
    for name in args.missions:
        default_noise = NOISE_M.get(name, DEFAULT_NOISE_M) if args.source == "camera" else _TEL.std_m
        noise = args.noise if args.noise is not None else default_noise
        runs = []
        for seed in range(args.seeds):
            m = load_mission(name).with_updates({"seed": seed})
            dock = m.build_dock(m.build_sea())
            runs.append(run_one(dock, args.train, args.duration, noise, args.outliers, seed, source))
        sig = math.sqrt(float(np.mean([r["var"] for r in runs])))
        err = np.concatenate([r["err"] for r in runs])
        std = np.concatenate([r["std"] for r in runs])
        rows = {
            "forecast": err,
            "persistence": np.concatenate([r["pers"] for r in runs]),
            "climatology": np.concatenate([r["clim"] for r in runs]),
        }
        print(
            f"\n{name}: {args.seeds} seas, heave std {sig:.3f} m, noise {noise:g} m, "
            f"{err.shape[0]} forecasts"
        )
        print(f"  {'horizon s':<22}" + "".join(f"{h:>8g}" for h in HORIZONS_S))
        for label, e in rows.items():
            r = np.sqrt(np.mean(e**2, axis=0))
            print(_row(f"{label} RMS m", r, ".4f"))
            print(_row("  / heave std", r / sig, ".3f"))
        print(_row("forecast std RMS m", np.sqrt(np.mean(std**2, axis=0)), ".4f"))
        print(_row("coverage of +-2 std", np.mean(np.abs(err) <= 2.0 * std, axis=0), ".3f"))
        for r in runs:
            all_update += r["t_update"]  # type: ignore[arg-type]
            all_forecast += r["t_forecast"]  # type: ignore[arg-type]
    u = np.array(all_update) * 1e6
    fc = np.array(all_forecast) * 1e6
    print(f"\ncost per call (this machine, {u.size} updates, {fc.size} forecasts):")
    print(
        f"  update              median {np.median(u):6.0f} us   p95 {np.percentile(u, 95):6.0f} us   "
        f"max {u.max():6.0f} us (a refit of the spectrum, every 10 s)"
    )
    print(
        f"  forecast {MPC_STEPS} steps   median {np.median(fc):6.0f} us   "
        f"p95 {np.percentile(fc, 95):6.0f} us   "
        f"max {fc.max():6.0f} us (solved again after new fixes: every 50 ms step)"
    )
    print(f"total {time.perf_counter() - t_start:.0f} s")


if __name__ == "__main__":
    main()
