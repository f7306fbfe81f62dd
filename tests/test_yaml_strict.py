"""A key given twice in a user's YAML file is an error naming both lines (PyYAML keeps the last)."""

from __future__ import annotations

import pytest
import yaml
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.schema.yamlio import load_yaml_strict


def test_duplicate_key_in_a_nested_mapping() -> None:
    with pytest.raises(yaml.YAMLError, match=r"duplicate key 'R' \(first on line 3\)"):
        load_yaml_strict("controller:\n  weights:\n    R: 1\n    R: 2\n")
    assert load_yaml_strict("a: 1\nb: {a: 2}\n") == {"a": 1, "b": {"a": 2}}  # same key, other mappings


def test_validate_refuses_a_mission_with_a_key_twice(tmp_path) -> None:
    path = tmp_path / "dup.yaml"
    path.write_text("name: x\ncontroller:\n  type: oracle\nseed: 1\ncontroller:\n  type: naive\n")
    res = CliRunner().invoke(app, ["validate", str(path)])
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: {path}: YAML syntax error: line 5, column 1: duplicate key 'controller' (first on line 2)"
    )


def test_horizon_steps_is_bounded(tmp_path) -> None:
    path = tmp_path / "h.yaml"
    path.write_text("name: x\ncontroller:\n  type: oracle\n  horizon_steps: 100000\n")
    res = CliRunner().invoke(app, ["validate", str(path)])
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: {path}: controller.horizon_steps: input should be less than or equal to 200 (got 100000)"
    )
