"""The cost of the sea per control step: the truth's step with and without waves, and where it goes.

For each shipped sea (the basin's regular wave, PacWave's most common sea with its 560 components),
times, interleaved over ``--steps`` control periods of 0.05 s: the truth plant's step without waves
(the CasADi integrator), with the sea (RK4 in numpy, the sea evaluated at each of its 16 stages),
the sea's kinematics at the vehicle (one stage's share), the WEC dock's pose, and the
capture/collision test against the dock's body.  Prints median, p95 and p99 in microseconds and
the median's share of the 50 ms control period.

    python benchmarks/sea_step.py [--steps 2000]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from auvdock.config.mission import load_mission
from auvdock.world.dock_body import classify_contact
from auvdock.world.plant import TruthPlant


def _stats(samples: list[float]) -> str:
    a = np.asarray(samples) * 1e6
    med, p95, p99 = np.percentile(a, [50, 95, 99])
    return f"{med:9.1f} {p95:9.1f} {p99:9.1f}   {100 * med / 50_000:6.2f} %"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=2000)
    args = ap.parse_args()
    print(f"{'mission':<22} {'part':<34} {'median us':>9} {'p95 us':>9} {'p99 us':>9}   {'of 50 ms':>8}")
    for name in ("basin_regular", "pacwave_common_10m"):
        m = load_mission(name)
        v, flow, sea = m.build_vehicle(), m.build_flow(), m.build_sea()
        dock = m.build_dock(sea)
        contact = m.build_contact(dock)
        assert sea is not None and contact is not None
        dt = m.controller.dt_s
        calm = TruthPlant(v, flow, m.start_state(), dt=dt, substeps=m.simulation.substeps)
        wavy = TruthPlant(v, flow, m.start_state(), dt=dt, substeps=m.simulation.substeps, sea=sea)
        u = np.full(v.n_thrusters, 2.0)
        names = ("step, no waves", "step, in the sea", "sea kinematics at the vehicle")
        names += ("WEC dock pose", "contact test")
        parts: dict[str, list[float]] = {k: [] for k in names}
        for k in range(args.steps):
            t = k * dt
            t0 = time.perf_counter()
            calm.step(u, t)
            t1 = time.perf_counter()
            x = wavy.step(u, t)
            t2 = time.perf_counter()
            sea.kinematics_at(x, t)
            t3 = time.perf_counter()
            p, w = dock.position(t), dock.velocity(t)
            t4 = time.perf_counter()
            classify_contact(x, p, w, *contact, dock_heading_rad=dock.heading_rad)
            t5 = time.perf_counter()
            for key, s in zip(parts, (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4), strict=True):
                parts[key].append(s)
            if k % 200 == 199:  # back to the start: stay near the dock's depth
                calm.reset()
                wavy.reset()
        label = f"{name} ({sea.n_components} comp.)"
        for key, samples in parts.items():
            print(f"{label:<22} {key:<34} {_stats(samples)}")
            label = ""


if __name__ == "__main__":
    main()
