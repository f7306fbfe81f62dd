"""The ``auvdock`` command line (Typer + rich).

Exit status: 0 success; 1 a run finished but did not dock / a command failed at run
time; 2 bad input (a mission file, an option) -- with ONE line on stderr naming the
file, the field and the problem, and no traceback.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import typer
import yaml
from rich.console import Console
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table

from . import __version__
from .mission import CONTROLLER_TYPES, Mission, MissionError, load_mission

if TYPE_CHECKING:
    from .simulation import Progress as SimProgress

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


def _summary_table(title: str, outcome: dict[str, Any]) -> Table:
    def f(key: str, scale: float = 1.0, fmt: str = "{:.3f}", unit: str = "") -> str:
        v = outcome.get(key)
        if v is None or (isinstance(v, float) and not np.isfinite(v)):
            return "-"
        return fmt.format(v * scale) + unit

    t = Table(title=title, show_header=False)
    t.add_column("figure", style="cyan")
    t.add_column("value")
    docked = bool(outcome.get("docked"))
    t.add_row("docked", "[green]yes[/green]" if docked else f"[red]no[/red] ({outcome.get('reason', '')})")
    t.add_row(
        "time to dock",
        f("time_to_dock_s", fmt="{:.2f}", unit=" s")
        if docked
        else f"timeout {outcome.get('end_time_s', 0):.0f} s",
    )
    t.add_row("path length", f("path_length_m", unit=" m"))
    t.add_row("closest approach", f("closest_approach_m", unit=" m"))
    t.add_row("contact speed", f("contact_speed_m_s", unit=" m/s"))
    t.add_row(
        "heading error at contact", f("heading_error_rad", scale=180 / np.pi, fmt="{:.2f}", unit=" deg")
    )
    if "flow_rmse_m_s" in outcome:
        t.add_row("flow estimate RMSE", f("flow_rmse_m_s", fmt="{:.4f}", unit=" m/s"))
        t.add_row("final flow estimate error", f("flow_final_error_m_s", fmt="{:.4f}", unit=" m/s"))
    t.add_row(
        "solve time median / p95 / max",
        f"{f('solve_time_median_s', 1e3, '{:.2f}')} / {f('solve_time_p95_s', 1e3, '{:.2f}')} / "
        f"{f('solve_time_max_s', 1e3, '{:.2f}')} ms",
    )
    t.add_row(
        "solver trouble (steps)", f"{outcome.get('solver_failures', 0)} ({outcome.get('status_counts', '')})"
    )
    t.add_row("wall time", f("wall_time_s", fmt="{:.2f}", unit=" s"))
    t.add_row("real-time factor", f("real_time_factor", fmt="{:.1f}", unit=" x"))
    return t


@app.command()
def sim(
    mission: Path = typer.Argument(..., help="Mission YAML file."),
    controller: str | None = typer.Option(
        None,
        "--controller",
        "-c",
        help="naive | kinematic | oracle | sequential | optimized (default: the mission's).",
    ),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Output directory (default: the mission's output.dir)."
    ),
    no_plots: bool = typer.Option(False, "--no-plots", help="Do not draw the PNG plots."),
    seed: int | None = typer.Option(None, "--seed", help="Random seed (default: the mission's)."),
    timeout: float | None = typer.Option(
        None, "--timeout", help="Simulated-time limit in s (default: the mission's)."
    ),
) -> None:
    """Run one closed-loop docking simulation: HDF5 results, summary table and plots."""
    from .plots import plot_run
    from .results import read_run
    from .simulation import simulate

    m = load_or_exit(mission)
    if controller is not None and controller not in CONTROLLER_TYPES:
        fail_input(f"--controller: unknown controller {controller!r} (known: {', '.join(CONTROLLER_TYPES)})")
    if timeout is not None and not (timeout > 0 and np.isfinite(timeout)):
        fail_input(f"--timeout: must be a positive number of seconds (got {timeout})")
    if seed is not None:
        if seed < 0:
            fail_input(f"--seed: must be >= 0 (got {seed})")
        m = m.with_updates(seed=seed)
    if controller is not None:
        m = m.with_updates(**{"controller.type": controller})
    name = m.controller.type
    out_dir = out if out is not None else Path(m.output.dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    h5 = out_dir / f"{m.name}_{name}.h5"
    limit = m.docking.timeout_s if timeout is None else timeout

    from .controllers import resolve_solver

    solver = resolve_solver(m.controller.solver.name, name)
    console.print(
        f"[bold]{m.name}[/bold]: {m.build_flow().describe()}; controller [bold]{name}[/bold] "
        f"(N = {m.controller.horizon_steps}, dt = {m.controller.dt_s} s, {solver})"
    )
    with Progress(
        SpinnerColumn(),
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("t = {task.completed:5.1f} / {task.total:.0f} s"),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
        console=console,
        transient=False,
    ) as bar:
        task = bar.add_task("simulating", total=limit, info="")
        last = [0.0]

        def on_step(p: SimProgress) -> None:
            now = time.monotonic()
            if now - last[0] > 0.1 or p.t + m.controller.dt_s >= limit:
                last[0] = now
                bar.update(
                    task,
                    completed=p.t,
                    info=f"distance {p.distance_m:6.3f} m  solve {p.solve_time_s * 1e3:5.1f} ms",
                )

        try:
            summary = simulate(m, out=h5, progress=on_step, timeout_s=timeout)
        except KeyboardInterrupt:
            err_console.print(f"interrupted: the steps so far are in {h5} (complete = False)")
            raise typer.Exit(code=130) from None
        bar.update(task, completed=summary.outcome["end_time_s"])

    console.print(_summary_table(f"{m.name} / {name}", summary.outcome))
    console.print(f"results: {h5}")
    if not no_plots:
        paths = plot_run(read_run(h5), out_dir, prefix=f"{m.name}_{name}_", flow_field=m.build_flow())
        console.print("plots: " + ", ".join(str(p) for p in paths))
    if not summary.docked:
        raise typer.Exit(code=1)


@app.command()
def plot(
    results: Path = typer.Argument(..., help="Results file written by auvdock sim."),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Directory for the PNGs (default: next to the file)."
    ),
) -> None:
    """Redraw the plots of a results file from the file alone."""
    from .mission import parse_mission
    from .plots import plot_run
    from .results import read_run

    if not results.is_file():
        fail_input(f"{results}: file not found")
    try:
        r = read_run(results)
    except (ValueError, OSError) as e:
        fail_input(str(e) if str(results) in str(e) else f"{results}: {e}")
        raise AssertionError("unreachable") from None
    flow = None
    try:
        flow = parse_mission(yaml.safe_load(r.mission_yaml), f"{results}:mission_yaml").build_flow()
    except (MissionError, yaml.YAMLError):
        err_console.print("note: the stored mission could not be read; drawing the recorded flow instead")
    out_dir = out if out is not None else results.parent
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = plot_run(r, out_dir, prefix=f"{results.stem}_", flow_field=flow)
    for p in paths:
        console.print(str(p))


def main() -> None:
    """Console-script entry point."""
    try:
        app()
    except KeyboardInterrupt:
        err_console.print("interrupted")
        sys.exit(130)


if __name__ == "__main__":  # pragma: no cover
    main()
