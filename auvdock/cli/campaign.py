"""``auvdock compare``, ``auvdock report`` and ``auvdock sweep``: many runs, tables and figures."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table

from ..mission import MissionError
from .app import app, console, controller_list, err_console, fail_input


def _campaign_outputs(path: Path, out_dir: Path, *, pdf: bool, plots: bool, records=None, attrs=None) -> None:
    """Tables, findings and figures of a campaign file, printed and written to ``out_dir``."""
    from ..campaign import SUMMARY_HEADER, check_findings, read_campaign, summary_rows, write_tables

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
        from ..campaign import read_campaign_runs
        from ..campaign_plots import plot_campaign

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

    from ..campaign import PAPER_MISSIONS, campaign_specs, default_missions_dir, run_campaign

    ctrls = controller_list(controllers)
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
    from ..campaign import read_campaign

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
    from ..sweep import SweepError, sweep_main

    try:
        code = sweep_main(sweep_file, out, workers, scheduler, resume, trajectories, console)
    except (SweepError, MissionError) as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    raise typer.Exit(code=code)
