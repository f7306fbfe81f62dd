"""MPC solve-time benchmark: each controller on paper cases (default 1 and 2).

Prints, per case x controller x solver: outcome, time to dock, and the per-step solve
time median / p95 / p99 / max (ms) and the real-time factor (simulated s per wall s).

    python benchmarks/mpc_solve.py                       # cases 1, 2; naive kinematic oracle; sqp
    python benchmarks/mpc_solve.py --cases 1 2 3 4 5 6 --solvers sqp ipopt --json
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

import numpy as np

from auvdock.mission import load_mission
from auvdock.simulation import simulate

ROOT = Path(__file__).resolve().parents[1]
CASE_FILES = {1: "still", 2: "diagonal", 3: "south", 4: "east_strong", 5: "gyre", 6: "gyre_fast"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--controllers", nargs="+", default=["naive", "kinematic", "oracle"])
    ap.add_argument("--solvers", nargs="+", default=["sqp"])
    ap.add_argument("--timeout", type=float, default=None, help="simulated-time limit, s (default: mission)")
    ap.add_argument("--json", action="store_true", help="print one JSON object per run instead of a table")
    args = ap.parse_args()

    if not args.json:
        print(f"# {platform.processor() or platform.machine()}, {platform.python_version()}")
        print(
            f"{'case':>4} {'controller':<10} {'solver':<6} {'docked':<6} {'t_dock s':>8} "
            f"{'median ms':>9} {'p95 ms':>7} {'p99 ms':>7} {'max ms':>7} {'RTF':>6} {'fails':>5}"
        )
    for case in args.cases:
        base = load_mission(ROOT / "missions" / f"{CASE_FILES[case]}.yaml")
        for ctrl in args.controllers:
            for solver in args.solvers:
                m = base.with_updates(**{"controller.type": ctrl, "controller.solver.name": solver})
                s = simulate(m, timeout_s=args.timeout)
                o = s.outcome
                ms = s.solve_times_s * 1e3
                row = {
                    "case": case,
                    "controller": ctrl,
                    "solver": solver,
                    "docked": o["docked"],
                    "time_to_dock_s": o["time_to_dock_s"],
                    "median_ms": float(np.median(ms)),
                    "p95_ms": float(np.percentile(ms, 95)),
                    "p99_ms": float(np.percentile(ms, 99)),
                    "max_ms": float(ms.max()),
                    "real_time_factor": o["real_time_factor"],
                    "solver_failures": o["solver_failures"],
                    "closest_approach_m": o["closest_approach_m"],
                }
                if args.json:
                    print(json.dumps(row))
                else:
                    t = f"{o['time_to_dock_s']:.2f}" if o["docked"] else "timeout"
                    print(
                        f"{case:>4} {ctrl:<10} {solver:<6} {str(o['docked']):<6} {t:>8} "
                        f"{row['median_ms']:9.2f} {row['p95_ms']:7.2f} {row['p99_ms']:7.2f} "
                        f"{row['max_ms']:7.2f} {row['real_time_factor']:6.1f} {row['solver_failures']:>5}",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
