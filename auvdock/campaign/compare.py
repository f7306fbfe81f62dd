"""The ``compare`` plan: every (mission, controller) pair, one run each.

A run's id is ``<case>/<controller>`` (the case is the mission's name) and its trajectory
is kept in the run group ``/runs/<case>/<controller>`` of ``campaign.h5``; its table row
is labelled with the case, a readable case label (``case 2 (diagonal): constant ...``) and
the paper's case number (1-6, 0 for other flows).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from auvdock.campaign.engine import CampaignResult, EventFn, run_plan
from auvdock.campaign.executor import Runner
from auvdock.campaign.spec import ID_COLUMNS, OUTCOME_COLUMNS, Plan, RunSpec, apply_overrides, mission_data
from auvdock.campaign.worker import execute_run
from auvdock.config.catalog import PAPER_MISSIONS, missions_dir, resolve

__all__ = [
    "PAPER_MISSIONS",
    "COMPARE_LABELS",
    "TABLE_COLUMNS",
    "default_missions",
    "default_missions_dir",
    "campaign_specs",
    "compare_plan",
    "run_campaign",
]

#: The label columns of a compare campaign's table.
COMPARE_LABELS: dict[str, str] = {"case": "str", "case_label": "str", "paper_case": "int"}
#: Columns of a compare campaign's table (and of ``summary.csv``): name -> kind.
TABLE_COLUMNS: dict[str, str] = {**ID_COLUMNS, **COMPARE_LABELS, **OUTCOME_COLUMNS}


def default_missions_dir() -> Path:
    """The shipped missions folder (installed with the package; :mod:`auvdock.config.catalog`)."""
    return missions_dir()


def default_missions() -> list[Path]:
    """The paper's six cases, as shipped mission files, in case order."""
    return [missions_dir() / f"{m}.yaml" for m in PAPER_MISSIONS]


def _case_info(mission) -> tuple[str, int]:
    from auvdock.world.flow import FLOW_CASE_ALIASES, FLOW_CASES

    desc = mission.build_flow().describe()
    w = mission.sea.waves
    if w is not None or mission.docking.criterion == "capture":
        # in a sea, or docking on contact: not the paper's study, whatever its current
        if w is None:
            sea = "no waves"
        elif w.type == "regular":
            sea = f"regular waves H {w.height_m:g} m, T {w.period_s:.2f} s"
        elif w.type == "jonswap":
            sea = f"JONSWAP Hs {w.hs_m:g} m, Tp {w.tp_s:g} s"
        else:
            sea = f"waves from {w.file}"
        return f"{mission.name}: {desc}; {sea}", 0
    case = mission.flow.case
    if case is not None:
        key = FLOW_CASE_ALIASES.get(case, case)
        if key in FLOW_CASES and key.startswith("case"):
            n = int(key[4:])
            return f"case {n} ({mission.name}): {desc}", n
    return f"{mission.name}: {desc}", 0


def campaign_specs(
    missions: Sequence[str | Path],
    controllers: Sequence[str],
    *,
    seed: int | None = None,
    timeout_s: float | None = None,
    estimation: str | None = None,
) -> list[RunSpec]:
    """Every (mission, controller) pair, missions in the given order.

    ``missions`` are files or shipped mission names (``gyre``); ``seed``, ``timeout_s`` and
    ``estimation`` (``truth`` or ``filter``: one choice for every controller) override every
    mission's.

    Raises
    ------
    auvdock.config.mission.MissionError
        If a mission file is invalid, or invalid with the overrides (checked here, before
        anything runs).
    ValueError
        If two missions have the same name.
    """
    from auvdock.config.mission import load_mission

    specs: list[RunSpec] = []
    seen: dict[str, str] = {}
    for given in missions:
        path = resolve(given)
        m = load_mission(path)
        if m.name in seen:
            raise ValueError(f"{given}: mission name {m.name!r} is also the name of {seen[m.name]}")
        seen[m.name] = str(given)
        data = mission_data(m)
        label, paper_case = _case_info(m)
        for c in controllers:
            overrides: dict[str, Any] = {"controller.type": c}
            if seed is not None:
                overrides["seed"] = int(seed)
            if timeout_s is not None:
                overrides["docking.timeout_s"] = float(timeout_s)
            if estimation is not None:
                overrides["estimation"] = str(estimation)
            run = apply_overrides(data, overrides, path)  # fails here, not in a worker
            specs.append(
                RunSpec(
                    run_id=f"{m.name}/{c}",
                    mission=data,
                    controller=c,
                    seed=int(run.seed),
                    overrides=overrides,
                    labels={"case": m.name, "case_label": label, "paper_case": paper_case},
                    group=f"/runs/{m.name}/{c}",
                )
            )
    return specs


def compare_plan(specs: Sequence[RunSpec]) -> Plan:
    """The plan of a compare campaign made of ``specs`` (:func:`campaign_specs`).

    Its file records the missions (case names) and controllers it was made with; ``--resume``
    with another set of either is refused (:func:`auvdock.campaign.store.check_resume`).
    """
    specs = list(specs)
    attrs = {
        "missions": list(dict.fromkeys(str(s.labels.get("case", "")) for s in specs)),
        "controllers": list(dict.fromkeys(s.controller for s in specs)),
    }
    return Plan(
        "compare",
        specs,
        dict(COMPARE_LABELS),
        attrs=attrs,
        same_on_resume={"missions": "case", "controllers": "controller"},
    )


def run_campaign(
    specs: Sequence[RunSpec] | Plan,
    path: str | Path,
    *,
    jobs: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    force: bool = False,
    command_line: str = "",
    on_event: EventFn | None = None,
    runner: Runner = execute_run,
) -> CampaignResult:
    """Run a compare campaign into ``path`` (``campaign.h5``); :func:`auvdock.campaign.engine.run_plan`.

    ``jobs`` local worker processes (default: all cores), or the Dask cluster at
    ``scheduler``.  An existing file raises :class:`auvdock.campaign.store.ResultsFileError`
    unless ``resume`` (skip what is done) or ``force`` (start again).
    """
    plan = specs if isinstance(specs, Plan) else compare_plan(specs)
    return run_plan(
        plan,
        path,
        workers=jobs,
        scheduler=scheduler,
        resume=resume,
        force=force,
        command_line=command_line,
        on_event=on_event,
        runner=runner,
    )
