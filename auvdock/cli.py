"""The ``auvdock`` command line (Typer + rich).

Exit status: 0 success; 1 a run finished but did not dock / a command failed at run
time; 2 bad input (a mission file, an option) -- with ONE line on stderr naming the
file, the field and the problem, and no traceback.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.table import Table

from . import __version__
from .mission import Mission, MissionError, load_mission

app = typer.Typer(
    name="auvdock",
    help="Dock a BlueROV2 Heavy to a heaving wave-energy-converter dock in ocean currents.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

console = Console()
err_console = Console(stderr=True)


def fail_input(message: str) -> None:
    """Print one line on stderr and exit with status 2 (bad input)."""
    err_console.print(f"error: {message}", markup=False, highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


def load_or_exit(path: Path) -> Mission:
    """Load a mission, or exit 2 with the one-line error."""
    try:
        return load_mission(path)
    except MissionError as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None


def _version_callback(value: bool) -> None:
    if value:
        console.print(f"auvdock {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: bool = typer.Option(
        False, "--version", callback=_version_callback, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """auvdock: flow-state-estimating MPC docking for underwater vehicles."""


def _flatten(prefix: str, value: Any, rows: list[tuple[str, str]]) -> None:
    if isinstance(value, dict):
        if not value:
            rows.append((prefix, "{}"))
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else str(k), v, rows)
    else:
        rows.append((prefix, str(value)))


def _describe(field_path: str) -> str:
    """The schema description of a dotted field, if any."""
    model: Any = Mission
    info = None
    for part in field_path.split("."):
        fields = getattr(model, "model_fields", None)
        if not fields or part not in fields:
            return ""
        info = fields[part]
        model = info.annotation
    return (info.description or "") if info is not None else ""


@app.command()
def validate(mission: Path = typer.Argument(..., help="Mission YAML file.")) -> None:
    """Check a mission file and print it with every default filled in."""
    m = load_or_exit(mission)
    rows: list[tuple[str, str]] = []
    _flatten("", m.resolved(), rows)
    table = Table(title=f"mission {m.name} ({mission})", show_lines=False)
    table.add_column("field", style="cyan", no_wrap=True)
    table.add_column("value")
    table.add_column("meaning / unit", style="dim")
    for k, v in rows:
        table.add_row(k, v, _describe(k))
    console.print(table)
    flow = m.build_flow()
    dock = m.build_dock()
    console.print(f"flow: {flow.describe()}")
    console.print(
        f"dock: at {tuple(round(c, 3) for c in dock.position_ned_m)} m NED, heave "
        f"{dock.amplitude_m:g} m at {dock.angular_frequency_rad_s:g} rad/s ({dock.frequency_hz:.4g} Hz)"
    )
    console.print("[green]valid[/green]")


def main() -> None:
    """Console-script entry point."""
    try:
        app()
    except KeyboardInterrupt:
        err_console.print("interrupted")
        sys.exit(130)


if __name__ == "__main__":  # pragma: no cover
    main()
