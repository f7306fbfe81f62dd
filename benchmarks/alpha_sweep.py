"""Optimized FSE-MPC: sweep alpha on paper case 2 and print travel time vs flow RMSE.

The Pareto trade-off the paper describes in words: a larger alpha makes the vehicle move
to make the current observable (better estimate) at the price of docking later.

    python benchmarks/alpha_sweep.py [--alphas 0 1e-4 1e-3 1e-2] [--case 2] [--timeout 75]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation

ROOT = Path(__file__).resolve().parents[1]
CASE_FILES = {1: "still", 2: "diagonal", 3: "south", 4: "east_strong", 5: "gyre", 6: "gyre_fast"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--alphas", type=float, nargs="+", default=[0.0, 1e-4, 1e-3, 1e-2])
    ap.add_argument("--case", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=None)
    ap.add_argument("--with-sequential", action="store_true", help="also run Sequential FSE-MPC")
    args = ap.parse_args()
    base = load_mission(ROOT / "missions" / f"{CASE_FILES[args.case]}.yaml")
    print(
        f"{'controller':<11} {'alpha':>8} {'docked':<6} {'t_dock s':>8} {'path m':>7} {'RMSE m/s':>9} "
        f"{'final err':>9} {'median ms':>9} {'p99 ms':>7} {'wall s':>7}"
    )
    runs = [("optimized", a) for a in args.alphas]
    if args.with_sequential:
        runs.insert(0, ("sequential", 0.0))
    for ctrl, alpha in runs:
        m = base.with_updates(**{"controller.type": ctrl, "controller.alpha": alpha})
        o = run_simulation(m, timeout_s=args.timeout).outcome
        t = f"{o['time_to_dock_s']:.2f}" if o["docked"] else "timeout"
        print(
            f"{ctrl:<11} {alpha:8.1e} {str(o['docked']):<6} {t:>8} {o['path_length_m']:7.2f} "
            f"{o['flow_rmse_m_s']:9.4f} {o['flow_final_error_m_s']:9.4f} "
            f"{o['solve_time_median_s'] * 1e3:9.2f} "
            f"{o['solve_time_p99_s'] * 1e3:7.2f} {o['wall_time_s']:7.1f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
