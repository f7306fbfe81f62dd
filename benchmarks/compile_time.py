"""How long a new horizon or time grid takes to compile: the real-time iteration's step (``rti_ocp_qp``).

For each grid, a fresh cache folder and a fresh Python process that builds Oracle's controller on the
paper's case 2 (``diagonal``) with ``AUVDOCK_COMPILE=wait`` and runs 0.05 s of flight (so everything the
run needs is compiled before its first step), then a second process on the same folder (everything
loads from the cache).  Printed per grid: the stages, the first process's wall time, the second's, their
difference (the compiling), and the size of the compiled step's library.  The QP's data are generated
stage by stage (:mod:`auvdock.controllers.qp_stages`), so the difference should not grow with the
horizon.  Asserts nothing.

    python benchmarks/compile_time.py [--grid "uniform 80" ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

GRIDS: dict[str, dict[str, float]] = {
    "uniform 10": {"controller.horizon_steps": 10},
    "uniform 40": {"controller.horizon_steps": 40},
    "uniform 80": {"controller.horizon_steps": 80},
    "10 + 8 x 0.5": {"controller.coarse.steps": 8, "controller.coarse.dt_s": 0.5},
}

_CHILD = """
import json, sys, warnings
warnings.simplefilter("ignore")
from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation
updates = json.loads(sys.argv[1])
m = load_mission("diagonal").with_updates(**updates)
run_simulation(m, controller="oracle", timeout_s=0.05)
"""


def _timed(updates: dict, cache: str) -> float:
    env = {**os.environ, "AUVDOCK_CACHE_DIR": cache, "AUVDOCK_COMPILE": "wait"}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", _CHILD, json.dumps(updates)], env=env, check=True)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--grid", action="append", choices=list(GRIDS), help="a grid (repeat); default: all")
    args = ap.parse_args()
    print(f"{'grid':<14} {'stages':>6} {'cold s':>7} {'warm s':>7} {'compiling s':>11} {'rti_ocp_qp':>10}")
    for name in args.grid or list(GRIDS):
        updates = GRIDS[name]
        stages = int(updates.get("controller.horizon_steps", 10))
        stages += int(updates.get("controller.coarse.steps", 0))
        with tempfile.TemporaryDirectory() as cache:
            cold = _timed(updates, cache)
            warm = _timed(updates, cache)
            libs = list(Path(cache).rglob("rti_ocp_qp-*.so"))
            size = f"{libs[0].stat().st_size / 1e3:.0f} kB" if libs else "-"
        print(f"{name:<14} {stages:6d} {cold:7.1f} {warm:7.1f} {cold - warm:11.1f} {size:>10}", flush=True)


if __name__ == "__main__":
    main()
