"""The outcomes of a set of representative runs, as JSON, to hold one checkout against another.

    python benchmarks/outcome_fingerprint.py OUT.json [--cases gyre:optimized,tank_0p6hz ...]

A restructure that claims to change no behaviour must leave every outcome of every run bit-identical.
This runs one simulation per case (``MISSION[:CONTROLLER]``, the mission's controller when omitted;
compiled solvers off, so that both checkouts solve the same way) and writes each outcome (times and
wall-clock figures left out), the sum of |thrust| over the run and its last state.  Run it in each
checkout (``PYTHONPATH=CHECKOUT python benchmarks/outcome_fingerprint.py ...`` from outside them) and
compare the files with ``cmp``.  The default cases cover the paper's missions (the three FSE families
and a baseline), the camera-only tank trials, the wave basin with the dock's telemetry, and PacWave.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys

DEFAULT_CASES = (
    "gyre:optimized,diagonal:sequential,south:naive,tank_0p6hz,basin_regular,pacwave_common_10m,tank_0p8hz:ce"
)


def _plain(value: object) -> object:
    if hasattr(value, "tolist"):
        return value.tolist()  # type: ignore[attr-defined]
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    return value


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="the JSON file to write")
    ap.add_argument("--cases", default=DEFAULT_CASES, help="MISSION[:CONTROLLER],... (default: %(default)s)")
    args = ap.parse_args()
    os.environ["AUVDOCK_COMPILE"] = "never"
    from auvdock.config.mission import load_mission
    from auvdock.loop.simulation import run_simulation

    skip = ("solve_time", "wall_time", "setup_time", "real_time")
    out: dict[str, dict[str, object]] = {}
    for case in args.cases.split(","):
        name, _, controller = case.partition(":")
        s = run_simulation(load_mission(name), controller=controller or None, keep=True)
        assert s.run is not None
        figures = {k: _plain(v) for k, v in s.outcome.items() if not k.startswith(skip)}
        figures["thrust_abs_sum_N"] = float(abs(s.run.thrust_N).sum())
        figures["state_last"] = [float(v) for v in s.run.state[-1]]
        out[case] = figures
        print(f"{case}: {s.outcome['reason']} at {s.outcome['end_time_s']:.2f} s", file=sys.stderr)
    with open(args.out, "w") as f:
        json.dump(out, f, indent=1, sort_keys=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
