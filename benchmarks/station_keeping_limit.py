"""Where can the BlueROV2 Heavy hold station at PacWave?  The sea states of the ``pacwave_sea_states``
sweep against the thrust the one model needs there (``auvdock.world.station_keeping``).

For each significant height x peak period x depth of the sweep, with its 0.3 m/s current towards the
worst of north, east, south and west: the thrusters' utilisation (the largest minimum-norm thrust as a
share of its limit) at the 99th percentile and at the maximum over 10 minutes of the sea (the sweep's
JONSWAP, gamma 3.3, 25 deg spread, seed 0), and whether a fifth of the thrust is left over (holds with
margin).  Then, per period and depth, the largest significant height held with that margin (bisection
on Hs, the spectrum's shape kept).

    python benchmarks/station_keeping_limit.py [--margin 0.2] [--duration 600]
"""

from __future__ import annotations

import argparse
import time
import warnings

from auvdock.config.mission import load_mission
from auvdock.world.station_keeping import station_keeping_limit

HS_M = (1.0, 1.75, 2.75)
TP_S = (7.8, 9.44, 11.67)
DEPTHS_M = (5.0, 10.0)
CURRENT_M_S = 0.3


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--margin", type=float, default=0.2)
    ap.add_argument("--duration", type=float, default=600.0, help="seconds of each sea, s")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    t0 = time.perf_counter()
    base = load_mission("pacwave_common_10m")
    vehicle = base.build_vehicle()

    def limit(hs: float, tp: float, depth: float):  # noqa: ANN202
        sea = base.with_updates({"sea.waves.hs_m": hs, "sea.waves.tp_s": tp}).build_sea()
        assert sea is not None
        return station_keeping_limit(
            vehicle, sea, depth, current_speed_m_s=CURRENT_M_S, duration_s=args.duration, margin=args.margin
        )

    head = f"{'Hs m':>5} {'Tp s':>6} {'depth m':>7} {'p99 use':>8} {'max use':>8}"
    print(f"{head}  holds with {args.margin:.0%} margin")
    for hs in HS_M:
        for tp in TP_S:
            for depth in DEPTHS_M:
                s = limit(hs, tp, depth)
                row = f"{hs:5.2f} {tp:6.2f} {depth:7.1f} {s.utilisation_p99:8.3f} {s.utilisation_max:8.3f}"
                print(f"{row}  {s.holds}")
    print("\nlargest Hs held with the margin (m):")
    for tp in TP_S:
        for depth in DEPTHS_M:
            lo, hi = 0.5, 12.0
            if not limit(lo, tp, depth).holds:
                print(f"  Tp {tp:5.2f} s, depth {depth:4.1f} m: below {lo:g} m")
                continue
            if limit(hi, tp, depth).holds:
                print(f"  Tp {tp:5.2f} s, depth {depth:4.1f} m: above {hi:g} m")
                continue
            for _ in range(10):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if limit(mid, tp, depth).holds else (lo, mid)
            print(f"  Tp {tp:5.2f} s, depth {depth:4.1f} m: {lo:.2f} m")
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
