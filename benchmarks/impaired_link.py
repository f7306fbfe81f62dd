"""fly through an impaired link: delay, jitter and loss between fly and vehicle-sim, scored on the truth.

    python benchmarks/impaired_link.py [--mission tank_positioned] [--controllers oracle,sequential,optimized]
        [--seeds 10] [--delay 0.1] [--jitter 0.03] [--loss 0.05] [--timeout 60]

For each controller and seed: a :class:`auvdock.standins.vehicle_sim.VehicleSim` (sensor noise drawn
from the seed, its truth written) sends to a :class:`auvdock.standins.link_relay.LinkRelay` that
delays each datagram, each way, by ``--delay`` s plus a normal jitter of std ``--jitter`` s and loses
``--loss`` of them (its draws from the seed), and ``auvdock fly --arm`` flies the mission through it,
all in simulated time on one :class:`auvdock.runtime.clock.SimClock` (reproducible, at any load).
Per run it prints how fly ended, the truth's closest approach (within the tolerance: a true docking),
whether fly's verdict was right (WRONG: docked declared with the truth beyond the tolerance at the
instant judged, or a run ended undocked with the truth within it), and whether the truth left the
geofence; then per controller how many seeds docked truly, and the two kinds of wrong verdict.
A flow-estimating controller flies the mission on the navigation filter
(``estimation: filter``: fly refuses it on the autopilot's state).  These are the figures of issue 29
(not timed tests).
"""

from __future__ import annotations

import argparse
import math
import socket
import tempfile
import warnings
from pathlib import Path


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mission", default="tank_positioned")
    ap.add_argument("--controllers", default="oracle,sequential,optimized")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--delay", type=float, default=0.1, help="one-way delay, s")
    ap.add_argument("--jitter", type=float, default=0.03, help="std of the delay's jitter, s")
    ap.add_argument("--loss", type=float, default=0.05, help="fraction of datagrams lost, each way")
    ap.add_argument("--timeout", type=float, default=60.0)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    import numpy as np
    from typer.testing import CliRunner

    from auvdock.cli import app
    from auvdock.cli.app import Runtime
    from auvdock.config.catalog import resolve
    from auvdock.config.mission import load_mission
    from auvdock.controllers.registry import CONTROLLERS, split_controller
    from auvdock.results.store import read_run
    from auvdock.runtime.clock import SimClock
    from auvdock.standins.link_relay import Impairment, LinkRelay
    from auvdock.standins.truth_check import check_flight
    from auvdock.standins.vehicle_sim import VehicleSim

    mission = resolve(args.mission)
    m = load_mission(mission)
    imp = Impairment(delay_s=args.delay, jitter_s=args.jitter, loss=args.loss)
    out = Path(tempfile.mkdtemp(prefix="auvdock-impaired-"))
    print(
        f"{mission.stem} through {imp.describe()} each way; tolerance {m.docking.tolerance_m} m; "
        f"files in {out}"
    )
    print("controller  seed  fly ended                         truth closest  verdict  geofence")
    for controller in args.controllers.split(","):
        true_docks = fly_docks = false_docks = missed = left_fence = 0
        # a flow-estimating controller flies on the navigation filter on a vehicle (fly refuses truth)
        needs_filter = CONTROLLERS[split_controller(controller)[0]].estimates_flow and m.estimation == "truth"
        estimation = ["--estimation", "filter"] if needs_filter else []
        for seed in range(args.seeds):
            d = out / f"{controller}_{seed}"
            d.mkdir(parents=True)
            clock = SimClock()
            port = _free_port()
            relay = LinkRelay(port, imp, imp, seed=seed, clock=clock).start()
            truth = d / "truth.h5"
            sim = VehicleSim(
                m,
                port=f"udpout:127.0.0.1:{relay.port}",
                clock=clock,
                noise=True,
                seed=seed,
                hold_start=True,
                truth_out=truth,
            ).start()
            try:
                fly = [
                    "fly",
                    str(mission),
                    *estimation,
                    "--port",
                    f"udpin:127.0.0.1:{port}",
                    "--out",
                    str(d),
                    "--arm",
                ]
                res = CliRunner().invoke(
                    app, [*fly, "--timeout", f"{args.timeout:g}", "-c", controller], obj=Runtime(clock)
                )
            finally:
                sim.stop()
                relay.stop()
                clock.close()
            h5 = next(d.glob("*_fly_*.h5"), None)
            if h5 is None:
                print(f"{controller:10s} {seed:5d}  no results: {res.output.strip()[-80:]}")
                continue
            c = check_flight(h5, truth)
            tr = read_run(truth)
            fence = m.fly.geofence
            x = tr.state[np.asarray(tr.extras["armed"]) > 0.5]
            left = bool(
                x.size
                and (
                    np.any(x[:, 2] < fence.min_depth_m)
                    or np.any(x[:, 2] > fence.max_depth_m)
                    or np.any(np.hypot(x[:, 0] - x[0, 0], x[:, 1] - x[0, 1]) > fence.max_distance_m)
                )
            )
            docked_truly = math.isfinite(c.truth_closest_m) and c.truth_closest_m <= c.tolerance_m
            true_docks += int(docked_truly)
            fly_docks += int(c.flight_docked)
            false_docks += int(c.flight_docked and not c.verdict_right)  # docked said, the truth beyond
            missed += int(not c.flight_docked and not c.verdict_right)  # ended undocked within the tolerance
            left_fence += int(left)
            ended = (res.output.strip().splitlines() or ["?"])[-1][:33]
            print(
                f"{controller:10s} {seed:5d}  {ended:33s} {c.truth_closest_m:9.3f} m  "
                f"{'right' if c.verdict_right else 'WRONG':7s}  {'LEFT' if left else 'inside'}"
            )
        print(
            f"{controller}: truly docked (truth within the tolerance) in {true_docks} of {args.seeds} seeds; "
            f"fly declared docked in {fly_docks}; wrongly (the truth beyond the tolerance then) in "
            f"{false_docks}; ended undocked within the tolerance in {missed}; "
            f"left the geofence in {left_fence}"
        )


if __name__ == "__main__":
    main()
