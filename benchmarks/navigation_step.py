"""Time NavigationFilter.step: median, p95, p99 and where the time goes.

    python benchmarks/navigation_step.py [--steps 4000] [--never-compile] [--waves]

BlueROV2 Heavy, dt = 0.05 s, 5-6 readings a step (attitude, gyro, accel, depth every step,
position every 10th, DVL every step).  Readings are precomputed so only the filter is timed.
``--waves``: the filter with its wave model (29 states: PacWave's common sea at 10 m, as
``pacwave_common_10m``'s filter has it) instead of the current alone (23).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=4000)
    ap.add_argument("--never-compile", action="store_true", help="AUVDOCK_COMPILE=never")
    ap.add_argument("--waves", action="store_true", help="the filter with its wave states")
    args = ap.parse_args()
    if args.never_compile:
        os.environ["AUVDOCK_COMPILE"] = "never"
    from auvdock.estimation.navigation_filter import NavigationFilter
    from auvdock.estimation.settings import NavigationSettings
    from auvdock.estimation.wave_model import WaveModel
    from auvdock.sensing import measurements as ms
    from auvdock.sensing.readings import Reading
    from auvdock.vehicle import load_vehicle

    dt = 0.05
    v = load_vehicle("bluerov2_heavy")
    waves = WaveModel(0.723, 0.1, (0.071, 0.161, 0.174)) if args.waves else None
    nav = NavigationFilter(NavigationSettings(), v, dt, waves=waves)
    print(f"step function: {nav.build}; {nav.nz} states")
    rng = np.random.default_rng(0)
    x = np.zeros(12)
    x[2] = 5.0
    u = np.full(v.n_thrusters, 2.0)
    std = {"attitude": 0.01, "gyro": 0.005, "accel": 0.05, "depth": 0.02, "position": 0.05, "dvl": 0.02}
    steps = []
    for k in range(args.steps):
        kinds = ["attitude", "gyro", "accel", "depth", "dvl"] + (["position"] if k % 10 == 0 else [])
        rd = []
        for kind in kinds:
            y = ms.measure(kind, v, x, u)
            rd.append(
                Reading(kind, k * dt, y + rng.normal(size=y.shape) * std[kind], np.full(y.shape, std[kind]))
            )
        steps.append(rd)
    nav.reset(x)
    t_step, t_pred, t_upd = [], [], []
    pc = time.perf_counter
    for k, rd in enumerate(steps):
        t = k * dt
        a = pc()
        nav.step(t, rd, u)
        t_step.append(pc() - a)
    # where the time goes: the CasADi call alone, the update alone (numpy)
    for _ in range(min(2000, args.steps)):
        a = pc()
        nav._evaluate(dt, 0.0)
        t_pred.append(pc() - a)
    rows, ang, _, _ = nav._rows[tuple(r.kind for r in steps[1])]
    vals = np.concatenate([r.value for r in steps[1]])
    var = np.concatenate([r.std for r in steps[1]]) ** 2
    P0, z0 = nav.P.copy(), nav.z.copy()
    for _ in range(min(2000, args.steps)):
        nav.P[:], nav.z[:] = P0, z0
        a = pc()
        nav._update(rows, vals, var, ang)
        t_upd.append(pc() - a)

    def show(name: str, ts: list[float]) -> None:
        us = np.array(ts) * 1e6
        print(
            f"{name:34s} median {np.median(us):7.1f} us  p95 {np.percentile(us, 95):7.1f}  "
            f"p99 {np.percentile(us, 99):7.1f}"
        )

    show("step (5-6 readings)", t_step)
    show("  CasADi call (predict + h, H)", t_pred)
    show("  stacked update (numpy)", t_upd)


if __name__ == "__main__":
    main()
