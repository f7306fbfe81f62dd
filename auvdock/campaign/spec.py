"""The plan of a campaign: one :class:`RunSpec` per run, the same for ``compare`` and ``sweep``.

A run spec is plain data (it travels to worker processes and to Dask workers): the
resolved mission, the dotted overrides applied to it for this run (controller, seed,
timeout), the truth-only model error, the extra table columns that label the run, and
where its trajectory goes in the results file.  A :class:`Plan` is the list of specs with
the columns of its run table and the attributes stored in the file.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from auvdock.config.mission import Mission, MissionError
from auvdock.schema.strict import first_error

__all__ = [
    "ID_COLUMNS",
    "OUTCOME_COLUMNS",
    "RunSpec",
    "Plan",
    "mission_data",
    "apply_overrides",
    "empty_row",
]

#: Columns every run table starts with: name -> kind ("str", "bool", "int", "float").
ID_COLUMNS: dict[str, str] = {"run_id": "str"}

#: Columns every run table ends with (after the plan's label columns).
OUTCOME_COLUMNS: dict[str, str] = {
    "controller": "str",
    "seed": "int",
    "status": "str",  # "done" or "failed"
    "error": "str",  # "" for a run that ran
    "attempts": "int",  # 1, or 2 when the first worker died
    "docked": "bool",
    "reason": "str",  # docked, captured, collided, timeout, diverged or error
    "time_to_dock_s": "float",
    "end_time_s": "float",
    "timeout_s": "float",
    "tolerance_m": "float",
    "path_length_m": "float",
    "closest_approach_m": "float",
    "contact_speed_m_s": "float",
    "collided": "bool",  # docking.criterion capture: struck the dock's body outside the entry
    "impact_speed_m_s": "float",  # ... at this speed (NaN otherwise)
    "contact_what": "str",  # what it touched: back plate, funnel wall, structure face, buoy ("" if nothing)
    "flow_rmse_m_s": "float",
    "flow_final_error_m_s": "float",
    # estimation: filter: the navigation filter's errors against the truth
    "relative_position_rmse_m": "float",  # the vehicle's position relative to the dock
    "navigation_current_rmse_m_s": "float",  # the horizontal current
    # with a dock camera (the guidance): the camera's losses of the dock and how they ended
    "lost_track_events": "int",
    "lost_track_reacquired": "int",
    "lost_track_longest_s": "float",
    "lost_track_log": "str",
    # with the entry gate (guidance.entry_gate): entries aborted back to the hold point
    "entry_aborts": "int",
    "solve_time_median_s": "float",
    "solve_time_p95_s": "float",
    "solve_time_p99_s": "float",
    "solver_failures": "int",
    "wall_time_s": "float",  # the closed loop only
    "setup_time_s": "float",  # building (and compiling) the controller
    "worker": "str",  # host:pid
    "spec_sha": "str",  # fingerprint of the run spec (resume checks it)
}

_BLANK = {"str": "", "bool": False, "int": 0, "float": float("nan")}


@dataclass(frozen=True)
class RunSpec:
    """One run.

    Attributes
    ----------
    run_id : str
        Unique in the plan (``still/oracle`` in a compare campaign, ``p0003-oracle-s1-m0``
        in a sweep).
    mission : dict
        The resolved mission the run starts from (:func:`mission_data`).
    overrides : dict
        Dotted mission fields set for this run, e.g. ``{"controller.type": "oracle",
        "seed": 3, "docking.timeout_s": 30.0}``; :func:`apply_overrides`.
    controller, seed : str, int
        The run's controller and seed (the same as in the overridden mission).
    truth_overrides : dict
        ``vehicle.overrides`` entries of the TRUTH model only (model error); the
        controller and its estimator keep the nominal model.  ``{}``: truth = nominal.
    labels : dict
        Values of the plan's label columns for this run (``case``, ``point``, ...).
    group : str or None
        The run group (:mod:`auvdock.results.store` layout) that keeps the run's trajectory in
        the results file, e.g. ``/runs/still/oracle``; None: the table row only.
    """

    run_id: str
    mission: dict[str, Any]
    controller: str
    seed: int
    overrides: dict[str, Any] = field(default_factory=dict)
    truth_overrides: dict[str, Any] = field(default_factory=dict)
    labels: dict[str, Any] = field(default_factory=dict)
    group: str | None = None

    @property
    def sha(self) -> str:
        """Fingerprint of what the run computes (mission, overrides, model error)."""
        text = json.dumps(
            [self.mission, self.overrides, self.truth_overrides], sort_keys=True, separators=(",", ":")
        )
        return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass
class Plan:
    """A campaign to run: its kind, its runs in order, and what its results file records.

    Attributes
    ----------
    kind : str
        ``"compare"`` or ``"sweep"`` (stored; ``auvdock report`` picks its report by it).
    specs : list of RunSpec
        The runs, in the order of the tables.
    label_columns : dict
        Columns between ``run_id`` and the outcome columns: name -> kind.
    attrs : dict
        Extra attributes of the results file (str or numbers; JSON text for structures).
    same_on_resume : dict
        Attributes (lists, in ``attrs``) a resumed file must have been made with, as sets:
        attribute name -> the table column that holds the same values in files written
        before the attribute was (``{"controllers": "controller"}``); resuming with other
        values is refused (:func:`auvdock.campaign.store.check_resume`).
    """

    kind: str
    specs: list[RunSpec]
    label_columns: dict[str, str] = field(default_factory=dict)
    attrs: dict[str, Any] = field(default_factory=dict)
    same_on_resume: dict[str, str] = field(default_factory=dict)

    @property
    def columns(self) -> dict[str, str]:
        """The run table's columns: name -> kind."""
        return {**ID_COLUMNS, **self.label_columns, **OUTCOME_COLUMNS}

    def check(self) -> None:
        """ValueError if two runs share an id."""
        seen: set[str] = set()
        for s in self.specs:
            if s.run_id in seen:
                raise ValueError(f"run id {s.run_id!r} is in the plan twice")
            seen.add(s.run_id)


def mission_data(mission: Mission) -> dict[str, Any]:
    """The resolved mission as plain data that runs anywhere (a relative vehicle file made absolute)."""
    data = mission.resolved()
    vf = mission.vehicle.file
    if vf is not None and not Path(vf).is_absolute() and mission.source is not None:
        data["vehicle"]["file"] = str((mission.source.parent / vf).resolve())
    return data


def apply_overrides(
    data: dict[str, Any], overrides: dict[str, Any], source: str | Path = "<mission>"
) -> Mission:
    """The validated mission ``data`` with the dotted ``overrides`` set.

    Raises
    ------
    MissionError
        ``<source>: <field>: <problem>`` if the result does not validate.
    """
    try:
        m = Mission.model_validate(data)
    except ValidationError as e:
        raise MissionError(source, *first_error(Mission, e)) from None
    return m.with_updates(overrides, where=source) if overrides else m


def empty_row(spec: RunSpec, columns: dict[str, str]) -> dict[str, Any]:
    """The table row of a run that has not produced an outcome (status "failed")."""
    row = {name: _BLANK[kind] for name, kind in columns.items()}
    row.update(spec.labels)
    row.update(
        run_id=spec.run_id,
        controller=spec.controller,
        seed=int(spec.seed),
        status="failed",
        reason="error",
        spec_sha=spec.sha,
    )
    docking = spec.mission.get("docking", {})
    row["timeout_s"] = float(spec.overrides.get("docking.timeout_s", docking.get("timeout_s", float("nan"))))
    row["tolerance_m"] = float(
        spec.overrides.get("docking.tolerance_m", docking.get("tolerance_m", float("nan")))
    )
    return row
