"""Terminal tables keep every number whole at 80 columns: columns that do not fit are left out
(and named), never wrapped through a number."""

from __future__ import annotations

import re

from rich.console import Console
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.cli.tables import fitted_table


def _render(table, width: int) -> str:
    c = Console(width=width, record=True, file=open("/dev/null", "w"))  # noqa: SIM115
    c.print(table)
    return c.export_text()


def test_every_shown_cell_is_whole_and_the_rest_is_named() -> None:
    header = ["case", "controller", "docked", "time to dock", "closest approach m", "flow RMSE m/s",
              "median solve ms", "p95 solve ms", "wall s", "setup s", "interval"]  # fmt: skip
    rows = [["east_strong", "sequential@paper", "yes", "timeout 75 s", "0.245", "0.1190", "12.34", "123.45",
             "1234.5", "0.4", "51.0-97.3 %"]] * 5  # fmt: skip
    t = fitted_table("t", header, rows, 80, priority=[0, 1, 2, 10, 3, 4, 5], where="summary.md")
    out = _render(t, 80)
    assert max(len(line) for line in out.splitlines()) <= 80
    shown = [c.header.plain if hasattr(c.header, "plain") else str(c.header) for c in t.columns]
    shown = [h.replace("\n", " ") for h in shown]
    for h in shown:
        assert all(
            rows[0][header.index(h)] in line for line in out.splitlines() if line.startswith("│ east_strong")
        ), h
    assert "51.0-97.3 %" in out  # the interval, whole
    dropped = [h for h in header if h not in shown]
    assert dropped and t.caption == f"not shown at 80 columns: {', '.join(dropped)} (in summary.md)"
    # the most important columns are the ones kept, in their own order
    assert shown[:4] == ["case", "controller", "docked", "time to dock"] and "interval" in shown


def test_wide_terminal_shows_everything() -> None:
    header = ["case", "median", "p99"]
    t = fitted_table("t", header, [["diagonal", "1.00", "2.17"]], 200)
    assert len(t.columns) == 3 and t.caption is None


def test_bench_at_80_columns_keeps_numbers_whole() -> None:
    res = CliRunner().invoke(
        app, ["bench", "--case", "2", "-c", "oracle", "--timeout", "0.2"], env={"COLUMNS": "80"}
    )
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert max(len(line) for line in lines) <= 80
    for line in lines:
        if line.startswith("│ 2"):
            # every cell of a run's row is one token: "1.23", "rti/hpipm", "timeout" ...
            cells = [c.strip() for c in line.strip("│").split("│")]
            assert all(re.fullmatch(r"[\w./@ -]+", c) for c in cells), line
