"""A compare campaign's tables: ``summary.csv``, ``summary.md`` and ``findings.md``, from its rows alone."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from auvdock.campaign.compare import TABLE_COLUMNS
from auvdock.campaign.findings import check_findings, coverage_note
from auvdock.campaign.sea_findings import sea_findings

__all__ = ["SUMMARY_HEADER", "FINDINGS_HEADER", "summary_rows", "markdown_table", "write_tables"]

SUMMARY_HEADER = (
    "case",
    "controller",
    "docked",
    "time to dock",
    "path length m",
    "closest approach m",
    "contact speed m/s",
    "flow RMSE m/s",
    "median solve ms",
    "p95 solve ms",
    "wall s",
    "setup s",
)
FINDINGS_HEADER = ("finding", "measured here", "verdict", "why it differs")


def _fmt(v: Any, spec: str, unit: str = "", scale: float = 1.0) -> str:
    if v is None or not isinstance(v, int | float) or not math.isfinite(v):
        return "-"
    return format(v * scale, spec) + unit


def summary_rows(records: Sequence[dict[str, Any]]) -> list[list[str]]:
    """The summary table (:data:`SUMMARY_HEADER` columns) as text, one row per run.

    "wall s" is the closed loop alone; "setup s" building (and compiling) the controller.
    """
    rows = []
    for r in records:
        if r["status"] != "done":
            docked, ttd = "failed", f"failed: {r['error']}"
        elif r["docked"]:
            docked, ttd = "yes", _fmt(r["time_to_dock_s"], ".2f", " s")
        elif r.get("reason") in ("", "timeout", None):
            docked, ttd = "no", f"timeout {r['timeout_s']:.0f} s"
        else:  # collided, gave up finding the dock, diverged
            docked, ttd = "no", f"{r['reason']} at {r['end_time_s']:.1f} s"
        rows.append(
            [
                r["case"],
                r["controller"],
                docked,
                ttd,
                _fmt(r["path_length_m"], ".2f"),
                _fmt(r["closest_approach_m"], ".3f"),
                _fmt(r["contact_speed_m_s"], ".3f"),
                _fmt(r["flow_rmse_m_s"], ".4f"),
                _fmt(r["solve_time_median_s"], ".2f", scale=1e3),
                _fmt(r["solve_time_p95_s"], ".2f", scale=1e3),
                _fmt(r["wall_time_s"], ".1f"),
                _fmt(r.get("setup_time_s"), ".1f"),
            ]
        )
    return rows


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """A Markdown table (``|`` in cells escaped)."""
    esc = [[c.replace("|", "\\|") for c in row] for row in rows]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in esc]
    return "\n".join(lines) + "\n"


def write_tables(records: Sequence[dict[str, Any]], out_dir: str | Path, attrs: dict[str, Any]) -> list[Path]:
    """Write ``summary.csv``, ``summary.md`` and ``findings.md`` into ``out_dir``.

    The CSV has every table column (:data:`~auvdock.campaign.compare.TABLE_COLUMNS`,
    full precision); the Markdown files the human summary and the paper's findings.  Same
    inputs, same bytes.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    cols = list(TABLE_COLUMNS)
    w.writerow(cols)
    for r in records:
        w.writerow([repr(r.get(c)) if isinstance(r.get(c), float) else r.get(c) for c in cols])
    csv_path = out / "summary.csv"
    csv_path.write_text(buf.getvalue())

    md_path = out / "summary.md"
    cmd = attrs.get("command_line", "")
    head = "# Campaign summary\n\n"
    if cmd:
        head += f"Made with `{cmd}` (auvdock {attrs.get('auvdock_version', '')}).\n\n"
    head += (
        "wall s: the closed loop of the run; setup s: building (and compiling) its controller, "
        "not included in wall s.\n\n"
    )
    md_path.write_text(head + markdown_table(SUMMARY_HEADER, summary_rows(records)))

    fd_path = out / "findings.md"
    rows = [[f.finding, f.measured, f.verdict, f.explanation] for f in check_findings(records)]
    fd_path.write_text(
        "# The paper's findings (docs/parameter-sources.md section 5b), checked\n\n"
        "Every explanation is computed from this campaign's table.\n\n"
        + (f"{note}\n\n" if (note := coverage_note(records)) else "")
        + markdown_table(FINDINGS_HEADER, rows)
        + (f"\n{sea}" if (sea := sea_findings(records)) else "")
    )
    return [csv_path, md_path, fd_path]
