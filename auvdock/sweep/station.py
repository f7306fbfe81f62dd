"""A sweep's sea states beside what holding station in each takes (:mod:`auvdock.world.station_keeping`).

For a sweep whose base mission has waves, :func:`station_keeping_report` groups the runs by sea state --
the values of the varied ``sea.*`` fields, the dock's depth (``dock.depth_m``, else the base mission's)
and the current (``flow.speed_m_s`` and ``flow.direction_deg``, else the base mission's at the dock) --
and gives, per sea state, the thrusters' utilisation that holding station there takes (99th percentile
and maximum over ten minutes of the sea, :func:`~auvdock.world.station_keeping.station_keeping`), whether
a fifth of the thrust is left over, and each controller's captures there: where a controller fails in a
sea the vehicle can hold station in, the thrust is not what failed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import yaml

from auvdock.config.mission import Mission, parse_mission
from auvdock.sweep.rates import success_rate
from auvdock.world.station_keeping import DEFAULT_MARGIN, station_keeping

__all__ = ["station_keeping_report", "SEA_FIELDS"]

#: The varied fields that make a sea state (beside ``sea.*``).
SEA_FIELDS = ("dock.depth_m", "flow.speed_m_s", "flow.direction_deg")


def _key_fields(varied: Sequence[str]) -> list[str]:
    return [f for f in varied if f.startswith("sea.") or f in SEA_FIELDS]


def _sea_state(
    base: Mission, row: dict[str, Any], fields: Sequence[str]
) -> tuple[Mission, float, tuple[float, float]]:
    """The mission whose sea a row flew, the dock's depth (m) and the current at the dock (north, east,
    m/s)."""
    sea = {f: row[f] for f in fields if f.startswith("sea.")}
    m = base.with_updates(sea, where="sweep") if sea else base
    depth = float(row["dock.depth_m"]) if "dock.depth_m" in fields else float(base.dock.position_ned_m[2])
    if "flow.speed_m_s" in fields or "flow.direction_deg" in fields:
        speed = float(row.get("flow.speed_m_s", 0.0) or 0.0)
        a = math.radians(float(row.get("flow.direction_deg", 0.0) or 0.0))
        current = (speed * math.cos(a), speed * math.sin(a))
    else:
        v = base.build_flow().velocity(np.asarray(base.dock.position_ned_m, dtype=float), 0.0)
        current = (float(v[0]), float(v[1]))
    return m, depth, current


def station_keeping_report(
    rows: Sequence[dict[str, Any]],
    base_mission_yaml: str,
    varied: Sequence[str],
    margin: float = DEFAULT_MARGIN,
) -> tuple[list[str], list[list[str]]]:
    """The station-keeping table of a sweep: header and rows (strings), one row per sea state; empty when
    the base mission has no waves.  ``rows`` the sweep's run table, ``varied`` its varied fields."""
    base = parse_mission(yaml.safe_load(base_mission_yaml or "") or {})
    if base.sea.waves is None or not rows:
        return [], []
    fields = _key_fields(varied)
    controllers = list(dict.fromkeys(str(r["controller"]) for r in rows))
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(tuple(r.get(f) for f in fields), []).append(r)
    vehicle = base.build_vehicle()
    header = [*fields, "p99 thrust use", "max", f"holds ({margin:.0%} margin)", *controllers]
    body = []
    for key, members in groups.items():
        m, depth, current = _sea_state(base, members[0], fields)
        sea = m.build_sea()
        assert sea is not None
        heading = math.radians(m.dock.heading_deg)
        s = station_keeping(vehicle, sea, depth, current_ned_m_s=current, heading_rad=heading, margin=margin)
        caught = []
        for c in controllers:
            rate = success_rate([r for r in members if r["controller"] == c])
            caught.append(f"{rate['docked']}/{rate['n']}")
        body.append(
            [*(f"{v:g}" if isinstance(v, float) else str(v) for v in key)]
            + [f"{s.utilisation_p99:.2f}", f"{s.utilisation_max:.2f}", "yes" if s.holds else "no", *caught]
        )
    return header, body
