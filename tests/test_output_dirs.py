"""An output directory that cannot be one (a file is there, a place no directory can be made):
exit 2 with one line naming the option, the path and the problem; no traceback."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from auvdock.cli import app

runner = CliRunner()


@pytest.mark.parametrize(
    "command",
    [
        ["sim", "still", "--timeout", "1"],
        ["compare", "still", "--timeout", "1"],
        ["sweep", "model_error"],
    ],
)
def test_out_is_a_file(tmp_path, command) -> None:
    target = tmp_path / "taken"
    target.write_text("x")
    res = runner.invoke(app, [*command, "--out", str(target)])
    assert res.exit_code == 2, res.output
    assert res.stderr.strip() == f"error: --out {target}: exists and is not a directory"


def test_out_where_no_directory_can_be_made(tmp_path) -> None:
    blocked = tmp_path / "file"
    blocked.write_text("x")
    target = blocked / "sub"  # a directory under a file
    res = runner.invoke(app, ["sim", "still", "--timeout", "1", "--out", str(target)])
    assert res.exit_code == 2, res.output
    line = res.stderr.strip()
    assert line.startswith(f"error: --out {target}: cannot create the directory (")
    assert "\n" not in line and "Traceback" not in res.output
