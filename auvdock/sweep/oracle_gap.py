"""Oracle against the best deployable controller, per sea state: what being told the truth is worth.

For a sweep that flies Oracle (told the realised sea and the dock's true motion) beside controllers that
are not told (the deployable ones), :func:`oracle_gap_report` groups the runs by sea state (the varied
``sea.*`` fields, the dock's depth, the current: :data:`auvdock.sweep.station.SEA_FIELDS`) and sensor
suite, and gives per group Oracle's captures (Wilson 95 % interval) and median time to capture, the
best deployable controller's (most captures; the sooner median time breaks a tie), and the gaps: in
capture rate (percentage points) and in median time (s).  The findings say in how many groups Oracle
captures more, and in how many its interval lies wholly above the best deployable's.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from auvdock.controllers.registry import reads_true_flow as _reads_truth
from auvdock.controllers.registry import split_controller
from auvdock.sweep.rates import success_rate
from auvdock.sweep.station import SEA_FIELDS

__all__ = ["oracle_gap_report"]


def _median_time(rows: Sequence[dict[str, Any]]) -> float:
    times = [float(r["time_to_dock_s"]) for r in rows if r["docked"]]
    return float(np.median(times)) if times else math.nan


def _captures(rate: dict[str, Any]) -> str:
    return f"{rate['docked']}/{rate['n']} [{100 * rate['lo']:.0f}-{100 * rate['hi']:.0f} %]"


def _t(v: float) -> str:
    return "-" if not math.isfinite(v) else f"{v:.1f} s"


def oracle_gap_report(
    rows: Sequence[dict[str, Any]], varied: Sequence[str]
) -> tuple[list[str], list[list[str]], list[str]]:
    """(header, rows, findings) of the gap table; all empty without Oracle or without a deployable
    controller, or when no sea field is varied."""
    fields = [f for f in varied if f.startswith("sea.") or f in SEA_FIELDS or f == "sensors.suite"]
    controllers = list(dict.fromkeys(str(r["controller"]) for r in rows))
    oracle = [c for c in controllers if split_controller(c)[0] == "oracle"]
    deploy = [c for c in controllers if not _reads_truth(c)]
    if not fields or not oracle or not deploy:
        return [], [], []
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(tuple(r.get(f) for f in fields), []).append(r)
    header = [*fields, "Oracle", "Oracle time", "best deployable", "its captures", "its time"]
    header += ["gap", "time gap"]
    body: list[list[str]] = []
    more = above = 0
    for key, members in groups.items():
        o_rows = [r for r in members if r["controller"] == oracle[0]]
        o = success_rate(o_rows)
        o_t = _median_time(o_rows)
        best, best_rate, best_t = "", None, math.nan
        for c in deploy:
            c_rows = [r for r in members if r["controller"] == c]
            rate, t = success_rate(c_rows), _median_time(c_rows)
            better = best_rate is None or rate["docked"] > best_rate["docked"] or (
                rate["docked"] == best_rate["docked"] and (t < best_t or not math.isfinite(best_t))
            )
            if better:
                best, best_rate, best_t = c, rate, t
        assert best_rate is not None
        if best_rate["docked"] == 0:
            best = "(none captured)"
        gap = 100.0 * (o["rate"] - best_rate["rate"])
        more += int(o["docked"] > best_rate["docked"])
        above += int(o["lo"] > best_rate["hi"])
        body.append(
            [*(f"{v:g}" if isinstance(v, float) else str(v) for v in key)]
            + [
                _captures(o),
                _t(o_t),
                best,
                _captures(best_rate),
                _t(best_t),
                f"{gap:+.0f} pp",
                _t(best_t - o_t) if math.isfinite(best_t - o_t) else "-",
            ]
        )
    n = len(groups)
    findings = [
        f"Oracle captures more than the best deployable controller in {more} of {n} sea states (x suites); "
        f"its 95 % interval lies wholly above the best deployable's in {above}.",
    ]
    return header, body, findings
