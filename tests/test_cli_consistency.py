"""The command line is consistent: the same option means the same thing everywhere, and the help
reads like click's (``MISSION``, flags without a value type)."""

from __future__ import annotations

import re
import signal

import pytest
from typer.testing import CliRunner

from auvdock.cli import app, main

runner = CliRunner()

COMMANDS = [
    "validate", "missions", "sim", "plot", "compare", "report", "sweep", "fly", "vehicle-sim", "replay",
    "sitl-physics", "bench", "markers", "calibrate", "dock-table",
]  # fmt: skip


@pytest.mark.parametrize("command", COMMANDS)
def test_help_has_no_bool_values_and_click_argument_names(command: str) -> None:
    res = runner.invoke(app, [command, "--help"], env={"COLUMNS": "80"})
    assert res.exit_code == 0, res.output
    assert "<bool>" not in res.output
    usage = res.output.splitlines()[0]
    assert usage.startswith(f"Usage: auvdock {command} [OPTIONS]")
    assert "{" not in usage and not re.search(r"\b[a-z_]+\b$", usage.split("[OPTIONS]")[1].strip() or "X")


def test_mission_is_positional_everywhere() -> None:
    for command, usage in (
        ("sim", "Usage: auvdock sim [OPTIONS] MISSION"),
        ("fly", "Usage: auvdock fly [OPTIONS] MISSION"),
        ("vehicle-sim", "Usage: auvdock vehicle-sim [OPTIONS] [MISSION]"),
        ("sitl-physics", "Usage: auvdock sitl-physics [OPTIONS] MISSION"),
    ):
        res = runner.invoke(app, [command, "--help"])
        assert res.output.splitlines()[0] == usage


def test_vehicle_sim_mission_given_twice() -> None:
    res = runner.invoke(app, ["vehicle-sim", "tank_positioned", "--mission", "tank_0p8hz"])
    assert res.exit_code == 2
    assert (
        res.stderr.strip()
        == "error: --mission tank_0p8hz: the mission is also given as tank_positioned; give it once"
    )


@pytest.mark.parametrize(
    "command",
    [["sim", "still"], ["compare", "still"], ["bench", "--case", "2"], ["fly", "tank_positioned"]],
)
@pytest.mark.parametrize("value", ["0", "-1", "inf"])
def test_timeout_must_be_positive_in_every_command(command: list[str], value: str) -> None:
    res = runner.invoke(app, [*command, "--timeout", value])
    assert res.exit_code == 2, res.output
    assert (
        res.stderr.strip() == f"error: --timeout: must be a positive number of seconds (got {float(value)})"
    )


def test_jobs_means_worker_processes_in_compare_and_sweep(capsys) -> None:
    for command in ("compare", "sweep"):
        res = runner.invoke(app, [command, "--help"], env={"COLUMNS": "120"})
        assert re.search(r"-j, --jobs", res.output), res.output
    previous = signal.getsignal(signal.SIGINT)
    try:
        with pytest.raises(SystemExit) as e:  # through the console script's one-line option errors
            main(["sweep", "model_error", "--jobs", "0"])
    finally:  # main() ignores a late Ctrl-C as it exits: give the other tests theirs back
        signal.signal(signal.SIGINT, previous)
    assert e.value.code == 2
    # one format for every option error (tests/test_defects_cli.py)
    assert capsys.readouterr().err == "error: --jobs: must be at least 1 (got 0)\n"


def test_sim_says_it_does_not_use_the_camera(tmp_path) -> None:
    res = runner.invoke(app, ["sim", "tank_camera", "--timeout", "0.1", "--no-plots", "--out", str(tmp_path)])
    assert res.exit_code == 1, res.output  # ran, did not dock in 0.1 s
    assert res.stderr.splitlines()[0] == (
        "note: tank_camera: dock.source camera is what fly and vehicle-sim rehearsals track; sim gives the "
        "controller the mission's dock trajectory (Assumption 2), so the camera section (its dock offset "
        "included) is not used here"
    )


@pytest.mark.parametrize("mission", ["still", "tank_camera", "sitl_vec6_0p6hz"])
def test_validate_keeps_every_value_whole_at_80_columns_and_prints_brackets(mission: str) -> None:
    from auvdock.cli.validate import _flatten
    from auvdock.config.catalog import missions_dir
    from auvdock.config.mission import load_mission

    res = runner.invoke(app, ["validate", mission], env={"COLUMNS": "80"})
    assert res.exit_code == 0, res.output
    rows: list[tuple[str, str]] = []
    _flatten("", load_mission(missions_dir() / f"{mission}.yaml").resolved(), rows)
    lines = res.output.splitlines()
    for k, v in rows:
        assert f"{k} = {v}" in lines, k
    # descriptions are text, not markup: "[x y z (NED m), ...]" and "[{id, size_m, ...}]" survive
    assert any(line.strip().startswith("[x y z (NED m)") for line in lines)
    assert any("markers: [{id, size_m, position_dock_m, rpy_deg}]" in line for line in lines)
