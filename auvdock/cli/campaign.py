"""``auvdock compare``, ``auvdock report`` and ``auvdock sweep``: many runs on the one campaign engine.

Both run commands: an existing results file in ``--out`` is never overwritten silently
(exit 2 and one line, unless ``--resume`` or ``--force``); Ctrl-C stops the workers at
once, keeps every finished run and exits 130; ``--resume`` continues.  Exit 1 when some
run failed (its error is in the table).
"""

from __future__ import annotations

import os
import shlex
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from auvdock.cli.app import (
    app,
    check_estimation,
    check_seed,
    console,
    controller_list,
    exit_interrupted,
    fail_input,
    output_dir,
    positive_timeout,
)
from auvdock.cli.tables import fitted_table
from auvdock.config.mission import MissionError


def controllers_text(specs: list[str]) -> str:
    """The controllers of a plan in words: ``5 controllers x 2 variants (robust, paper)`` when every
    controller runs in every variant (the default ``compare``), else ``3 controllers``."""
    from auvdock.controllers import split_controller

    pairs = [split_controller(c) for c in specs]
    names = list(dict.fromkeys(n for n, _ in pairs))
    variants = list(dict.fromkeys(v or "robust" for _, v in pairs))
    if len(variants) > 1 and len(names) * len(variants) == len(set(pairs)) == len(specs):
        return f"{len(names)} controllers x {len(variants)} variants ({', '.join(variants)})"
    return f"{len(specs)} controller{'s' if len(specs) != 1 else ''}"


def _interrupted(path: Path) -> None:
    exit_interrupted(f"interrupted: the finished runs are in {path}; continue with --resume")


def _campaign_outputs(path: Path, out_dir: Path, *, pdf: bool, plots: bool, records=None, attrs=None) -> None:
    """Tables, findings and figures of a compare campaign file, printed and written to ``out_dir``."""
    from auvdock.campaign import SUMMARY_HEADER, check_findings, read_campaign, summary_rows, write_tables
    from auvdock.campaign.findings import coverage_note

    if records is None or attrs is None:
        records, attrs = read_campaign(path)
    rows = summary_rows(records)
    # most important first: the outcome, then the figures of Figs. 2-5, then the timings
    priority = [SUMMARY_HEADER.index(h) for h in (
        "case", "controller", "docked", "time to dock", "closest approach m", "flow RMSE m/s",
        "median solve ms", "path length m", "contact speed m/s", "p95 solve ms", "wall s", "setup s",
    )]  # fmt: skip
    console.print(
        fitted_table(
            f"campaign {path}",
            SUMMARY_HEADER,
            rows,
            console.width,
            priority=priority,
            where="summary.md",
            row_styles=["red" if r[2] == "failed" else ("green" if r[2] == "yes" else None) for r in rows],
        )
    )
    ft = Table(
        title="the paper's findings (docs/parameter-sources.md section 5b), explained with this campaign's "
        "figures",
        show_lines=True,
    )
    for h in ("finding", "measured here", "verdict", "why it differs"):
        ft.add_column(h)  # prose: wrapped at spaces, never inside a number
    for f in check_findings(records):
        colour = {"holds": "green", "not run": "dim"}.get(f.verdict, "yellow")
        ft.add_row(
            escape(f.finding),
            escape(f.measured),
            f"[{colour}]{escape(f.verdict)}[/{colour}]",
            escape(f.explanation),
        )
    note = coverage_note(records)
    if note:
        ft.caption = note
    console.print(ft)
    written = write_tables(records, out_dir, attrs)
    if plots and records:
        from auvdock.campaign import read_campaign_runs
        from auvdock.campaign.plots import plot_campaign

        runs = read_campaign_runs(path)
        written += plot_campaign(records, runs, out_dir, formats=("png", "pdf") if pdf else ("png",))
    console.print("written: " + ", ".join(str(p) for p in written), markup=False, highlight=False)


def _sweep_outputs(path: Path, out_dir: Path, title: str) -> list[Path]:
    """The success table printed; summary.md and the figures written (from the file alone)."""
    from auvdock.sweep import read_sweep
    from auvdock.sweep.stats import report_sweep, success_table

    rows, _ = read_sweep(path)
    header, table_rows = success_table(rows)
    console.print(fitted_table(title, header, table_rows, console.width, where="summary.md"))
    written = report_sweep(path, out_dir)
    md = [p for p in written if p.suffix == ".md"]
    if md:
        console.print(f"summary: {md[0]}", markup=False, highlight=False)
    console.print(
        f"figures: {sum(p.suffix == '.png' for p in written)} PNG files in {out_dir}",
        markup=False,
        highlight=False,
    )
    return written


def _worker_logs(out_dir: Path) -> None:
    logs = out_dir / "logs"
    if logs.is_dir() and any(p.stat().st_size > 0 for p in logs.glob("worker-*.log")):
        console.print(f"worker output (solver warnings): {logs}", markup=False, highlight=False)


def _ran_line(res) -> None:
    ran = set(res.ran)
    rows = [r for r in res.records if r["run_id"] in ran]
    loop = sum(r["wall_time_s"] for r in rows if r["wall_time_s"] == r["wall_time_s"])
    setup = sum(r["setup_time_s"] for r in rows if r["setup_time_s"] == r["setup_time_s"])
    if res.skipped:
        console.print(f"resumed: {len(res.skipped)} runs already complete, {len(res.ran)} run now")
    console.print(
        f"campaign wall time {res.wall_time_s:.1f} s on {res.executor}; in the runs: {loop:.1f} s of closed "
        f"loop (mean {loop / max(1, len(rows)):.1f} s per run) + {setup:.1f} s of controller set-up",
        markup=False,
        highlight=False,
    )
    if res.ran and res.cores > 0:  # throughput, comparable across machines and worker counts
        console.print(
            f"throughput: {res.runs_per_core_second:.3f} runs per core-second ({len(res.ran)} runs in "
            f"{res.wall_time_s:.1f} s on {res.cores} core{'s' if res.cores != 1 else ''})",
            markup=False,
            highlight=False,
        )


@app.command()
def compare(
    missions: list[Path] | None = typer.Argument(
        None, help="Mission files or shipped mission names (default: the paper's six cases)."
    ),
    controllers: list[str] | None = typer.Option(
        None,
        "--controllers",
        "-c",
        help="Controllers, comma-separated or repeated, NAME or NAME@VARIANT (default: all five, "
        "robust, and each @paper beside it).",
    ),
    jobs: int | None = typer.Option(
        None, "--jobs", "-j", min=1, help="Worker processes (default: all cores)."
    ),
    scheduler: str | None = typer.Option(
        None, "--scheduler", help="Run on a Dask cluster instead, e.g. tcp://HOST:8786."
    ),
    out: Path = typer.Option(Path("runs/compare"), "--out", "-o", help="Output directory."),
    seed: int | None = typer.Option(None, "--seed", help="Seed for every run (default: each mission's)."),
    timeout: float | None = typer.Option(
        None,
        "--timeout",
        callback=positive_timeout,
        help="Docking timeout for every run, s (default: each mission's).",
    ),
    estimation: str | None = typer.Option(
        None,
        "--estimation",
        help="truth (the paper's Assumption 1) or filter (the navigation filter on the sensor suite), "
        "for every controller (default: each mission's).",
    ),
    resume: bool = typer.Option(
        False, "--resume", help="Continue the campaign in --out: skip the runs done."
    ),
    force: bool = typer.Option(False, "--force", help="Replace the campaign in --out: start again."),
    pdf: bool = typer.Option(False, "--pdf", help="Also write the figures as PDF."),
    no_plots: bool = typer.Option(False, "--no-plots", help="Skip the figures."),
    sea: bool = typer.Option(
        False,
        "--sea",
        help="Add the cases in a sea after the others: the wave basin (basin_regular) and PacWave's most "
        "common sea (pacwave_common_10m); findings.md then says how each run there ended.",
    ),
) -> None:
    """Run the paper's six-case study (cases x controllers) in parallel, with tables and figures."""
    from auvdock.campaign import (
        ExecutorError,
        ResultsFileError,
        campaign_specs,
        compare_plan,
        default_missions,
        run_plan,
    )
    from auvdock.campaign.display import CampaignProgress
    from auvdock.campaign.store import check_output, check_resume
    from auvdock.config.catalog import SEA_MISSIONS, resolve

    ctrls = controller_list(controllers, variants=True)
    given = list(missions or [])
    paths = [resolve(m) for m in given] or default_missions()
    if sea:
        paths += [resolve(m) for m in SEA_MISSIONS if resolve(m) not in paths]
    for m in paths:
        if not m.is_file():
            fail_input(f"{m}: file not found")
    check_seed(seed)
    check_estimation(estimation)
    try:
        specs = campaign_specs(paths, ctrls, seed=seed, timeout_s=timeout, estimation=estimation)
    except (MissionError, ValueError) as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    path = output_dir(out) / "campaign.h5"
    plan = compare_plan(specs)
    try:
        check_output(path, "compare", resume=resume, force=force)
        if resume:  # other missions or controllers than the file's: refused, never merged
            check_resume(path, plan)
    except ResultsFileError as e:
        fail_input(str(e))
    n_jobs = jobs or os.cpu_count() or 1
    words = ["auvdock", "compare", *(str(m) for m in given)]
    if controllers:
        words += ["--controllers", ",".join(ctrls)]
    words += ["--scheduler", scheduler] if scheduler else ["--jobs", str(n_jobs)]
    words += ["--out", str(out)]
    for flag, value in (("--seed", seed), ("--timeout", timeout), ("--estimation", estimation)):
        if value is not None:
            words += [flag, str(value)]
    flags = (
        ("--resume", resume), ("--force", force), ("--pdf", pdf), ("--no-plots", no_plots), ("--sea", sea),
    )  # fmt: skip
    words += [w for w, on in flags if on]
    cmd = shlex.join(words)
    n_cases = len(specs) // max(1, len(ctrls))
    where = f"Dask scheduler {scheduler}" if scheduler else f"{n_jobs} worker processes"
    console.print(
        f"[bold]campaign[/bold]: {n_cases} cases x {controllers_text(ctrls)} = {len(specs)} runs, "
        f"{escape(where)} -> {escape(str(path))}",
        highlight=False,
    )
    try:
        with CampaignProgress(
            console, len(specs), lines=True, label=lambda s: s.run_id.replace("/", " / ")
        ) as bar:
            res = run_plan(
                plan,
                path,
                workers=n_jobs,
                scheduler=scheduler,
                resume=resume,
                force=force,
                command_line=cmd,
                on_event=bar,
            )
    except (ResultsFileError, ExecutorError) as e:
        fail_input(str(e))
    except KeyboardInterrupt:
        _interrupted(path)
    _ran_line(res)
    _campaign_outputs(path, out, pdf=pdf, plots=not no_plots)
    _worker_logs(out)
    if res.errors:
        raise typer.Exit(code=1)


@app.command()
def report(
    results: Path = typer.Argument(..., help="Results file written by auvdock compare or auvdock sweep."),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Output directory (default: next to the file)."
    ),
    pdf: bool = typer.Option(False, "--pdf", help="Also write the figures as PDF (compare)."),
    no_plots: bool = typer.Option(False, "--no-plots", help="Skip the figures (compare)."),
) -> None:
    """Rebuild a campaign's or sweep's tables, findings and figures from its HDF5 file alone."""
    from auvdock.campaign import read_results

    if not results.is_file():
        fail_input(f"{results}: file not found")
    try:
        records, attrs = read_results(results)
    except ValueError as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    out_dir = output_dir(out if out is not None else results.parent)
    if attrs.get("kind") == "sweep":
        _sweep_outputs(results, out_dir, f"sweep {attrs.get('sweep_name', '')}: success per controller")
        return
    _campaign_outputs(results, out_dir, pdf=pdf, plots=not no_plots, records=records, attrs=attrs)


@app.command()
def sweep(
    sweep_file: Path = typer.Argument(
        ..., help="Sweep YAML file or shipped sweep name (e.g. current_speed, tank_trials)."
    ),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Output directory (default: runs/sweeps/<name>)."
    ),
    workers: int | None = typer.Option(
        None,
        "--jobs",
        "-j",
        "--workers",
        min=1,
        help="Local worker processes (default: one per core; --workers is its older name).",
    ),
    scheduler: str | None = typer.Option(
        None, "--scheduler", help="Run on a Dask cluster instead, e.g. tcp://HOST:8786."
    ),
    resume: bool = typer.Option(False, "--resume", help="Continue the sweep in --out: skip the runs done."),
    force: bool = typer.Option(False, "--force", help="Replace the sweep in --out: start again."),
    trajectories: bool = typer.Option(False, "--trajectories", help="Also keep every run's trajectory."),
) -> None:
    """Monte Carlo robustness campaign: success rates with Wilson intervals, figures, summary."""
    from auvdock.campaign import ExecutorError, ResultsFileError, run_plan
    from auvdock.campaign.display import CampaignProgress
    from auvdock.campaign.store import check_output
    from auvdock.sweep import RESULTS_NAME, SweepError, load_sweep, sweep_plan

    try:
        s = load_sweep(sweep_file)
        plan = sweep_plan(s, trajectories=trajectories)
    except (SweepError, MissionError) as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None
    out_dir = output_dir(out if out is not None else Path("runs") / "sweeps" / str(s.name))
    path = out_dir / RESULTS_NAME
    try:
        check_output(path, "sweep", resume=resume, force=force)
    except ResultsFileError as e:
        fail_input(str(e))
    words = ["auvdock", "sweep", str(sweep_file), "--out", str(out_dir)]
    if workers:
        words += ["--jobs", str(workers)]
    if scheduler:
        words += ["--scheduler", scheduler]
    words += [
        w for w, on in (("--resume", resume), ("--force", force), ("--trajectories", trajectories)) if on
    ]

    def n_of(k: int, what: str) -> str:
        return f"{k} {what}" + ("" if k == 1 else "s")

    parts = [n_of(s.n_points, "point"), n_of(len(s.controllers), "controller"), n_of(s.seeds, "seed")]
    if s.model_error.n:
        parts.append(n_of(s.model_error.n, "model-error draw"))
    console.print(
        f"[bold]sweep[/bold] {escape(str(s.name))}: {' x '.join(parts)} = {n_of(s.n_runs, 'run')} "
        f"-> {escape(str(path))}",
        highlight=False,
    )
    try:
        with CampaignProgress(console, len(plan.specs)) as bar:
            res = run_plan(
                plan,
                path,
                workers=workers,
                scheduler=scheduler,
                resume=resume,
                force=force,
                command_line=shlex.join(words),
                on_event=bar,
            )
    except (ResultsFileError, ExecutorError) as e:
        fail_input(str(e))
    except KeyboardInterrupt:
        _interrupted(path)
    _ran_line(res)
    _sweep_outputs(res.path, out_dir, f"sweep {s.name}: success per controller (Wilson 95 % intervals)")
    console.print(f"results: {res.path}", markup=False, highlight=False)
    _worker_logs(out_dir)
    if res.errors:
        for rid, err in list(res.errors.items())[:5]:
            console.print(f"  [red]failed[/red] {escape(f'{rid}: {err}')}", highlight=False)
        if len(res.errors) > 5:
            console.print(f"  ... and {len(res.errors) - 5} more (column 'error' of the run table)")
        raise typer.Exit(code=1)
