"""What fails at PacWave, variant by variant: ``pacwave_common_10m`` (Hs 1.75 m, the dock 10 m below the
WEC buoy) flown on the same seeds with one thing changed at a time.

Variants (each on ``--seeds`` seeds from ``--first-seed``):

* ``camera``: the mission as shipped (the camera alone, no acoustic positioning), CE;
* ``acoustic``: acoustic positioning added, Oracle (told the sea and the dock), CE told the dock's true
  motion (``sensors.dock_telemetry`` off: Assumption 2) and CE forecasting it from the telemetry;
* ``fast anchor``: the last, the camera's fixes moving the dock's anchor fast
  (``navigation.dock_walk_m_sqrt_s`` 0.2 instead of 0.005);
* ``telemetry 1 cm``: the last but one, the telemetry's noise 1 cm instead of 5;
* ``axis weights``: the same, the MPC's position error weighted 1, 10, 10 (north, east, down; the dock
  faces north: across its axis ten times along it) and velocity 1, 3, 3.

Prints per variant how each run ended, the captures, the forecast's displacement error 0.5 s ahead and,
for the camera alone without the wave model (``navigation.waves: off``, seed 1), how far the vehicle got
from the dock.

    python benchmarks/pacwave_capture.py [--seeds 8] [--first-seed 0] [--jobs 2]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from typing import Any

ACOUSTIC = {"sensors__position__source": "acoustic"}
AXIS_Q = [1.0, 10.0, 10.0, 100.0, 100.0, 100.0, 1.0, 3.0, 3.0, 100.0, 100.0, 100.0]
VARIANTS: list[tuple[str, str, dict[str, Any]]] = [
    ("camera", "ce", {}),
    ("acoustic", "oracle", ACOUSTIC),
    ("acoustic, told the dock", "ce", {**ACOUSTIC, "sensors__dock_telemetry__enabled": False}),
    ("acoustic", "ce", ACOUSTIC),
    ("acoustic, fast anchor", "ce", {**ACOUSTIC, "navigation__dock_walk_m_sqrt_s": 0.2}),
    ("acoustic, telemetry 1 cm", "ce", {**ACOUSTIC, "sensors__dock_telemetry__std_m": 0.01}),
    (
        "acoustic, axis weights",
        "ce",
        {**ACOUSTIC, "controller__weights__Q": AXIS_Q, "controller__weights__P": AXIS_Q},
    ),
]


def one(job: tuple[int, int, str]) -> tuple[int, int, str, float, float, float]:
    import auvdock

    warnings.simplefilter("ignore")
    i, seed, extra = job
    _, controller, kw = VARIANTS[i]
    run = auvdock.simulate("pacwave_common_10m", controller=controller, seed=seed, **json.loads(extra))
    o = run.outcome
    return (
        i,
        seed,
        o["reason"],
        o["end_time_s"],
        o.get("dock_forecast_rmse_0p5s_m", float("nan")),
        float(max(run.distance_m)),
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=8, help="how many seeds")
    ap.add_argument("--first-seed", type=int, default=0, help="the first of them")
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args()
    t0 = time.perf_counter()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    jobs = [(i, s, json.dumps(kw)) for i, (_, _, kw) in enumerate(VARIANTS) for s in seeds]
    jobs.append((0, 1, json.dumps({"navigation__waves": "off"})))
    results: dict[int, list[tuple[int, str, float, float]]] = {}
    waves_off = None
    with ProcessPoolExecutor(args.jobs) as ex:
        for k, (i, seed, reason, end, fc, far) in enumerate(ex.map(one, jobs)):
            if k == len(jobs) - 1:
                waves_off = (reason, end, far)
            else:
                results.setdefault(i, []).append((seed, reason, fc, far))
    for i, (label, controller, _) in enumerate(VARIANTS):
        rows = results[i]
        counts = Counter(r for _, r, _, _ in rows)
        fc = [f for _, _, f, _ in rows if f == f]
        fcs = f", forecast 0.5 s ahead {min(fc) * 100:.1f}-{max(fc) * 100:.1f} cm" if fc else ""
        caught = f"captured {counts.get('captured', 0)}/{len(rows)}"
        print(f"{label:<26} {controller:<7} {caught}  {dict(counts)}{fcs}")
        print("    " + ", ".join(f"{s}:{r}" for s, r, _, _ in rows))
    if waves_off is not None:
        reason, end, far = waves_off
        print(f"camera, CE, seed 1, navigation.waves off: {reason} at {end:.1f} s, farthest {far:.1f} m away")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
