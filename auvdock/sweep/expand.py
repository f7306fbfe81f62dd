"""A sweep's plan: points (grid x random draws) x controllers x seeds x model-error draws.

:func:`expand_sweep` turns a loaded :class:`~auvdock.sweep.schema.Sweep` into campaign run
specs (:class:`auvdock.campaign.RunSpec`, the same type ``compare`` uses): each carries the
point's resolved mission, the run's controller and seed as overrides, the truth-only model
error, and its labels -- point, model-error draw, the varied fields' values and the
model-error factors -- which become columns of the run table.  :func:`sweep_plan` wraps
them in a :class:`~auvdock.campaign.Plan` with the sweep's file attributes.
"""

from __future__ import annotations

import itertools
import json
import math
import zlib
from collections.abc import Sequence
from typing import Any

import numpy as np
from pydantic import ValidationError

from auvdock.campaign.spec import Plan, RunSpec, mission_data
from auvdock.config.mission import Mission
from auvdock.schema.strict import first_error
from auvdock.sweep.schema import DERIVED_FIELDS, Sweep, SweepError

__all__ = ["expand_sweep", "label_columns", "sweep_plan"]

_GYRE_FIELDS = ("flow.amplitude_m_s", "flow.period_h", "flow.epsilon")
_HEAVE_PAIR = {
    "dock.heave.frequency_hz": "dock.heave.angular_frequency_rad_s",
    "dock.heave.angular_frequency_rad_s": "dock.heave.frequency_hz",
}


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
    derived = [k for k in DERIVED_FIELDS if k in values and k.startswith("flow.")]
    if derived and "flow.velocity_ned_m_s" in values:
        raise SweepError(p, _section(sweep, derived[0]), "vary either it or flow.velocity_ned_m_s, not both")
    base_flow = base.build_flow()
    if derived:
        for k in derived:
            v = values[k]
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise SweepError(p, _section(sweep, k), f"must be a finite number (got {v!r})")
        from auvdock.world.flow import ConstantCurrent

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
        from auvdock.world.flow import DoubleGyre

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


def _point_mission(
    sweep: Sweep, base: Mission, values: dict[str, Any], point: int, controller: str
) -> Mission:
    """The mission of one point flown by ``controller`` (its settings checked for that type)."""
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
    if "sensors.suite" in values:
        from auvdock.sensing.suites import suite_updates

        try:
            upd.update(suite_updates(str(values["sensors.suite"])))
        except ValueError as e:
            raise SweepError(p, _section(sweep, "sensors.suite"), str(e)) from None
    data = mission_data(base.with_controller(controller))
    if "dock.distance_m" in values:
        dist = values["dock.distance_m"]
        if isinstance(dist, bool) or not isinstance(dist, int | float) or not dist > 0:
            raise SweepError(
                p, _section(sweep, "dock.distance_m"), f"must be a positive number (got {dist!r})"
            )
        start = np.asarray(data["start"]["state"][0:3], dtype=float)
        dock = np.asarray(data["dock"]["position_ned_m"], dtype=float)
        bearing = dock[0:2] - start[0:2]
        if not np.any(bearing):
            raise SweepError(
                p,
                _section(sweep, "dock.distance_m"),
                "the base mission's dock is above the start: no bearing",
            )
        horizontal = float(dist) ** 2 - float(dock[2] - start[2]) ** 2
        if horizontal <= 0:
            raise SweepError(
                p,
                _section(sweep, "dock.distance_m"),
                f"{dist:g} m is less than the depth between the start and the dock",
            )
        dock[0:2] = start[0:2] + bearing / np.linalg.norm(bearing) * np.sqrt(horizontal)
        data["dock"]["position_ned_m"] = [round(float(v), 9) for v in dock]
    if "dock.depth_m" in values:
        depth = values["dock.depth_m"]
        if isinstance(depth, bool) or not isinstance(depth, int | float) or not depth > 0:
            raise SweepError(p, _section(sweep, "dock.depth_m"), f"must be a positive number (got {depth!r})")
        data["dock"]["position_ned_m"][2] = float(depth)
        data["start"]["state"][2] = float(depth)
    for path, value in upd.items():
        node = data
        keys = path.split(".")
        for k in keys[:-1]:
            node = node.setdefault(k, {})
        node[keys[-1]] = value
    try:
        m = Mission.model_validate(data)
        m._source = base.source
    except ValidationError as e:
        loc, problem = first_error(Mission, e)
        where, note = _blame(sweep, values, [loc], point)
        if loc.startswith("controller."):
            note += f"controller {controller}: "
        raise SweepError(p, where, note + problem) from None
    if any(k.startswith("vehicle.") for k in values):
        from auvdock.vehicle.params import VehicleParamsError

        try:
            m.build_vehicle()
        except VehicleParamsError as e:
            locs = [f"vehicle.{e.field}", f"vehicle.overrides.{e.field}"]
            where, note = _blame(sweep, values, locs, point)
            raise SweepError(p, where, note + e.message) from None
    bad = m.world_problem()
    if bad is not None:
        where, note = _blame(sweep, values, [bad[0]], point)
        raise SweepError(p, where, note + bad[1]) from None
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


def _model_error_draws(sweep: Sweep, m: Mission, point: int, cache: dict[str, Any]):
    """[(factors, truth overrides)] of the point's model-error draws ([({}, {})] without)."""
    if sweep.model_error.n == 0:
        return [({}, {})]
    key = json.dumps(m.vehicle.model_dump(mode="json"), sort_keys=True)
    if key not in cache:
        cache[key] = m.build_vehicle().params.raw
    raw = cache[key]
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
    return draws


def expand_sweep(sweep: Sweep, *, trajectories: bool = False) -> list[RunSpec]:
    """Every run of the sweep, in order: point, controller, seed, model-error draw.

    A run's id is ``p<point>-<controller>-s<seed>-m<draw>`` (``p0003-oracle-s1-m0``; ``m0``
    is the nominal model without model error).  With ``trajectories`` each run keeps its
    trajectory in the run group ``/runs/<run id>``.

    Raises
    ------
    SweepError
        For the first point whose mission does not validate.
    """
    base = sweep.base_mission
    runs: list[RunSpec] = []
    cache: dict[str, Any] = {}
    for point, values in enumerate(_points(sweep)):
        draws = None
        for controller in sweep.controllers:
            m = _point_mission(sweep, base, values, point, controller)
            if draws is None:
                draws = _model_error_draws(sweep, m, point, cache)
            data = mission_data(m)
            for i in range(sweep.seeds):
                seed = int(base.seed) + i
                for d, (factors, overrides) in enumerate(draws):
                    rid = f"p{point:04d}-{controller}-s{seed}-m{d}"
                    labels = {"point": point, "model_error_draw": d, **values}
                    labels.update({f"model_error.{k}": v for k, v in factors.items()})
                    runs.append(
                        RunSpec(
                            run_id=rid,
                            mission=data,
                            controller=controller,
                            seed=seed,
                            overrides={"seed": seed},
                            truth_overrides=dict(overrides),
                            labels=labels,
                            group=f"/runs/{rid}" if trajectories else None,
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


def label_columns(sweep: Sweep, runs: Sequence[RunSpec]) -> dict[str, str]:
    """The sweep's label columns of the run table: point, model-error draw, varied fields, factors."""
    cols = {"point": "int", "model_error_draw": "int"}
    for key in sweep.varied:
        cols[key] = _kind([r.labels.get(key) for r in runs])
    if sweep.model_error.n > 0:
        for param in sweep.model_error.scale:
            cols[f"model_error.{param}"] = "float"
    return cols


def sweep_plan(sweep: Sweep, *, trajectories: bool = False) -> Plan:
    """The sweep as a campaign :class:`~auvdock.campaign.Plan` (kind ``"sweep"``)."""
    runs = expand_sweep(sweep, trajectories=trajectories)
    cols = label_columns(sweep, runs)
    attrs = {
        "sweep_name": str(sweep.name),
        "sweep_file": str(sweep.path or ""),
        "sweep_yaml": sweep.text,
        "base_mission_yaml": sweep.base_mission.to_yaml(),
        "controllers": list(sweep.controllers),
        "varied": list(sweep.varied),
        "grid_fields": list(sweep.grid),
        "model_error_columns": [c for c in cols if c.startswith("model_error.")],
    }
    return Plan("sweep", runs, cols, attrs)
