"""The progress display of ``auvdock compare`` and ``auvdock sweep`` (rich).

An overall bar (runs done of the plan, failures, ETA), one bar per running run while its
worker reports progress (simulated time, distance to the dock; local workers only), and,
for compare, a line per finished run.  It is the engine's ``on_event``
(:data:`auvdock.campaign.engine.EventFn`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from rich.console import Console
from rich.markup import escape
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    SpinnerColumn,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
)

from auvdock.campaign.spec import RunSpec

__all__ = ["CampaignProgress", "outcome_text"]


def outcome_text(row: dict[str, Any]) -> str:
    """A finished run in a few words, with rich markup: docked 19.90 s / timeout 75 s / failed: ..."""
    if row["status"] != "done":
        return f"[red]failed[/red]: {escape(str(row['error']))}"
    if row["docked"]:
        return f"[green]docked[/green] {row['time_to_dock_s']:.2f} s"
    return f"[yellow]{escape(str(row.get('reason') or 'timeout'))}[/yellow] {row['end_time_s']:.0f} s"


def _eta(seconds: float | None) -> str:
    if seconds is None:
        return "ETA -"
    m, s = divmod(int(round(seconds)), 60)
    h, m = divmod(m, 60)
    return f"ETA {h}:{m:02d}:{s:02d}"


class CampaignProgress:
    """``with CampaignProgress(console, total) as on_event: run_plan(..., on_event=on_event)``.

    Parameters
    ----------
    console : rich.console.Console
    total : int
        Runs in the plan.
    lines : bool
        Print a line per finished run (compare).
    label : callable, optional
        The name shown for a run (default: its id).
    """

    def __init__(
        self,
        console: Console,
        total: int,
        *,
        lines: bool = False,
        label: Callable[[RunSpec], str] | None = None,
    ) -> None:
        self.console = console
        self.total = total
        self.lines = lines
        self.label = label or (lambda s: s.run_id)
        self.bar = Progress(
            SpinnerColumn(),
            TextColumn("{task.description:<28}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            console=console,
        )
        self._tasks: dict[str, Any] = {}
        self._done = 0
        self._now = 0
        self._failed = 0
        self._t0 = time.perf_counter()
        self._overall: TaskID | None = None

    def __enter__(self) -> CampaignProgress:
        self.bar.__enter__()
        self._overall = self.bar.add_task("all runs", total=self.total, info="")
        return self

    def __exit__(self, *exc: Any) -> None:
        self.bar.__exit__(*exc)

    def stop(self) -> None:
        self.bar.stop()

    def _update_overall(self) -> None:
        left = self.total - self._done
        eta = (time.perf_counter() - self._t0) / self._now * left if self._now else None
        info = _eta(eta if left else 0.0) + (f"  [red]{self._failed} failed[/red]" if self._failed else "")
        if self._overall is not None:
            self.bar.update(self._overall, completed=self._done, info=info)

    def _run_task(self, spec: RunSpec, info: str) -> Any:
        if spec.run_id not in self._tasks:
            self._tasks[spec.run_id] = self.bar.add_task(escape(self.label(spec)), total=1.0, info=info)
        return self._tasks[spec.run_id]

    def __call__(self, kind: str, spec: RunSpec | None, info: dict[str, Any]) -> None:
        if kind == "plan":
            self._done = info["skipped"]
            self._t0 = time.perf_counter()
            self._update_overall()
        elif spec is None:
            return
        elif kind == "start":
            self._run_task(spec, "setting up the controller")
        elif kind == "progress":
            self.bar.update(
                self._run_task(spec, ""),
                total=info["timeout_s"],
                completed=info["t"],
                info=f"t = {info['t']:5.1f} s  d = {info['distance_m']:.3f} m",
            )
        elif kind == "retry":
            if spec.run_id in self._tasks:
                self.bar.remove_task(self._tasks.pop(spec.run_id))
            self.bar.console.print(
                f"  {escape(f'{self.label(spec):<28}')} [yellow]retried[/yellow]: "
                f"{escape(str(info['error']))}",
                highlight=False,
            )
        elif kind == "done":
            if spec.run_id in self._tasks:
                self.bar.remove_task(self._tasks.pop(spec.run_id))
            self._done += 1
            self._now += 1
            self._failed += info["status"] != "done"
            self._update_overall()
            if self.lines:
                wall = info.get("wall_time_s", float("nan"))
                self.bar.console.print(
                    f"  {escape(f'{self.label(spec):<28}')} {outcome_text(info)}  (wall {wall:.1f} s)",
                    highlight=False,
                )
