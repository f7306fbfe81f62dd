"""``fly`` / ``replay`` / ``vehicle-sim`` / ``truth-check`` defects: no heartbeat says what to check; the
tlog of a flight that ended before its first control step is said to have nothing to replay (not "not
written by auvdock fly"); what a new user trips over (issue 37): a mission fly refuses is refused before
the banner, with nothing written; a host that does not resolve is said at once; vehicle-sim without
events says so; truth-check on a truth file still being written, or on a sim results file, says what
it is.  In simulated time on 127.0.0.1 (tests/helpers/loopback.py)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest
from helpers.loopback import HOST, ROOT, TANK, Loopback, free_port, write_mission

import auvdock.standins.vehicle_sim as vehicle_sim_module
from auvdock.cli import app
from auvdock.fly.link import connection_string, no_heartbeat_hint


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


def test_no_heartbeat_says_what_to_check(loop, tmp_path) -> None:
    port = free_port()
    res = loop.fly(port, tmp_path, "--connect-timeout", "1")
    assert res.exit_code == 3
    assert res.stderr == (
        f"aborted: no ArduSub heartbeat on udpin:127.0.0.1:{port} within 1 s: is `auvdock vehicle-sim` "
        "running (it sends to udpout:127.0.0.1:14550 unless its --port says otherwise), or the vehicle's "
        f"BlueOS sending MAVLink to 127.0.0.1's port {port}? (BlueOS: the MAVLink Endpoints page, a UDP "
        f"Client endpoint to the topside's address and port {port}; --port udp:{port} listens on "
        f"0.0.0.0:{port})\n"
    )


def test_no_heartbeat_hints_by_kind_of_port() -> None:
    assert "this computer's port 14550" in no_heartbeat_hint("udp:14550")
    assert "udp:14550 listens on 0.0.0.0:14550" in no_heartbeat_hint("udp:14550")
    assert no_heartbeat_hint("udpout:192.168.2.2:14550") == (
        "is `auvdock vehicle-sim --port udpin:192.168.2.2:14550` running, or a BlueOS MAVLink endpoint "
        "(the MAVLink Endpoints page) serving 192.168.2.2:14550?"
    )
    assert no_heartbeat_hint("/dev/ttyACM0,115200") == (
        "is the autopilot connected on /dev/ttyACM0,115200 (and at that baud rate)?"
    )


def test_replay_of_a_flight_no_vehicle_answered(loop, tmp_path) -> None:
    res = loop.fly(free_port(), tmp_path, "--connect-timeout", "1")
    assert res.exit_code == 3
    tlog = next(tmp_path.glob("*.tlog"))
    res = loop.runner.invoke(app, ["replay", str(tlog), str(TANK)])
    assert res.exit_code == 2, res.output
    assert res.stderr == (
        f"error: {tlog}: the flight ended before its first control step (nothing to replay): no vehicle "
        "ever answered (no ArduSub heartbeat in the tlog)\n"
    )


def test_replay_of_a_flight_refused_before_arming(loop, tmp_path) -> None:
    """The vehicle answered, the telemetry came, the pre-flight check refused to arm (a battery
    floor above the vehicle's voltage): no control step, and replay says where it stopped."""
    mission = write_mission(tmp_path / "floor.yaml", fly={"min_battery_v": 100.0})
    _, port = loop.vehicle()
    res = loop.fly(port, tmp_path, "--arm", mission=mission)
    assert res.exit_code == 3, res.output + res.stderr
    assert res.stderr.startswith("aborted: refusing to arm: battery ")
    tlog = next(tmp_path.glob("*.tlog"))
    res = loop.runner.invoke(app, ["replay", str(tlog), str(mission)])
    assert res.exit_code == 2, res.output
    assert res.stderr == (
        f"error: {tlog}: the flight ended before its first control step (nothing to replay): it stopped "
        "after the telemetry wait, before arming (camera start or pre-flight checks)\n"
    )


def test_a_tlog_not_written_by_fly_is_still_called_so(tmp_path) -> None:
    from auvdock.config.mission import load_mission
    from auvdock.fly.replay import ReplayError, replay

    empty = tmp_path / "x.tlog"
    empty.write_bytes(b"")
    with pytest.raises(ReplayError, match="no auvdock step markers"):
        replay(empty, load_mission(TANK), tmp_path / "r.h5")


# ------------------------------------------------------------------- issue 37: what a new user trips over
def test_a_mission_fly_refuses_is_refused_before_the_banner_and_writes_nothing(loop, tmp_path) -> None:
    """A: pacwave_common_10m with its Oracle (told the WEC dock's true motion in the realised sea, which no
    vehicle knows) with --arm: one line naming what is missing on a vehicle, exit 2, nothing said to be
    armed, no link opened: no tlog, no results.  (It was tank_0p6hz, the dock camera, which fly now flies:
    tests/test_fly_camera_sensor.py.)"""
    mission = ROOT / "missions" / "pacwave_common_10m.yaml"
    res = loop.runner.invoke(
        app, ["fly", str(mission), "--port", f"udpin:{HOST}:{free_port()}", "--arm", "--out", str(tmp_path)]
    )
    assert res.exit_code == 2, res.output
    assert res.stdout == ""
    assert res.stderr == (
        f"error: {mission}: dock.wec: oracle is told the dock's true motion in the realised sea (its "
        "definition), which no vehicle knows; fly a controller that forecasts it from the dock's telemetry "
        "(-c ce, sequential, optimized or naive)\n"
    )
    assert "ARMED" not in res.output
    assert list(tmp_path.iterdir()) == []


def test_the_arm_banner_says_it_arms_when_the_checks_pass(loop, tmp_path) -> None:
    """A: before connecting nothing is armed; the banner of --arm says what will happen."""
    port = free_port()
    res = loop.fly(port, tmp_path, "--arm", "--connect-timeout", "1")
    assert res.exit_code == 3, res.output  # no vehicle
    assert res.stdout.splitlines()[0] == (
        f"fly tank_positioned / oracle on udpin:{HOST}:{port}: --arm: arming when the pre-flight checks pass"
    )
    assert "ARMED" not in res.output


def test_a_host_that_does_not_resolve_is_said_at_once(loop, tmp_path) -> None:
    """D: fly, vehicle-sim and sitl-physics name the host in one line and exit 2, before any wait (a name
    under .invalid never resolves, RFC 6761: no network is asked)."""
    port = "udpout:notahost.invalid:14550"
    with pytest.raises(ValueError, match="^cannot resolve host 'notahost.invalid'$"):
        connection_string(port)
    assert connection_string(port, resolve=False) == port
    res = loop.runner.invoke(app, ["fly", "tank_positioned", "--port", port, "--out", str(tmp_path)])
    assert res.exit_code == 2, res.output
    assert res.stdout == ""
    assert res.stderr == f"error: --port {port}: cannot resolve host 'notahost.invalid'\n"
    assert loop.clock.now() == 0.0  # no connect timeout waited, even in simulated time
    assert list(tmp_path.iterdir()) == []
    port = "udpin:notahost.invalid:14550"
    res = loop.runner.invoke(app, ["vehicle-sim", "--port", port])
    assert res.exit_code == 2, res.output
    assert res.stderr == f"error: --port {port}: cannot resolve host 'notahost.invalid'\n"
    for option, value in [("--listen", "notahost.invalid:9002"), ("--camera", "udp:notahost.invalid:5600")]:
        res = loop.runner.invoke(app, ["sitl-physics", "tank_camera", option, value])
        assert res.exit_code == 2, res.output
        assert res.stderr == f"error: {option} {value}: cannot resolve host 'notahost.invalid'\n"


def test_vehicle_sim_without_events_says_no_events(loop, monkeypatch) -> None:
    """E: stopped before anyone armed it: "no events", not an empty "events: "."""
    run_forever = vehicle_sim_module.VehicleSim.run_forever

    def briefly(self, then=None) -> bool:  # stopped from elsewhere after 0.3 s (not a signal: exit 0)
        def stop() -> None:
            self.clock.sleep(0.3)
            self.stop()

        self.start()
        self.clock.start_thread(stop, "stopper")
        return run_forever(self, then)

    monkeypatch.setattr(vehicle_sim_module.VehicleSim, "run_forever", briefly)
    res = loop.runner.invoke(app, ["vehicle-sim", "--port", f"udpout:{HOST}:{free_port()}"])
    assert res.exit_code == 0, res.output + res.stderr
    assert res.stdout.splitlines()[-1] == "stopped at t = 0.3 s; no events"


_HOLD_TRUTH_OPEN = textwrap.dedent(
    """
    import sys
    from auvdock.config.mission import load_mission
    from auvdock.standins.truth_record import TruthRecord

    m = load_mission(sys.argv[2])
    truth = TruthRecord.for_stand_in(sys.argv[1], "vehicle-sim", m, {}, m.build_vehicle().n_thrusters)
    print("open", flush=True)
    sys.stdin.readline()  # until told to stop
    truth.end(False, "", 0.0)
    """
)


def test_truth_check_on_a_truth_file_still_being_written(tmp_path) -> None:
    """C: the truth file of a running vehicle-sim is locked by HDF5 while it is written (its writer's
    lock, in another process: TruthRecord as vehicle-sim opens it); truth-check says so in one line."""
    from typer.testing import CliRunner

    from auvdock.results.store import RunWriter

    flight = tmp_path / "flight.h5"  # a results file (its rows do not matter: the truth is not read)
    RunWriter(flight, mission_yaml="", mission_name="tank_positioned", controller="oracle").close()
    truth = tmp_path / "truth.h5"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    writer = subprocess.Popen(
        [sys.executable, "-c", _HOLD_TRUTH_OPEN, str(truth), str(TANK)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        assert writer.stdout is not None and writer.stdout.readline() == "open\n"
        res = CliRunner().invoke(app, ["truth-check", str(flight), str(truth)])
    finally:
        writer.communicate("stop\n", timeout=60)
    assert res.exit_code == 2, res.output
    assert res.stdout == ""
    assert res.stderr == (
        f"error: {truth}: still being written (is vehicle-sim or sitl-physics still running? stop it first)\n"
    )
    assert writer.returncode == 0


def test_truth_check_on_a_sim_results_file_says_what_it_is(tmp_path) -> None:
    """F: a sim run is not a flight (it was not "recorded before" anything); nor is a truth file."""
    from typer.testing import CliRunner

    from auvdock.config.mission import load_mission
    from auvdock.standins.truth_record import TruthRecord

    runner = CliRunner()
    args = ["sim", "still", "-c", "naive", "--timeout", "0.1", "--no-plots", "--out", str(tmp_path)]
    res = runner.invoke(app, args)
    assert res.exit_code == 1, res.output  # ran, not docked in 0.1 s
    run = tmp_path / "still_naive.h5"
    truth = tmp_path / "truth.h5"
    m = load_mission(TANK)
    TruthRecord.for_stand_in(truth, "vehicle-sim", m, {}, 8).end(False, "", 0.0)
    res = runner.invoke(app, ["truth-check", str(run), str(truth)])
    assert res.exit_code == 2, res.output
    assert res.stderr == (
        f"error: {run}: a sim results file, not a fly flight; truth-check scores the results file of a fly "
        "session flown against vehicle-sim (or sitl-physics) with --truth-out, on that truth file\n"
    )
    res = runner.invoke(app, ["truth-check", str(truth), str(truth)])
    assert res.exit_code == 2, res.output
    assert res.stderr == (
        f"error: {truth}: a truth file (--truth-out), not a fly flight; truth-check takes the flight's "
        "results file (fly's .h5) first, then the truth file\n"
    )


@pytest.mark.parametrize(
    ("signame", "after_banner_s"),
    [("SIGINT", 1.0), ("SIGTERM", 0.0), ("SIGTERM", 1.0), ("SIGTERM", None)],
    ids=["ctrl-c-1s", "sigterm-at-banner", "sigterm-1s", "sigterm-while-loading"],
)
def test_vehicle_sim_stopped_by_a_signal_completes_its_truth_file(tmp_path, signame, after_banner_s) -> None:
    """Ctrl-C (SIGINT) or SIGTERM to a vehicle-sim process writing --truth-out, at the banner, a second after
    it, or while it loads (``None``): it ends (exit 130, one line: what stopped it, and the truth file only
    when it is there), and the file is complete when named (on Python 3.11 a Ctrl-C that interrupted the
    wait for the simulator thread left the thread marked as ended while it still wrote, and the process
    exited in the middle: complete = False; a signal while stopping is now noted, not obeyed).  A real
    process on the wall clock and loopback, as signals come from outside (tests/test_fly_sigint.py)."""
    import signal
    import time

    from auvdock.results.store import read_run

    truth = tmp_path / "truth.h5"
    env = {**os.environ, "AUVDOCK_COMPILE": "never", "PYTHONUNBUFFERED": "1"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    cmd = [sys.executable, "-m", "auvdock", "vehicle-sim", "tank_positioned",
           "--port", f"udpout:{HOST}:{free_port()}", "--truth-out", str(truth)]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    try:
        seen = ""
        if after_banner_s is None:
            time.sleep(0.3)  # python is starting, auvdock importing
        else:
            while "Ctrl-C to stop" not in seen:  # the banner: the simulator is being built
                line = proc.stdout.readline() if proc.stdout is not None else ""
                assert line, seen
                seen += line
            if after_banner_s > 0:  # once it runs (its thread has created the truth file), however busy
                waited = 0.0
                while not truth.exists() and waited < 60.0 and proc.poll() is None:
                    time.sleep(0.05)
                    waited += 0.05
            time.sleep(after_banner_s)
        proc.send_signal(getattr(signal, signame))
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    out = seen + out
    if after_banner_s is None and proc.returncode == -signal.SIGTERM:  # before Python ran auvdock's code
        assert not truth.exists()
        return
    assert proc.returncode == 130, out
    assert "Traceback" not in out, out
    last = out.strip().splitlines()[-1]
    assert last.startswith("interrupted"), out
    if "truth in" in last:  # named: there, and complete
        assert last.endswith(f"truth in {truth}")
        r = read_run(truth)
        assert r.attrs["complete"] and r.outcome()["reason"] == "stopped"
    name = "Ctrl-C" if signame == "SIGINT" else "SIGTERM"
    stopped, before = f"interrupted ({name}): stopped at t = ", f"interrupted ({name}): before"
    if after_banner_s is None:  # nothing started
        said = f"interrupted ({name}): before the simulator started; nothing written"
        assert last in ("interrupted (SIGTERM)", said) and not truth.exists(), out
    elif after_banner_s == 0.0:  # the simulator may not have started
        assert last.startswith((stopped, before)), out
    else:
        assert last.startswith(stopped), out
