"""ArduSub's parameters against fly's commands (auvdock.fly.conformance): exact lines, one per problem."""

from __future__ import annotations

import pytest

from auvdock.fly.conformance import check_parameters, parameter_names
from auvdock.standins.vehicle_sim import default_parameters

DT = 0.05


def check(**changes: float | None) -> list[str]:
    params = default_parameters(255)
    for name, value in changes.items():
        if value is None:
            params.pop(name, None)
        else:
            params[name] = value
    return check_parameters(params, sysid=255, dt=DT)


def test_a_blue_rov2_heavy_as_shipped_passes() -> None:
    assert check() == []


def test_master_names_the_gcs_id_mav_gcs_sysid() -> None:
    """ArduPilot 4.7 renamed SYSID_MYGCS to MAV_GCS_SYSID: either is read."""
    assert check(SYSID_MYGCS=None, MAV_GCS_SYSID=255) == []
    assert check(SYSID_MYGCS=None, MAV_GCS_SYSID=254) == [
        "MAV_GCS_SYSID is 254, but fly sends as system 255: ArduSub would ignore every override; "
        "set MAV_GCS_SYSID = 255 or run fly --sysid 254"
    ]


@pytest.mark.parametrize(
    ("changes", "line"),
    [
        (
            {"SYSID_MYGCS": 254},
            "SYSID_MYGCS is 254, but fly sends as system 255: ArduSub would ignore every override; "
            "set SYSID_MYGCS = 255 or run fly --sysid 254",
        ),
        (
            {"FRAME_CONFIG": 1},
            "FRAME_CONFIG is 1 (Vectored), but fly's channel map inverts frame 2 (Vectored_6DOF, "
            "the BlueROV2 Heavy): set FRAME_CONFIG = 2 and reboot",
        ),
        (
            {"SERVO3_FUNCTION": 1},
            "SERVO3_FUNCTION is 1, but fly's channel map needs motor 3 on output 3: "
            "set SERVO3_FUNCTION = 35 (Motor3)",
        ),
        ({"MOT_5_DIRECTION": 0}, "MOT_5_DIRECTION is 0: must be 1 or -1 (set it from a thruster test)"),
        (
            {"RC_OVERRIDE_TIME": 0},
            "RC_OVERRIDE_TIME is 0: ArduSub ignores RC overrides; set RC_OVERRIDE_TIME = 1 (s)",
        ),
        (
            {"RC_OVERRIDE_TIME": -1},
            "RC_OVERRIDE_TIME is -1: overrides never lapse, so the last thrust stays on if fly's link "
            "drops; set RC_OVERRIDE_TIME = 1 (s)",
        ),
        (
            {"RC_OVERRIDE_TIME": 0.1},
            "RC_OVERRIDE_TIME is 0.1 s, shorter than 3 control periods (0.15 s): overrides would lapse "
            "between fly's commands; set RC_OVERRIDE_TIME = 1 (s)",
        ),
        (
            {"RC_OVERRIDE_TIME": 10},
            "RC_OVERRIDE_TIME is 10 s: after a lost link the last thrust stays on that long; set "
            "RC_OVERRIDE_TIME to at most 3 s",
        ),
        (
            {"FS_PILOT_TIMEOUT": 0.1},
            "FS_PILOT_TIMEOUT is 0.1 s, shorter than 3 control periods (0.15 s): the pilot-input "
            "failsafe would disarm between fly's commands; set FS_PILOT_TIMEOUT = 3",
        ),
        (
            {"FS_GCS_ENABLE": 1},
            "FS_GCS_ENABLE is 1 (warn only): a lost link would leave the vehicle to itself; set "
            "FS_GCS_ENABLE = 2 (disarm) or 3 (depth hold)",
        ),
        (
            {"FS_GCS_ENABLE": None},
            "FS_GCS_ENABLE: not reported; cannot tell what the vehicle does when fly's link drops",
        ),
    ],
)
def test_each_problem_is_one_exact_line(changes, line) -> None:
    assert check(**changes) == [line]


def test_the_pilot_failsafe_may_be_short_when_it_only_warns() -> None:
    assert check(FS_PILOT_INPUT=1, FS_PILOT_TIMEOUT=0.1) == []


def test_mission_pins_parameters() -> None:
    params = default_parameters(255)
    params["MOT_3_DIRECTION"] = 1.0
    lines = check_parameters(params, sysid=255, dt=DT, expected={"MOT_3_DIRECTION": -1, "BTN0_FUNCTION": 1})
    assert lines == [
        "MOT_3_DIRECTION is 1, but the mission requires -1 (fly.parameters): set MOT_3_DIRECTION = -1",
        "BTN0_FUNCTION: not reported, but the mission requires 1 (fly.parameters)",
    ]
    assert "BTN0_FUNCTION" in parameter_names({"BTN0_FUNCTION": 1})


def test_no_parameters_at_all() -> None:
    assert check_parameters({}, sysid=255, dt=DT) == [
        "parameters: the vehicle answered no PARAM_REQUEST_READ (is it ArduSub?)"
    ]
