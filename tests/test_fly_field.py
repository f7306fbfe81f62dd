"""fly's field checks on loopback (127.0.0.1), in simulated time: parameter conformance before
arming, pre-flight limits on measured values, arming that waits for pre-arm checks, takeover by
another station (disarm, mode change, pilot input), battery floor, time limit, rates re-requested.

Each refusal and abort is checked by its exact line; takeovers by the exit code (4), by the
vehicle hearing nothing from fly but the release after one control period, and by fly not
disarming a vehicle someone else now flies.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
from helpers.loopback import HOST, NEUTRAL, RELEASE, TANK, Loopback, arm_commands, overrides, write_mission
from pymavlink import mavutil

from auvdock.config.mission import load_mission
from auvdock.fly import FlySession
from auvdock.fly.link import MavlinkLink

DT = 0.05
ARM_DISARM = 400


@pytest.fixture
def loop(monkeypatch):
    lb = Loopback(monkeypatch)
    yield lb
    lb.close()


def station(loop: Loopback, address: tuple[str, int], sysid: int = 254) -> Any:
    """Another ground station on loopback, sending to ``address``, its datagrams counted by the clock."""
    url = f"udpout:{address[0]}:{address[1]}"
    conn = mavutil.mavlink_connection(url, source_system=sysid, source_component=190)
    loop.clock.attach(conn)
    return conn


def session(loop: Loopback, port: int, tmp_path: Path, mission: Any = TANK, **kwargs: Any) -> FlySession:
    m = load_mission(mission) if isinstance(mission, str | Path) else mission
    link = MavlinkLink(f"udpin:{HOST}:{port}", clock=loop.clock)
    return FlySession(m, link, arm=kwargs.pop("arm", True), out=tmp_path / "run.h5", **kwargs)


def events_of(result: Any) -> list[str]:
    return [text for _, text in result.events]


# -- conformance and pre-flight: refused before any arm command -------------------------------------
@pytest.mark.parametrize(
    ("params", "line"),
    [
        (
            {"SYSID_MYGCS": 254},
            "aborted: refusing to arm: SYSID_MYGCS is 254, but fly sends as system 255: ArduSub would "
            "ignore every override; set SYSID_MYGCS = 255 or run fly --sysid 254",
        ),
        (
            {"RC_OVERRIDE_TIME": -1, "FS_GCS_ENABLE": 0},
            "aborted: refusing to arm: RC_OVERRIDE_TIME is -1: overrides never lapse, so the last thrust "
            "stays on if fly's link drops; set RC_OVERRIDE_TIME = 1 (s) (and 1 more, in the events)",
        ),
    ],
)
def test_parameter_problems_refuse_to_arm(loop, tmp_path, params, line) -> None:
    sim, port = loop.vehicle(params=params)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "5")
    assert res.exit_code == 3, res.output
    assert res.stderr.strip() == line
    assert arm_commands(sim) == [] and not sim.armed
    assert "parameters: SYSID_MYGCS=" in res.output  # what was read is shown and recorded


def test_dry_run_reports_parameter_problems_and_goes_on(loop, tmp_path) -> None:
    sim, port = loop.vehicle(params={"FRAME_CONFIG": 1})
    res = loop.fly(port, tmp_path, "--timeout", "1")
    assert res.exit_code == 1, res.output  # the dry run's ending: not docked
    assert "parameter check: FRAME_CONFIG is 1 (Vectored)" in res.output
    assert "dry run: arming would be refused (1 problem(s))" in res.output
    assert arm_commands(sim) == []


def test_refuses_to_arm_at_the_surface_for_a_mission_at_depth(loop, tmp_path) -> None:
    """The vehicle floats at the surface (depth 0 from its pressure sensor); the mission starts at
    1 m.  The mission frame would call it 1 m deep; the pressure sensor does not."""
    surface = write_mission(tmp_path / "surface.yaml", start={"state": [0.0] * 12})
    sim, port = loop.vehicle(surface)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "5")
    assert res.exit_code == 3, res.output
    median = r"SCALED_PRESSURE2, median of \d+ readings over [0-9.]+ s"
    assert re.fullmatch(
        rf"aborted: refusing to arm: geofence: depth 0\.00 m above the minimum 0\.1 m \({median}\) "
        r"\(and 1 more, in the events\)",
        res.stderr.strip(),
    ), res.stderr
    said = rf"pre-flight: depth 0\.00 m \({median}\), but the mission starts at 1\.00 m: bring the vehicle"
    tail = r"\s+within 0\.3 m of it \(fly\.start_depth_tolerance_m\)"
    assert re.search(said + tail, res.output), res.output
    assert arm_commands(sim) == []


@pytest.mark.parametrize("seed", range(4))
def test_the_pre_flight_depth_is_a_median_so_a_noisy_barometer_does_not_refuse(loop, tmp_path, seed):
    """SITL's second barometer has 0.2 m of noise by default (SIM_BAR2_RND): one raw reading is off by
    more than the 0.3 m tolerance one time in eight.  The check reads the median over
    fly.preflight_window_s, and passes on every seed."""
    noisy = write_mission(tmp_path / "noisy.yaml", sensors={"depth": {"std_m": 0.2}}, seed=seed)
    sim, port = loop.vehicle(noisy, noise=True)
    res = loop.fly(port, tmp_path, "--timeout", "1", mission=noisy)
    assert "pre-flight checks pass" in res.output, res.output
    assert arm_commands(sim) == []


def test_the_filtered_depth_is_the_median_of_the_window():
    from types import SimpleNamespace

    from auvdock.fly.telemetry import TelemetrySensors
    from auvdock.fly.units import pressure_hpa

    tel = TelemetrySensors.__new__(TelemetrySensors)
    tel._latest, tel._new, tel._history = {}, {}, {}
    tel._surface_hpa = {"SCALED_PRESSURE2": pressure_hpa(0.0)}
    tel._density = 1025.0  # WATER_DENSITY of pressure_hpa
    depths = [1.0, 5.0, 1.2, 0.9, 1.1]  # one wild reading
    msgs = []
    for k, d in enumerate(depths):
        msg = SimpleNamespace(press_abs=pressure_hpa(d), get_type=lambda: "SCALED_PRESSURE2")
        msgs.append((1_000_000 + 200_000 * k, msg))
    tel.feed(msgs)
    depth, what = tel.filtered_depth(0.5)  # the last three: 1.2, 0.9, 1.1
    assert depth == pytest.approx(1.1, abs=2e-3)
    assert what == "SCALED_PRESSURE2, median of 3 readings over 0.40 s"
    assert tel.depth_readings(10.0) == 5


def test_refuses_to_arm_on_a_low_battery(loop, tmp_path) -> None:
    sim, port = loop.vehicle(battery_v=13.0)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "5")
    assert res.exit_code == 3, res.output
    assert res.stderr.strip() == (
        "aborted: refusing to arm: battery 13.00 V, below the floor 13.6 V (fly.min_battery_v)"
    )
    assert arm_commands(sim) == []


# -- arming waits for pre-arm checks ---------------------------------------------------------------
def test_arming_waits_for_pre_arm_checks_and_shows_why(loop, tmp_path) -> None:
    reason = "Must assign a disarm or arm_toggle button or disarm aux function"
    sim, port = loop.vehicle()
    sim.set_prearm_failure(reason)
    s = session(loop, port, tmp_path, timeout_s=0.5)
    clear_at = []

    def on_event(t: float, text: str) -> None:
        if text == f"vehicle: Arm: {reason}" and not clear_at:
            clear_at.append(loop.clock.now())
        if len(clear_at) == 1 and text.startswith("vehicle: Arm:") and loop.clock.now() - clear_at[0] > 1.0:
            sim.set_prearm_failure(None)  # the operator fixed it (after two refusals, 2 s apart)
            clear_at.append(loop.clock.now())

    result = s.run(on_event=on_event)
    events = events_of(result)
    assert events.count(f"vehicle: Arm: {reason}") >= 2  # shown each time the vehicle refused
    assert "armed" in events and result.reason == "timeout"
    assert len(arm_commands(sim)) >= 3  # retried every 2 s


def test_arming_gives_up_with_the_vehicles_reason(loop, tmp_path) -> None:
    reason = "Must assign a disarm or arm_toggle button or disarm aux function"
    mission = write_mission(tmp_path / "m.yaml", fly={"arm_timeout_s": 5.0})
    sim, port = loop.vehicle(mission)
    sim.set_prearm_failure(reason)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "5", mission=mission)
    assert res.exit_code == 3, res.output
    assert res.stderr.strip() == f"aborted: arming refused for 5 s (fly.arm_timeout_s): Arm: {reason}"
    assert 2 <= len(arm_commands(sim)) <= 4 and not sim.armed


def test_waiting_for_the_position_shows_progress_and_names_the_stream(loop, tmp_path) -> None:
    mission = write_mission(tmp_path / "m.yaml", fly={"telemetry_timeout_s": 12.0})
    sim, port = loop.vehicle(mission)
    original = sim._send_local_position_ned
    sim._send_local_position_ned = lambda: None  # no position estimate (yet)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "5", mission=mission)
    assert res.exit_code == 3, res.output
    assert "waiting for LOCAL_POSITION_NED: 5 s of 12 s" in res.output
    assert "waiting for LOCAL_POSITION_NED: 10 s of 12 s" in res.output
    assert res.stderr.strip() == (
        f"aborted: no LOCAL_POSITION_NED from udpin:{HOST}:{port} within 12 s (fly.telemetry_timeout_s) "
        "(ArduSub's position estimate: does the vehicle have a position source and an origin?)"
    )
    assert arm_commands(sim) == []
    sim._send_local_position_ned = original


# -- takeover: another station flies -------------------------------------------------------------------
def takeover_run(
    loop: Loopback, tmp_path: Path, act: Any, at: float = 2.0, **sim_kwargs: Any
) -> tuple[Any, Any, float]:
    """Fly; at mission time ``at`` call ``act(sim)`` once; (result, sim, clock time of the act)."""
    sim, port = loop.vehicle(**sim_kwargs)
    s = session(loop, port, tmp_path, timeout_s=20.0)
    when: list[float] = []

    def progress(t: float, dist: float, status: str) -> None:
        if t >= at and not when:
            when.append(loop.clock.time())
            act(sim, port)

    result = s.run(progress=progress)
    return result, sim, when[0]


def assert_stopped(sim: Any, since: float) -> None:
    """After ``since`` (+ one control period and the datagram's way), fly sent only the release,
    and never disarmed (the vehicle is someone else's now)."""
    after = [(stamp, ch) for stamp, ch in overrides(sim) if stamp > since]
    assert after and after[-1][1] == RELEASE, after
    assert all(ch == RELEASE for stamp, ch in after if stamp > since + DT + 1e-3), after
    disarms = [d for _, mtype, src, d in sim.received if mtype == "COMMAND_LONG" and src == 255
               and d["command"] == ARM_DISARM and d["param1"] == 0]  # fmt: skip
    assert disarms == []


def test_disarm_by_another_station_stops_fly(loop, tmp_path) -> None:
    def disarm(sim, port):
        station(loop, sim.local_address).mav.command_long_send(1, 1, ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)

    result, sim, when = takeover_run(loop, tmp_path, disarm)
    assert (result.reason, result.exit_code) == ("takeover", 4)
    assert result.message == "the vehicle was disarmed, not by fly (the vehicle said: Disarming motors)"
    assert_stopped(sim, when)
    r = json.loads(result.outcome["events_json"])
    assert r[-1][1] == "end: takeover: " + result.message


def test_mode_change_by_another_station_stops_fly(loop, tmp_path) -> None:
    def stabilize(sim, port):
        station(loop, sim.local_address).mav.set_mode_send(1, 1, 0)  # custom mode 0: STABILIZE

    result, sim, when = takeover_run(loop, tmp_path, stabilize)
    assert (result.reason, result.exit_code) == ("takeover", 4)
    assert result.message == "the vehicle changed to STABILIZE, not by fly"
    assert_stopped(sim, when)
    assert sim.armed  # left as the other station has it


def test_pilot_input_from_another_system_stops_fly(loop, tmp_path) -> None:
    """A joystick (MANUAL_CONTROL from system 254) seen on fly's link."""

    def joystick(sim, port):
        station(loop, (HOST, port)).mav.manual_control_send(1, 300, 0, 500, 0, 0)

    result, sim, when = takeover_run(loop, tmp_path, joystick)
    assert (result.reason, result.exit_code) == ("takeover", 4)
    assert result.message == "pilot input from system 254 (MANUAL_CONTROL)"
    assert_stopped(sim, when)


def test_joystick_with_our_system_id_seen_in_rc_channels(loop, tmp_path) -> None:
    """QGroundControl and fly both default to system 255: ArduSub obeys the joystick too.  fly
    sees it in RC_CHANNELS (channels it did not send) and stops."""
    sim, port = loop.vehicle()
    s = session(loop, port, tmp_path, timeout_s=20.0)
    qgc: list[Any] = []

    def progress(t: float, dist: float, status: str) -> None:
        if t >= 2.0:
            if not qgc:
                qgc.append(station(loop, sim.local_address, sysid=255))
            qgc[0].mav.manual_control_send(1, 400, 0, 500, 0, 0)  # forward half stick, every step

    result = s.run(progress=progress)
    assert (result.reason, result.exit_code) == ("takeover", 4)
    # the joystick's channels (forward 1500 + 400 * 0.5 (gain) * 0.4 = 1580 us, the others 1500)
    assert re.fullmatch(
        r"the vehicle uses channel \d = 1(500|580) us where fly sends \d+ us \(RC_CHANNELS\): "
        r"another ground station with our system id is flying",
        result.message,
    ), result.message
    t_take = next(t for t, e in result.events if e.startswith("takeover:"))
    t_first = next(t for t, e in result.events if e.startswith("armed"))
    assert t_take > t_first + 2.0


# -- limits during the flight ----------------------------------------------------------------------
def test_battery_floor_aborts_in_flight(loop, tmp_path) -> None:
    sim, port = loop.vehicle()
    s = session(loop, port, tmp_path, timeout_s=20.0)

    def progress(t: float, dist: float, status: str) -> None:
        if t >= 2.0:
            sim.set_battery(12.0)

    result = s.run(progress=progress)
    assert (result.reason, result.exit_code) == ("aborted", 3)
    assert result.message.startswith("battery 13.")  # low-passed (1 s): crosses the floor on its way down
    assert result.message.endswith(" V, below the floor 13.6 V (fly.min_battery_v)")
    assert not sim.armed  # an abort disarms


def test_time_limit_aborts(loop, tmp_path) -> None:
    mission = write_mission(tmp_path / "m.yaml", fly={"time_limit_s": 3.0})
    sim, port = loop.vehicle(mission)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "20", mission=mission)
    assert res.exit_code == 3, res.output
    assert res.stderr.strip() == "aborted: time limit: 3 s since arming (fly.time_limit_s)"
    assert not sim.armed


def test_rates_are_re_requested(loop, tmp_path) -> None:
    """A ground station reset the rates: fly asks again every fly.rates_refresh_s."""
    mission = write_mission(tmp_path / "m.yaml", fly={"rates_refresh_s": 2.0})
    sim, port = loop.vehicle(mission)
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "7", mission=mission)
    assert res.exit_code in (0, 1), res.output
    requests = [stamp for stamp, mtype, src, d in sim.received
                if mtype == "COMMAND_LONG" and d["command"] == 511 and d["param1"] == 30]  # fmt: skip
    assert len(requests) >= 1 + 3  # at the start, then every 2 s of a 7 s flight
    assert "telemetry rates re-requested 3 time(s)" in res.output


def test_neutral_overrides_only_before_arming(loop, tmp_path) -> None:
    """Every override before the arm command is neutral (conformance and waits stream neutral)."""
    sim, port = loop.vehicle()
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "1")
    assert res.exit_code in (0, 1), res.output
    t_arm = next(stamp for stamp, mtype, _, d in sim.received
                 if mtype == "COMMAND_LONG" and d["command"] == ARM_DISARM and d["param1"] == 1)  # fmt: skip
    assert all(ch == NEUTRAL for stamp, ch in overrides(sim) if stamp <= t_arm)


def test_no_battery_monitor_refuses_to_arm_with_the_fix(loop, tmp_path) -> None:
    sim, port = loop.vehicle(battery_v=0.0)  # SYS_STATUS voltage_battery 0: no monitor
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "5")
    assert res.exit_code == 3, res.output
    assert res.stderr.strip() == (
        "aborted: refusing to arm: battery: the vehicle reports no voltage (SYS_STATUS; is BATT_MONITOR "
        "set?); set fly.min_battery_v: 0 to fly without a floor"
    )
    free = write_mission(tmp_path / "m.yaml", fly={"min_battery_v": 0})
    sim2, port2 = loop.vehicle(free, battery_v=0.0)
    res = loop.fly(port2, tmp_path, "--arm", "--timeout", "1", mission=free)
    assert res.exit_code in (0, 1), res.output  # flies without a floor


def test_depth_limit_acts_on_the_pressure_sensor_in_flight(loop, tmp_path) -> None:
    """A plant 300 N buoyant (beyond the vertical thrusters) rises out of a 0.9 m depth floor:
    abort on the pressure sensor's depth, disarm."""
    mission = write_mission(tmp_path / "m.yaml", fly={"geofence": {"min_depth_m": 0.9}})
    plant = write_mission(tmp_path / "plant.yaml", base=mission, vehicle={"overrides": {"buoyancy_N": 412.8}})
    sim, port = loop.vehicle(plant, hold_start=True)  # held at the start until armed
    res = loop.fly(port, tmp_path, "--arm", "--timeout", "20", mission=mission)
    assert res.exit_code == 3, res.output
    line = res.stderr.strip()
    pattern = r"aborted: geofence: depth 0\.\d\d m above the minimum 0\.9 m \(SCALED_PRESSURE2\)"
    assert re.fullmatch(pattern, line), line
    assert not sim.armed
