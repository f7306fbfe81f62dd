"""A camera rehearsal on the wall clock: vehicle-sim streams the camera's view as RTP/H.264, fly flies on it.

    python benchmarks/camera_rehearsal.py [--flights 5] [--mission tank_0p6hz] [--out DIR]

Three programs, as on a real vehicle: ``auvdock vehicle-sim MISSION --camera udp:127.0.0.1:5600
--truth-out TRUTH.h5`` (the vehicle, its truth and its camera, rendered from the true pose and encoded as
BlueOS streams a BlueROV2's camera) and, one after another, ``--flights`` runs of ``auvdock fly MISSION
--arm`` (the mission as shipped: ``camera.source: udp:5600``, decoded, detected and fed to the navigation
filter).  After the last flight vehicle-sim is stopped (SIGINT) and every flight is scored on the truth
(``auvdock truth-check``).  Per flight it prints fly's ending, its camera line (fixes a second and the
capture-to-fix latency) and its pace line (how late the control steps started on the wall clock), then
the truth's verdict.  Every figure depends on the machine and its load: the command prints the load
average before and after.
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _load() -> str:
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--flights", type=int, default=5)
    ap.add_argument("--mission", default="tank_0p6hz", help="a mission (camera.source udp:PORT)")
    ap.add_argument("--camera-port", type=int, default=5600, help="where the mission's camera.source listens")
    ap.add_argument("--timeout", type=float, default=60.0, help="fly --timeout, s")
    ap.add_argument("--out", type=Path, default=None, help="where the files go (default: a temporary folder)")
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="auvdock-camera-rehearsal-"))
    out.mkdir(parents=True, exist_ok=True)
    port = _free_port()
    truth = out / "truth.h5"
    exe = [sys.executable, "-m", "auvdock"]
    print(f"camera rehearsal: {args.flights} flights of {args.mission}, files in {out}; load {_load()}")
    sim = subprocess.Popen(
        [*exe, "vehicle-sim", args.mission, "--port", f"udpout:127.0.0.1:{port}", "--truth-out", str(truth),
         "--camera", f"udp:127.0.0.1:{args.camera_port}"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    flights: list[Path] = []
    try:
        assert sim.stdout is not None
        for _ in range(2):  # the banner, the camera line
            print("  " + sim.stdout.readline().strip())
        for i in range(args.flights):
            d = out / f"flight{i:02d}"
            fly = [*exe, "fly", args.mission, "--port", f"udpin:127.0.0.1:{port}", "--arm", "--out", str(d),
                   "--timeout", f"{args.timeout:g}"]  # fmt: skip
            t0 = time.monotonic()
            res = subprocess.run(fly, capture_output=True, text=True)
            lines = (res.stdout + res.stderr).strip().splitlines()
            said = [ln for ln in lines if ln.startswith(("camera:", "pace:"))]
            last = lines[-1] if lines else "?"
            print(f"{i:3d}  exit {res.returncode}, {time.monotonic() - t0:5.1f} s: {last}")
            for ln in said:
                print(f"       {ln}")
            h5 = next(d.glob("*.h5"), None)
            if h5 is not None:
                flights.append(h5)
    finally:
        sim.send_signal(signal.SIGINT)
        rest, _ = sim.communicate(timeout=60)
        print("  vehicle-sim: " + (rest.strip().splitlines() or ["?"])[-1])
    docked = wrong = 0
    for i, h5 in enumerate(flights):
        res = subprocess.run([*exe, "truth-check", str(h5), str(truth)], capture_output=True, text=True)
        lines = res.stdout.strip().splitlines()
        text = " ".join(lines[:3])
        wrong += int(res.returncode != 0)
        docked += int("fly's verdict: docked" in text and res.returncode == 0)  # docked, and right
        print(f"{i:3d}  {' '.join(text.split())}")
    n = len(flights)
    print(f"docked by the truth in {docked} of {n} flights; verdict wrong in {wrong} of {n}; load {_load()}")


if __name__ == "__main__":
    main()
