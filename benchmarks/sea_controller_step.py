"""Per-step cost of every controller in the sea, with what it knows of the sea in its step.

Each controller flies one closed-loop run (seed 0) of the wave basin (``basin_regular``: the camera
alone) and of PacWave's most common sea (``pacwave_common_10m`` with acoustic positioning added, so
that the runs last to the dock): the deployable controllers run the navigation filter with its wave
states and forecast the dock's motion from its telemetry every step; Oracle is told both.  Prints,
per run, the whole control step's median, p95 and p99 (ms; the estimation stage, the dock's forecast,
the flow filter and the solver included: everything between the readings and the thrust) and where the
median step's time goes, beside the 50 ms control period.  Times are this machine's; the solvers are
compiled first (``AUVDOCK_COMPILE=wait``), and the first step (the telemetry's 300 s backlog) is left
out.  ``--busy N`` runs N busy loops (processes spinning on the CPU) beside the runs, as the test suite
does on the 2-core machine, to measure the tails when the machine is loaded: the largest step is printed
too.

    python benchmarks/sea_controller_step.py [--controllers oracle ce sequential optimized] [--busy 2]
"""

from __future__ import annotations

import argparse
import os
import warnings

import numpy as np

from auvdock.campaign.bench import _parts_median_ms, busy_loops
from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation

RUNS = (
    ("basin_regular", {}),
    ("pacwave_common_10m", {"sensors.position.source": "acoustic"}),
)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--controllers", nargs="+", default=["oracle", "ce", "sequential", "optimized"])
    ap.add_argument("--busy", type=int, default=0, help="busy loops beside the runs (default 0)")
    args = ap.parse_args()
    with busy_loops(args.busy):
        _measure(args.controllers, args.busy)


def _measure(controllers: list[str], busy: int) -> None:
    os.environ.setdefault("AUVDOCK_COMPILE", "wait")
    warnings.simplefilter("ignore")
    head = f"{'mission':<20} {'controller':<11} {'ended':<11} {'median ms':>9} {'p95 ms':>7} {'p99 ms':>7}"
    print(f"beside {busy} busy loop(s)")
    print(head + f" {'max ms':>7}  where the median step goes (ms)")
    for name, updates in RUNS:
        for controller in controllers:
            m = load_mission(name).with_updates({**updates, "controller.type": controller})
            s = run_simulation(m)
            ms = np.asarray(s.solve_times_s)[1:] * 1e3
            parts = {k: v[1:] for k, v in s.time_parts_s.items()}
            where = _parts_median_ms(parts, ms)
            med, p95, p99 = np.percentile(ms, [50, 95, 99])
            share = ", ".join(f"{k} {v:.2f}" for k, v in where.items())
            ended = s.outcome["reason"]
            row = f"{name:<20} {controller:<11} {ended:<11} {med:9.2f} {p95:7.2f} {p99:7.2f} {ms.max():7.2f}"
            print(f"{row}  {share}", flush=True)


if __name__ == "__main__":
    main()
