"""Rehearsals against the real ArduSub firmware (SITL) flying in auvdock's ocean, scored on the truth.

    python benchmarks/sitl_rehearsals.py --ardusub PATH/build/sitl/bin/ardusub \\
        --defaults PATH/Tools/autotest/default_params/sub-6dof.parm [--mission tank_positioned] \\
        [--controller oracle] [--estimation truth] [--runs 20] [--camera] [--rate 0.5] [--out DIR]

Per run, three programs on loopback, as docs/ardusub.md describes them: ``auvdock sitl-physics MISSION
--truth-out`` (the physics, and the truth), ``ardusub -w --model JSON --speedup 1`` with a home on the water
surface and ``--defaults DEFAULTS,extra.parm`` (``BATT_MONITOR 4``, ``SIM_BATT_VOLTAGE 16``,
``SIM_BARO_RND`` and ``SIM_BAR2_RND`` at a Bar30's 2 mm), a ground-station stand-in on TCP 5760
until ArduSub's EKF uses GPS (SITL boots when it connects), then ``auvdock fly MISSION --port
tcp:127.0.0.1:5762 --arm``; then sitl-physics is stopped with SIGTERM (it writes its truth) and ``auvdock
truth-check`` scores the flight.
Each run starts SITL afresh (``-w``: parameters wiped), so runs differ by SITL's own sensor noise and timing.
With ``--camera`` sitl-physics streams the dock's markers as RTP/H.264 to UDP 5600 (for
``missions/sitl_tank_camera.yaml``).  Prints per run how fly ended, the truth-check verdict and fly's lines on
the camera's rate, the loop's pace and the vehicle's clock; then how many runs docked by the truth (declared
docked, the verdict right) and how many verdicts were wrong: docked declared with the truth beyond the
tolerance at the instant judged (issue 29's figure 2), or a run ended undocked with the truth within it.

``--rate R`` runs the whole rehearsal at R x real time, for a machine that cannot keep real time (SITL,
the physics, the camera's rendering and fly on 2 cores ran at 0.33-0.52 x on 2026-12-07): SITL with
``--speedup R``, sitl-physics and fly with ``auvdock --clock-rate R``, so that every program agrees on how
long a control period is (fly refuses to arm a vehicle whose clock runs at another pace than its own).

Real time: about 75 s a run at rate 1 (SITL's EKF needs about 45 s after boot before ArduSub can arm).
Needs an ArduSub SITL built outside this project (``./waf configure --board sitl && ./waf sub`` in an
ArduPilot checkout); nothing here builds it, and no test needs it.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import time
from pathlib import Path

HOME = "33.810313,-118.393867,0,185"  # ArduSub's autotest home, at altitude 0 (the water surface)
#: The battery; the barometers' noise (:func:`_extra_parm`)
EXTRA_PARM = "BATT_MONITOR 4\nSIM_BATT_VOLTAGE 16.0\n"
#: A Bar30's depth resolution, m (the depth sensor's default, :class:`auvdock.sensing.settings.DepthSettings`)
BAR30_STD_M = 0.002


def _extra_parm() -> str:
    """SITL's extra parameters: the battery, and both barometers' noise at a Bar30's 2 mm (fly reads the
    second barometer, SCALED_PRESSURE2, whose SITL noise ``SIM_BAR2_RND`` is 0.2 m by default: a hundred
    times a Bar30's).  What ArduSub then reports is the mission's to state (``missions/sitl_tank_camera.yaml``
    measured 4-8.5 mm and 40 ms)."""
    # SITL's underwater barometer is sea water's (1024 kg/m^3, AP_Baro::SimpleUnderWaterAtmosphere): ArduSub,
    # and fly after it, convert pressure to depth with BARO_SPEC_GRAV (1.0 fresh water by default: every
    # depth 2.4 % deep, 2.4 cm at 1 m, twelve times the tank's stated 2 mm, and the filter left it out)
    return f"{EXTRA_PARM}SIM_BARO_RND {BAR30_STD_M:g}\nSIM_BAR2_RND {BAR30_STD_M:g}\nBARO_SPEC_GRAV 1.024\n"


def _stop(proc: subprocess.Popen, sig: int = signal.SIGTERM, wait_s: float = 20.0) -> None:
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(timeout=wait_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def _await_gps(timeout_s: float) -> bool:
    """Hold SITL's TCP 5760 as a ground station would (heartbeats) until ArduSub's EKF uses GPS."""
    from pymavlink import mavutil

    deadline = time.monotonic() + timeout_s
    gcs = None
    while gcs is None and time.monotonic() < deadline:
        try:
            gcs = mavutil.mavlink_connection("tcp:127.0.0.1:5760", source_system=250, autoreconnect=False)
        except OSError:
            time.sleep(0.2)
    if gcs is None:
        return False
    try:
        while time.monotonic() < deadline:
            gcs.mav.heartbeat_send(6, 8, 0, 0, 0)  # a GCS
            m = gcs.recv_match(type="STATUSTEXT", blocking=True, timeout=1.0)
            if m is not None and "using GPS" in m.text:
                return True
        return False
    finally:
        gcs.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ardusub", required=True, type=Path, help="the ArduSub SITL binary")
    ap.add_argument(
        "--defaults", required=True, help="SITL's defaults file(s), comma-separated (sub-6dof.parm)"
    )
    ap.add_argument("--mission", default="tank_positioned")
    ap.add_argument("--controller", default="oracle")
    ap.add_argument("--estimation", default=None, help="truth or filter (default: the mission's)")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--first", type=int, default=0, help="number of the first run (the physics' seed)")
    ap.add_argument("--timeout", type=float, default=60.0, help="fly's docking timeout, s")
    ap.add_argument("--camera", action="store_true", help="stream the dock's markers (sitl_camera)")
    ap.add_argument("--rate", type=float, default=1.0, help="every program's pace, x real time (<= 1)")
    ap.add_argument("--out", type=Path, default=Path("runs/sitl_rehearsals"))
    args = ap.parse_args()
    if not args.ardusub.is_file():
        print(f"error: --ardusub {args.ardusub}: no such file", file=sys.stderr)
        return 2
    for f in args.defaults.split(","):
        if not Path(f).is_file():
            print(f"error: --defaults {f}: no such file", file=sys.stderr)
            return 2
    if not 0.05 <= args.rate <= 1.0:
        print(f"error: --rate {args.rate:g}: expected a rate in [0.05, 1]", file=sys.stderr)
        return 2
    rate = ["--clock-rate", f"{args.rate:g}"] if args.rate != 1.0 else []
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"{args.mission}, {args.controller}, {args.runs} runs against {args.ardusub}; files in {args.out}")
    false_docks = missed = flown = truly = 0
    for i in range(args.first, args.first + args.runs):
        d = (args.out / f"{Path(args.mission).stem}_{args.controller}_{i}").resolve()
        d.mkdir(parents=True, exist_ok=True)
        (d / "extra.parm").write_text(_extra_parm())
        camera = ["--camera", "udp:127.0.0.1:5600"] if args.camera else []
        physics = subprocess.Popen(
            [
                "auvdock",
                *rate,
                "sitl-physics",
                args.mission,
                "--truth-out",
                str(d / "truth.h5"),
                "--seed",
                str(i),
                *camera,
            ],
            stdout=(d / "physics.log").open("w"),
            stderr=subprocess.STDOUT,
        )
        time.sleep(2.0)
        sitl = subprocess.Popen(
            [str(args.ardusub.resolve()), "-w", "--model", "JSON:127.0.0.1", "--speedup", f"{args.rate:g}",
             "--home", HOME,
             "--defaults", f"{args.defaults},{d / 'extra.parm'}", "-I0", "--sim-address=127.0.0.1"],
            cwd=d,
            stdout=(d / "sitl.log").open("w"),
            stderr=subprocess.STDOUT,
        )  # fmt: skip
        try:
            ready = _await_gps(120.0 / args.rate)
            time.sleep(3.0 / args.rate)
            fly = ["auvdock", *rate, "fly", args.mission, "--port", "tcp:127.0.0.1:5762", "--arm",
                   "--timeout", f"{args.timeout:g}", "-c", args.controller, "--out", str(d)]  # fmt: skip
            if args.estimation:
                fly += ["--estimation", args.estimation]
            res = subprocess.run(fly, capture_output=True, text=True) if ready else None
        finally:
            _stop(physics)
            _stop(sitl, signal.SIGTERM, 10.0)
        if res is None:
            print(f"run {i}: ArduSub's EKF did not use GPS within 120 s (see {d / 'sitl.log'})", flush=True)
            continue
        (d / "fly.log").write_text(res.stdout + res.stderr)
        ended = (res.stdout.strip().splitlines() or ["(no output)"])[-1]
        flight = next(d.glob(f"{Path(args.mission).stem}_*_fly_*.h5"), None)
        if flight is None:
            print(f"run {i}: fly wrote no results (exit {res.returncode}): {ended}", flush=True)
            continue
        check = subprocess.run(
            ["auvdock", "truth-check", str(flight), str(d / "truth.h5")], capture_output=True, text=True
        )
        (d / "check.log").write_text(check.stdout + check.stderr)
        flown += 1
        lines = check.stdout.strip().splitlines()
        right = "the verdict is right" in check.stdout
        docked = ended.startswith("docked")
        false_docks += int(docked and not right)
        missed += int(not docked and not right)
        truly += int(docked and right)
        print(f"run {i}: fly exit {res.returncode}: {ended}", flush=True)
        for line in lines:
            print(f"    {line}", flush=True)
        for line in (res.stdout + res.stderr).splitlines():  # the camera, the pace, the vehicle's clock
            if line.startswith(("camera:", "pace:")) or "the vehicle's clock ran at" in line:
                print(f"    fly: {line.strip()}", flush=True)
    print(
        f"{flown} runs flown: docked by the truth (declared docked, the verdict right) in {truly}; "
        f"docked declared with the truth beyond the tolerance in {false_docks}; "
        f"ended undocked with the truth within it in {missed}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
