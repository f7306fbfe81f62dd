"""Run a mission and plot it with matplotlib (Agg: no display needed).

    python examples/plot_run.py [OUTDIR]

Flies the shipped mission ``gyre`` for 4 s and draws, from the run's pandas DataFrame and
xarray Dataset, the top view of the path (east right, north up, m), the distance to the
dock (m) and the eight thruster forces (N) against time (s).  The figure goes to
``OUTDIR/run.png`` (default: a new temporary folder); its path is printed.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402

import auvdock  # noqa: E402


def main(argv: list[str]) -> int:
    out = Path(argv[1]) if len(argv) > 1 else Path(tempfile.mkdtemp(prefix="auvdock-example-"))
    out.mkdir(parents=True, exist_ok=True)
    run = auvdock.simulate("gyre", docking__timeout_s=4.0)
    df = run.to_dataframe()  # index time_s (s); columns state.x, thrust_N.T1, ...
    ds = run.to_xarray()  # dimension time_s; position (time_s, ned) m, thrust_N (time_s, thruster) N, ...

    fig, (top, dist, thrust) = plt.subplots(1, 3, figsize=(14, 4.2), layout="constrained")
    top.plot(df["state.y"], df["state.x"], label="vehicle")
    top.plot(df["dock_position_m.east"], df["dock_position_m.north"], "s", label="dock")
    top.set(xlabel="east (m)", ylabel="north (m)", title="top view (NED)", aspect="equal")
    top.legend()
    dist.plot(df.index, df["distance_m"])
    dist.set(xlabel="time (s)", ylabel="distance (m)", title="distance to the dock")
    thrust_N = ds["thrust_N"].isel(time_s=run.control_rows())
    for name in thrust_N["thruster"].values:
        thrust.plot(thrust_N["time_s"], thrust_N.sel(thruster=name), label=str(name))
    thrust.set(xlabel="time (s)", ylabel=f"thrust ({ds['thrust_N'].attrs['units']})", title="thrusters")
    thrust.legend(ncols=2, fontsize="small")
    fig.suptitle(repr(run))
    path = out / "run.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(run)
    print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
