"""Run one mission from Python and print its outcome.

    python examples/run_mission.py [OUTDIR]

The shipped mission ``gyre`` (paper case 5: a double-gyre current, the dock heaving 0.5 m
around 5 m depth) made quick with overrides: the dock 1 m from the start instead of
3.6 m, docked within 0.2 m, 10 s at most.  With OUTDIR the run is also saved there as
``run.h5``, the results file ``auvdock sim`` writes (``auvdock plot OUTDIR/run.h5`` draws it).
"""

from __future__ import annotations

import sys
from pathlib import Path

import auvdock


def main(argv: list[str]) -> int:
    run = auvdock.simulate(
        "gyre",
        controller="oracle",
        dock__position_ned_m=[0.8, 0.6, 5.0],  # NED, m
        docking={"tolerance_m": 0.2, "timeout_s": 10.0},
    )
    print(run)
    o = run.outcome
    print(f"docked:             {o['docked']}")
    print(f"time to dock:       {o['time_to_dock_s']:.2f} s")
    print(f"contact speed:      {o['contact_speed_m_s']:.3f} m/s")
    print(f"closest approach:   {o['closest_approach_m']:.3f} m")
    print(f"path length:        {o['path_length_m']:.3f} m")
    print(f"median solve time:  {o['solve_time_median_s'] * 1e3:.1f} ms")
    x_end = run.state[-1]  # (12,): x y z (NED, m), phi theta psi (rad), u v w (m/s), p q r (rad/s)
    print(f"final position:     north {x_end[0]:.3f} m, east {x_end[1]:.3f} m, down {x_end[2]:.3f} m")
    if len(argv) > 1:
        path = run.save(Path(argv[1]) / "run.h5")
        print(f"saved:              {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
