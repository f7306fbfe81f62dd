"""Instructions per control step, counted by valgrind's callgrind: a figure no load on the machine moves.

Times on a shared 2-core machine swing by a factor of three between its quiet and its busy hours; the
number of instructions a step executes does not.  For each QP solver (``controller.solver.qp``: the
whole step compiled, ``hpipm``, against HPIPM through CasADi's plugin, ``hpipm_casadi``) this runs the
same closed loop twice under ``valgrind --tool=callgrind`` (the solvers compiled and cached first,
outside valgrind): ``--short`` simulated seconds and ``--long``.  The difference of the two totals over
the difference of their control steps is the instructions of one period of the loop (the controller's
step, and the simulated plant's and sensors' work, the same for both solvers: the difference between
the two rows is the controllers'); the start-up and the build cancel out.

    python benchmarks/step_instructions.py [--mission diagonal] [--controller oracle] [--short 2 --long 6]

Needs valgrind (Debian's package); says so in one line and exits 2 without it.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

RUN = """
import os, sys
from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation
m = load_mission(sys.argv[1]).with_updates(**{"controller.type": sys.argv[2],
    "controller.solver.name": "rti", "controller.solver.qp": sys.argv[3]})
s = run_simulation(m, timeout_s=float(sys.argv[4]))
print("steps", len(s.solve_times_s))
"""


def _count(args: list[str], env: dict[str, str]) -> tuple[int, int]:
    """(instructions, control steps) of one run under callgrind."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "cg.out")
        cmd = [
            "valgrind",
            "--tool=callgrind",
            f"--callgrind-out-file={out}",
            sys.executable,
            "-c",
            RUN,
            *args,
        ]
        p = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True)
        steps = int(re.search(r"^steps (\d+)$", p.stdout, re.M).group(1))  # type: ignore[union-attr]
        total = re.search(r"Collected : (\d+)", p.stderr) or re.search(r"refs:\s+([\d,]+)", p.stderr)
        assert total is not None, p.stderr[-500:]
        return int(total.group(1).replace(",", "")), steps


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mission", default="diagonal")
    ap.add_argument("--controller", default="oracle")
    ap.add_argument("--short", type=float, default=2.0, help="simulated seconds of the short run")
    ap.add_argument("--long", type=float, default=6.0, help="simulated seconds of the long run")
    ap.add_argument("--qp", action="append", help="QP solvers (repeat); default: hpipm and hpipm_casadi")
    args = ap.parse_args()
    if shutil.which("valgrind") is None:
        print("error: valgrind: not found (Debian's package counts the instructions)", file=sys.stderr)
        return 2
    env = {**os.environ, "AUVDOCK_COMPILE": "wait", "PYTHONHASHSEED": "0"}
    qps = args.qp or ["hpipm", "hpipm_casadi"]
    for qp in qps:  # compiled and cached outside valgrind first
        subprocess.run(
            [sys.executable, "-c", RUN, args.mission, args.controller, qp, "0.1"], check=True, env=env,
            capture_output=True,
        )  # fmt: skip
    print(f"instructions per whole control step, {args.mission} with {args.controller} (rti), callgrind:")
    for qp in qps:
        a, na = _count([args.mission, args.controller, qp, str(args.short)], env)
        b, nb = _count([args.mission, args.controller, qp, str(args.long)], env)
        per = (b - a) / (nb - na)
        print(f"  {qp:<13} {per / 1e6:8.2f} M  ({nb - na} steps between runs of {na} and {nb})", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
