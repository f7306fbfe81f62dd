"""MPC solve-time benchmark: ``auvdock bench`` as a script (same code, same figures).

Prints, per case x controller x solver: outcome, time to dock, and the per-step solve
time median / p95 / p99 / max (ms) and the real-time factor (simulated s per wall s).

    python benchmarks/mpc_solve.py                                 # cases 1, 2, 6; all five; auto
    python benchmarks/mpc_solve.py --case 1 --case 2 -c oracle --solvers sqp,ipopt --json
"""

from __future__ import annotations

import sys

from auvdock.cli import app

if __name__ == "__main__":
    sys.exit(app(["bench", *sys.argv[1:]]))
