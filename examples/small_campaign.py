"""A small campaign from Python: two controllers on two shipped missions, one table.

    python examples/small_campaign.py [OUTDIR]

Naive MPC (no current in its model) and Oracle MPC (the true current) each fly the paper's
case 2 (``diagonal``: a constant 0.5 m/s current) and case 5 (``gyre``: a double gyre),
for 2 s of simulated time each, so that the example takes seconds (a real campaign drops
the ``docking__timeout_s`` override and flies to the mission's 75 s timeout, or uses
``auvdock compare`` / ``auvdock sweep``).  The table (one row per run: how far each got) is
printed, and with OUTDIR also saved as ``campaign.csv`` and every run as
``<mission>_<controller>.h5``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

import auvdock

MISSIONS = ("diagonal", "gyre")
CONTROLLERS = ("naive", "oracle")
TIMEOUT_S = 2.0  # simulated s per run


def main(argv: list[str]) -> int:
    out = Path(argv[1]) if len(argv) > 1 else None
    rows = []
    for name in MISSIONS:
        for controller in CONTROLLERS:
            run = auvdock.simulate(name, controller, docking__timeout_s=TIMEOUT_S)
            start = run.distance_m[0]  # m
            rows.append(
                {
                    "mission": name,
                    "controller": controller,
                    "docked": run.outcome["docked"],
                    "start_distance_m": start,
                    "end_distance_m": run.distance_m[-1],
                    "closed_m": start - run.distance_m[-1],
                    "mean_thrust_N": float(np.mean(np.abs(run.thrust_N[run.control_rows()]))),
                    "solve_time_median_ms": run.outcome["solve_time_median_s"] * 1e3,
                    "steps": run.n_steps,
                }
            )
            if out is not None:
                run.save(out / f"{name}_{controller}.h5")
    table = pd.DataFrame(rows)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    best = table.loc[table.groupby("mission")["end_distance_m"].idxmin()]
    for _, row in best.iterrows():
        print(f"closest after {TIMEOUT_S:g} s on {row['mission']}: {row['controller']}")
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        table.to_csv(out / "campaign.csv", index=False)
        print(f"saved: {out / 'campaign.csv'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
