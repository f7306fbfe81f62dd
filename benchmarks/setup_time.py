"""Per-run set-up of ``auvdock sim`` runs: the first run of a process and the runs after it.

A run's set-up is everything :func:`auvdock.loop.simulation.run_simulation` does before its first
control step (the world, the autopilot: the controller's and the filters' CasADi functions, the
compiled libraries' cache lookups, the stages), reported as the run's ``setup_time_s``.  A sweep or
a comparison runs many runs of one vehicle and problem in one process; their functions are built once
per process and vehicle (:meth:`auvdock.vehicle.Vehicle.built`), so from the second run on a run's
set-up is that of its state only.

For each case (mission, controller) a fresh Python process runs ``--runs`` runs of 0.05 s of simulated
time, each with another seed, and prints the first run's set-up and the median and largest of the
others.  The compiled-library cache is used as it stands (``AUVDOCK_COMPILE`` as set: ``auto`` by
default); run once before to warm it.  Asserts nothing.

    python benchmarks/setup_time.py [--runs 6]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: (mission, controller): the paper's case 2, a tank trial on the camera alone, PacWave's sea.
CASES = [
    ("diagonal", "oracle"),
    ("diagonal", "sequential"),
    ("diagonal", "optimized"),
    ("tank_0p6hz", "oracle"),
    ("tank_0p6hz", "ce"),
    ("pacwave_common_10m", "ce"),
]

_CHILD = """
import json, sys
from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation
mission, controller, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
m = load_mission(mission)
out = []
for seed in range(runs):
    s = run_simulation(m.with_updates(seed=seed), controller=controller, timeout_s=0.05)
    out.append(float(s.outcome["setup_time_s"]))
print(json.dumps(out))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=6, help="runs per process (default 6)")
    args = ap.parse_args()
    print(f"per-run set-up, s ({args.runs} runs of 0.05 s per fresh process; the first run builds)")
    print(f"{'mission':<20} {'controller':<11} {'first':>7} {'later median':>13} {'later max':>10}")
    for mission, controller in CASES:
        res = subprocess.run(
            [sys.executable, "-c", _CHILD, mission, controller, str(args.runs)],
            capture_output=True,
            text=True,
            cwd=ROOT,
            check=False,
        )
        if res.returncode != 0:
            print(f"{mission:<20} {controller:<11} failed: {res.stderr.strip().splitlines()[-1:]}")
            continue
        t = json.loads(res.stdout.strip().splitlines()[-1])
        later = t[1:]
        print(
            f"{mission:<20} {controller:<11} {t[0]:7.3f} {statistics.median(later):13.3f} {max(later):10.3f}"
        )


if __name__ == "__main__":
    main()
