"""The paper's six cases flown without its Assumptions 1-2: position none until the dock is in view.

Each of the paper's six flow cases (start 3.6 m from the dock, paper VII.A) is flown on the
navigation filter with the ``camera`` sensor suite (:mod:`auvdock.sensing.suites`: no acoustic
positioning, no DVL; the dock found by its markers through the camera with its field of view), the
start and the dock drawn per seed (``--placement`` m per horizontal axis, the filter's priors
saying as much; the vehicle starts at rest over ground, paper VII.A, and its filter knows that to
5 cm/s) and the guidance's approach through a standoff point.  For each case and controller
it prints how many seeds docked (the paper's 5 cm rule) with the Wilson 95 % interval, the median
time, and how the others ended (gave up finding the dock, timed out; closest approach); then, per
case, which deployable controllers (every one but Oracle, which reads the true current) docked in
every seed, and why the others did not (the median errors of the navigation filter: the vehicle
relative to the dock, the current).

    python benchmarks/paper_cases_camera.py [--seeds 5] [--jobs 2] [--placement 0.3]
        [--controllers oracle ce sequential optimized sequential@paper optimized@paper]
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from auvdock.config.catalog import PAPER_MISSIONS
from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation
from auvdock.sensing.suites import suite_updates
from auvdock.sweep.rates import wilson_interval

CONTROLLERS = ("oracle", "ce", "sequential", "optimized", "sequential@paper", "optimized@paper")


def one(job: tuple[str, str, int, float]) -> dict[str, Any]:
    case, controller, seed, placement = job
    m = load_mission(case).with_controller(controller)
    m = m.with_updates(
        {
            **suite_updates("camera"),
            "seed": seed,
            "start.position_std_m": placement,
            "dock.position_std_m": placement,
            "navigation.prior_position_std_m": max(placement, 0.05),
            "navigation.prior_dock_std_m": max(placement, 0.05),
            "navigation.prior_velocity_std_m_s": 0.05,  # it starts at rest over ground (paper VII.A)
        }
    )
    o = run_simulation(m).outcome
    return {"case": case, "controller": controller, "seed": seed, **o}


def _med(values: list[float], spec: str = ".1f") -> str:
    v = [x for x in values if x is not None and math.isfinite(x)]
    return format(float(np.median(v)), spec) if v else "-"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--placement", type=float, default=0.3, help="start and dock drawn this far, m per axis")
    ap.add_argument("--controllers", nargs="+", default=list(CONTROLLERS))
    args = ap.parse_args()
    jobs = [
        (c, k, s, args.placement) for c in PAPER_MISSIONS for k in args.controllers for s in range(args.seeds)
    ]
    with ProcessPoolExecutor(args.jobs) as ex:
        rows = list(ex.map(one, jobs))
    print(
        f"{'case':<12} {'controller':<18} {'docked':>7} {'95 % interval':>14} {'t dock s':>8} {'gave up':>7} "
        f"{'t/o':>4} {'closest m':>9} {'rel err m':>9} {'cur err m/s':>11} {'losses':>6}"
    )
    for case in PAPER_MISSIONS:
        for c in args.controllers:
            rs = [r for r in rows if r["case"] == case and r["controller"] == c]
            k = sum(1 for r in rs if r["docked"])
            lo, hi = wilson_interval(k, len(rs))
            reasons = Counter(r["reason"] for r in rs)
            print(
                f"{case:<12} {c:<18} {f'{k}/{len(rs)}':>7} {f'{100 * lo:.0f}-{100 * hi:.0f} %':>14} "
                f"{_med([r['time_to_dock_s'] for r in rs if r['docked']]):>8} {reasons['lost_target']:>7} "
                f"{reasons['timeout']:>4} {_med([r['closest_approach_m'] for r in rs], '.3f'):>9} "
                f"{_med([r.get('relative_position_rmse_m') for r in rs], '.3f'):>9} "
                f"{_med([r.get('navigation_current_rmse_m_s') for r in rs], '.3f'):>11} "
                f"{sum(int(r.get('lost_track_events') or 0) for r in rs):>6}",
                flush=True,
            )
    print()
    deployable = [c for c in args.controllers if not c.startswith("oracle") and not c.startswith("kinematic")]
    every = {c: True for c in deployable}
    for case in PAPER_MISSIONS:
        ok = []
        for c in deployable:
            rs = [r for r in rows if r["case"] == case and r["controller"] == c]
            if rs and all(r["docked"] for r in rs):
                ok.append(c)
            else:
                every[c] = False
        failing = [c for c in deployable if c not in ok]
        why = []
        for c in failing:
            rs = [r for r in rows if r["case"] == case and r["controller"] == c and not r["docked"]]
            reasons = Counter(r["reason"] for r in rs)
            why.append(
                f"{c}: {', '.join(f'{n} {k}' for k, n in reasons.items())} (relative error "
                f"{_med([r.get('relative_position_rmse_m') for r in rs], '.2f')} m, current error "
                f"{_med([r.get('navigation_current_rmse_m_s') for r in rs], '.2f')} m/s)"
            )
        print(
            f"{case}: docked in every seed: {', '.join(ok) or 'none'}"
            + (f"; not: {'; '.join(why)}" if why else "")
        )
    all_six = [c for c, v in every.items() if v]
    print(
        "deployable controllers that docked in every seed of all six cases: "
        + (", ".join(all_six) if all_six else "none")
    )


if __name__ == "__main__":
    main()
