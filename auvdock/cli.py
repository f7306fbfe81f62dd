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
from rich import box
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
    from .codegen import set_reporter

    set_reporter(_compile_notice)


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
    from .autopilot import Autopilot

    # build (and, the first time, compile) the controller before the progress display starts
    ap = Autopilot(m, m.build_vehicle(), m.build_dock(), name)
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
            summary = simulate(m, out=h5, progress=on_step, timeout_s=timeout, autopilot=ap)
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


def _split_list(values: list[str] | None) -> list[str]:
    out: list[str] = []
    for v in values or []:
        out += [x.strip() for x in v.split(",") if x.strip()]
    return out


def _controller_list(controllers: list[str] | None) -> list[str]:
    """``--controllers`` (comma-separated or repeated; default all five), or exit 2 naming the bad one."""
    from .controllers import CONTROLLER_NAMES

    ctrls = _split_list(controllers) or list(CONTROLLER_NAMES)
    for c in ctrls:
        if c not in CONTROLLER_NAMES:
            fail_input(f"--controllers: unknown controller {c!r} (known: {', '.join(CONTROLLER_NAMES)})")
    return ctrls


def _campaign_outputs(path: Path, out_dir: Path, *, pdf: bool, plots: bool, records=None, attrs=None) -> None:
    """Tables, findings and figures of a campaign file, printed and written to ``out_dir``."""
    from .campaign import SUMMARY_HEADER, check_findings, read_campaign, summary_rows, write_tables

    if records is None or attrs is None:
        records, attrs = read_campaign(path)
    t = Table(title=f"campaign {path}")
    for h in SUMMARY_HEADER:
        t.add_column(h, overflow="fold")
    for row in summary_rows(records):
        style = "red" if row[2] == "failed" else ("green" if row[2] == "yes" else None)
        t.add_row(*row, style=style)
    console.print(t)
    ft = Table(title="the paper's findings (parameters.md 5b)", show_lines=True)
    for h in ("finding", "measured here", "verdict", "why it differs"):
        ft.add_column(h, overflow="fold")
    for f in check_findings(records):
        colour = {"holds": "green", "not run": "dim"}.get(f.verdict, "yellow")
        ft.add_row(f.finding, f.measured, f"[{colour}]{f.verdict}[/{colour}]", f.explanation)
    console.print(ft)
    written = write_tables(records, out_dir, attrs)
    if plots:
        from .campaign import read_campaign_runs
        from .campaign_plots import plot_campaign

        runs = read_campaign_runs(path)
        written += plot_campaign(records, runs, out_dir, formats=("png", "pdf") if pdf else ("png",))
    console.print("written: " + ", ".join(str(p) for p in written))


@app.command()
def compare(
    missions: list[Path] | None = typer.Argument(
        None, help="Mission files (default: the paper's six cases from missions/)."
    ),
    controllers: list[str] | None = typer.Option(
        None,
        "--controllers",
        "-c",
        help="Controllers, comma-separated or repeated (default: all five).",
    ),
    jobs: int | None = typer.Option(
        None, "--jobs", "-j", min=1, help="Worker processes (default: all cores)."
    ),
    out: Path = typer.Option(Path("runs/compare"), "--out", "-o", help="Output directory."),
    seed: int | None = typer.Option(None, "--seed", help="Seed for every run (default: each mission's)."),
    timeout: float | None = typer.Option(
        None, "--timeout", min=0.0, help="Docking timeout for every run, s (default: each mission's)."
    ),
    resume: bool = typer.Option(False, "--resume", help="Skip runs already complete in the campaign file."),
    pdf: bool = typer.Option(False, "--pdf", help="Also write the figures as PDF."),
    no_plots: bool = typer.Option(False, "--no-plots", help="Skip the figures."),
) -> None:
    """Run the paper's six-case study (cases x controllers) in parallel, with tables and figures."""
    import os
    import shlex

    from .campaign import PAPER_MISSIONS, campaign_specs, default_missions_dir, run_campaign

    ctrls = _controller_list(controllers)
    given_missions = list(missions or [])
    if not missions:
        d = default_missions_dir()
        missions = [d / f"{m}.yaml" for m in PAPER_MISSIONS]
    for m in missions:
        if not m.is_file():
            fail_input(f"{m}: file not found")
    try:
        specs = campaign_specs(missions, ctrls, out, seed=seed, timeout_s=timeout)
    except MissionError as e:
        fail_input(str(e))
    except ValueError as e:
        fail_input(str(e))
    n_jobs = jobs or os.cpu_count() or 1
    path = out / "campaign.h5"
    n_cases = len(specs) // max(1, len(ctrls))
    console.print(
        f"[bold]campaign[/bold]: {n_cases} cases x {len(ctrls)} controllers = {len(specs)} runs, "
        f"{n_jobs} worker processes -> {path}"
    )
    # the command as parsed (sys.argv is not the command line when called as a library)
    words = ["auvdock", "compare", *(str(m) for m in (given_missions or []))]
    if controllers:
        words += ["--controllers", ",".join(ctrls)]
    words += ["--jobs", str(n_jobs), "--out", str(out)]
    for flag, value in (("--seed", seed), ("--timeout", timeout)):
        if value is not None:
            words += [flag, str(value)]
    words += [w for w, on in (("--resume", resume), ("--pdf", pdf), ("--no-plots", no_plots)) if on]
    cmd = " ".join(shlex.quote(w) for w in words)

    with Progress(
        SpinnerColumn(),
        TextColumn("{task.description:<28}"),
        BarColumn(),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
        console=console,
    ) as bar:
        overall = bar.add_task("all runs", total=len(specs), info="")
        tasks: dict[tuple[str, str], Any] = {}
        done_count = [0]

        def on_event(kind: str, key: tuple[str, str], info: dict[str, Any]) -> None:
            label = f"{key[0]} / {key[1]}"
            if kind == "start" and key not in tasks:
                tasks[key] = bar.add_task(label, total=1.0, info="")
            elif kind == "progress":
                if key not in tasks:
                    tasks[key] = bar.add_task(label, total=1.0, info="")
                bar.update(
                    tasks[key],
                    total=info["timeout_s"],
                    completed=info["t"],
                    info=f"t = {info['t']:5.1f} s  d = {info['distance_m']:.3f} m",
                )
            elif kind == "done":
                if key in tasks:
                    bar.remove_task(tasks.pop(key))
                done_count[0] += 1
                bar.update(overall, completed=done_count[0], info=f"{done_count[0]}/{len(specs)}")
                if info["status"] != "done":
                    verdict = f"[red]failed[/red]: {info['error']}"
                elif info["docked"]:
                    verdict = f"[green]docked[/green] {info['time_to_dock_s']:.2f} s"
                else:
                    verdict = f"[yellow]timeout[/yellow] {info['timeout_s']:.0f} s"
                bar.console.print(f"  {label:<28} {verdict}  (wall {info['wall_time_s']:.1f} s)")

        try:
            res = run_campaign(specs, path, jobs=n_jobs, resume=resume, command_line=cmd, on_event=on_event)
        except ValueError as e:
            fail_input(str(e))
        except KeyboardInterrupt:
            err_console.print(f"interrupted: the finished runs are in {path}; continue with --resume")
            raise typer.Exit(code=130) from None
        bar.update(overall, completed=len(specs), info=f"{len(specs)}/{len(specs)}")

    if res.skipped:
        console.print(f"resumed: {len(res.skipped)} runs already complete, {len(res.ran)} run now")
    wall_runs = sum(r["wall_time_s"] for r in res.records if (r["case"], r["controller"]) in set(res.ran))
    console.print(
        f"campaign wall time {res.wall_time_s:.1f} s; compute in runs {wall_runs:.1f} s "
        f"({len(res.ran)} runs, mean {wall_runs / max(1, len(res.ran)):.1f} s per run)"
    )
    _campaign_outputs(path, out, pdf=pdf, plots=not no_plots)
    if any(r["status"] != "done" for r in res.records):
        raise typer.Exit(code=1)


@app.command()
def report(
    results: Path = typer.Argument(..., help="Campaign file written by auvdock compare."),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Output directory (default: next to the file)."
    ),
    pdf: bool = typer.Option(False, "--pdf", help="Also write the figures as PDF."),
    no_plots: bool = typer.Option(False, "--no-plots", help="Skip the figures."),
) -> None:
    """Rebuild a campaign's tables, findings and figures from its HDF5 file alone."""
    from .campaign import read_campaign

    if not results.is_file():
        fail_input(f"{results}: file not found")
    try:
        records, attrs = read_campaign(results)
    except ValueError as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    _campaign_outputs(
        results, out if out is not None else results.parent, pdf=pdf, plots=not no_plots,
        records=records, attrs=attrs,
    )  # fmt: skip


@app.command()
def fly(
    mission: Path = typer.Argument(..., help="Mission YAML file (e.g. missions/tank_0p6hz.yaml)."),
    port: str = typer.Option(
        "udp:14550",
        "--port",
        help="pymavlink connection string; udp:PORT listens on 0.0.0.0:PORT (where BlueOS sends MAVLink).",
    ),
    arm: bool = typer.Option(
        False,
        "--arm",
        help="Arm the vehicle and command thrust. Without it: a dry run, neutral overrides only.",
    ),
    controller: str | None = typer.Option(
        None, "--controller", "-c", help="Override the mission's controller."
    ),
    out: Path | None = typer.Option(None, "--out", "-o", help="Output directory (default: the mission's)."),
    timeout: float | None = typer.Option(None, "--timeout", min=0.0, help="Override the docking timeout, s."),
    sysid: int = typer.Option(
        255, "--sysid", min=1, max=255, help="Our MAVLink system id (ArduSub SYSID_MYGCS)."
    ),
    connect_timeout: float = typer.Option(
        10.0, "--connect-timeout", min=0.1, help="Wait for the vehicle, s."
    ),
) -> None:
    """Dock a real BlueROV2 (ArduSub) over MAVLink with the mission's controller."""
    from .fly import FlySession
    from .hardware.link import MavlinkLink, connection_string

    m = load_or_exit(mission)
    if controller is not None and controller not in CONTROLLER_TYPES:
        fail_input(f"--controller: unknown controller {controller!r} (known: {', '.join(CONTROLLER_TYPES)})")
    try:
        connection_string(port)
    except ValueError as e:
        fail_input(f"--port {port}: {e}")
    out_dir = out if out is not None else Path(m.output.dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    name = controller or m.controller.type
    h5 = out_dir / f"{m.name}_{name}_fly_{stamp}.h5"
    tlog = h5.with_suffix(".tlog")
    mode = "[bold red]ARMED[/bold red]" if arm else "[yellow]dry run (no --arm): neutral thrust only[/yellow]"
    console.print(f"[bold]fly[/bold] {m.name} / {name} on {port}: {mode}")
    try:
        link = MavlinkLink(port, sysid=sysid, tlog=tlog)
    except OSError as e:
        fail_input(f"--port {port}: {e}")
        raise AssertionError("unreachable") from None
    try:
        session = FlySession(m, link, arm=arm, out=h5, controller=controller, timeout_s=timeout,
                             connect_timeout_s=connect_timeout)  # fmt: skip
    except MissionError as e:
        link.close()
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    last = [0.0]

    def on_step(t: float, dist: float, status: str) -> None:
        now = time.monotonic()
        if now - last[0] > 1.0:
            last[0] = now
            console.print(f"  t = {t:6.2f} s  distance {dist:6.3f} m  solver {status}")

    result = session.run(progress=on_step)
    for t_ev, text in result.events:
        console.print(f"  [dim]{t_ev:7.2f} s[/dim] {text}", markup=True, highlight=False)
    if result.results_path is not None:
        console.print(f"results: {result.results_path}")
    console.print(f"tlog: {tlog}")
    if result.reason == "docked":
        console.print(f"[green]{result.message}[/green]")
    elif result.reason == "timeout":
        err_console.print(f"not docked: {result.message}", markup=False, highlight=False)
    else:
        err_console.print(f"{result.reason}: {result.message}", markup=False, highlight=False)
    raise typer.Exit(code=result.exit_code)


@app.command("vehicle-sim")
def vehicle_sim(
    port: str = typer.Option(
        "udpout:127.0.0.1:14550",
        "--port",
        help="pymavlink connection string to serve the vehicle's MAVLink on.",
    ),
    mission: Path | None = typer.Option(
        None, "--mission", "-m", help="Mission for the start state, vehicle and flow (default: tank_0p6hz)."
    ),
    speed: float = typer.Option(1.0, "--speed", min=0.01, help="Simulated seconds per wall-clock second."),
) -> None:
    """Run auvdock's 6-DOF simulator as an ArduSub MAVLink vehicle (for rehearsing and testing fly)."""
    from .campaign import default_missions_dir
    from .hardware.vehicle_sim import VehicleSim

    path = mission if mission is not None else default_missions_dir() / "tank_0p6hz.yaml"
    m = load_or_exit(path)
    console.print(
        f"[bold]vehicle-sim[/bold]: ArduSub-like BlueROV2 (sysid 1) on {port}, mission {m.name}, "
        f"speed {speed:g}x; Ctrl-C to stop"
    )
    try:
        sim = VehicleSim(m, port=port, speed=speed)
        sim.run_forever()
    except OSError as e:
        fail_input(f"--port {port}: {e}")
    console.print(f"stopped at t = {sim.t:.1f} s; events: " + ", ".join(e.kind for e in sim.events))


@app.command()
def bench(
    cases: list[int] | None = typer.Option(None, "--case", help="Paper case (repeat; default 1, 2 and 6)."),
    controllers: list[str] | None = typer.Option(
        None, "--controllers", "-c", help="Controllers, comma-separated or repeated (default: all five)."
    ),
    solvers: list[str] | None = typer.Option(
        None,
        "--solvers",
        "-s",
        help="Solvers: auto, sqp, ipopt; comma-separated or repeated (default: auto).",
    ),
    timeout: float | None = typer.Option(None, "--timeout", min=0.0, help="Simulated-time limit per run, s."),
    json_out: bool = typer.Option(False, "--json", help="One JSON object per run on stdout, nothing else."),
) -> None:
    """Per-step solve time (median, p95, p99, max), real-time factor and outcome per controller x solver."""
    import json

    from .bench import DEFAULT_CASES, bench_rows, machine_line
    from .mission import SOLVER_NAMES

    ctrls = _controller_list(controllers)
    solv = _split_list(solvers) or ["auto"]
    for s_ in solv:
        if s_ not in SOLVER_NAMES:
            fail_input(f"--solvers: unknown solver {s_!r} (known: {', '.join(SOLVER_NAMES)})")
    case_list = list(cases or DEFAULT_CASES)
    for c in case_list:
        if not 1 <= c <= 6:
            fail_input(f"--case: {c} is not one of the paper's cases 1..6")

    if json_out:

        def emit(r: dict[str, Any]) -> None:  # strict JSON: NaN (not docked) as null
            clean = {k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()}
            print(json.dumps(clean), flush=True)

        bench_rows(case_list, ctrls, solv, timeout_s=timeout, on_row=emit)
        return
    console.print(f"[bold]bench[/bold] on {machine_line()}")
    t = Table(title="per controller step, ms (full closed-loop runs)")
    for h in ("case", "controller", "solver", "docked", "time to dock", "median", "p95", "p99", "max", "RTF",
              "failures"):  # fmt: skip
        t.add_column(h, justify="right" if h not in ("controller", "solver") else "left")

    def add(r: dict[str, Any]) -> None:
        ttd = f"{r['time_to_dock_s']:.2f} s" if r["docked"] else "timeout"
        console.print(
            f"  case {r['case']} {r['controller']:<10} {r['solver']:<5} {ttd:>9}"
            f"  median {r['median_ms']:6.2f} ms  p99 {r['p99_ms']:6.2f} ms"
        )
        t.add_row(
            str(r["case"]), r["controller"], r["solver"], "yes" if r["docked"] else "no", ttd,
            f"{r['median_ms']:.2f}", f"{r['p95_ms']:.2f}", f"{r['p99_ms']:.2f}", f"{r['max_ms']:.2f}",
            f"{r['real_time_factor']:.1f}", str(r["solver_failures"]),
        )  # fmt: skip

    bench_rows(case_list, ctrls, solv, timeout_s=timeout, on_row=add)
    console.print(t)


@app.command()
def sweep(
    sweep_file: Path = typer.Argument(..., help="Sweep YAML file (e.g. missions/sweeps/current_speed.yaml)."),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Output directory (default: runs/sweeps/<name>)."
    ),
    workers: int | None = typer.Option(
        None, "--workers", "-j", min=1, help="Local Dask worker processes (default: one per core)."
    ),
    scheduler: str | None = typer.Option(
        None, "--scheduler", help="Submit to a running Dask cluster, e.g. tcp://HOST:8786."
    ),
    resume: bool = typer.Option(False, "--resume", help="Skip runs already in the results file."),
    trajectories: bool = typer.Option(False, "--trajectories", help="Also store every run's trajectory."),
) -> None:
    """Monte Carlo robustness campaign on Dask: success rates with Wilson intervals, figures, summary."""
    from .sweep import SweepError, sweep_main

    try:
        code = sweep_main(sweep_file, out, workers, scheduler, resume, trajectories, console)
    except (SweepError, MissionError) as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    raise typer.Exit(code=code)


def _load_layout(path: Path):
    """A marker layout from a mission file (its dock.markers) or a layout YAML file."""
    from .camera.layout import MarkerLayout

    if not path.is_file():
        fail_input(f"{path}: no such file")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        fail_input(f"{path}: not YAML ({str(e).splitlines()[0]})")
    if isinstance(data, dict) and "markers" in data and "name" not in data:
        try:
            return MarkerLayout.from_dict(data)
        except ValueError as e:
            fail_input(f"{path}: {e}")
    return load_or_exit(path).dock.marker_layout()


@app.command()
def markers(
    layout: Path = typer.Argument(
        ..., help="Mission file (its dock.markers, or the default layout) or layout YAML."
    ),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Sheet file (default: <name>_markers.pdf/.png)."
    ),
    pdf: bool = typer.Option(True, "--pdf/--png", help="Printable PDF (default) or PNG."),
) -> None:
    """Print the dock's marker sheet at true scale (check the 100 mm bar after printing)."""
    from .camera.layout import sheet_size_in, write_sheet

    lay = _load_layout(layout)
    target = out or Path(f"{layout.stem}_markers.{'pdf' if pdf else 'png'}")
    written = write_sheet(lay, target, pdf=pdf)
    w_in, h_in = sheet_size_in(lay)
    t = Table(title=f"{lay.dictionary} markers", box=box.SIMPLE)
    for col in ("id", "size", "position in the dock frame (m)", "rpy (deg)"):
        t.add_column(col)
    for mk in lay.markers:
        t.add_row(
            str(mk.id),
            f"{mk.size_m * 1000:.0f} mm",
            ", ".join(f"{v:+.3f}" for v in mk.position_dock_m),
            ", ".join(f"{v:g}" for v in mk.rpy_deg),
        )
    console.print(t)
    console.print(f"sheet: {written} ({w_in * 25.4:.0f} x {h_in * 25.4:.0f} mm; print at 100 %, no scaling)")


def _parse_board(board: str) -> tuple[int, int]:
    try:
        cols, rows = (int(v) for v in board.lower().split("x"))
    except ValueError:
        fail_input(f"--board {board}: expected COLSxROWS inner corners, e.g. 9x6")
        raise AssertionError("unreachable") from None
    if cols < 2 or rows < 2:
        fail_input(f"--board {board}: need at least 2x2 inner corners")
    return cols, rows


@app.command()
def calibrate(
    source: str = typer.Argument(
        ..., help="Folder of images, a video file, or a live camera (udp:5600, /dev/video0, v4l2:0)."
    ),
    board: str = typer.Option(..., "--board", help="Checkerboard inner corners, COLSxROWS (e.g. 9x6)."),
    square: float = typer.Option(..., "--square", min=1e-4, help="Checkerboard square side, m."),
    out: Path = typer.Option(Path("camera.yaml"), "--out", "-o", help="Camera file to write."),
    frames: int = typer.Option(
        25, "--frames", min=5, help="Live camera: board views to collect (0.5 s apart)."
    ),
    every: int = typer.Option(1, "--every", min=1, help="Video file: use every Nth frame."),
) -> None:
    """OpenCV checkerboard calibration: writes the camera file missions point to (camera.calibration)."""
    from .camera.calibration import calibrate as run_calibration
    from .camera.calibration import find_corners, image_sources
    from .camera.model import save_camera

    cols, rows = _parse_board(board)
    images = []
    if Path(source).exists():
        try:
            images = list(image_sources(source, every=every))
        except ValueError as e:
            fail_input(str(e))
    else:
        from .camera.video import open_source

        try:
            src = open_source(source)
        except (OSError, ValueError, RuntimeError) as e:
            fail_input(f"{source}: {e}")
            raise AssertionError("unreachable") from None
        last = 0.0
        with src, console.status(f"collecting {frames} views of the {cols}x{rows} board from {source}") as st:
            deadline = time.monotonic() + 60.0 + frames
            while len(images) < frames and time.monotonic() < deadline:
                f = src.read(timeout_s=1.0)
                if f is None or f.t_capture - last < 0.5:
                    continue
                if find_corners(f.image, cols, rows) is not None:
                    images.append(f.image)
                    last = f.t_capture
                    st.update(f"board views: {len(images)}/{frames}")
    try:
        cam = run_calibration(images, cols, rows, square)
    except ValueError as e:
        fail_input(f"{source}: {e}")
        raise AssertionError("unreachable") from None
    save_camera(cam, out)
    K = cam.K
    console.print(
        f"{cam.n_views} views, RMS reprojection error {cam.rms_px:.3f} px; fx {K[0, 0]:.1f} fy {K[1, 1]:.1f} "
        f"cx {K[0, 2]:.1f} cy {K[1, 2]:.1f} px; image {cam.width}x{cam.height}"
    )
    console.print(f"camera file: {out} (set camera.calibration: {out} in the mission)")


cache_app = typer.Typer(help="The compiled-solver cache (see auvdock.codegen).", no_args_is_help=True)
app.add_typer(cache_app, name="cache")


@cache_app.command("info")
def cache_info() -> None:
    """Where the compiled solvers are, how many, how large; and whether compiling is possible."""
    from .codegen import cache_dir, cache_entries, compile_mode, find_compiler

    entries = cache_entries()
    total = sum(n for _, n in entries)
    console.print(f"cache: {cache_dir()}")
    console.print(f"compiled solvers: {len(entries)} ({total / 1e6:.1f} MB)")
    for p, n in entries:
        console.print(f"  {p.name}  {n / 1e6:.1f} MB")
    cc = find_compiler()
    console.print(
        f"compiler: {cc or 'none found (solvers run uncompiled)'}; AUVDOCK_COMPILE={compile_mode()}"
    )


@cache_app.command("clear")
def cache_clear() -> None:
    """Remove every compiled solver from the cache."""
    from .codegen import cache_dir, clear_cache

    n = clear_cache()
    console.print(f"removed {n} compiled solver{'s' if n != 1 else ''} from {cache_dir()}")


def _compile_notice(message: str):
    """Shown while a solver compiles (first use of a problem)."""
    return err_console.status(f"[bold]{message}[/bold] - about a minute, once", spinner="dots")


def main() -> None:
    """Console-script entry point."""
    try:
        app()
    except KeyboardInterrupt:
        err_console.print("interrupted")
        sys.exit(130)


if __name__ == "__main__":  # pragma: no cover
    main()
