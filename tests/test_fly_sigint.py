"""Ctrl-C (SIGINT) at random moments of ``auvdock fly`` (a real process on the wall clock).

``python -m auvdock.cli fly --arm`` flies against an in-process ``VehicleSim`` on 127.0.0.1
(wall clock); once the command has started (its first line), SIGINT comes after a random
delay drawn here, anywhere from loading the controller, connecting and arming to flying
(--timeout 4; a SIGINT during the ending is in tests/test_fly.py, deterministically).  Each
interrupted run must exit with status 130, print no traceback, leave the vehicle disarmed
and leave a readable, complete results file if it made one.  Only exit codes, output and
files are checked, never durations.  The drawn delays are in every failure message;
``AUVDOCK_SIGINT_SEED`` replays a draw.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import h5py
from helpers.loopback import HOST, TANK, free_port

from auvdock.config.mission import load_mission
from auvdock.results.store import read_run
from auvdock.standins.vehicle_sim import VehicleSim

N_MOMENTS = 6
MAX_DELAY_S = 4.5  # after the command's first line; a run lasts 6 s or more from there


def _fly_interrupted(delay_s: float, out: Path, mission) -> dict:
    """One fly process, SIGINT after ``delay_s`` (s after its first line); what happened."""
    port = free_port()
    # wall clock; held at the start while disarmed, as vehicle-sim does
    sim = VehicleSim(mission, port=f"udpout:{HOST}:{port}", hold_start=True).start()
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    args = ["fly", str(TANK), "--port", f"udpin:{HOST}:{port}", "--out", str(out), "--arm", "--timeout", "4"]
    proc = subprocess.Popen(
        [sys.executable, "-m", "auvdock.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        text=True,
    )
    try:
        first = proc.stdout.readline()  # "fly tank_0p6hz / oracle on ...: ARMED"
        time.sleep(delay_s)
        sent = proc.poll() is None
        if sent:
            proc.send_signal(signal.SIGINT)
        try:
            rest, err = proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            proc.kill()
            rest, err = proc.communicate()
        time.sleep(0.2)  # the vehicle handles what reached it
        return {
            "delay_s": delay_s,
            "sent": sent,
            "rc": proc.returncode,
            "stdout": first + rest,
            "stderr": err,
            "armed": sim.armed,
            "files": sorted(out.glob("*.h5")),
        }
    finally:
        if proc.poll() is None:
            proc.kill()
        sim.stop()


def test_sigint_at_random_moments_exits_130_cleanly(tmp_path) -> None:
    seed = int(os.environ.get("AUVDOCK_SIGINT_SEED", random.SystemRandom().randrange(2**32)))
    rng = random.Random(seed)
    mission = load_mission(TANK)
    results: list[dict] = []
    attempt = 0
    with ThreadPoolExecutor(max_workers=N_MOMENTS) as pool:  # all at once
        while sum(r["sent"] for r in results) < N_MOMENTS and attempt < 3 * N_MOMENTS:
            jobs = []
            for _ in range(N_MOMENTS - sum(r["sent"] for r in results)):
                attempt += 1
                out = tmp_path / f"run{attempt}"
                out.mkdir()
                jobs.append(pool.submit(_fly_interrupted, rng.uniform(0.0, MAX_DELAY_S), out, mission))
            results.extend(job.result() for job in jobs)
    interrupted = [r for r in results if r["sent"]]
    where = f"seed {seed}, delays {[round(r['delay_s'], 2) for r in results]}"
    assert len(interrupted) >= N_MOMENTS, where
    for r in interrupted:
        what = f"{where}; this one {r['delay_s']:.2f} s:\n{r['stdout']}\n{r['stderr']}"
        assert r["rc"] == 130, what
        assert "Traceback" not in r["stderr"] + r["stdout"], what
        assert "interrupted" in r["stderr"], what
        assert not r["armed"], what  # every ending disarms
        for h5 in r["files"]:  # a results file, if the run had made one, reads back whole
            run = read_run(h5)
            with h5py.File(h5, "r") as f:
                assert bool(f.attrs["complete"]), what
                assert f.attrs["reason"] in ("interrupted", "timeout", "docked"), what
            assert len(run.time_s) >= 0
