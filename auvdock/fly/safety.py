"""The safety rules of a flight, on measured values, without a link: each says why to stop, or None.

:class:`~auvdock.fly.session.FlySession` asks these every control step and ends the session
(neutral, release, disarm if it armed) on the first answer; a takeover ends with the channels
released at once.  Being functions of values, each rule is tested on its own
(``tests/test_fly_safety.py``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from auvdock.controllers.status import FAILURE_CODES, STATUS_NAMES
from auvdock.fly.telemetry import geofence_violation
from auvdock.vehicle.ardusub import MODES

if TYPE_CHECKING:
    from auvdock.config.mission import FlySpec, Mission
    from auvdock.fly.link_health import LinkFigures

__all__ = [
    "CLOCK_RATE_TOLERANCE",
    "clock_rate_problem",
    "preflight_problems",
    "takeover_reason",
    "limit_reason",
    "link_problem",
    "staleness",
    "FailedSolves",
]


#: How far the vehicle's clock may run from fly's (a fraction) before arming is refused: a rehearsal whose
#: simulator cannot keep fly's pace flies a vehicle that answers at another speed than its model's.
CLOCK_RATE_TOLERANCE = 0.05


def clock_rate_problem(rate: float, span_s: float, fly_rate: float = 1.0) -> str | None:
    """Why not to arm when the vehicle's clock runs at ``rate`` times fly's (measured over ``span_s`` s of
    its ATTITUDE ``time_boot_ms``; NaN: not measured yet), fly's own clock running at ``fly_rate`` times
    the wall clock (``auvdock --clock-rate``); None within :data:`CLOCK_RATE_TOLERANCE`."""
    if not math.isfinite(rate) or abs(rate - 1.0) <= CLOCK_RATE_TOLERANCE:
        return None
    wall = rate * fly_rate  # the vehicle's seconds per wall-clock second
    return (
        f"the vehicle's clock runs at {rate:.2f} x fly's (its ATTITUDE time_boot_ms over {span_s:.1f} s): "
        f"a simulator at {wall:.2f} x real time needs fly at the same rate "
        f"(auvdock --clock-rate {wall:.2f} fly ...; ArduSub SITL with --speedup {wall:.2f})"
    )


def preflight_problems(
    mission: Mission,
    refusals: list[str],
    measured: tuple[float, str] | None,
    p_dock: np.ndarray,
    battery_v: float | None,
    link: LinkFigures | None = None,
) -> list[str]:
    """Why not to arm, on measured values (empty: arm): the parameter checks' ``refusals``, the
    pressure sensor's depth ``measured`` (m, and its source) inside the geofence and within
    ``fly.start_depth_tolerance_m`` of the mission's start depth, the dock (at ``p_dock`` (3,), m,
    mission frame) inside the geofence, the battery (V) above its floor, the ``link``'s round trip and
    loss within their limits (:func:`link_problem`)."""
    fly = mission.fly
    fence = fly.geofence
    problems = list(refusals)
    if measured is not None:
        depth, source = measured
        outside = geofence_violation(fence, depth, None)
        if outside is not None:
            problems.append(f"{outside} ({source})")
        start = float(mission.start_state()[2])
        if abs(depth - start) > fly.start_depth_tolerance_m:
            problems.append(
                f"depth {depth:.2f} m ({source}), but the mission starts at {start:.2f} m: bring "
                f"the vehicle within {fly.start_depth_tolerance_m:g} m of it "
                "(fly.start_depth_tolerance_m)"
            )
    p0 = np.asarray(mission.start_state()[0:3], dtype=float)
    dock_dist = float(np.hypot(*(p_dock[0:2] - p0[0:2])))
    if dock_dist > fence.max_distance_m:
        problems.append(
            f"the dock is {dock_dist:.2f} m from the start, beyond fly.geofence.max_distance_m "
            f"{fence.max_distance_m:g} m"
        )
    if not fence.min_depth_m <= p_dock[2] <= fence.max_depth_m:
        problems.append(
            f"the dock's depth {p_dock[2]:.2f} m is outside fly.geofence "
            f"[{fence.min_depth_m:g}, {fence.max_depth_m:g}] m"
        )
    floor = fly.min_battery_v
    if floor > 0 and battery_v is None:
        problems.append(
            "battery: the vehicle reports no voltage (SYS_STATUS; is BATT_MONITOR set?); "
            "set fly.min_battery_v: 0 to fly without a floor"
        )
    elif floor > 0 and battery_v is not None and battery_v < floor:
        problems.append(f"battery {battery_v:.2f} V, below the floor {floor:g} V (fly.min_battery_v)")
    if link is not None:
        why = link_problem(fly, link)
        if why is not None:
            problems.append(why)
    return problems


def link_problem(fly: FlySpec, link: LinkFigures) -> str | None:
    """The link beyond its limits: the median TIMESYNC round trip above ``fly.max_round_trip_s``, or more
    of the vehicle's messages lost than ``fly.max_link_loss``; None within them (or not yet measured)."""
    if link.rtt_s > fly.max_round_trip_s:  # (NaN: not measured, compares False)
        return (
            f"link: round trip {1e3 * link.rtt_s:.0f} ms, above fly.max_round_trip_s "
            f"{1e3 * fly.max_round_trip_s:.0f} ms"
        )
    if link.loss > fly.max_link_loss:
        return (
            f"link: {100 * link.loss:.1f} % of the vehicle's messages lost, above fly.max_link_loss "
            f"{100 * fly.max_link_loss:g} %"
        )
    return None


def takeover_reason(
    foreign: list[str], we_armed: bool, armed: bool, mode: int | None, vehicle_said: str = ""
) -> str | None:
    """Someone else flies: another station's pilot input (``foreign``), or -- once fly armed --
    a disarm or a mode change fly did not command.  ``vehicle_said``: its latest text since arming."""
    if foreign:
        return foreign[0]
    if not we_armed:
        return None
    if not armed:
        why = f" (the vehicle said: {vehicle_said})" if vehicle_said else ""
        return f"the vehicle was disarmed, not by fly{why}"
    if mode != MODES["MANUAL"]:
        name = next((k for k, v in MODES.items() if v == mode), f"mode {mode}")
        return f"the vehicle changed to {name}, not by fly"
    return None


def limit_reason(
    fly: FlySpec, battery_v: float | None, since_armed_s: float | None, timeout_s: float
) -> str | None:
    """The battery floor (low-passed voltage, V) and the time limit since arming (s)."""
    if fly.min_battery_v > 0 and battery_v is not None and battery_v < fly.min_battery_v:
        return f"battery {battery_v:.2f} V, below the floor {fly.min_battery_v:g} V (fly.min_battery_v)"
    limit = fly.time_limit_s if fly.time_limit_s is not None else timeout_s + 60.0
    if since_armed_s is not None and since_armed_s > limit:
        return f"time limit: {limit:g} s since arming (fly.time_limit_s)"
    return None


def staleness(fly: FlySpec, stale_s: float) -> str:
    """What telemetry ``stale_s`` old (s) calls for: ``ok``, ``neutral`` (no control step on old
    readings) or ``abort`` (lost)."""
    if stale_s > fly.stale_abort_s:
        return "abort"
    if stale_s > fly.stale_neutral_s:
        return "neutral"
    return "ok"


class FailedSolves:
    """Counts controller steps in a row without a converged solve; says when ``limit`` is reached."""

    def __init__(self, limit: int) -> None:
        self.limit = int(limit)
        self.in_a_row = 0

    def update(self, status: int) -> str | None:
        """Count one step's status; the reason to abort once ``limit`` steps in a row failed."""
        self.in_a_row = self.in_a_row + 1 if status in FAILURE_CODES else 0
        if self.in_a_row >= self.limit:
            return (
                f"controller: {self.limit} steps in a row without a converged solve "
                f"(last status {STATUS_NAMES.get(status, status)})"
            )
        return None
