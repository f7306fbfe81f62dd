"""Soak: many dockings in a row in one vehicle-sim session, scored on its truth.

    python benchmarks/soak.py [--flights 10] [--mission tank_positioned] [--controller oracle]
                              [--noise/--no-noise] [--out DIR]

One :class:`auvdock.standins.vehicle_sim.VehicleSim` (``--mission``, default ``tank_positioned``; the truth
written with
``truth_out``) serves ``--flights`` runs of ``auvdock fly --arm`` one after another, all in simulated
time on one :class:`auvdock.runtime.clock.SimClock` (as ``tests/test_fly.py`` flies; the vehicle held at
the start while disarmed, so each flight starts where the last one was set up).  After each flight it
prints how the flight ended, whether its results file and tlog are complete, this process's resident
memory (MB; and again after glibc's ``malloc_trim``: the memory in use, not the free pages the allocator
keeps) and open file descriptors, and -- once the simulator stops -- every flight scored on the
truth (:func:`auvdock.standins.truth_check.check_flight`: fly's verdict right or wrong, the truth's distance
at the verdict, and for a mission judged by capture the truth's contact with the dock's body then).
Memory and descriptors should stay flat; every file complete.

A mission whose dock camera is a sensor (``tank_0p6hz``, ``tank_0p8hz``) flies its camera as
``camera.source: synthetic`` here: frames rendered from vehicle-sim's true pose (its SIM_STATE) and the
true dock, through the same detection and pose pipeline as the vehicle's RTP stream, which cannot run in
simulated time (the rest of the mission as shipped; the soak says so).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import warnings
from pathlib import Path


def _rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _trimmed_rss_mb() -> float:
    """The resident memory after glibc's ``malloc_trim(0)`` has returned the allocator's free pages to the
    system (what is in use, not what the allocator keeps for later), MB; NaN where there is no glibc."""
    import ctypes
    import gc

    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        return float("nan")
    return _rss_mb()


def _fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flights", type=int, default=10)
    ap.add_argument("--mission", default="tank_positioned", help="a shipped mission or a file")
    ap.add_argument("--controller", default="oracle")
    ap.add_argument("--noise", action=argparse.BooleanOptionalAction, default=True, help="sensor noise")
    ap.add_argument("--out", type=Path, default=None, help="where the files go (default: a temporary folder)")
    ap.add_argument(
        "--received-log",
        type=int,
        default=100_000,
        help="entries of vehicle-sim's log of received messages (a test hook; 100,000 by default, about "
        "0.5 MB a tank flight until full)",
    )
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    import h5py
    from typer.testing import CliRunner

    from auvdock.cli import app
    from auvdock.cli.app import Runtime
    from auvdock.config.catalog import resolve
    from auvdock.config.mission import load_mission
    from auvdock.runtime.clock import SimClock
    from auvdock.standins.truth_check import check_flight
    from auvdock.standins.vehicle_sim import VehicleSim

    out = args.out or Path(tempfile.mkdtemp(prefix="auvdock-soak-"))
    out.mkdir(parents=True, exist_ok=True)
    mission = resolve(args.mission)
    m = load_mission(mission)
    camera_note = ""
    if m.estimation == "filter" and m.sensors.dock_camera.enabled and m.camera.source != "synthetic":
        import yaml

        data = yaml.safe_load(mission.read_text())
        data["camera"] = {**data.get("camera", {}), "source": "synthetic", "calibration": None}
        mission = out / mission.name
        mission.write_text(yaml.safe_dump(data))
        m = load_mission(mission)
        camera_note = " (camera.source: synthetic, rendered from vehicle-sim's truth; else as shipped)"
    clock = SimClock()
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = int(s.getsockname()[1])
    truth = out / "truth.h5"
    link = f"udpout:127.0.0.1:{port}"
    sim = VehicleSim(
        m,
        port=link,
        clock=clock,
        noise=args.noise,
        hold_start=True,
        truth_out=truth,
        received_maxlen=args.received_log,
    ).start()
    runner = CliRunner()
    flights = []
    noise = "on" if args.noise else "off"
    print(
        f"soak: {args.flights} flights of {args.controller} on {mission.stem}{camera_note}, noise {noise}, "
        f"vehicle-sim's received log {args.received_log} entries"
    )
    print("flight  ended                      files     RSS MB  trimmed  fds")
    try:
        for i in range(args.flights):
            d = out / f"flight{i:02d}"
            fly = ["fly", str(mission), "--port", f"udpin:127.0.0.1:{port}", "--out", str(d), "--arm"]
            res = runner.invoke(app, [*fly, "--timeout", "40", "-c", args.controller], obj=Runtime(clock))
            h5 = next(d.glob("*.h5"), None)
            complete = h5 is not None and h5.with_suffix(".tlog").is_file()
            if h5 is not None:
                with h5py.File(h5, "r") as f:
                    complete = complete and bool(f.attrs["complete"])
            ended = (res.output.strip().splitlines() or ["?"])[-1][:26]
            files = "complete" if complete else "INCOMPLETE"
            rss = _rss_mb()
            print(f"{i:6d}  {ended:26s} {files:9s} {rss:7.1f} {_trimmed_rss_mb():8.1f} {_fds():4d}")
            flights.append(h5)
    finally:
        sim.stop()
        clock.close()
    print(f"truth: {truth}")
    wrong = docked = 0
    for i, h5 in enumerate(flights):
        if h5 is None:
            print(f"{i:6d}  no results file")
            continue
        c = check_flight(h5, truth)
        wrong += int(not c.verdict_right)
        said = "docked" if c.flight_docked else c.flight_reason
        d = c.truth_distance_at_verdict_m
        if c.truth_contact_at_verdict:
            truly = c.truth_contact_at_verdict == "captured"
            then = f"truth at the verdict: {c.truth_contact_at_verdict}, {d:.3f} m"
        else:
            truly = d <= c.tolerance_m
            then = f"truth at the verdict {d:.3f} m (tolerance {c.tolerance_m:.3f})"
        docked += int(truly and c.flight_docked)
        right = "right" if c.verdict_right else "WRONG"
        print(f"{i:6d}  fly: {said:8s} at {c.verdict_time_s:7.2f} s  {then}: {right}")
    n = len(flights)
    print(f"docked by the truth in {docked} of {n} flights; verdict wrong in {wrong} of {n}")


if __name__ == "__main__":
    main()
