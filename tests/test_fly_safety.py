"""fly's safety rules and the vehicle-state fold, without a link.

(auvdock.fly.safety, auvdock.fly.vehicle_state)
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from auvdock.config.catalog import resolve
from auvdock.config.mission import load_mission
from auvdock.controllers.status import STATUS_NAMES
from auvdock.fly.safety import FailedSolves, limit_reason, preflight_problems, staleness, takeover_reason
from auvdock.fly.vehicle_state import BATTERY_FILTER_S, StatustextJoiner, VehicleState
from auvdock.vehicle.ardusub import MODES

FLY = load_mission(resolve("tank_positioned")).fly


class Msg(SimpleNamespace):
    def get_type(self) -> str:
        return self.mtype

    def get_srcSystem(self) -> int:  # noqa: N802 -- pymavlink's name
        return self.src


def test_takeover_rules() -> None:
    manual = MODES["MANUAL"]
    assert takeover_reason([], we_armed=False, armed=False, mode=None) is None
    assert takeover_reason(["pilot input from system 2 (MANUAL_CONTROL)"], False, False, None) == (
        "pilot input from system 2 (MANUAL_CONTROL)"
    )
    assert takeover_reason([], True, True, manual) is None
    assert takeover_reason([], True, False, manual, "Crash: Disarming") == (
        "the vehicle was disarmed, not by fly (the vehicle said: Crash: Disarming)"
    )
    assert takeover_reason([], True, True, MODES["ALT_HOLD"]) == "the vehicle changed to ALT_HOLD, not by fly"


def test_limits_staleness_and_failed_solves() -> None:
    assert limit_reason(FLY, None, None, 30.0) is None
    limit = FLY.time_limit_s if FLY.time_limit_s is not None else 30.0 + 60.0
    assert (
        limit_reason(FLY, None, limit + 0.1, 30.0)
        == f"time limit: {limit:g} s since arming (fly.time_limit_s)"
    )
    assert limit_reason(FLY, None, limit - 0.1, 30.0) is None
    assert staleness(FLY, 0.0) == "ok"
    assert staleness(FLY, FLY.stale_neutral_s + 1e-3) == "neutral"
    assert staleness(FLY, FLY.stale_abort_s + 1e-3) == "abort"
    failed = next(code for code, name in STATUS_NAMES.items() if name == "failed")
    ok = next(code for code, name in STATUS_NAMES.items() if name == "ok")
    counter = FailedSolves(3)
    assert [counter.update(s) for s in (failed, failed, ok, failed, failed)] == [None] * 5
    assert (
        counter.update(failed)
        == "controller: 3 steps in a row without a converged solve (last status failed)"
    )


def test_preflight_problems_on_measured_values() -> None:
    m = load_mission(resolve("tank_positioned"))
    start = float(m.start_state()[2])
    p_dock = np.asarray(m.build_dock().position(0.0))
    assert preflight_problems(m, [], (start, "SCALED_PRESSURE2"), p_dock, 15.5) == []
    far = preflight_problems(m, [], (start + 1.0, "SCALED_PRESSURE2"), p_dock, 15.5)
    assert any(
        p.startswith(f"depth {start + 1.0:.2f} m (SCALED_PRESSURE2), but the mission starts") for p in far
    )
    if m.fly.min_battery_v > 0:
        low = preflight_problems(m, [], (start, "SCALED_PRESSURE2"), p_dock, m.fly.min_battery_v - 1)
        floor = m.fly.min_battery_v
        assert low == [f"battery {floor - 1:.2f} V, below the floor {floor:g} V (fly.min_battery_v)"]
    assert preflight_problems(m, ["SYSID_MYGCS is 1"], None, p_dock, 15.5)[0] == "SYSID_MYGCS is 1"


def test_statustext_chunks_joined() -> None:
    j = StatustextJoiner()
    first = "x" * 50
    assert j.join(SimpleNamespace(text=first, id=7)) is None
    assert j.join(SimpleNamespace(text="end", id=7)) == first + "end"
    assert j.join(SimpleNamespace(text=" PreArm: x ", id=0)) == "PreArm: x"


def test_vehicle_state_fold() -> None:
    s = VehicleState()
    events = s.feed(
        [
            (0, Msg(mtype="PARAM_VALUE", src=1, param_id=b"SYSID_MYGCS\x00", param_value=255.0)),
            (0, Msg(mtype="COMMAND_ACK", src=1, command=400, result=0)),
            (0, Msg(mtype="STATUSTEXT", src=1, text="PreArm: EKF not ready", id=0)),
            (0, Msg(mtype="SYS_STATUS", src=1, voltage_battery=16000)),
            (0, Msg(mtype="MANUAL_CONTROL", src=1)),  # the vehicle's own: not a takeover
        ],
        vehicle_sysid=1,
    )
    assert events == ["vehicle: PreArm: EKF not ready"]
    assert s.params == {"SYSID_MYGCS": 255.0} and s.acks == [(400, 0)]
    assert s.last_arm_text == "PreArm: EKF not ready" and s.battery_v == 16.0 and not s.foreign
    # the low-pass: a step to 15 V moves the estimate by dt / tau after dt
    s.feed([(int(0.1e6), Msg(mtype="SYS_STATUS", src=1, voltage_battery=15000))], vehicle_sysid=1)
    assert abs(s.battery_v - (16.0 - 0.1 / BATTERY_FILTER_S)) < 1e-12
    s.feed([(0, Msg(mtype="RC_CHANNELS_OVERRIDE", src=9))], vehicle_sysid=1)
    assert s.foreign == ["pilot input from system 9 (RC_CHANNELS_OVERRIDE)"]


def test_rc_channels_that_fly_did_not_send_are_a_takeover() -> None:
    s = VehicleState()
    ours = (1500, 1500, 1500, 1500, 1600, 1500)
    s.sent_channels(0, ours)

    def rc(stamp: int, ch: tuple[int, ...]) -> tuple[int, Msg]:
        return stamp, Msg(mtype="RC_CHANNELS", src=1, **{f"chan{i + 1}_raw": c for i, c in enumerate(ch)})

    s.feed([rc(600_000, ours)], 1)
    assert not s.foreign
    other = (1500, 1500, 1500, 1500, 1900, 1500)
    s.feed([rc(700_000, other), rc(800_000, other)], 1)
    assert s.foreign == [
        "the vehicle uses channel 5 = 1900 us where fly sends 1600 us (RC_CHANNELS): another ground "
        "station with our system id is flying"
    ]


def test_a_vehicle_clock_at_another_pace_is_refused_with_the_rate_to_give() -> None:
    """A simulator that cannot keep fly's pace (ArduSub SITL at 0.45 x real time on a busy machine) flies
    a vehicle that answers at another speed than its model's: refused, naming the rate that would match."""
    from auvdock.fly.safety import clock_rate_problem

    assert clock_rate_problem(1.03, 3.0) is None and clock_rate_problem(float("nan"), 0.0) is None
    assert clock_rate_problem(0.45, 3.2) == (
        "the vehicle's clock runs at 0.45 x fly's (its ATTITUDE time_boot_ms over 3.2 s): a simulator at "
        "0.45 x real time needs fly at the same rate (auvdock --clock-rate 0.45 fly ...; ArduSub SITL with "
        "--speedup 0.45)"
    )
    # fly already at half speed, the vehicle at a quarter: the rate to give is the vehicle's, in wall terms
    assert "needs fly at the same rate (auvdock --clock-rate 0.25 fly" in clock_rate_problem(0.5, 3.0, 0.5)

