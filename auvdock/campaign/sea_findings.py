"""What a compare campaign found beyond the paper's cases (the wave basin, PacWave: ``compare --sea``),
computed from its table alone.

Per case (a mission that is not one of the paper's six): how each controller's run ended (captured,
collided and on what at what speed, timed out, gave up), and the gap between Oracle (told the sea and
the dock) and the best deployable controller (the one that captured soonest; none captured: said so).
One run per controller and case: a single seed says what happened, not how often; the sweeps
(``basin_capture``, ``sea_states_deployable``) say how often.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from auvdock.controllers.registry import reads_true_flow as _reads_truth

__all__ = ["sea_findings"]


def _ended(r: dict[str, Any]) -> str:
    if r.get("status") != "done":
        return "failed"
    reason = str(r.get("reason", ""))
    if reason in ("captured", "docked"):
        return f"{reason} in {r['time_to_dock_s']:.1f} s"
    if reason == "collided":
        speed = r.get("impact_speed_m_s", math.nan)
        return f"collided ({r.get('contact_what') or 'the dock'}, {speed:.2f} m/s)"
    return reason or "?"


def sea_findings(records: Sequence[dict[str, Any]]) -> str:
    """Markdown: one section per case beyond the paper's (``paper_case`` 0), "" when there is none."""
    cases: dict[str, list[dict[str, Any]]] = {}
    for r in records:
        if int(r.get("paper_case") or 0) == 0:
            cases.setdefault(str(r["case"]), []).append(r)
    if not cases:
        return ""
    out = [
        "## Beyond the paper's cases\n",
        "One run per controller and case (its seed): what happened, not how often.\n",
    ]
    for case, rows in cases.items():
        out.append(f"### {case}\n")
        out += [f"- {r['controller']}: {_ended(r)}" for r in rows]
        done = [r for r in rows if r.get("status") == "done" and r.get("docked")]
        oracle = [r for r in done if _reads_truth(str(r["controller"]))]
        deploy = [r for r in done if not _reads_truth(str(r["controller"]))]
        n_deploy = sum(not _reads_truth(str(r["controller"])) for r in rows)
        if deploy:
            best = min(deploy, key=lambda r: float(r["time_to_dock_s"]))
            line = (
                f"- Deployable controllers that docked: {len(deploy)} of {n_deploy}; the soonest, "
                f"{best['controller']}, in {best['time_to_dock_s']:.1f} s"
            )
            if oracle:
                o = min(oracle, key=lambda r: float(r["time_to_dock_s"]))
                gap = float(best["time_to_dock_s"]) - float(o["time_to_dock_s"])
                line += f", {gap:+.1f} s against {o['controller']} (told the truth)"
            out.append(line + ".")
        else:
            names = ", ".join(str(r["controller"]) for r in oracle)
            told = f"; {names} (told the truth) did" if oracle else ""
            out.append(f"- No deployable controller docked ({n_deploy} ran){told}.")
        out.append("")
    return "\n".join(out)
