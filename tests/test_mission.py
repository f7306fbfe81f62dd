"""Mission files: every shipped mission validates; every class of bad input gives exit 2 and one line
naming the file and the field path."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.config.mission import MissionError, load_mission

ROOT = Path(__file__).resolve().parents[1]
MISSIONS = sorted((ROOT / "missions").glob("*.yaml"))

runner = CliRunner()

GOOD = """\
name: t
flow: {case: case2}
dock:
  position_ned_m: [2.0, 3.0, 5.0]
  heave: {amplitude_m: 0.5, angular_frequency_rad_s: 0.1}
start:
  state: [0, 0, 5, 0, 0, 0, 0, 0, 0, 0, 0, 0]
controller: {type: oracle, horizon_steps: 10, dt_s: 0.05}
docking: {tolerance_m: 0.05, timeout_s: 75}
"""


def test_shipped_missions_exist() -> None:
    names = {p.stem for p in MISSIONS}
    assert {
        "still",
        "diagonal",
        "south",
        "east_strong",
        "gyre",
        "gyre_fast",
        "tank_0p6hz",
        "tank_0p8hz",
    } <= names


@pytest.mark.parametrize("path", MISSIONS, ids=[p.stem for p in MISSIONS])
def test_shipped_mission_validates(path: Path) -> None:
    m = load_mission(path)
    assert m.name == path.stem
    result = runner.invoke(app, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    assert "valid" in result.output


def test_gyre_is_case5_with_paper_setup() -> None:
    m = load_mission(ROOT / "missions" / "gyre.yaml")
    assert m.flow.case == "case5"
    dock = m.build_dock()
    assert dock.position_ned_m == (2.0, 3.0, 5.0)
    assert dock.amplitude_m == 0.5 and dock.angular_frequency_rad_s == 0.1
    assert m.controller.horizon_steps == 10 and m.controller.dt_s == 0.05
    assert m.docking.tolerance_m == 0.05 and m.docking.timeout_s == 75.0


def test_tank_frequency_in_hz_becomes_rad_s() -> None:
    m = load_mission(ROOT / "missions" / "tank_0p8hz.yaml")
    assert m.build_dock().angular_frequency_rad_s == pytest.approx(2 * math.pi * 0.8)


def test_defaults_fill_minimal_mission(tmp_path: Path) -> None:
    p = tmp_path / "m.yaml"
    p.write_text("name: minimal\n")
    m = load_mission(p)
    assert m.vehicle.preset == "bluerov2_heavy"
    assert m.flow.case == "case1"
    assert m.controller.weights.Q[3] == 100.0
    assert m.controller.weights.R_for(8) == [10.0] * 8
    assert list(m.start_state()) == [0, 0, 5, 0, 0, 0, 0, 0, 0, 0, 0, 0]


def test_resolved_yaml_round_trips(tmp_path: Path) -> None:
    p = tmp_path / "m.yaml"
    p.write_text(GOOD)
    m = load_mission(p)
    q = tmp_path / "again.yaml"
    q.write_text(m.to_yaml())
    assert load_mission(q).resolved() == m.resolved()


def _edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


# (id, mission text, expected field path, expected words in the problem)
BAD = [
    ("unknown_key", GOOD + "colour: red\n", "colour", "unknown key"),
    (
        "unknown_nested_key",
        _edit(GOOD, "heave: {", "heave: {ampl_m: 1, "),
        "dock.heave.ampl_m",
        "unknown key",
    ),
    (
        "wrong_type",
        _edit(GOOD, "horizon_steps: 10", "horizon_steps: ten"),
        "controller.horizon_steps",
        "integer",
    ),
    ("nan", _edit(GOOD, "amplitude_m: 0.5", "amplitude_m: .nan"), "dock.heave.amplitude_m", "finite"),
    ("inf", _edit(GOOD, "timeout_s: 75", "timeout_s: .inf"), "docking.timeout_s", "finite"),
    ("zero_dt", _edit(GOOD, "dt_s: 0.05", "dt_s: 0"), "controller.dt_s", "greater than 0"),
    ("negative_dt", _edit(GOOD, "dt_s: 0.05", "dt_s: -0.05"), "controller.dt_s", "greater than 0"),
    (
        "horizon_zero",
        _edit(GOOD, "horizon_steps: 10", "horizon_steps: 0"),
        "controller.horizon_steps",
        "greater than or equal to 1",
    ),
    (
        "tolerance_zero",
        _edit(GOOD, "tolerance_m: 0.05", "tolerance_m: 0"),
        "docking.tolerance_m",
        "greater than 0",
    ),
    ("unknown_flow_case", _edit(GOOD, "case: case2", "case: case9"), "flow.case", "unknown flow case"),
    ("unknown_vehicle", GOOD + "vehicle: {preset: bluerov3}\n", "vehicle.preset", "unknown vehicle preset"),
    (
        "negative_amplitude",
        _edit(GOOD, "amplitude_m: 0.5", "amplitude_m: -0.1"),
        "dock.heave.amplitude_m",
        "greater than or equal to 0",
    ),
    (
        "short_start",
        _edit(GOOD, "state: [0, 0, 5, 0, 0, 0, 0, 0, 0, 0, 0, 0]", "state: [0, 0, 5]"),
        "start.state",
        "must have 12 values",
    ),
    ("bad_controller", _edit(GOOD, "type: oracle", "type: magic"), "controller.type", "naive"),
    (
        "bad_override",
        GOOD + "vehicle: {overrides: {mass_lb: 30}}\n",
        "vehicle.overrides.mass_lb",
        "not a vehicle parameter",
    ),
    ("missing_name", GOOD.replace("name: t\n", ""), "name", "required"),
    ("yaml_syntax", GOOD + "dock: [unclosed\n", "", "YAML syntax error"),
    ("not_a_mapping", "- just\n- a list\n", "", "mapping"),
]


@pytest.mark.parametrize(("text", "field", "words"), [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_mission_exit_2_one_line(tmp_path: Path, text: str, field: str, words: str) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    with pytest.raises(MissionError) as ei:
        load_mission(p)
    assert ei.value.field == field
    assert words in ei.value.problem
    result = runner.invoke(app, ["validate", str(p)])
    assert result.exit_code == 2
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, result.stderr
    assert str(p) in lines[0]
    assert (f": {field}: " in lines[0]) if field else True
    assert "Traceback" not in result.output + result.stderr
    assert result.stdout == ""


def test_missing_file_exit_2(tmp_path: Path) -> None:
    p = tmp_path / "nope.yaml"
    result = runner.invoke(app, ["validate", str(p)])
    assert result.exit_code == 2
    assert result.stderr.strip() == f"error: {p}: file not found"


def test_exact_message_for_negative_amplitude(tmp_path: Path) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text(_edit(GOOD, "amplitude_m: 0.5", "amplitude_m: -1.0"))
    with pytest.raises(MissionError) as ei:
        load_mission(p)
    assert (
        str(ei.value) == f"{p}: dock.heave.amplitude_m: input should be greater than or equal to 0 (got -1.0)"
    )


def test_vehicle_file_relative_to_mission(tmp_path: Path) -> None:
    src = ROOT / "auvdock" / "vehicle" / "data" / "bluerov2_heavy.yaml"
    (tmp_path / "myrov.yaml").write_text(src.read_text().replace("mass_kg: 13.5", "mass_kg: 14.0"))
    p = tmp_path / "m.yaml"
    p.write_text("name: own\nvehicle: {file: myrov.yaml}\n")
    v = load_mission(p).build_vehicle()
    assert v.params.mass_kg == 14.0


def test_vehicle_file_missing(tmp_path: Path) -> None:
    p = tmp_path / "m.yaml"
    p.write_text("name: own\nvehicle: {file: nothere.yaml}\n")
    with pytest.raises(MissionError) as ei:
        load_mission(p)
    assert ei.value.field == "vehicle.file"
    assert "does not exist" in ei.value.problem


def test_resolved_tank_mission_round_trips_through_yaml() -> None:
    """A mission given with frequency_hz, written back by to_yaml (both fields filled), reads again."""
    import yaml

    from auvdock.config.mission import load_mission, parse_mission

    m = load_mission(Path(__file__).resolve().parents[1] / "missions" / "tank_0p6hz.yaml")
    again = parse_mission(yaml.safe_load(m.to_yaml()), "<written>")
    assert again.dock.heave.angular_frequency_rad_s == m.dock.heave.angular_frequency_rad_s
