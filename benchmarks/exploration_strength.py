"""Does stronger exploration change the outcome where dead reckoning fails?

The regime of the ``active_perception`` sweep where the sensor-poor vehicle fails: ``diagonal_camera``
(the camera alone, no position until the dock is in view) in a 1 m/s current towards the north-east,
the filter not told the vehicle starts at rest (prior velocity 0.5 m/s).  Certainty-equivalent MPC
against Sequential FSE-MPC with its perception wrench bound ten times the authors' (1 N, N m instead
of 0.1) and Optimized FSE-MPC with ten times the default alpha (0.01), per seed: how the run ended,
its time, and the navigation filter's errors (the relative position to the dock, the current).

    python benchmarks/exploration_strength.py [--seeds 6] [--jobs 1]
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import auvdock

REGIME: dict[str, Any] = {
    "navigation__prior_velocity_std_m_s": 0.5,
    "flow__case": None,
    "flow__type": "constant",
    "flow__velocity_ned_m_s": [0.7071, 0.7071],
}
VARIANTS: list[tuple[str, dict[str, Any]]] = [
    ("ce", {}),
    ("sequential", {"controller__perception_wrench_max": [1.0] * 6}),
    ("optimized", {"controller__alpha": 0.01}),
]


def one(job: tuple[str, int, str]) -> tuple[str, int, str, str, float, float, float]:
    controller, seed, extra = job
    o = auvdock.simulate(
        "diagonal_camera", controller=controller, seed=seed, **REGIME, **json.loads(extra)
    ).outcome
    return (
        controller,
        seed,
        extra,
        o["reason"],
        o["end_time_s"],
        o["relative_position_rmse_m"],
        o["navigation_current_rmse_m_s"],
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    jobs = [(c, s, json.dumps(extra)) for s in range(args.seeds) for c, extra in VARIANTS]
    head = f"{'controller':<12} {'seed':>4} {'reason':<12} {'end s':>6} {'rel rmse m':>10} {'cur m/s':>8}"
    print(head + "  settings")
    with ProcessPoolExecutor(args.jobs) as ex:
        for c, s, extra, reason, end, rel, cur in ex.map(one, jobs):
            print(f"{c:<12} {s:>4} {reason:<12} {end:>6.1f} {rel:>10.3f} {cur:>8.3f}  {extra}", flush=True)


if __name__ == "__main__":
    main()
