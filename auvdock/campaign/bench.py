"""``auvdock bench``: per-step solve time of each controller x solver on the paper's cases.

Each row is one full closed-loop run (:func:`auvdock.loop.simulation.run_simulation`) of a shipped
paper mission with the given controller and solver; the figures are the wall time of the
whole controller step (estimator, perception law and MPC for the FSE controllers), in ms:
median, p95, p99 and max, plus the real-time factor (simulated s per wall s), the docking
outcome and the time to dock.  Figures are measured, never asserted in tests.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from auvdock.campaign.machine import machine_line
from auvdock.config.catalog import PAPER_MISSIONS, missions_dir

__all__ = [
    "PAPER_MISSIONS",
    "DEFAULT_CASES",
    "machine_line",
    "default_missions_dir",
    "bench_rows",
    "StepFigures",
    "step_figures",
    "rounds_median",
    "busy_loops",
]

DEFAULT_CASES = (1, 2, 6)


def _parts_median_ms(parts_s: dict[str, np.ndarray], total_ms: np.ndarray) -> dict[str, float]:
    """Median ms per part of the step (:mod:`auvdock.runtime.timing`), in print order, and ``python``:
    the median of what the parts leave of each step's wall time."""
    from auvdock.runtime.timing import PARTS

    order = [p for p in PARTS if p in parts_s] + sorted(set(parts_s) - set(PARTS))
    out = {p: float(np.median(parts_s[p])) * 1e3 for p in order}
    timed = np.sum([parts_s[p] for p in order], axis=0) * 1e3 if order else np.zeros_like(total_ms)
    out["python"] = float(np.median(total_ms - timed)) if len(total_ms) else float("nan")
    return out


class StepFigures(NamedTuple):
    """A run's whole control step."""

    #: (median, p95, p99), ms.
    percentiles_ms: np.ndarray
    #: The largest, ms.
    max_ms: float
    #: The median ms per part (``python``: what the parts leave).
    parts_ms: dict[str, float]


def step_figures(solve_times_s: np.ndarray, time_parts_s: dict[str, np.ndarray]) -> StepFigures:
    """A run's :data:`StepFigures` from its steps' times and parts (s; :class:`RunSummary`'s), the first
    step left out (a cold start: it iterates to convergence)."""
    ms = np.asarray(solve_times_s)[1:] * 1e3
    parts = {k: np.asarray(v)[1:] for k, v in time_parts_s.items()}
    return StepFigures(np.percentile(ms, [50, 95, 99]), float(ms.max()), _parts_median_ms(parts, ms))


def rounds_median(rounds: Sequence[StepFigures]) -> StepFigures:
    """The median over interleaved rounds of one run's :data:`StepFigures`, figure by figure (a part
    missing from a round counts as NaN)."""
    pct = np.median([r[0] for r in rounds], axis=0)
    mx = float(np.median([r[1] for r in rounds]))
    names = list(rounds[-1][2])
    return StepFigures(pct, mx, {k: float(np.median([r[2].get(k, np.nan) for r in rounds])) for k in names})


def _spin() -> None:
    while True:
        pass


@contextlib.contextmanager
def busy_loops(n: int) -> Iterator[None]:
    """``n`` processes spinning on the CPU while the block runs (a benchmark's steps measured beside
    them, as the test suite's run beside each other); stopped when it ends."""
    spinners = [mp.Process(target=_spin, daemon=True) for _ in range(max(0, int(n)))]
    for p in spinners:
        p.start()
    try:
        yield
    finally:
        for p in spinners:
            p.terminate()
            p.join(timeout=5.0)


def default_missions_dir() -> Path:
    """The shipped missions folder (:func:`auvdock.config.catalog.missions_dir`)."""
    return missions_dir()


def bench_rows(
    cases: Sequence[int] = DEFAULT_CASES,
    controllers: Sequence[str] | None = None,
    solvers: Sequence[str] = ("auto",),
    *,
    qps: Sequence[str] = ("hpipm",),
    timeout_s: float | None = None,
    on_row: Callable[[dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Run every case x controller x solver once and return one row (dict) per run.

    Parameters
    ----------
    cases : sequence of int
        Paper case numbers 1..6 (the shipped missions ``missions/<name>.yaml``).
    controllers, solvers : sequence of str
        Controller names (default: every registered one, in the registry's order) and
        ``controller.solver.name`` values (``auto``, ``rti``, ``sqp``, ``ipopt``).
    qps : sequence of str
        ``controller.solver.qp`` values (``hpipm``, ``hpipm_casadi``, ``qrqp``) for the solvers that solve QPs
        (``rti``, ``sqp``); ``ipopt`` runs once whatever they are.
    timeout_s : float, optional
        Simulated-time limit (default: the mission's 75 s).
    on_row : callable, optional
        Called with each row as soon as it is measured.
    """
    from auvdock.config.mission import load_mission
    from auvdock.controllers import controller_names, resolve_solver
    from auvdock.loop.simulation import run_simulation

    if controllers is None:
        controllers = controller_names(paper_only=True)
    d = default_missions_dir()
    rows = []
    for case in cases:
        if not 1 <= case <= len(PAPER_MISSIONS):
            raise ValueError(f"case {case}: the paper's cases are 1..{len(PAPER_MISSIONS)}")
        base = load_mission(d / f"{PAPER_MISSIONS[case - 1]}.yaml")
        for ctrl in controllers:
            for solver in solvers:
                resolved = resolve_solver(solver, ctrl)
                for qp in qps if resolved in ("rti", "sqp") else qps[:1]:
                    m = base.with_updates(
                        **{
                            "controller.type": ctrl,
                            "controller.solver.name": solver,
                            "controller.solver.qp": qp,
                        }
                    )
                    s = run_simulation(m, timeout_s=timeout_s)
                    o = s.outcome
                    ms = np.asarray(s.solve_times_s) * 1e3
                    row = {
                        "case": case,
                        "mission": base.name,
                        "controller": ctrl,
                        "solver": resolved,
                        "qp": qp if resolved in ("rti", "sqp") else "",
                        "docked": bool(o["docked"]),
                        "time_to_dock_s": float(o["time_to_dock_s"]),
                        "median_ms": float(np.median(ms)),
                        "p95_ms": float(np.percentile(ms, 95)),
                        "p99_ms": float(np.percentile(ms, 99)),
                        "max_ms": float(ms.max()),
                        "real_time_factor": float(o["real_time_factor"]),
                        "wall_time_s": float(o["wall_time_s"]),
                        "setup_time_s": float(o.get("setup_time_s", float("nan"))),
                        "solver_failures": int(o["solver_failures"]),
                        "steps": int(len(ms)),
                        "parts_median_ms": _parts_median_ms(s.time_parts_s, ms),
                    }
                    rows.append(row)
                    if on_row is not None:
                        on_row(row)
    return rows
