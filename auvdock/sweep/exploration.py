"""Where exploration pays: the flow-estimating controllers against certainty equivalence, from a sweep table.

A sweep that flies Certainty-equivalent MPC (``ce``: the FSE controllers' flow filter and MPC with
no exploration) beside one or more flow-state-estimating controllers (``sequential``,
``optimized``, and their ``@paper`` variants) answers, per regime -- each combination of the
sweep's grid fields --, whether the exploration (the perception law (9), the information reward
of cost (10)) changed anything measurable:

* **success**: the share of runs that docked, with Wilson 95 % intervals; a controller *beats*
  CE in a regime when its interval lies wholly above CE's, *loses* when wholly below, and is
  *the same within the intervals* otherwise;
* **time** to dock (median of the docked runs) and the **estimate errors** of the navigation
  filter (the relative position to the dock, the current) and of the controller's flow filter
  (medians over the runs).

:func:`exploration_report` computes the per-regime table and the findings, as sentences built
from the numbers (none is written in advance): how many regimes show a difference beyond the
intervals, which, and by how much; when none does, it says so.

Imports nothing from :mod:`auvdock.sweep` (which uses it) but :mod:`auvdock.sweep.rates`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from auvdock.controllers.registry import CONTROLLERS
from auvdock.sweep.rates import success_rate

__all__ = ["BASELINE", "RegimeComparison", "is_explorer", "compare_regimes", "exploration_report"]

#: The controller the explorers are measured against.
BASELINE = "ce"


def _median(values: list[float]) -> float:
    v = [float(x) for x in values if x is not None and np.isfinite(x)]
    return float(np.median(v)) if v else math.nan


class RegimeComparison:
    """One regime (a combination of grid values) and one controller against CE.

    Attributes: ``regime`` (field -> value), ``controller``, ``s`` and ``s_ce`` (:func:`success_rate`
    dicts), ``verdict`` (``beats``, ``loses`` or ``same``), the medians ``time``/``time_ce`` (s),
    ``rel``/``rel_ce`` (m), ``cur``/``cur_ce`` (m/s).
    """

    def __init__(
        self, regime: dict[str, Any], controller: str, rows: list[dict], ce_rows: list[dict]
    ) -> None:
        self.regime = regime
        self.controller = controller
        self.s = success_rate(rows)
        self.s_ce = success_rate(ce_rows)
        if self.s["n"] and self.s_ce["n"] and self.s["lo"] > self.s_ce["hi"]:
            self.verdict = "beats"
        elif self.s["n"] and self.s_ce["n"] and self.s["hi"] < self.s_ce["lo"]:
            self.verdict = "loses"
        else:
            self.verdict = "same"
        self.time = _median([r["time_to_dock_s"] for r in rows if r["docked"]])
        self.time_ce = _median([r["time_to_dock_s"] for r in ce_rows if r["docked"]])
        self.rel = _median([r.get("relative_position_rmse_m", math.nan) for r in rows])
        self.rel_ce = _median([r.get("relative_position_rmse_m", math.nan) for r in ce_rows])
        self.cur = _median([r.get("navigation_current_rmse_m_s", math.nan) for r in rows])
        self.cur_ce = _median([r.get("navigation_current_rmse_m_s", math.nan) for r in ce_rows])

    def label(self) -> str:
        return ", ".join(f"{k} = {v}" for k, v in self.regime.items()) or "(one point)"


def is_explorer(spec: str) -> bool:
    """A flow-state-estimating controller that explores (Sequential, Optimized, either variant):
    the ones measured against CE (not Oracle or the other baselines, not CE itself)."""
    name = str(spec).partition("@")[0]
    entry = CONTROLLERS.get(name)
    return entry is not None and entry.estimates_flow and name != BASELINE


def compare_regimes(rows: Sequence[dict[str, Any]], grid_fields: Sequence[str]) -> list[RegimeComparison]:
    """Every (regime, explorer) of the table against CE in the same regime (empty without CE)."""
    done = [r for r in rows]
    if not any(r["controller"] == BASELINE for r in done):
        return []
    # a field with one value in the whole table names no regime
    grid_fields = [f for f in grid_fields if len({str(r.get(f)) for r in done}) > 1]
    regimes: dict[tuple, dict[str, list[dict]]] = {}
    for r in done:
        key = tuple(r.get(f) for f in grid_fields)
        regimes.setdefault(key, {}).setdefault(r["controller"], []).append(r)
    out = []
    for key in sorted(regimes, key=lambda k: tuple(str(v) for v in k)):
        by = regimes[key]
        ce = by.get(BASELINE, [])
        for c, rs in by.items():
            if not is_explorer(c) or not ce:
                continue
            out.append(RegimeComparison(dict(zip(grid_fields, key, strict=True)), c, rs, ce))
    return out


def _pct(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{100 * x:.0f} %"


def _num(x: float, spec: str) -> str:
    return "-" if not np.isfinite(x) else format(x, spec)


def exploration_report(
    rows: Sequence[dict[str, Any]], grid_fields: Sequence[str]
) -> tuple[list[str], list[list[str]], list[str]]:
    """``(header, table rows, findings)`` of the comparison (empty table and findings without CE).

    The findings are sentences computed from the comparisons: per explorer, in how many regimes it
    beats, loses to, or equals CE within the intervals, the regimes where it differs with both
    rates, and how its time and estimate errors compare where both dock.
    """
    comps = compare_regimes(rows, grid_fields)
    header = [
        "regime",
        "controller",
        "docked",
        f"docked ({BASELINE})",
        "verdict",
        "time s",
        f"time s ({BASELINE})",
        "relative position rmse m",
        f"... ({BASELINE})",
        "current rmse m/s",
        f"... ({BASELINE})",
    ]
    table = []
    for c in comps:
        table.append(
            [
                c.label(),
                c.controller,
                f"{c.s['docked']}/{c.s['n']} ({_pct(c.s['lo'])}-{_pct(c.s['hi'])})",
                f"{c.s_ce['docked']}/{c.s_ce['n']} ({_pct(c.s_ce['lo'])}-{_pct(c.s_ce['hi'])})",
                c.verdict,
                _num(c.time, ".1f"),
                _num(c.time_ce, ".1f"),
                _num(c.rel, ".3f"),
                _num(c.rel_ce, ".3f"),
                _num(c.cur, ".3f"),
                _num(c.cur_ce, ".3f"),
            ]
        )
    findings: list[str] = []
    for ctrl in dict.fromkeys(c.controller for c in comps):
        mine = [c for c in comps if c.controller == ctrl]
        beats = [c for c in mine if c.verdict == "beats"]
        loses = [c for c in mine if c.verdict == "loses"]
        same = len(mine) - len(beats) - len(loses)
        line = (
            f"{ctrl}: beats {BASELINE} beyond the Wilson intervals in {len(beats)} of {len(mine)} regimes, "
            f"loses in {len(loses)}, the same within the intervals in {same}."
        )
        for c in beats + loses:
            word = "above" if c.verdict == "beats" else "below"
            line += f" {c.label()}: {c.s['docked']}/{c.s['n']} {word} {c.s_ce['docked']}/{c.s_ce['n']}."
        both = [c for c in mine if np.isfinite(c.time) and np.isfinite(c.time_ce)]
        if both:
            dt = [c.time - c.time_ce for c in both]
            line += (
                f" Where both dock, its median time is {float(np.median(dt)):+.1f} s from {BASELINE}'s "
                f"(median over {len(both)} regimes)."
            )
        rel = [c.rel - c.rel_ce for c in mine if np.isfinite(c.rel) and np.isfinite(c.rel_ce)]
        cur = [c.cur - c.cur_ce for c in mine if np.isfinite(c.cur) and np.isfinite(c.cur_ce)]
        if rel:
            line += (
                f" The navigation filter's relative-position error: {float(np.median(rel)):+.3f} m, its "
                f"current error: {float(np.median(cur)) if cur else math.nan:+.3f} m/s from {BASELINE}'s "
                "(medians of the per-regime differences)."
            )
        findings.append(line)
    if comps and not any(c.verdict != "same" for c in comps):
        findings.append(
            f"No explorer's success differs from {BASELINE}'s beyond the Wilson intervals in any regime of "
            "this sweep: within these regimes, exploration changed no docking outcome measurably."
        )
    return header, table, findings
