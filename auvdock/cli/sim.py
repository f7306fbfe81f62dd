"""``auvdock sim`` and ``auvdock plot``: one closed-loop run, its summary and plots."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import typer
import yaml
from rich.markup import escape
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table

from auvdock.cli.app import (
    app,
    check_controller,
    check_estimation,
    check_seed,
    console,
    err_console,
    exit_interrupted,
    fail_input,
    load_or_exit,
    output_dir,
    positive_timeout,
    water_line,
)
from auvdock.config.mission import MissionError
from auvdock.controllers.registry import controller_names
from auvdock.estimation.stage import FORECAST_HORIZONS_S, forecast_rmse_key

if TYPE_CHECKING:
    from auvdock.loop.stages import Progress as SimProgress


#: How a run that did not dock ended, in words (the outcome's ``reason``).
ENDINGS = {
    "timeout": "not docked in time",
    "lost_target": "gave up finding the dock",
    "diverged": "the simulation diverged",
}


def ending_text(outcome: dict[str, Any], timeout_s: float | None = None) -> str:
    """When and how a run ended, for the summary's ``time to dock`` row: ``19.25 s`` if it docked;
    else e.g. ``collided at 12.40 s``, ``gave up finding the dock at 45.05 s``, ``timeout 75 s``."""
    end = float(outcome.get("end_time_s", math.nan))
    reason = str(outcome.get("reason", ""))
    if outcome.get("docked"):
        t = outcome.get("time_to_dock_s")
        return f"{t:.2f} s" if isinstance(t, float) and math.isfinite(t) else "-"
    if outcome.get("collided"):
        return f"collided at {end:.2f} s"
    if reason == "timeout":
        return f"timeout {timeout_s if timeout_s is not None else end:.0f} s"
    return f"{ENDINGS.get(reason, reason or 'ended')} at {end:.2f} s"


def _why(outcome: dict[str, Any]) -> str:
    reason = str(outcome.get("reason", ""))
    words = ENDINGS.get(reason)
    return escape(f"{reason}: {words}" if words else reason)


def _losses_text(outcome: dict[str, Any]) -> str:
    """The camera's sightings and losses of the dock: ``never seen by the camera``, or
    ``2 (1 re-acquired); first seen at 8.35 s``."""
    first = outcome.get("dock_first_seen_s")
    if isinstance(first, float) and not math.isfinite(first):
        return "never seen by the camera"
    n, back = int(outcome["lost_track_events"]), int(outcome.get("lost_track_reacquired", 0))
    text = f"{n} ({back} re-acquired)" if n else "0"
    if isinstance(first, float):
        text += f"; first seen at {first:.2f} s"
    return text


def _summary_table(title: str, outcome: dict[str, Any], timeout_s: float | None = None) -> Table:
    def f(key: str, scale: float = 1.0, fmt: str = "{:.3f}", unit: str = "") -> str:
        v = outcome.get(key)
        if v is None or (isinstance(v, float) and not np.isfinite(v)):
            return "-"
        return fmt.format(v * scale) + unit

    t = Table(title=escape(title), show_header=False)
    t.add_column("figure", style="cyan")
    t.add_column("value")
    docked = bool(outcome.get("docked"))
    if "captured" in outcome:  # docking.criterion: capture
        if docked:
            t.add_row("captured", "[green]yes[/green]")
        elif outcome.get("collided"):
            t.add_row(
                "captured",
                f"[red]no[/red] (collided with the {outcome.get('contact_what', 'dock')} at "
                f"{f('impact_speed_m_s', unit=' m/s')})",
            )
        else:
            t.add_row("captured", f"[red]no[/red] ({_why(outcome)})")
    else:
        t.add_row("docked", "[green]yes[/green]" if docked else f"[red]no[/red] ({_why(outcome)})")
    t.add_row("time to dock", ending_text(outcome, timeout_s))
    t.add_row("path length", f("path_length_m", unit=" m"))
    t.add_row("closest approach", f("closest_approach_m", unit=" m"))
    t.add_row("contact speed", f("contact_speed_m_s", unit=" m/s"))
    t.add_row(
        "heading error at contact", f("heading_error_rad", scale=180 / np.pi, fmt="{:.2f}", unit=" deg")
    )
    if "relative_position_rmse_m" in outcome:
        t.add_row("navigation: relative position error RMSE", f("relative_position_rmse_m", unit=" m"))
    keys = [forecast_rmse_key(h) for h in FORECAST_HORIZONS_S]
    if all(k in outcome for k in keys):
        ahead = " / ".join(f"{h:g}" for h in FORECAST_HORIZONS_S)
        errors = " / ".join(f"{outcome[k] * 100:.1f}" for k in keys)
        t.add_row(f"dock motion forecast error {ahead} s ahead", f"{errors} cm (RMS)")
    if "lost_track_events" in outcome:
        t.add_row("losses of the dock", _losses_text(outcome))
    if "flow_rmse_m_s" in outcome:
        t.add_row("flow estimate RMSE", f("flow_rmse_m_s", fmt="{:.4f}", unit=" m/s"))
        t.add_row("final flow estimate error", f("flow_final_error_m_s", fmt="{:.4f}", unit=" m/s"))
    t.add_row(
        "solve time median / p95 / max",
        f"{f('solve_time_median_s', 1e3, '{:.2f}')} / {f('solve_time_p95_s', 1e3, '{:.2f}')} / "
        f"{f('solve_time_max_s', 1e3, '{:.2f}')} ms",
    )
    t.add_row(
        "solver trouble (steps)",
        escape(f"{outcome.get('solver_failures', 0)} ({outcome.get('status_counts', '')})"),
    )
    t.add_row("wall time", f("wall_time_s", fmt="{:.2f}", unit=" s"))
    t.add_row("real-time factor", f("real_time_factor", fmt="{:.1f}", unit=" x"))
    return t


@app.command()
def sim(
    mission: Path = typer.Argument(..., help="Mission YAML file or shipped mission name (e.g. gyre)."),
    controller: str | None = typer.Option(
        None,
        "--controller",
        "-c",
        help=f"{' | '.join(controller_names())} (default: the mission's).",
    ),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Output directory (default: the mission's output.dir)."
    ),
    no_plots: bool = typer.Option(False, "--no-plots", help="Do not draw the PNG plots."),
    seed: int | None = typer.Option(None, "--seed", help="Random seed (default: the mission's)."),
    timeout: float | None = typer.Option(
        None,
        "--timeout",
        callback=positive_timeout,
        help="Simulated-time limit in s (default: the mission's).",
    ),
    estimation: str | None = typer.Option(
        None,
        "--estimation",
        help="truth (the paper's Assumption 1) or filter (the navigation filter on the sensor suite); "
        "default: the mission's.",
    ),
    variant: str | None = typer.Option(
        None,
        "--variant",
        help="paper (the paper's formulation) or robust (offset-free MPC); default: the mission's.",
    ),
) -> None:
    """Run one closed-loop docking simulation: HDF5 results, summary table and plots."""
    from auvdock.loop.simulation import run_simulation
    from auvdock.results.plots import save_run_plots
    from auvdock.results.store import read_run

    m = load_or_exit(mission)
    if controller is not None:
        check_controller(controller)
    if check_seed(seed) is not None:
        m = m.with_updates(seed=seed)
    if controller is not None:
        m = m.with_updates(**{"controller.type": controller})
    if check_estimation(estimation) is not None:
        m = m.with_updates(estimation=estimation)
    if variant is not None:
        from auvdock.controllers.registry import VARIANTS

        if variant not in VARIANTS:
            fail_input(f"--variant: must be {' or '.join(VARIANTS)} (got {variant!r})")
        m = m.with_updates(**{"controller.variant": variant})
    if m.dock.source == "camera":
        err_console.print(
            f"note: {m.name}: dock.source camera is what fly and vehicle-sim rehearsals track; sim gives the "
            "controller the mission's dock trajectory (Assumption 2), so the camera section "
            "(its dock offset included) is not used here",
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    name = m.controller.type + ("_paper" if m.controller.variant == "paper" else "")
    out_dir = output_dir(out if out is not None else Path(m.output.dir))
    stem = run_stem(m.name, m.controller.type, m.controller.variant)
    h5 = out_dir / f"{stem}.h5"
    limit = m.docking.timeout_s if timeout is None else timeout

    from auvdock.controllers import resolve_solver

    solver = resolve_solver(m.controller.solver.name, m.controller.type, m.controller.variant)
    console.print(
        f"[bold]{escape(m.name)}[/bold]: {escape(water_line(m))}; controller [bold]{name}[/bold] "
        f"({m.controller.horizon_text()}, {solver})"
    )
    earlier_files = [p for p in [h5, *sorted(out_dir.glob(f"{stem}_*.png"))] if p.is_file()]
    if earlier_files:  # said before they go (compare and replay refuse; a rerun of sim replaces)
        console.print(
            f"note: replacing an earlier run's files in {out_dir}: "
            + ", ".join(p.name for p in earlier_files),
            markup=False,
            highlight=False,
            soft_wrap=True,
        )
    from auvdock.loop.assemble import build_autopilot
    from auvdock.loop.simulation import idealisations
    from auvdock.runtime.interrupts import SigintDeferred

    # build (and, the first time, compile) the controller before the progress display starts;
    # whole: CasADi would swallow a Ctrl-C landing in the construction (it is raised after it)
    with SigintDeferred():
        ap = build_autopilot(m, m.build_vehicle(), m.build_dock())
    kept = idealisations(m, ap.reads_true_flow)
    console.print(
        "idealisations kept: " + ("; ".join(kept) if kept else "none"), markup=False, highlight=False
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

        earlier = _file_stamp(h5)  # an earlier run's file there is not this run's
        try:
            summary = run_simulation(m, out=h5, progress=on_step, timeout_s=timeout, autopilot=ap)
        except KeyboardInterrupt:
            if not h5.is_file() or _file_stamp(h5) == earlier:
                exit_interrupted("interrupted before the first step: no results file was written")
            if read_run(h5).complete:  # the Ctrl-C came as the outcome was written, held back to its end
                exit_interrupted(f"interrupted after the run ended: its results are complete in {h5}")
            exit_interrupted(f"interrupted: the steps so far are in {h5} (complete = False)")
        bar.update(task, completed=summary.outcome["end_time_s"])

    console.print(_summary_table(f"{m.name} / {name}", summary.outcome, limit))
    console.print(f"results: {h5}", markup=False, highlight=False, soft_wrap=True)
    if not no_plots:
        written: list[Path] = []
        try:
            for path in save_run_plots(read_run(h5), out_dir, prefix=f"{stem}_", flow_field=m.build_flow()):
                written.append(path)
        except KeyboardInterrupt:
            drawn = f"; plots written before it: {', '.join(str(p) for p in written)}" if written else ""
            exit_interrupted(f"interrupted while drawing the plots: the results are complete in {h5}{drawn}")
        console.print("plots: " + ", ".join(str(p) for p in written), markup=False, highlight=False)
    if not summary.docked:
        raise typer.Exit(code=1)


def run_stem(mission_name: str, controller: str, variant: str | None = None) -> str:
    """The file name (without suffix) of a run's results and the prefix of its plots:
    ``gyre_optimized``, ``gyre_optimized_paper`` for the paper's variant."""
    return f"{mission_name}_{controller}" + ("_paper" if variant == "paper" else "")


def _file_stamp(path: Path) -> tuple[int, int] | None:
    """(inode, modification time in ns) of a file, None if there is none."""
    try:
        st = path.stat()
    except OSError:
        return None
    return (st.st_ino, st.st_mtime_ns)


@app.command()
def plot(
    results: Path = typer.Argument(..., help="Results file written by auvdock sim."),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Directory for the PNGs (default: next to the file)."
    ),
) -> None:
    """Redraw the plots of a results file from the file alone."""
    from auvdock.config.mission import parse_mission
    from auvdock.results.plots import save_run_plots
    from auvdock.results.store import read_run

    if not results.is_file():
        fail_input(f"{results}: file not found")
    try:
        r = read_run(results)
    except (ValueError, OSError) as e:
        fail_input(str(e) if str(results) in str(e) else f"{results}: {e}")
        raise AssertionError("unreachable") from None
    flow = None
    stem = results.stem
    try:
        stored = parse_mission(yaml.safe_load(r.mission_yaml), f"{results}:mission_yaml")
        flow = stored.build_flow()
        stem = run_stem(stored.name, stored.controller.type, stored.controller.variant)
    except (MissionError, yaml.YAMLError):
        err_console.print(
            "note: the stored mission could not be read; drawing the recorded flow instead",
            markup=False,
            highlight=False,
        )
    out_dir = output_dir(out if out is not None else results.parent)
    written: list[Path] = []
    try:  # named as sim names them: MISSION_CONTROLLER_*.png
        for p in save_run_plots(r, out_dir, prefix=f"{stem}_", flow_field=flow):
            written.append(p)
            console.print(str(p), markup=False, highlight=False, soft_wrap=True)
    except KeyboardInterrupt:
        kept = f"{len(written)} plots written before it (listed above)" if written else "no plot written"
        exit_interrupted(f"interrupted while drawing the plots: {kept}")
