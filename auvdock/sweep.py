"""Monte Carlo sweeps: one YAML file expands into many closed-loop runs, run on Dask.

A *sweep file* names a base mission and what to vary around it::

    name: current_speed
    base: ../diagonal.yaml              # base mission, relative to the sweep file
    controllers: [naive, kinematic, oracle, sequential, optimized]
    seeds: 1                            # seeds per point: mission.seed = base seed + i
    grid:                               # full factorial over dotted mission fields
      flow.speed_m_s: [0.0, 0.5, 1.0, 1.5, 2.0, 2.5]
      flow.direction_deg: [0, 45, 90, 135, 180, 225, 270, 315]
    random:                             # n draws (seeded by sweep_seed), crossed with the grid
      n: 0
      fields:
        dock.heave.amplitude_m: {uniform: [0.0, 0.5]}      # [low, high]
        sensors.accel_std_m_s2: {normal: [0.0045, 0.001]}  # [mean, std]
        controller.horizon_steps: {choice: [8, 10, 12]}
    model_error:                        # the truth model only: vehicle parameters x random factors
      n: 0                              # draws per point (0: none)
      scale: {added_mass: 0.1, mass_kg: 0.05}   # relative std, or {uniform: [low, high]}
    timeout_s: 75                       # docking timeout of every run (default: the mission's)
    sweep_seed: 0
    reference:                          # optional: success rates to set beside the sweep's
      - {label: "paper tank trials", docked: 8, runs: 11}

:func:`load_sweep` validates the file like a mission (:mod:`auvdock.mission`) and raises
:class:`SweepError` -- one line naming the sweep file, the field path (e.g.
``grid.flow.speedd_m_s`` or ``random.fields.dock.heave.amplitude_m.uniform``) and the
problem -- on any bad input: unknown keys, unknown mission fields, bad distributions, a
base mission that is missing or invalid, and the FIRST expanded mission that does not
validate.

Points and runs
---------------
The *points* are the grid's full factorial (in file order, the last field fastest), each
crossed with the ``random.n`` draws (draw 0..n-1; without a grid the draws alone; with
neither, the base mission alone).  Every point runs every controller with ``seeds``
seeds and, when ``model_error.n > 0``, ``model_error.n`` truth models.  A run is
(point, controller, seed, model-error draw) with the stable id
``p0003-oracle-s1-m0`` (point 3, seed 1, draw 0; ``m0`` is the nominal model when
``model_error.n`` is 0).

Draws are reproducible and independent of one another: each random field draws its ``n``
values from its own generator seeded by ``(sweep_seed, crc32(field))``, so adding a field
leaves the others' draws unchanged; model-error factors of draw m at point p come from
``(sweep_seed, crc32(parameter), p, m)``, the same for every controller and seed (common
random numbers: controllers are compared on the same truth vehicles).

Derived and coupled fields
--------------------------
* ``flow.speed_m_s`` and ``flow.direction_deg`` (the mission's FlowSpec has only the
  vector ``flow.velocity_ned_m_s``) set a constant current of that speed (m/s, >= 0)
  flowing TOWARDS that direction, degrees clockwise from north (0 north, 90 east):
  ``velocity_ned_m_s = [speed cos(dir), speed sin(dir)]``.  If only one is varied, the
  other comes from the base mission's constant current (paper case 2 is 0.71 m/s towards
  45 deg); a base without a current has no direction, so give both.
* Varying ``flow.velocity_ned_m_s`` (or the derived fields) makes the flow an explicit
  ``type: constant`` (the base's ``case`` is dropped); varying ``flow.amplitude_m_s``,
  ``flow.period_h`` or ``flow.epsilon`` turns a double-gyre case into the explicit
  ``type: double_gyre`` with the case's values; varying ``flow.case`` drops a ``type``.
* ``dock.heave.frequency_hz`` and ``dock.heave.angular_frequency_rad_s`` are two forms of
  one value: varying one clears the other (HeaveSpec accepts both only when they agree).
* ``seed`` and ``controller.type`` are set by ``seeds`` and ``controllers`` and cannot be
  varied; list values are varied whole (``dock.position_ned_m: [[2, 3, 5], [3, 3, 5]]``).

Model error
-----------
With ``model_error.n > 0`` each run's TRUTH mission gets ``vehicle.overrides`` =
nominal value x factor for every parameter in ``scale`` (one factor per parameter: a
vector such as ``added_mass`` is scaled as a whole), while the controller and its
estimator are built from the NOMINAL mission::

    simulate(truth, autopilot=Autopilot(nominal, nominal.build_vehicle(), nominal.build_dock(), c))

``simulate`` integrates the plant with ``truth.build_vehicle()`` and the autopilot
predicts with the nominal model.  A number in ``scale`` is a relative standard deviation:
factor ``1 + s z`` with z standard normal truncated at +-3 (s < 1/3 keeps factors
positive); ``{uniform: [low, high]}`` draws the factor itself (0 < low <= high).

Execution (:func:`run_sweep`)
-----------------------------
One Dask task per run (``dask.distributed``): without ``scheduler`` a
``LocalCluster(n_workers, threads_per_worker=1, processes=True)`` is started and closed;
with ``scheduler="tcp://host:8786"`` the runs go to that cluster (its workers need auvdock
and its dependencies installed; the runs carry their resolved missions, so the workers
need no mission files -- except a vehicle ``file:``, which must exist at the same path).
Tasks return plain dicts; only the driver writes the results file.

* A worker process that dies (killed, out of memory, segfault): Dask reschedules its
  running task on another worker; results it held but the driver had not fetched are
  recomputed.  The local cluster's scheduler is started with
  ``distributed.scheduler.allowed-failures = 2`` (:data:`ALLOWED_FAILURES`): a run is
  attempted at most 3 times, then recorded with a ``KilledWorker`` error.  A remote
  scheduler uses its own configuration (Dask's default is 3).
* A run that raises is recorded with ``docked = False`` and its error text; it is not
  retried.
* The driver writes a run's row only when its result arrives and never writes a run id
  twice; fetched results are released at once, so a later worker death does not recompute
  them.
* Ctrl-C: unfinished runs are cancelled, the cluster is closed and KeyboardInterrupt is
  raised again; the file keeps every row written so far (flushed after each) and
  ``resume=True`` continues.

Results file ``<out>/sweep.h5``
-------------------------------
::

    /                   attrs: format = "auvdock-sweep", format_version, sweep_name,
                               sweep_file, sweep_yaml (the file's text), base_mission_yaml
                               (the resolved base), controllers (JSON), total_runs,
                               command_line (and resumed_with), auvdock_version,
                               dask_version, distributed_version, machine (JSON),
                               scheduler, created_utc, wall_time_s (summed over resumes)
    /runs               compound table, one row per finished run, in completion order
                        (:func:`read_sweep` sorts it); attrs: columns (JSON name -> kind),
                        varied, grid_fields, model_error_columns (JSON lists)
    /trajectories/<run id>/time_s (T,), state (T, 12)     with trajectories=True

The local workers' output (CasADi's warnings of a diverging run, Dask's messages) goes to
``<out>/logs/worker-<pid>.log``, not over the progress bar; the local workers ignore
SIGINT, which only the driver handles.

Columns of ``/runs``: ``run_id``, ``point``, ``controller``, ``seed``,
``model_error_draw``, one column per varied field (named by its dotted path; float, int,
bool or str -- lists as JSON text), one ``model_error.<parameter>`` factor column per
scaled parameter, then ``docked``, ``reason`` (docked, timeout, diverged or error),
``time_to_dock_s``, ``contact_speed_m_s``, ``closest_approach_m``, ``path_length_m``,
``flow_rmse_m_s`` (FSE controllers; NaN otherwise), ``solver_failures``, ``end_time_s``,
``wall_time_s``, ``worker`` (host:pid) and ``error`` ("" for a run that ran).

Test hook
---------
``AUVDOCK_SWEEP_FAULTS`` (tests only, not a user option) injects faults into
:func:`run_one`: JSON ``{"kill": {"<sweep>/<run id>": "<marker file>"}, "raise":
["<sweep>/<run id>"]}``.  ``kill``: the first attempt of that run (the marker file does
not exist yet; it is created atomically) SIGKILLs its own worker process.  ``raise``: that
run raises RuntimeError out of the task.  Worker processes read it from their
environment, so it must be set before the cluster starts.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import itertools
import json
import math
import os
import shlex
import signal
import socket
import sys
import time
import typing
import uuid
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import h5py
import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from . import __version__
from .mission import CONTROLLER_TYPES, Mission, MissionError, load_mission, read_yaml_file
from .results import open_format

__all__ = [
    "SweepError",
    "Sweep",
    "RunSpec",
    "SweepResult",
    "ALLOWED_FAILURES",
    "FAULTS_ENV",
    "load_sweep",
    "expand_sweep",
    "run_columns",
    "build_run",
    "run_one",
    "run_sweep",
    "read_sweep",
    "sweep_main",
]

FORMAT = "auvdock-sweep"
FORMAT_VERSION = 1
#: Worker deaths a run may cause before it is given up (LocalCluster scheduler setting).
ALLOWED_FAILURES = 2
#: Environment variable of the test-only fault hook (see the module docstring).
FAULTS_ENV = "AUVDOCK_SWEEP_FAULTS"

#: Fields the sweep derives (not in the mission schema), mapped onto the flow.
DERIVED_FIELDS = ("flow.speed_m_s", "flow.direction_deg")
_FIXED_BY_SWEEP = {"seed": "seeds", "controller.type": "controllers"}
_GYRE_FIELDS = ("flow.amplitude_m_s", "flow.period_h", "flow.epsilon")
_HEAVE_PAIR = {
    "dock.heave.frequency_hz": "dock.heave.angular_frequency_rad_s",
    "dock.heave.angular_frequency_rad_s": "dock.heave.frequency_hz",
}

# outcome columns of /runs after the varied and model-error columns: name -> kind
_OUTCOME_COLUMNS: dict[str, str] = {
    "docked": "bool",
    "reason": "str",
    "time_to_dock_s": "float",
    "contact_speed_m_s": "float",
    "closest_approach_m": "float",
    "path_length_m": "float",
    "flow_rmse_m_s": "float",
    "solver_failures": "int",
    "end_time_s": "float",
    "wall_time_s": "float",
    "worker": "str",
    "error": "str",
}
_ID_COLUMNS: dict[str, str] = {
    "run_id": "str",
    "point": "int",
    "controller": "str",
    "seed": "int",
    "model_error_draw": "int",
}


class SweepError(MissionError):
    """A sweep file is missing or wrong.  ``str(err)`` is the one line shown to users:
    ``<file>: <field.path>: <problem>`` (the same shape as :class:`MissionError`)."""


# ---------------------------------------------------------------------------------------
# schema


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, validate_default=True)


def _pair(v: list[float] | None, what: str) -> list[float] | None:
    if v is not None and len(v) != 2:
        raise ValueError(f"must have 2 values {what}, got {len(v)}")
    return v


class Distribution(_Strict):
    """One random field: give exactly one of ``uniform``, ``normal``, ``choice``."""

    uniform: list[float] | None = Field(default=None, description="[low, high]")
    normal: list[float] | None = Field(default=None, description="[mean, standard deviation]")
    choice: list[Any] | None = Field(default=None, description="values drawn with equal probability")

    @field_validator("uniform")
    @classmethod
    def _uniform(cls, v: list[float] | None) -> list[float] | None:
        v = _pair(v, "[low, high]")
        if v is not None and v[0] > v[1]:
            raise ValueError(f"low {v[0]:g} is above high {v[1]:g}")
        return v

    @field_validator("normal")
    @classmethod
    def _normal(cls, v: list[float] | None) -> list[float] | None:
        v = _pair(v, "[mean, std]")
        if v is not None and v[1] < 0:
            raise ValueError(f"the standard deviation must be >= 0, got {v[1]:g}")
        return v

    @field_validator("choice")
    @classmethod
    def _choice(cls, v: list[Any] | None) -> list[Any] | None:
        if v is not None and not v:
            raise ValueError("must not be empty")
        return v

    @model_validator(mode="after")
    def _one(self) -> Distribution:
        given = [k for k in ("uniform", "normal", "choice") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("give exactly one of uniform, normal, choice")
        return self

    def draw(self, rng: np.random.Generator, n: int) -> list[Any]:
        """``n`` values (floats; a choice keeps its values' types)."""
        if self.uniform is not None:
            return [float(x) for x in rng.uniform(self.uniform[0], self.uniform[1], size=n)]
        if self.normal is not None:
            return [float(x) for x in rng.normal(self.normal[0], self.normal[1], size=n)]
        choice = list(self.choice or [])
        return [choice[int(i)] for i in rng.integers(0, len(choice), size=n)]


class RandomSpec(_Strict):
    """Random draws over mission fields, crossed with the grid."""

    n: Annotated[int, Field(ge=0)] = Field(default=0, description="number of draws")
    fields: dict[str, Distribution] = Field(default_factory=dict, description="dotted field -> distribution")


class FactorSpec(_Strict):
    """Model-error factor of one vehicle parameter: a relative std (a number) or ``{uniform: [lo, hi]}``."""

    std: float | None = Field(default=None, description="relative standard deviation (truncated at 3 std)")
    uniform: list[float] | None = Field(default=None, description="[low, high] of the factor itself")

    @model_validator(mode="before")
    @classmethod
    def _number(cls, v: Any) -> Any:
        if isinstance(v, bool):
            raise ValueError("must be a relative standard deviation (a number) or {uniform: [low, high]}")
        if isinstance(v, int | float):
            if not math.isfinite(v) or v < 0:
                raise ValueError(f"the relative standard deviation must be >= 0 (got {v!r})")
            if v >= 1 / 3:
                raise ValueError(
                    f"the relative standard deviation must be below 1/3 (got {v!r}): factors are "
                    "truncated at 3 std and must stay positive"
                )
            return {"std": float(v)}
        return v

    @field_validator("uniform")
    @classmethod
    def _uniform(cls, v: list[float] | None) -> list[float] | None:
        v = _pair(v, "[low, high]")
        if v is not None and not 0 < v[0] <= v[1]:
            raise ValueError(f"needs 0 < low <= high, got [{v[0]:g}, {v[1]:g}]")
        return v

    @model_validator(mode="after")
    def _one(self) -> FactorSpec:
        if (self.std is None) == (self.uniform is None):
            raise ValueError("give a relative standard deviation (a number) or {uniform: [low, high]}")
        return self

    def draw(self, rng: np.random.Generator) -> float:
        """One factor."""
        if self.uniform is not None:
            return float(rng.uniform(self.uniform[0], self.uniform[1]))
        while True:
            z = float(rng.standard_normal())
            if abs(z) <= 3.0:
                return 1.0 + float(self.std or 0.0) * z


class ModelErrorSpec(_Strict):
    """Truth-model error: vehicle parameters scaled by random factors (controller keeps nominal)."""

    n: Annotated[int, Field(ge=0)] = Field(default=0, description="draws per point (0: none)")
    scale: dict[str, FactorSpec] = Field(default_factory=dict, description="parameter -> factor spec")


class ReferenceSpec(_Strict):
    """A success rate measured elsewhere, shown beside the sweep's (e.g. the paper's tank trials)."""

    label: str
    docked: Annotated[int, Field(ge=0)]
    runs: Annotated[int, Field(ge=1)]

    @model_validator(mode="after")
    def _le(self) -> ReferenceSpec:
        if self.docked > self.runs:
            raise ValueError(f"docked ({self.docked}) must not exceed runs ({self.runs})")
        return self


class Sweep(_Strict):
    """A validated sweep file (see the module docstring)."""

    name: str | None = Field(default=None, description="sweep name (default: the file's stem)")
    description: str = Field(default="", description="free text")
    base: str = Field(description="base mission file, relative to the sweep file")
    controllers: list[Literal["naive", "kinematic", "oracle", "sequential", "optimized"]] = Field(
        default_factory=lambda: list(CONTROLLER_TYPES)
    )
    seeds: Annotated[int, Field(ge=1)] = Field(default=1, description="seeds per point")
    grid: dict[str, list[Any]] = Field(default_factory=dict, description="dotted field -> values")
    random: RandomSpec = Field(default_factory=RandomSpec)
    model_error: ModelErrorSpec = Field(default_factory=ModelErrorSpec)
    timeout_s: Annotated[float, Field(gt=0)] | None = Field(default=None, description="docking timeout, s")
    sweep_seed: Annotated[int, Field(ge=0)] = Field(default=0, description="seed of the random draws")
    reference: list[ReferenceSpec] = Field(default_factory=list)

    _path: Path | None = None
    _text: str = ""
    _base: Mission | None = None

    @field_validator("controllers")
    @classmethod
    def _controllers(cls, v: list[str]) -> list[str]:
        if not v:
            raise ValueError("must not be empty")
        for c in v:
            if v.count(c) > 1:
                raise ValueError(f"{c} is listed twice")
        return v

    @field_validator("grid")
    @classmethod
    def _grid(cls, v: dict[str, list[Any]]) -> dict[str, list[Any]]:
        for key, values in v.items():
            if not values:
                raise ValueError(f"{key}: must not be empty")
            seen: list[str] = []
            for x in values:
                s = json.dumps(x, sort_keys=True)
                if s in seen:
                    raise ValueError(f"{key}: value {x!r} is listed twice")
                seen.append(s)
        return v

    @property
    def path(self) -> Path | None:
        """The sweep file."""
        return self._path

    @property
    def text(self) -> str:
        """The sweep file's text."""
        return self._text

    @property
    def base_mission(self) -> Mission:
        """The validated base mission."""
        assert self._base is not None, "load the sweep with load_sweep"
        return self._base

    @property
    def varied(self) -> list[str]:
        """The varied fields: grid fields, then random fields (column names of the results)."""
        out = list(self.grid)
        if self.random.n > 0:
            out += [k for k in self.random.fields if k not in out]
        return out

    @property
    def n_points(self) -> int:
        g = math.prod(len(v) for v in self.grid.values()) if self.grid else 1
        return g * max(1, self.random.n)

    @property
    def n_runs(self) -> int:
        return self.n_points * len(self.controllers) * self.seeds * max(1, self.model_error.n)


# ---------------------------------------------------------------------------------------
# errors


def _allowed_keys(model: Any, loc: tuple[Any, ...]) -> list[str]:
    """Keys allowed where the unknown key at ``loc`` is (a mapping's own keys are skipped)."""
    in_mapping = False
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        if in_mapping:  # this part is a key of a dict[str, Model] field
            in_mapping = False
            continue
        fields = getattr(model, "model_fields", None)
        if fields is None or part not in fields:
            return []
        model = _unwrap(fields[part].annotation)
        if typing.get_origin(model) is dict:
            model = _unwrap(typing.get_args(model)[1])
            in_mapping = True
        elif typing.get_origin(model) is list:
            model = _unwrap(typing.get_args(model)[0])
    return list(getattr(model, "model_fields", {}))


def _problem(model: Any, err: dict[str, Any]) -> str:
    kind = err.get("type", "")
    msg = str(err.get("msg", "invalid"))
    if kind == "extra_forbidden":
        allowed = _allowed_keys(model, tuple(err.get("loc", ())))
        return "unknown key" + (f" (allowed: {', '.join(allowed)})" if allowed else "")
    if kind == "finite_number":
        return "must be a finite number (no NaN or inf)"
    if kind == "missing":
        return "is required"
    for prefix in ("Value error, ", "Assertion failed, "):
        if msg.startswith(prefix):
            return msg[len(prefix) :]
    msg = msg[0].lower() + msg[1:] if msg else msg
    if "input" in err and not isinstance(err["input"], dict | list):
        msg += f" (got {err['input']!r})"
    return msg


def _clean_loc(loc: Sequence[Any]) -> tuple[Any, ...]:
    return tuple(
        p
        for p in loc
        if not (isinstance(p, str) and (p.startswith("function-") or p in ("list[float]", "nullable")))
    )


def _loc_str(loc: Sequence[Any]) -> str:
    return ".".join(str(p) for p in loc) if loc else ""


def _unwrap(ann: Any) -> Any:
    """Strip Annotated and Optional from a type annotation."""
    while True:
        origin = typing.get_origin(ann)
        if origin is Annotated:
            ann = typing.get_args(ann)[0]
            continue
        if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
            args = [a for a in typing.get_args(ann) if a is not type(None)]
            if len(args) == 1:
                ann = args[0]
                continue
        return ann


# ---------------------------------------------------------------------------------------
# loading


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file, its base mission and every expanded mission.

    Raises
    ------
    SweepError
        ``<file>: <field.path>: <problem>`` on a missing file, a YAML error, an unknown key,
        an unknown mission field, a bad distribution, a missing or invalid base mission,
        or the first expanded mission that does not validate.
    """
    p = Path(path)
    data, text = read_yaml_file(p, SweepError)
    if not isinstance(data, dict):
        raise SweepError(p, "", "a sweep file must hold a YAML mapping (key: value pairs)")
    try:
        sweep = Sweep.model_validate(data)
    except ValidationError as e:
        err = e.errors()[0]
        loc = _clean_loc(err.get("loc", ()))
        raise SweepError(p, _loc_str(loc) or "(top level)", _problem(Sweep, err)) from None
    sweep._path = p
    sweep._text = text
    if sweep.name is None:
        sweep.name = p.stem
    base = Path(sweep.base)
    if not base.is_absolute():
        base = p.parent / base
    if not base.is_file():
        raise SweepError(p, "base", f"mission file not found: {base}")
    try:
        sweep._base = load_mission(base)
    except MissionError as e:
        raise SweepError(p, "base", str(e)) from None
    _check_fields(sweep)
    expand_sweep(sweep)  # every expanded mission validates, or the first bad one is reported
    return sweep


def _mission_field_problem(path: str) -> str | None:
    """None if ``path`` is a mission field the sweep may vary, else the problem."""
    if path in _FIXED_BY_SWEEP:
        return f"is set by the sweep's {_FIXED_BY_SWEEP[path]!r} and cannot be varied"
    if path in DERIVED_FIELDS:
        return None
    parts = path.split(".")
    model: Any = Mission
    for i, part in enumerate(parts):
        fields = model.model_fields
        if part not in fields:
            where = ".".join(parts[:i]) or "a mission"
            known = ", ".join(fields)
            derived = [d.split(".")[-1] for d in DERIVED_FIELDS if d.rsplit(".", 1)[0] == ".".join(parts[:i])]
            extra = f"; derived by the sweep: {', '.join(derived)}" if derived else ""
            return f"unknown mission field ({where} has: {known}{extra})"
        ann = _unwrap(fields[part].annotation)
        if i == len(parts) - 1:
            return None
        if isinstance(ann, type) and issubclass(ann, BaseModel):
            model = ann
            continue
        if typing.get_origin(ann) is dict:
            return None  # a free-form mapping (vehicle.overrides): checked when the mission is built
        return f"{'.'.join(parts[: i + 1])} is a value, not a section: vary it whole"
    return None


def _check_fields(sweep: Sweep) -> None:
    p = sweep._path or "<sweep>"
    for key in sweep.grid:
        problem = _mission_field_problem(key)
        if problem:
            raise SweepError(p, f"grid.{key}", problem)
    for key in sweep.random.fields:
        problem = _mission_field_problem(key)
        if problem:
            raise SweepError(p, f"random.fields.{key}", problem)
        if key in sweep.grid:
            raise SweepError(p, f"random.fields.{key}", "is also a grid field")
    if sweep.random.n > 0 and not sweep.random.fields:
        raise SweepError(p, "random.fields", "give at least one field when n > 0")
    if sweep.model_error.n > 0:
        if not sweep.model_error.scale:
            raise SweepError(p, "model_error.scale", "give at least one vehicle parameter when n > 0")
        raw = sweep.base_mission.build_vehicle().params.raw
        scalable = sorted(k for k, v in raw.items() if _numeric(v))
        for key in sweep.model_error.scale:
            if key not in scalable:
                raise SweepError(
                    p,
                    f"model_error.scale.{key}",
                    f"is not a numeric vehicle parameter (scalable: {', '.join(scalable)})",
                )


def _numeric(v: Any) -> bool:
    if isinstance(v, bool):
        return False
    if isinstance(v, int | float):
        return True
    return (
        isinstance(v, list)
        and bool(v)
        and all(isinstance(x, int | float) and not isinstance(x, bool) for x in v)
    )


# ---------------------------------------------------------------------------------------
# expansion


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep (plain data: it travels to the Dask workers).

    Attributes
    ----------
    run_id : str
        ``p<point>-<controller>-s<seed>-m<model-error draw>``, e.g. ``p0003-oracle-s1-m0``.
    sweep : str
        The sweep's name.
    point, seed, model_error_draw : int
        Point index, the mission's seed, model-error draw index.
    controller : str
        Controller name.
    values : dict
        The varied fields' values at this point (sweep field -> value).
    factors : dict
        Model-error factor per scaled vehicle parameter ({} without model error).
    mission : dict
        The resolved NOMINAL mission of the run (seed, controller and timeout applied).
    truth_overrides : dict
        ``vehicle.overrides`` entries of the truth mission ({}: truth = nominal).
    trajectories : bool
        Return the run's time and state arrays too.
    """

    run_id: str
    sweep: str
    point: int
    controller: str
    seed: int
    model_error_draw: int
    values: dict[str, Any]
    factors: dict[str, float]
    mission: dict[str, Any]
    truth_overrides: dict[str, Any] = field(default_factory=dict)
    trajectories: bool = False


def _points(sweep: Sweep) -> list[dict[str, Any]]:
    grid = [dict(zip(sweep.grid, combo, strict=True)) for combo in itertools.product(*sweep.grid.values())]
    if sweep.random.n == 0:
        return grid
    draws: dict[str, list[Any]] = {}
    for key, dist in sweep.random.fields.items():
        rng = np.random.default_rng([sweep.sweep_seed, zlib.crc32(key.encode())])
        draws[key] = dist.draw(rng, sweep.random.n)
    return [{**g, **{k: v[d] for k, v in draws.items()}} for g in grid for d in range(sweep.random.n)]


def _section(sweep: Sweep, key: str) -> str:
    return f"grid.{key}" if key in sweep.grid else f"random.fields.{key}"


def _flow_updates(sweep: Sweep, base: Mission, values: dict[str, Any], point: int) -> dict[str, Any]:
    """Mission updates for the flow fields of one point (derived and coupled fields)."""
    p = sweep._path or "<sweep>"
    upd: dict[str, Any] = {}
    derived = [k for k in DERIVED_FIELDS if k in values]
    if derived and "flow.velocity_ned_m_s" in values:
        raise SweepError(p, _section(sweep, derived[0]), "vary either it or flow.velocity_ned_m_s, not both")
    base_flow = base.build_flow()
    if derived:
        for k in derived:
            v = values[k]
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise SweepError(p, _section(sweep, k), f"must be a finite number (got {v!r})")
        from .flow import ConstantCurrent

        speed0 = dir0 = None  # the base's current, if it has one
        if isinstance(base_flow, ConstantCurrent) and math.hypot(base_flow.north_m_s, base_flow.east_m_s) > 0:
            speed0 = math.hypot(base_flow.north_m_s, base_flow.east_m_s)
            dir0 = math.degrees(math.atan2(base_flow.east_m_s, base_flow.north_m_s))
        if "flow.speed_m_s" in values:
            speed = float(values["flow.speed_m_s"])
        elif speed0 is not None:
            speed = speed0
        else:
            raise SweepError(
                p,
                _section(sweep, "flow.direction_deg"),
                f"needs flow.speed_m_s too: the base mission's flow ({base_flow.describe()}) "
                "has no constant current to take the speed from",
            )
        if speed < 0:
            raise SweepError(p, _section(sweep, "flow.speed_m_s"), f"must be >= 0 (got {speed!r})")
        if "flow.direction_deg" in values:
            direction = float(values["flow.direction_deg"])
        elif dir0 is not None:
            direction = dir0
        elif speed == 0:
            direction = 0.0
        else:
            raise SweepError(
                p,
                _section(sweep, "flow.speed_m_s"),
                "needs flow.direction_deg too: the base mission's flow has no direction",
            )
        a = math.radians(direction)
        upd["flow.case"] = None
        upd["flow.type"] = "constant"
        upd["flow.velocity_ned_m_s"] = [
            round(speed * math.cos(a), 12) + 0.0,
            round(speed * math.sin(a), 12) + 0.0,
        ]
    if "flow.velocity_ned_m_s" in values:
        upd["flow.case"] = None
        upd["flow.type"] = "constant"
    if any(k in values for k in _GYRE_FIELDS) and base.flow.case is not None:
        from .flow import DoubleGyre

        if not isinstance(base_flow, DoubleGyre):
            k = next(k for k in _GYRE_FIELDS if k in values)
            raise SweepError(
                p, _section(sweep, k), f"has no effect: the base mission's flow is {base_flow.describe()}"
            )
        upd.update(
            {
                "flow.case": None,
                "flow.type": "double_gyre",
                "flow.amplitude_m_s": base_flow.amplitude,
                "flow.period_h": base_flow.period_s / 3600.0,
                "flow.epsilon": base_flow.epsilon,
            }
        )
    if "flow.case" in values:
        upd["flow.type"] = None
    return upd


def _point_mission(sweep: Sweep, base: Mission, values: dict[str, Any], point: int) -> Mission:
    p = sweep._path or "<sweep>"
    upd: dict[str, Any] = {}
    if sweep.timeout_s is not None:
        upd["docking.timeout_s"] = float(sweep.timeout_s)
    upd.update(_flow_updates(sweep, base, values, point))
    for key, value in values.items():
        if key in DERIVED_FIELDS:
            continue
        if key in _HEAVE_PAIR:
            upd[_HEAVE_PAIR[key]] = None
        upd[key] = value
    data = base.resolved()
    for path, value in upd.items():
        node = data
        keys = path.split(".")
        for k in keys[:-1]:
            node = node.setdefault(k, {})
        node[keys[-1]] = value
    if base.vehicle.file is not None and base.source is not None:
        vf = Path(base.vehicle.file)
        if not vf.is_absolute():
            data["vehicle"]["file"] = str((base.source.parent / vf).resolve())
    try:
        m = Mission.model_validate(data)
        m._source = base.source
    except ValidationError as e:
        err = e.errors()[0]
        loc = _loc_str(_clean_loc(err.get("loc", ())))
        where, note = _blame(sweep, values, [loc], point)
        raise SweepError(p, where, note + _problem(Mission, err)) from None
    if any(k.startswith("vehicle.") for k in values):
        from .vehicle.params import VehicleParamsError

        try:
            m.build_vehicle()
        except VehicleParamsError as e:
            locs = [f"vehicle.{e.field}", f"vehicle.overrides.{e.field}"]
            where, note = _blame(sweep, values, locs, point)
            raise SweepError(p, where, note + e.message) from None
    return m


def _blame(sweep: Sweep, values: dict[str, Any], locs: list[str], point: int) -> tuple[str, str]:
    """(sweep field, note) to blame for an invalid mission field (one of ``locs``) at a point."""
    keys = list(values)
    for loc in locs:
        for k in keys:
            if k == loc or k.startswith(loc + ".") or loc.startswith(k + "."):
                return _section(sweep, k), _draw_note(sweep, k, point)
    loc = locs[0]
    if loc == "flow" or loc.startswith("flow."):
        for k in keys:
            if k.startswith("flow."):
                return _section(sweep, k), _draw_note(sweep, k, point)
    if loc.startswith("docking.timeout_s") and sweep.timeout_s is not None:
        return "timeout_s", ""
    return f"point {point}: {loc}", ""


def _draw_note(sweep: Sweep, key: str, point: int) -> str:
    if key in sweep.grid or sweep.random.n == 0:
        return ""
    return f"draw {point % sweep.random.n}: "


def expand_sweep(sweep: Sweep) -> list[RunSpec]:
    """Every run of the sweep, in order: point, controller, seed, model-error draw.

    Raises
    ------
    SweepError
        For the first point whose mission does not validate.
    """
    base = sweep.base_mission
    name = str(sweep.name)
    runs: list[RunSpec] = []
    nominal_cache: dict[str, Any] = {}
    for point, values in enumerate(_points(sweep)):
        m = _point_mission(sweep, base, values, point)
        draws: list[tuple[dict[str, float], dict[str, Any]]] = [({}, {})]
        if sweep.model_error.n > 0:
            key = json.dumps(m.vehicle.model_dump(mode="json"), sort_keys=True)
            if key not in nominal_cache:
                nominal_cache[key] = m.build_vehicle().params.raw
            raw = nominal_cache[key]
            draws = []
            for d in range(sweep.model_error.n):
                factors: dict[str, float] = {}
                overrides: dict[str, Any] = {}
                for param, spec in sweep.model_error.scale.items():
                    rng = np.random.default_rng([sweep.sweep_seed, zlib.crc32(param.encode()), point, d])
                    f = spec.draw(rng)
                    factors[param] = f
                    nominal = raw[param]
                    overrides[param] = (
                        [float(x) * f for x in nominal] if isinstance(nominal, list) else float(nominal) * f
                    )
                draws.append((factors, overrides))
        resolved = m.resolved()
        for controller in sweep.controllers:
            for i in range(sweep.seeds):
                seed = int(base.seed) + i
                mission = json.loads(json.dumps(resolved))
                mission["seed"] = seed
                mission["controller"]["type"] = controller
                for d, (factors, overrides) in enumerate(draws):
                    runs.append(
                        RunSpec(
                            run_id=f"p{point:04d}-{controller}-s{seed}-m{d}",
                            sweep=name,
                            point=point,
                            controller=controller,
                            seed=seed,
                            model_error_draw=d,
                            values=dict(values),
                            factors=dict(factors),
                            mission=mission,
                            truth_overrides=dict(overrides),
                        )
                    )
    return runs


def _kind(values: list[Any]) -> str:
    if values and all(isinstance(v, bool) for v in values):
        return "bool"
    if values and all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return "int"
    if values and all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        return "float"
    return "str"


def run_columns(sweep: Sweep, runs: Sequence[RunSpec]) -> dict[str, str]:
    """The columns of the sweep's ``/runs`` table: name -> kind (str, bool, int, float)."""
    cols = dict(_ID_COLUMNS)
    for key in sweep.varied:
        cols[key] = _kind([r.values.get(key) for r in runs])
    if sweep.model_error.n > 0:
        for param in sweep.model_error.scale:
            cols[f"model_error.{param}"] = "float"
    cols.update(_OUTCOME_COLUMNS)
    return cols


# ---------------------------------------------------------------------------------------
# one run (on a worker)


def build_run(spec: RunSpec) -> tuple[Mission, Mission]:
    """The run's (nominal, truth) missions; truth is nominal when there is no model error."""
    nominal = Mission.model_validate(spec.mission)
    if not spec.truth_overrides:
        return nominal, nominal
    truth = nominal.with_updates(**{f"vehicle.overrides.{k}": v for k, v in spec.truth_overrides.items()})
    return nominal, truth


def _faults(spec: RunSpec) -> None:
    """The test-only fault hook (``AUVDOCK_SWEEP_FAULTS``; see the module docstring)."""
    raw = os.environ.get(FAULTS_ENV)
    if not raw:
        return
    cfg = json.loads(raw)
    target = f"{spec.sweep}/{spec.run_id}"
    marker = (cfg.get("kill") or {}).get(target)
    if marker:
        try:
            fd = os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            pass
        else:
            os.close(fd)
            if hasattr(signal, "SIGKILL"):
                os.kill(os.getpid(), signal.SIGKILL)
            os._exit(137)
    if target in (cfg.get("raise") or []):
        raise RuntimeError(f"injected failure in run {spec.run_id} ({FAULTS_ENV})")


def _empty_row(spec: RunSpec) -> dict[str, Any]:
    row: dict[str, Any] = {
        "run_id": spec.run_id,
        "point": spec.point,
        "controller": spec.controller,
        "seed": spec.seed,
        "model_error_draw": spec.model_error_draw,
    }
    row.update(spec.values)
    row.update({f"model_error.{k}": v for k, v in spec.factors.items()})
    for name, kind in _OUTCOME_COLUMNS.items():
        row[name] = {"str": "", "bool": False, "int": 0, "float": math.nan}[kind]
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return row


def run_one(spec: RunSpec) -> dict[str, Any]:
    """Run one sweep run (in a Dask worker or anywhere) and return plain data.

    Returns ``{"run_id": ..., "row": {column: value}, "trajectory": None or {"time_s":
    (T,), "state": (T, 12)}}``.  An exception in the run becomes ``row["error"]`` (and
    ``docked = False``, ``reason = "error"``); it is not raised.
    """
    from .autopilot import Autopilot
    from .simulation import simulate

    _faults(spec)
    row = _empty_row(spec)
    traj: dict[str, np.ndarray] | None = None
    t0 = time.perf_counter()
    try:
        nominal, truth = build_run(spec)
        autopilot = None
        if truth is not nominal:
            autopilot = Autopilot(nominal, nominal.build_vehicle(), nominal.build_dock(), spec.controller)
        if spec.trajectories:
            with h5py.File(
                f"{spec.run_id}-{uuid.uuid4().hex}.h5", "w", driver="core", backing_store=False
            ) as f:
                s = simulate(truth, controller=spec.controller, autopilot=autopilot, out=f, group="/run")
                traj = {"time_s": f["run/time_s"][()], "state": f["run/state"][()]}
        else:
            s = simulate(truth, controller=spec.controller, autopilot=autopilot)
        o = s.outcome
        for name in _OUTCOME_COLUMNS:
            if name in o and name not in ("worker", "error"):
                row[name] = o[name]
        row["docked"] = bool(o.get("docked", False))
    except Exception as e:  # noqa: BLE001 -- recorded in the row, never stops the sweep
        row["error"] = f"{type(e).__name__}: {e}"
        row["reason"] = "error"
        row["docked"] = False
        traj = None
    row["wall_time_s"] = time.perf_counter() - t0
    return {"run_id": spec.run_id, "row": row, "trajectory": traj}


# ---------------------------------------------------------------------------------------
# the results file


def _dtype(columns: dict[str, str]) -> np.dtype:
    kinds = {"str": h5py.string_dtype(), "bool": np.bool_, "int": np.int64, "float": np.float64}
    return np.dtype([(name, kinds[kind]) for name, kind in columns.items()])


def _cell(kind: str, v: Any) -> Any:
    if kind == "str":
        if v is None:
            return ""
        return v if isinstance(v, str) else json.dumps(v)
    if kind == "bool":
        return bool(v)
    if kind == "int":
        try:
            return int(v)
        except (TypeError, ValueError, OverflowError):
            return 0
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def _decode(kind: str, v: Any) -> Any:
    if kind == "str":
        return v.decode() if isinstance(v, bytes) else str(v)
    if kind == "bool":
        return bool(v)
    if kind == "int":
        return int(v)
    return float(v)


class _ResultsFile:
    """The driver's handle on ``sweep.h5``: append rows (flushed), never one run id twice."""

    def __init__(self, path: Path, sweep: Sweep, columns: dict[str, str], resume: bool, info: dict[str, Any]):
        self.path = path
        self.columns = columns
        self.dtype = _dtype(columns)
        if path.exists():
            try:
                f = h5py.File(path, "r+")
            except OSError as e:
                raise SweepError(path, "", f"not an HDF5 file ({e}); not overwriting it") from None
            if f.attrs.get("format") != FORMAT:
                f.close()
                raise SweepError(path, "", "exists and is not an auvdock sweep file; not overwriting it")
            if not resume:
                f.close()
                path.unlink()
            else:
                self.f = f
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            self.f = h5py.File(path, "w")
            a = self.f.attrs
            a["format"] = FORMAT
            a["format_version"] = np.int64(FORMAT_VERSION)
            a["created_utc"] = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
            a["wall_time_s"] = 0.0
            ds = self.f.create_dataset("runs", shape=(0,), maxshape=(None,), dtype=self.dtype, chunks=(256,))
            ds.attrs["columns"] = json.dumps(columns)
            ds.attrs["varied"] = json.dumps(sweep.varied)
            ds.attrs["grid_fields"] = json.dumps(list(sweep.grid))
            ds.attrs["model_error_columns"] = json.dumps([c for c in columns if c.startswith("model_error.")])
            ds.attrs["units"] = "s, m, m/s as in the column names; NaN where not applicable"
        self.runs = self.f["runs"]
        old = json.loads(self.runs.attrs.get("columns", "{}"))
        if old != columns:
            self.f.close()
            raise SweepError(
                path,
                "",
                "was written by a different sweep (its columns differ): use another --out or run "
                "without --resume",
            )
        a = self.f.attrs
        a["sweep_name"] = str(sweep.name)
        a["sweep_file"] = str(sweep.path or "")
        a["sweep_yaml"] = sweep.text
        a["base_mission_yaml"] = sweep.base_mission.to_yaml()
        a["controllers"] = json.dumps(list(sweep.controllers))
        a["total_runs"] = np.int64(sweep.n_runs)
        a["auvdock_version"] = str(__version__)
        for k, v in info.items():
            a[k] = v
        self.f.flush()
        self.ids: dict[str, int] = {}
        if len(self.runs):
            for i, rid in enumerate(self.runs["run_id"][()]):
                self.ids[_decode("str", rid)] = i

    def row(self, run_id: str) -> dict[str, Any]:
        rec = self.runs[self.ids[run_id]]
        return {name: _decode(kind, rec[name]) for name, kind in self.columns.items()}

    def append(self, row: dict[str, Any], trajectory: dict[str, np.ndarray] | None) -> bool:
        """Write one run (trajectory first, then its row), flush; False if the id is already there."""
        rid = str(row["run_id"])
        if rid in self.ids:
            return False
        if trajectory is not None:
            gp = f"trajectories/{rid}"
            if gp in self.f:
                del self.f[gp]
            g = self.f.require_group(gp)
            for name, arr in trajectory.items():
                g.create_dataset(name, data=np.asarray(arr, dtype=np.float64))
        arr = np.zeros(1, dtype=self.dtype)
        for name, kind in self.columns.items():
            arr[name][0] = _cell(kind, row.get(name))
        n = self.runs.shape[0]
        self.runs.resize((n + 1,))
        self.runs[n : n + 1] = arr
        self.ids[rid] = n
        self.f.flush()
        return True

    def close(self, wall_s: float) -> None:
        if not self.f.id.valid:
            return
        try:
            self.f.attrs["wall_time_s"] = float(self.f.attrs.get("wall_time_s", 0.0)) + float(wall_s)
            self.f.flush()
        finally:
            self.f.close()


def _check_resume(file: _ResultsFile, runs: Sequence[RunSpec], sweep: Sweep) -> None:
    """Rows already in the file must be the runs the sweep now expands to (same values)."""
    for spec in runs:
        if spec.run_id not in file.ids:
            continue
        old = file.row(spec.run_id)
        want = _empty_row(spec)
        for name in [*_ID_COLUMNS, *sweep.varied, *(c for c in file.columns if c.startswith("model_error."))]:
            kind = file.columns[name]
            a, b = old[name], _cell(kind, want.get(name))
            same = math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-15) if kind == "float" else a == b
            if not same:
                raise SweepError(
                    file.path,
                    "",
                    f"run {spec.run_id} was made with {name} = {a!r}, the sweep file now gives {b!r}: "
                    "use another --out or run without --resume",
                )


def read_sweep(path: str | Path) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """The ``/runs`` rows (sorted by point, controller, seed, model-error draw) and the file's
    attributes (plus ``columns``, ``varied``, ``grid_fields``, ``model_error_columns`` of the table).

    Raises
    ------
    ValueError
        If the file is not an auvdock sweep file.
    """
    f, attrs = open_format(path, FORMAT, "sweep file (written by auvdock sweep)")
    with f:
        ds = f["runs"]
        columns = json.loads(ds.attrs["columns"])
        attrs["columns"] = columns
        attrs["varied"] = json.loads(ds.attrs.get("varied", "[]"))
        attrs["grid_fields"] = json.loads(ds.attrs.get("grid_fields", "[]"))
        attrs["model_error_columns"] = json.loads(ds.attrs.get("model_error_columns", "[]"))
        arr = ds[()]
    rows = [{name: _decode(kind, rec[name]) for name, kind in columns.items()} for rec in arr]
    order = {c: i for i, c in enumerate(json.loads(attrs.get("controllers", "[]")))}
    rows.sort(
        key=lambda r: (
            r["point"],
            order.get(r["controller"], 99),
            r["controller"],
            r["seed"],
            r["model_error_draw"],
        )
    )
    return rows, attrs


# ---------------------------------------------------------------------------------------
# the driver


@dataclass
class SweepResult:
    """What :func:`run_sweep` did."""

    path: Path
    out_dir: Path
    total: int
    ran: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    errors: dict[str, str] = field(default_factory=dict)
    wall_time_s: float = 0.0
    scheduler: str = ""


ProgressFn = Callable[[int, int, int, "float | None"], None]


def _error_result(spec: RunSpec, exc: BaseException | None) -> dict[str, Any]:
    row = _empty_row(spec)
    row["worker"] = ""
    row["reason"] = "error"
    name = type(exc).__name__ if exc is not None else "Error"
    text = str(exc) if exc is not None else "the task failed"
    if name == "KilledWorker":
        text = f"the worker process died every time it ran this run, given up ({text})"
    row["error"] = f"{name}: {text}"
    return {"run_id": spec.run_id, "row": row, "trajectory": None}


def run_sweep(
    sweep_path: str | Path,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    trajectories: bool = False,
    progress: ProgressFn | None = None,
    command_line: str | None = None,
) -> SweepResult:
    """Run every run of a sweep on Dask and keep the results in ``out_dir/sweep.h5``.

    Parameters
    ----------
    sweep_path : str or Path
        The sweep file (validated first: :class:`SweepError`).
    out_dir : str or Path
        Output directory (created).  Without ``resume`` an existing sweep file there is
        replaced; a file that is not a sweep file is never overwritten (SweepError).
    workers : int, optional
        Local worker processes (default: all cores, at most the number of runs to do).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``) instead of a local cluster.
    resume : bool
        Skip the runs whose id is already in the table (a finished sweep runs nothing).
    trajectories : bool
        Also store each run's ``time_s`` and ``state`` under ``/trajectories/<run id>``.
    progress : callable, optional
        ``progress(done, total, failures, eta_s)`` after every stored run (and once at the
        start); ``done`` counts the runs in the table, ``eta_s`` is None until a run ends.
    command_line : str, optional
        Stored in the file (default: this process's ``sys.argv``).

    Returns
    -------
    SweepResult
    """
    t0 = time.perf_counter()
    sweep = load_sweep(sweep_path)
    runs = expand_sweep(sweep)
    if trajectories:
        runs = [dataclasses.replace(r, trajectories=True) for r in runs]
    columns = run_columns(sweep, runs)
    out = Path(out_dir)
    path = out / "sweep.h5"
    import dask
    import distributed

    from .campaign import _machine

    cmd = command_line if command_line is not None else shlex.join(sys.argv)
    info: dict[str, Any] = {
        "dask_version": dask.__version__,
        "distributed_version": distributed.__version__,
        "machine": json.dumps(_machine()),
    }
    file = _ResultsFile(path, sweep, columns, resume, info)
    if resume and "command_line" in file.f.attrs:
        file.f.attrs["resumed_with"] = cmd
    else:
        file.f.attrs["command_line"] = cmd
    result = SweepResult(path=path, out_dir=out, total=len(runs))
    try:
        _check_resume(file, runs, sweep)
        todo = [r for r in runs if r.run_id not in file.ids]
        result.skipped = [r.run_id for r in runs if r.run_id in file.ids]
        for rid in result.skipped:
            err = file.row(rid)["error"]
            if err:
                result.errors[rid] = err
        failures = len(result.errors)
        finished = 0

        def report(eta: float | None) -> None:
            if progress is not None:
                progress(len(result.skipped) + finished, len(runs), failures, eta)

        report(None)
        if not todo:
            result.scheduler = "none (nothing to run)"
            return result
        pending: dict[str, Any] = {}
        client, cluster, desc = _connect(scheduler, workers, len(todo), (out / "logs").resolve())
        result.scheduler = desc
        file.f.attrs["scheduler"] = desc
        try:
            token = uuid.uuid4().hex[:8]
            by_key: dict[str, RunSpec] = {}
            for spec in todo:
                key = f"auvdock-sweep-{spec.run_id}-{token}"
                by_key[key] = spec
                pending[key] = client.submit(run_one, spec, key=key, pure=False)
            started = time.perf_counter()
            for fut in distributed.as_completed(list(pending.values())):
                spec = by_key[fut.key]
                if fut.status == "finished":
                    try:
                        res = fut.result()
                    except Exception as e:  # noqa: BLE001 -- lost between finishing and fetching
                        res = _error_result(spec, e)
                elif fut.status == "error":
                    res = _error_result(spec, fut.exception())
                else:  # cancelled (only on shutdown)
                    pending.pop(fut.key, None)
                    continue
                pending.pop(fut.key, None)
                fut.release()
                if file.append(res["row"], res.get("trajectory")):
                    finished += 1
                    result.ran.append(spec.run_id)
                    if res["row"].get("error"):
                        result.errors[spec.run_id] = res["row"]["error"]
                        failures += 1
                elapsed = time.perf_counter() - started
                left = len(todo) - finished
                report(elapsed / finished * left if finished else None)
        except BaseException:
            client.cancel(list(pending.values()), force=True)
            raise
        finally:
            _close(client, cluster)
    finally:
        wall = time.perf_counter() - t0
        result.wall_time_s = wall
        file.close(wall)
    return result


def _connect(scheduler: str | None, workers: int | None, n_todo: int, log_dir: Path):
    import logging

    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as e:
            raise SweepError(
                "--scheduler", "", f"cannot connect to the Dask scheduler {scheduler}: {e}"
            ) from None
        n = len(client.scheduler_info().get("workers", {}))
        return client, None, f"{scheduler} ({n} workers)"
    n = max(1, min(int(workers or os.cpu_count() or 1), n_todo))
    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES}):
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",  # a free port (the HTTP server runs even without a dashboard)
            silence_logs=logging.CRITICAL,
        )
    client = Client(cluster)
    client.register_plugin(_worker_setup_plugin(log_dir))
    return client, cluster, f"LocalCluster ({n} worker processes)"


def _worker_setup_plugin(log_dir: Path):
    """A plugin for the local worker processes: ignore SIGINT, write output to a log file.

    Ctrl-C in a terminal interrupts the whole process group, the local workers too; the
    driver alone handles it (cancels the runs and closes the cluster, which stops them).
    The workers' stdout and stderr (CasADi's warnings of a diverging run, Dask's messages)
    go to ``<log_dir>/worker-<pid>.log`` instead of over the progress bar.
    """
    from distributed.diagnostics.plugin import WorkerPlugin

    class LocalWorkerSetup(WorkerPlugin):
        name = "auvdock-local-worker"

        def __init__(self, log_dir: str) -> None:
            self.log_dir = log_dir

        def setup(self, worker) -> None:
            import threading

            if threading.current_thread() is threading.main_thread():
                signal.signal(signal.SIGINT, signal.SIG_IGN)
            try:
                Path(self.log_dir).mkdir(parents=True, exist_ok=True)
                fd = os.open(
                    os.path.join(self.log_dir, f"worker-{os.getpid()}.log"),
                    os.O_WRONLY | os.O_CREAT | os.O_APPEND,
                )
            except OSError:
                return  # no log file: output stays where it was
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(fd, 1)
            os.dup2(fd, 2)
            os.close(fd)

    return LocalWorkerSetup(str(log_dir))


def _close(client, cluster) -> None:
    try:
        client.close()
    finally:
        if cluster is not None:
            cluster.close()


# ---------------------------------------------------------------------------------------
# the command


def sweep_main(
    sweep: Path,
    out: Path | None,
    workers: int | None,
    scheduler: str | None,
    resume: bool,
    trajectories: bool,
    console,
) -> int:
    """``auvdock sweep``: run a sweep with a progress bar, then print and write its summary.

    Returns the exit code: 0 every run ran, 1 some runs errored (their error is in the
    table), 130 interrupted (Ctrl-C; the finished runs stay in the file, ``--resume``
    continues).  A bad sweep file (or results file, or scheduler address) raises
    :class:`SweepError` for the command line to print (exit 2).

    ``out`` defaults to ``runs/sweeps/<sweep name>``; the figures and ``summary.md`` go
    beside ``sweep.h5``.
    """
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    from .sweep_stats import report_sweep, success_table

    s = load_sweep(sweep)
    out_dir = out if out is not None else Path("runs") / "sweeps" / str(s.name)
    words = ["auvdock", "sweep", str(sweep), "--out", str(out_dir)]
    if workers:
        words += ["--workers", str(workers)]
    if scheduler:
        words += ["--scheduler", scheduler]
    words += [w for w, on in (("--resume", resume), ("--trajectories", trajectories)) if on]
    cmd = shlex.join(words)

    def n_of(k: int, what: str) -> str:
        return f"{k} {what}" + ("" if k == 1 else "s")

    parts = [n_of(s.n_points, "point"), n_of(len(s.controllers), "controller"), n_of(s.seeds, "seed")]
    if s.model_error.n:
        parts.append(n_of(s.model_error.n, "model-error draw"))
    console.print(
        f"[bold]sweep[/bold] {s.name}: {' x '.join(parts)} = {n_of(s.n_runs, 'run')} "
        f"-> {out_dir / 'sweep.h5'}",
        highlight=False,
    )

    def fmt_eta(eta: float | None) -> str:
        if eta is None:
            return "ETA -"
        m, sec = divmod(int(round(eta)), 60)
        h, m = divmod(m, 60)
        return f"ETA {h}:{m:02d}:{sec:02d}"

    with Progress(
        SpinnerColumn(),
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[info]}"),
        TimeElapsedColumn(),
        console=console,
    ) as bar:
        task = bar.add_task("runs", total=s.n_runs, info="")

        def on_progress(done: int, total: int, failures: int, eta: float | None) -> None:
            info = f"{fmt_eta(eta)}" + (f"  [red]{failures} errored[/red]" if failures else "")
            bar.update(task, completed=done, total=total, info=info)

        try:
            res = run_sweep(
                sweep,
                out_dir,
                workers=workers,
                scheduler=scheduler,
                resume=resume,
                trajectories=trajectories,
                progress=on_progress,
                command_line=cmd,
            )
        except KeyboardInterrupt:
            bar.stop()
            console.print(
                f"interrupted: the finished runs are in {out_dir / 'sweep.h5'}; continue with --resume",
                highlight=False,
            )
            return 130

    if res.skipped:
        console.print(f"resumed: {len(res.skipped)} runs already in the file, {len(res.ran)} run now")
    console.print(f"ran {len(res.ran)} runs in {res.wall_time_s:.1f} s on {res.scheduler}", highlight=False)
    rows, _ = read_sweep(res.path)
    from rich.table import Table

    header, table_rows = success_table(rows)
    t = Table(title=f"sweep {s.name}: success per controller (Wilson 95 % intervals)")
    for h in header:
        t.add_column(h, justify="left" if h == "controller" else "right")
    for r in table_rows:
        t.add_row(*r)
    console.print(t)
    written = report_sweep(res.path, out_dir)
    md = [p for p in written if p.suffix == ".md"]
    console.print(f"results: {res.path}", highlight=False)
    if md:
        console.print(f"summary: {md[0]}", highlight=False)
    console.print(
        f"figures: {sum(p.suffix == '.png' for p in written)} PNG files in {out_dir}", highlight=False
    )
    logs = out_dir / "logs"
    if logs.is_dir() and any(p.stat().st_size > 0 for p in logs.glob("worker-*.log")):
        console.print(f"worker output (solver warnings): {logs}", highlight=False)
    if res.errors:
        for rid, err in list(res.errors.items())[:5]:
            console.print(f"  [red]error[/red] {rid}: {err}", highlight=False)
        if len(res.errors) > 5:
            console.print(f"  ... and {len(res.errors) - 5} more (column 'error' of /runs)")
        return 1
    return 0
