"""The one campaign engine: run a :class:`Plan` on an executor into a results file.

:func:`run_plan` serves ``auvdock compare`` and ``auvdock sweep`` alike:

* **Existing file**: never replaced silently (:class:`~auvdock.campaign.store.ResultsFileError`)
  unless ``resume`` (skip the runs already done from the same spec) or ``force`` (start again).
* **Execution**: local worker processes (:class:`~auvdock.campaign.executor.LocalExecutor`)
  or a Dask cluster (``scheduler="tcp://host:8786"``).
* **Worker deaths**: a run whose worker died is submitted again ``retries`` times (default
  once), then recorded as failed with the reason; the other runs go on.
* **Run failures**: a run that raises is recorded as failed with its error, not retried.
* **Ctrl-C** (KeyboardInterrupt in the driver): the workers are killed at once, the file
  keeps every run that ended and is closed readable, and KeyboardInterrupt is raised again;
  ``resume=True`` continues.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from auvdock.campaign.executor import DaskExecutor, LocalExecutor, Runner
from auvdock.campaign.spec import Plan, RunSpec, empty_row
from auvdock.campaign.store import ResultsStore, read_results
from auvdock.campaign.worker import execute_run

__all__ = ["EventFn", "CampaignResult", "run_plan", "make_executor"]

#: ``on_event(kind, spec, info)`` in the driver: kind ``"plan"`` (spec None; info: total,
#: skipped, todo), ``"start"``, ``"progress"`` (info: t, timeout_s, distance_m),
#: ``"retry"`` (info: error) or ``"done"`` (info: the run's table row).
EventFn = Callable[[str, "RunSpec | None", dict[str, Any]], None]


@dataclass
class CampaignResult:
    """What :func:`run_plan` did.

    ``records`` are the file's table rows in plan order; ``ran`` and ``skipped`` the run ids
    run now and already done; ``errors`` run id -> error of the plan's runs that failed.
    """

    path: Path
    records: list[dict[str, Any]]
    total: int
    ran: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    errors: dict[str, str] = field(default_factory=dict)
    wall_time_s: float = 0.0
    executor: str = ""
    #: The runs the executor could run at once (its worker processes, or a cluster's threads); 0: none ran.
    cores: int = 0

    @property
    def runs_per_core_second(self) -> float:
        """Throughput: the runs run now per second of wall time per core the executor had (NaN: none)."""
        if not self.ran or self.cores <= 0 or self.wall_time_s <= 0:
            return float("nan")
        return len(self.ran) / (self.wall_time_s * self.cores)

    @property
    def out_dir(self) -> Path:
        return self.path.parent


def make_executor(
    workers: int | None, scheduler: str | None, n_runs: int, *, runner: Runner = execute_run, log_dir=None
):
    """A :class:`DaskExecutor` on ``scheduler`` if given, else a :class:`LocalExecutor`."""
    if scheduler:
        return DaskExecutor(scheduler, runner=runner)
    import os

    n = max(1, min(int(workers or os.cpu_count() or 1), max(1, n_runs)))
    return LocalExecutor(n, runner=runner, log_dir=log_dir)


def run_plan(
    plan: Plan,
    path: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    force: bool = False,
    command_line: str = "",
    on_event: EventFn | None = None,
    runner: Runner = execute_run,
    retries: int = 1,
    executor=None,
) -> CampaignResult:
    """Run ``plan`` and keep its results in ``path`` (module docstring).

    Parameters
    ----------
    plan : Plan
        The runs.
    path : str or Path
        The results file; the local workers' output goes to ``logs/`` beside it.
    workers : int, optional
        Local worker processes (default: all cores, at most one per run to do).
    scheduler : str, optional
        A Dask scheduler address instead of local processes.
    resume, force : bool
        What to do with an existing results file (module docstring).
    command_line : str
        Stored in the file.
    on_event : callable, optional
        Progress for a display (:data:`EventFn`).
    runner : callable
        What a worker calls for each run (tests inject faults with it).
    retries : int
        Times a run whose worker died is submitted again.
    executor : optional
        An executor to use instead of making one (it is closed at the end).

    Raises
    ------
    auvdock.campaign.store.ResultsFileError
        The file is there and neither resume nor force was given, or it cannot be resumed.
    auvdock.campaign.executor.ExecutorError
        The Dask scheduler cannot be reached.
    KeyboardInterrupt
        After a Ctrl-C, once the workers are stopped and the file is closed.
    """
    plan.check()
    path = Path(path)
    t0 = time.perf_counter()

    def emit(kind: str, spec: RunSpec | None, info: dict[str, Any]) -> None:
        if on_event is not None:
            on_event(kind, spec, info)

    ex = executor
    if ex is None and scheduler:  # connect first: an unreachable scheduler leaves no file behind
        ex = DaskExecutor(scheduler, runner=runner)
    try:
        store = ResultsStore(path, plan, resume=resume, force=force)
    except BaseException:
        if ex is not None:
            ex.close()
        raise
    ran: list[str] = []
    try:
        todo = [s for s in plan.specs if not store.done(s)]
        todo_ids = {s.run_id for s in todo}
        skipped = [s.run_id for s in plan.specs if s.run_id not in todo_ids]
        if todo and ex is None:
            ex = make_executor(workers, None, len(todo), runner=runner, log_dir=path.parent / "logs")
        desc = ex.description if todo and ex is not None else "none (nothing to run)"
        cores = ex.cores if todo and ex is not None else 0
        store.begin(
            command_line=command_line,
            executor=desc,
            workers=cores,
            resume=resume,
        )
        emit("plan", None, {"total": len(plan.specs), "skipped": len(skipped), "todo": len(todo)})
        if todo:
            _drive(ex, todo, plan, store, emit, retries, ran)
    except BaseException:  # Ctrl-C included: the workers are stopped at once
        if ex is not None:
            ex.close(kill=True)
        raise
    else:
        if ex is not None:
            ex.close()
    finally:
        store.close(time.perf_counter() - t0)
    records, _ = read_results(path)
    ids = {s.run_id for s in plan.specs}
    errors = {r["run_id"]: r["error"] for r in records if r["run_id"] in ids and r["status"] != "done"}
    return CampaignResult(
        path=path,
        records=records,
        total=len(plan.specs),
        ran=ran,
        skipped=skipped,
        errors=errors,
        wall_time_s=time.perf_counter() - t0,
        executor=desc,
        cores=cores,
    )


def _drive(
    ex, todo: list[RunSpec], plan: Plan, store: ResultsStore, emit, retries: int, ran: list[str]
) -> None:
    """Submit ``todo``, write each run as it ends, resubmit runs whose worker died."""
    by_id = {s.run_id: s for s in todo}
    attempts = dict.fromkeys(by_id, 1)
    for s in todo:
        ex.submit(s)

    def record(spec: RunSpec, row: dict[str, Any], image: bytes | None) -> None:
        row = {**row, **spec.labels}
        row.update(run_id=spec.run_id, controller=spec.controller, seed=spec.seed, spec_sha=spec.sha)
        row["attempts"] = attempts[spec.run_id]
        row.pop("traceback", None)
        if row["status"] == "done" and spec.group is not None and image is None:
            row["status"], row["error"] = "failed", "the worker returned no trajectory"
        store.put(row, image if row["status"] == "done" else None, spec.group)
        ran.append(spec.run_id)
        emit("done", spec, row)

    while ex.pending():
        for ev in ex.poll(0.2):
            spec = by_id.get(ev.run_id)
            if spec is None:
                continue
            if ev.kind == "start":
                emit("start", spec, {})
            elif ev.kind == "progress":
                t, timeout, dist = ev.data
                emit("progress", spec, {"t": t, "timeout_s": timeout, "distance_m": dist})
            elif ev.kind == "result":
                record(spec, ev.data["row"], ev.data.get("image"))
            elif ev.kind == "error":
                row = empty_row(spec, plan.columns)
                row["error"] = str(ev.data)
                record(spec, row, None)
            elif ev.kind == "lost":
                n = attempts[spec.run_id]
                if n <= retries:
                    attempts[spec.run_id] = n + 1
                    emit("retry", spec, {"error": str(ev.data)})
                    ex.submit(spec)
                else:
                    row = empty_row(spec, plan.columns)
                    row["error"] = f"{ev.data}; given up after {n} attempts"
                    record(spec, row, None)
    recorded = set(ran)
    for spec in todo:  # a safety net: every run submitted ends with a row
        if spec.run_id not in recorded:
            row = empty_row(spec, plan.columns)
            row["error"] = "no result came back from the executor"
            record(spec, row, None)
