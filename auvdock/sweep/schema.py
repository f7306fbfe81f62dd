"""The sweep file: its schema, loading, and the checks of the mission fields it varies.

See :mod:`auvdock.sweep` for the file format.  :func:`auvdock.sweep.load.load_sweep` validates a sweep file
like a mission (:mod:`auvdock.schema.strict`: strict keys, one-line errors) and raises
:class:`SweepError` -- ``<file>: <field.path>: <problem>`` -- on any bad input: unknown
keys, unknown mission fields (checked with :func:`auvdock.schema.strict.field_at`, which knows the
controller's settings per ``type``), bad distributions, a base mission that is missing or
invalid, and the first expanded mission that does not validate.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import Field, field_validator, model_validator

from auvdock.config.mission import CONTROLLER_TYPES, Mission, MissionError
from auvdock.controllers.registry import split_controller
from auvdock.schema.strict import Strict, field_at

__all__ = [
    "DERIVED_FIELDS",
    "SweepError",
    "Distribution",
    "RandomSpec",
    "FactorSpec",
    "ModelErrorSpec",
    "ReferenceSpec",
    "Sweep",
    "mission_field_problem",
]

#: Fields a sweep derives mission fields from: a constant current's speed and direction (towards,
#: degrees clockwise from north), the dock's depth (the vehicle starts at the same depth), the
#: dock's distance from the start (along the base mission's bearing, at the dock's depth), and a
#: named sensor suite (:data:`auvdock.sensing.suites.SENSOR_SUITES`: estimation and sensors).
DERIVED_FIELDS = ("flow.speed_m_s", "flow.direction_deg", "dock.depth_m", "dock.distance_m", "sensors.suite")
_FIXED_BY_SWEEP = {"seed": "seeds", "controller.type": "controllers"}


class SweepError(MissionError):
    """A sweep file is missing or wrong.  ``str(err)`` is the one line shown to users:
    ``<file>: <field.path>: <problem>`` (the same shape as :class:`MissionError`)."""


def _pair(v: list[float] | None, what: str) -> list[float] | None:
    if v is not None and len(v) != 2:
        raise ValueError(f"must have 2 values {what}, got {len(v)}")
    return v


class Distribution(Strict):
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


class RandomSpec(Strict):
    """Random draws over mission fields, crossed with the grid."""

    n: Annotated[int, Field(ge=0)] = Field(default=0, description="number of draws")
    fields: dict[str, Distribution] = Field(default_factory=dict, description="dotted field -> distribution")


class FactorSpec(Strict):
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


class ModelErrorSpec(Strict):
    """Truth-model error: vehicle parameters scaled by random factors (controller keeps nominal)."""

    n: Annotated[int, Field(ge=0)] = Field(default=0, description="draws per point (0: none)")
    scale: dict[str, FactorSpec] = Field(default_factory=dict, description="parameter -> factor spec")


class ReferenceSpec(Strict):
    """A success rate measured elsewhere, shown beside the sweep's (e.g. the paper's tank trials)."""

    label: str
    docked: Annotated[int, Field(ge=0)]
    runs: Annotated[int, Field(ge=1)]

    @model_validator(mode="after")
    def _le(self) -> ReferenceSpec:
        if self.docked > self.runs:
            raise ValueError(f"docked ({self.docked}) must not exceed runs ({self.runs})")
        return self


class Sweep(Strict):
    """A validated sweep file (see the module docstring)."""

    name: str | None = Field(default=None, description="sweep name (default: the file's stem)")
    description: str = Field(default="", description="free text")
    base: str = Field(description="base mission file, relative to the sweep file")
    controllers: list[str] = Field(
        default_factory=lambda: list(CONTROLLER_TYPES),
        description="controllers, NAME or NAME@VARIANT (e.g. sequential@paper)",
    )
    seeds: Annotated[int, Field(ge=1)] = Field(default=1, description="seeds per point")
    fixed: dict[str, Any] = Field(
        default_factory=dict,
        description="dotted field -> value set for every run (not varied): the base mission as the sweep "
        "flies it",
    )
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
            split_controller(c)  # ValueError naming an unknown controller or variant
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


def mission_field_problem(path: str) -> str | None:
    """None if ``path`` is a mission field a sweep may vary, else the problem."""
    if path in _FIXED_BY_SWEEP:
        return f"is set by the sweep's {_FIXED_BY_SWEEP[path]!r} and cannot be varied"
    if path in DERIVED_FIELDS:
        return None
    _, problem = field_at(Mission, path)
    if problem is None or not problem.startswith("unknown field"):
        return problem
    section = path.rsplit(".", 1)[0] if "." in path else ""
    derived = [d.split(".")[-1] for d in DERIVED_FIELDS if d.rsplit(".", 1)[0] == section]
    problem = "unknown mission field" + problem[len("unknown field") :]
    if derived and problem.endswith(")"):
        problem = problem[:-1] + f"; derived by the sweep: {', '.join(derived)})"
    return problem


def check_fields(sweep: Sweep) -> None:
    """Every varied field is a mission field a sweep may vary; model-error keys are numeric
    vehicle parameters.  SweepError naming the sweep field otherwise."""
    p = sweep._path or "<sweep>"
    for key in sweep.grid:
        problem = mission_field_problem(key)
        if problem:
            raise SweepError(p, f"grid.{key}", problem)
    for key in sweep.random.fields:
        problem = mission_field_problem(key)
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
        # the hull's box is the dock contact's geometry, not the plant's dynamics: no model error
        scalable = sorted(k for k, v in raw.items() if _numeric(v) and k != "hull_box_m")
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
