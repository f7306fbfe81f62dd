"""The real-time iteration's step compiled whole against HPIPM through CasADi's plugin, same runs.

For each mission x controller (``rti``): one closed-loop run with ``controller.solver.qp: hpipm`` (the QP
data, generated stage by stage, and HPIPM's OCP-QP interface in one compiled call, its memory made once:
``auvdock.controllers.ocp_qp``) and one with ``hpipm_casadi`` (the plugin on the whole problem's
derivatives, the reference), in interleaved rounds (``--rounds``; each pair in turn, so a busy machine
slows both alike), all compiled first (``AUVDOCK_COMPILE=wait``).  Printed per pair: how the runs ended,
how far apart their thrusts are (the same QP to rounding: the last bits, until an event that rounds, the
ArduSub path's whole microseconds of PWM, takes one of them to the other side), and per whole control
step median, p95, p99 and largest (ms; the rounds' medians) with where the median step goes (ms per
part; ``python``: what the parts leave).  Asserts nothing.

    python benchmarks/rti_step.py [--rounds 3] [--busy 2] [--case diagonal:oracle ...]

``--busy N`` runs N busy loops (processes spinning on the CPU) beside the runs: the tails (p99, the
largest) beside two of them, as the test suite's runs have each other.
"""

from __future__ import annotations

import argparse
import os
import warnings

import numpy as np

CASES = ["diagonal:oracle", "diagonal:optimized", "basin_regular:sequential", "pacwave_common_10m:ce"]
QPS = ("hpipm", "hpipm_casadi")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--busy", type=int, default=0, help="busy loops beside the runs (default 0)")
    ap.add_argument(
        "--case", action="append", help="MISSION:CONTROLLER (repeat); default: " + ", ".join(CASES)
    )
    ap.add_argument(
        "--timeout", type=float, default=None, help="simulated seconds per run (default: the mission's)"
    )
    args = ap.parse_args()
    os.environ.setdefault("AUVDOCK_COMPILE", "wait")
    warnings.simplefilter("ignore")
    from auvdock.campaign.bench import busy_loops, machine_line, rounds_median, step_figures
    from auvdock.config.mission import load_mission
    from auvdock.loop.simulation import run_simulation

    cases = args.case or CASES
    stats: dict[tuple[str, str], list[tuple]] = {(c, q): [] for c in cases for q in QPS}
    thrust: dict[tuple[str, str], np.ndarray] = {}
    print(f"rti_step on {machine_line()}, beside {args.busy} busy loop(s)", flush=True)
    with busy_loops(args.busy):  # beside busy loops, as the tests run (--busy 2: the tails)
        for r in range(args.rounds):
            for case in cases:
                mission, controller = case.split(":")
                for qp in QPS:
                    m = load_mission(mission).with_updates(
                        **{
                            "controller.type": controller,
                            "controller.solver.name": "rti",
                            "controller.solver.qp": qp,
                        }
                    )
                    s = run_simulation(m, keep=True, timeout_s=args.timeout)
                    assert s.run is not None
                    stats[(case, qp)].append((s.outcome, step_figures(s.solve_times_s, s.time_parts_s)))
                    thrust[(case, qp)] = np.asarray(s.run.thrust_N)
                print(f"round {r + 1}: {case} done", flush=True)
    for case in cases:
        a, b = thrust[(case, QPS[0])], thrust[(case, QPS[1])]
        n = min(a.shape[0], b.shape[0])
        gap = float(np.nanmax(np.abs(a[:n] - b[:n]))) if n else 0.0
        rows_text = f"{a.shape[0]} and {b.shape[0]} rows"
        print(f"\n{case}: thrusts {rows_text}, at most {gap:.3g} N apart over the first {n}")
        for qp in QPS:
            rows = stats[(case, qp)]
            out = rows[-1][0]
            pct, mx, parts = rounds_median([r[1] for r in rows])
            ended = f"{out.get('reason')} at {out.get('time_to_dock_s', float('nan')):.2f} s"
            where = ", ".join(f"{k} {v:.3f}" for k, v in parts.items())
            print(
                f"  {qp:<13} {ended:<22} median {pct[0]:.3f}  p95 {pct[1]:.3f}  p99 {pct[2]:.3f}"
                f"  max {mx:.3f} ms  ({where})"
            )


if __name__ == "__main__":
    main()
