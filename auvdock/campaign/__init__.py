"""Campaigns: many closed-loop runs in parallel, one results file -- ``compare`` and ``sweep`` alike.

One engine, a package of small modules with one job each:

=================  ======================================================================
module             job
=================  ======================================================================
``spec``           the plan: :class:`RunSpec` (resolved mission + overrides + controller +
                   seed + truth-only model error + table labels), :class:`Plan`
``worker``         one run, in whatever process runs it (:func:`execute_run`)
``executor``       where runs execute: local worker processes, or a Dask cluster
``store``          the results file: one run table + run groups (:class:`ResultsStore`)
``engine``         :func:`run_plan`: existing files, resume, retries, Ctrl-C
``compare``        the ``compare`` plan (cases x controllers) and :func:`run_campaign`
``tables``         ``summary.csv``, ``summary.md``, ``findings.md``
``findings``       the paper's findings, checked with the campaign's own figures
``machine``        the machine description (results files, ``auvdock bench``)
``display``        the progress display of the commands
=================  ======================================================================

The sweep plan (grid, random draws, model error) is :mod:`auvdock.sweep`; its statistics
and figures :mod:`auvdock.sweep.stats`; a compare campaign's figures
:mod:`auvdock.campaign.plots`.  The tables, findings and figures are computed from the
results file alone, so ``auvdock report`` rebuilds them without running anything.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from auvdock.campaign.compare import (
    COMPARE_LABELS,
    TABLE_COLUMNS,
    campaign_specs,
    compare_plan,
    default_missions,
    default_missions_dir,
    run_campaign,
)
from auvdock.campaign.engine import CampaignResult, run_plan
from auvdock.campaign.executor import DaskExecutor, ExecutorError, LocalExecutor
from auvdock.campaign.findings import Finding, check_findings
from auvdock.campaign.machine import machine_info, machine_line
from auvdock.campaign.spec import ID_COLUMNS, OUTCOME_COLUMNS, Plan, RunSpec
from auvdock.campaign.store import FORMAT, FORMAT_VERSION, ResultsFileError, read_results, read_run_groups
from auvdock.campaign.tables import SUMMARY_HEADER, summary_rows, write_tables
from auvdock.campaign.worker import execute_run
from auvdock.config.catalog import PAPER_MISSIONS

__all__ = [
    "PAPER_MISSIONS",
    "FORMAT",
    "FORMAT_VERSION",
    "ID_COLUMNS",
    "OUTCOME_COLUMNS",
    "COMPARE_LABELS",
    "TABLE_COLUMNS",
    "SUMMARY_HEADER",
    "RunSpec",
    "Plan",
    "CampaignResult",
    "Finding",
    "ResultsFileError",
    "ExecutorError",
    "LocalExecutor",
    "DaskExecutor",
    "default_missions",
    "default_missions_dir",
    "campaign_specs",
    "compare_plan",
    "execute_run",
    "run_plan",
    "run_campaign",
    "read_results",
    "read_campaign",
    "read_campaign_runs",
    "summary_rows",
    "write_tables",
    "check_findings",
    "machine_info",
    "machine_line",
]


def read_campaign(path: str | Path) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The table rows (plan order) and attributes of a compare campaign file.

    Raises
    ------
    ValueError
        If the file is not an auvdock campaign file written by ``auvdock compare``.
    """
    return read_results(path, "compare")


def read_campaign_runs(path: str | Path) -> dict[tuple[str, str], Any]:
    """Every run group of a compare campaign file, in memory: (case, controller) -> RunResults."""
    out = {}
    for key, run in read_run_groups(path).items():
        parts = key.split("/")
        if len(parts) == 2:
            out[(parts[0], parts[1])] = run
    return out
