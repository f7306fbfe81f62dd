"""What a longer horizon buys and what it costs: uniform grids against fine-then-coarse ones.

The paper's case 2 (``diagonal``: a constant current, the dock heaving) with Oracle MPC (robust variant,
``rti`` + HPIPM), one closed-loop run per grid, the solvers compiled first (``AUVDOCK_COMPILE=wait``, the
default here; the QP's data are generated stage by stage, :mod:`auvdock.controllers.qp_stages`, so a
grid compiles in seconds whatever its length) or all uncompiled (``AUVDOCK_COMPILE=never``):

* uniform grids of the control period (0.05 s): N = 10 (0.5 s, the paper's), 20 (1 s), 40 (2 s), 80 (4 s);
* fine-then-coarse grids (``controller.coarse``): 10 steps of 0.05 s, then 6 or 12 steps of 0.25 s
  (2 s, 3.5 s ahead) or 8 of 0.5 s (4.5 s).

Printed per grid: the horizon, the stages, how the run ended and its time to dock, and the whole
control step's median, p95, p99 and largest (ms) with where the median step goes.  Interleaved
rounds (``--rounds``, each grid once a round, in turn) so that a busy machine slows all alike; the
figures are the rounds' medians.  Asserts nothing.

    python benchmarks/horizon_grid.py [--rounds 2] [--controller oracle] [--mission diagonal]
"""

from __future__ import annotations

import argparse
import os
import warnings

import numpy as np

GRIDS: list[tuple[str, dict]] = [
    ("uniform 10", {"controller.horizon_steps": 10}),
    ("uniform 20", {"controller.horizon_steps": 20}),
    ("uniform 40", {"controller.horizon_steps": 40}),
    ("uniform 80", {"controller.horizon_steps": 80}),
    ("10 + 6 x 0.25", {"controller.coarse.steps": 6, "controller.coarse.dt_s": 0.25}),
    ("10 + 12 x 0.25", {"controller.coarse.steps": 12, "controller.coarse.dt_s": 0.25}),
    ("10 + 8 x 0.5", {"controller.coarse.steps": 8, "controller.coarse.dt_s": 0.5}),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--controller", default="oracle")
    ap.add_argument("--mission", default="diagonal")
    args = ap.parse_args()
    os.environ.setdefault("AUVDOCK_COMPILE", "wait")
    warnings.simplefilter("ignore")
    from auvdock.campaign.bench import rounds_median, step_figures
    from auvdock.config.mission import load_mission
    from auvdock.loop.simulation import run_simulation

    rows: dict[str, list[tuple]] = {name: [] for name, _ in GRIDS}
    for r in range(args.rounds):
        for name, updates in GRIDS:
            m = load_mission(args.mission).with_updates(**updates)
            s = run_simulation(m, controller=args.controller)
            rows[name].append((m, s.outcome, step_figures(s.solve_times_s, s.time_parts_s)))
            print(f"round {r + 1}: {name} done", flush=True)
    head = f"{'grid':<16} {'ahead s':>7} {'stages':>6} {'ended':<8} {'docked at':>9}"
    print(f"{args.mission}, {args.controller}; medians of {args.rounds} rounds")
    print(head + f" {'median ms':>9} {'p95':>6} {'p99':>6} {'max':>6}  where the median step goes (ms)")
    for name, runs in rows.items():
        m, outcome = runs[0][0], runs[0][1]
        q, mx, parts = rounds_median([x[2] for x in runs])
        lengths = m.controller.stage_lengths_s()
        t_dock = outcome.get("time_to_dock_s")
        t_text = f"{t_dock:9.2f}" if t_dock is not None and np.isfinite(t_dock) else f"{'-':>9}"
        share = ", ".join(f"{k} {v:.2f}" for k, v in parts.items())
        print(
            f"{name:<16} {sum(lengths):7.2f} {len(lengths):6d} {outcome['reason']:<8} {t_text}"
            f" {q[0]:9.2f} {q[1]:6.2f} {q[2]:6.2f} {mx:6.2f}  {share}"
        )


if __name__ == "__main__":
    main()
