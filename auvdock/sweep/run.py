"""Running a sweep: its plan on the campaign engine, into ``<out>/sweep.h5``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from auvdock.campaign.engine import CampaignResult, EventFn, run_plan
from auvdock.campaign.executor import Runner
from auvdock.campaign.store import read_results
from auvdock.campaign.worker import execute_run
from auvdock.sweep.expand import sweep_plan
from auvdock.sweep.load import load_sweep

__all__ = ["RESULTS_NAME", "run_sweep", "read_sweep"]

#: The results file's name in the output folder.
RESULTS_NAME = "sweep.h5"


def run_sweep(
    sweep_path: str | Path,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    force: bool = False,
    trajectories: bool = False,
    on_event: EventFn | None = None,
    command_line: str = "",
    runner: Runner = execute_run,
) -> CampaignResult:
    """Run every run of a sweep and keep the results in ``out_dir/sweep.h5``.

    Parameters
    ----------
    sweep_path : str or Path
        The sweep file or a shipped sweep's name (validated first: :class:`SweepError`).
    out_dir : str or Path
        Output directory (created).
    workers : int, optional
        Local worker processes (default: all cores, at most one per run to do).
    scheduler : str, optional
        A running Dask scheduler (``tcp://host:8786``) instead of local processes.
    resume, force : bool
        An existing ``sweep.h5`` is never replaced silently
        (:class:`auvdock.campaign.ResultsFileError`): ``resume`` skips the runs done,
        ``force`` starts again.
    trajectories : bool
        Also keep each run's trajectory (run group ``/runs/<run id>``).
    on_event : callable, optional
        Progress (:data:`auvdock.campaign.engine.EventFn`).
    command_line : str
        Stored in the file.
    runner : callable
        What a worker calls for each run (tests inject faults with it).
    """
    sweep = load_sweep(sweep_path)
    plan = sweep_plan(sweep, trajectories=trajectories)
    return run_plan(
        plan,
        Path(out_dir) / RESULTS_NAME,
        workers=workers,
        scheduler=scheduler,
        resume=resume,
        force=force,
        command_line=command_line,
        on_event=on_event,
        runner=runner,
    )


def read_sweep(path: str | Path) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The run table of a sweep file (point, controller, seed, model-error draw order) and its
    attributes; ``varied``, ``grid_fields``, ``model_error_columns`` and ``controllers`` as lists.

    Raises
    ------
    ValueError
        If the file is not an auvdock sweep file.
    """
    return read_results(path, "sweep")
