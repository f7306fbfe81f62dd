"""The supervisor of a flight: whether each step may fly, on what the vehicle measured.

:class:`FlySupervisor` is the :class:`~auvdock.loop.stages.Supervisor` of ``fly`` and ``replay``.  Every
period, on the messages just drained (:class:`auvdock.fly.vehicle_io.VehicleIO`), in this order:

* someone else flies (a disarm or a mode change fly did not command, another station's input on the
  link, RC channels fly did not send): the session ends as a **takeover**;
* the battery below its floor, or ``fly.time_limit_s`` since arming: **abort**;
* telemetry older than ``fly.stale_neutral_s``: **neutral** this period (no step on old readings); older
  than ``fly.stale_abort_s``: abort;
* the link beyond its limits (round trip, loss): neutral, and abort once it has lasted ``fly.link_hold_s``;
* the geofence, on measured values (the pressure sensor's depth, the vehicle's own position estimate's
  distance from the start); a pressure reading too old for the depth limits: abort;

and after each controller step, ``fly.max_failed_solves`` steps in a row without a converged solve:
abort.  An ending is a :class:`~auvdock.loop.stages.LoopEnding` (``takeover`` or ``aborted``); the rules
themselves are :mod:`auvdock.fly.safety`'s, tested without a link.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pymavlink import mavutil

from auvdock.fly.safety import (
    FailedSolves,
    geofence_violation,
    limit_reason,
    link_problem,
    staleness,
    takeover_reason,
)
from auvdock.loop.stages import LoopEnding

if TYPE_CHECKING:
    from auvdock.config.mission import FlySpec
    from auvdock.controllers.base import ControlOutput
    from auvdock.fly.vehicle_io import VehicleIO
    from auvdock.loop.stages import Observation

__all__ = ["FlySupervisor", "vehicle_mode"]


def vehicle_mode(io: VehicleIO) -> tuple[bool, int | None]:
    """(armed, custom_mode) of the vehicle's latest HEARTBEAT ((False, None) before one)."""
    hb, _ = io.telemetry.latest("HEARTBEAT")
    if hb is None:
        return False, None
    return bool(hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED), int(hb.custom_mode)


class FlySupervisor:
    """Whether each step of a flight may fly (see the module docstring).

    Parameters
    ----------
    io : VehicleIO
        The vehicle's link (drained by the plant before each check).
    fly : FlySpec
        The mission's ``fly`` section (limits, staleness, link, geofence).
    timeout_s : float
        The session's timeout, s (the time limit's default).
    in_control : bool
        fly flies an armed vehicle (it armed it, or it was handed over armed): a disarm is a takeover.
    t_armed : float or None
        When the vehicle was armed (or the dry run began), on the session's clock, s.
    """

    def __init__(
        self, io: VehicleIO, fly: FlySpec, timeout_s: float, *, in_control: bool, t_armed: float | None
    ) -> None:
        self.io = io
        self.fly = fly
        self.timeout_s = float(timeout_s)
        self.in_control = bool(in_control)
        self.t_armed = t_armed
        self._failed_solves = FailedSolves(fly.max_failed_solves)
        self._link_bad_since: float | None = None

    def check(self, obs: Observation) -> bool:
        """True: the step flies; False: neutral this period (stale telemetry, a bad link).  Raises
        :class:`~auvdock.loop.stages.LoopEnding` for a takeover or an abort."""
        self._takeover()
        self._limits()
        if self._stale() or not self._link_ok():
            return False
        self._geofence()
        return True

    def after_step(self, out: ControlOutput) -> None:
        """Abort after ``fly.max_failed_solves`` steps in a row without a converged solve."""
        why = self._failed_solves.update(out.status)
        if why is not None:
            raise LoopEnding("aborted", why)

    # -- the rules ------------------------------------------------------------------------
    def _takeover(self) -> None:
        """Someone else flies (:func:`auvdock.fly.safety.takeover_reason`)."""
        armed, mode = vehicle_mode(self.io)
        text = self.io.events.vehicle_text_since_arming()
        why = takeover_reason(self.io.state.foreign, self.in_control, armed, mode, text)
        if why is not None:
            raise LoopEnding("takeover", why)

    def _limits(self) -> None:
        """The battery floor and the time limit since arming (:func:`auvdock.fly.safety.limit_reason`)."""
        since = None if self.t_armed is None else self.io.clock.now() - self.t_armed
        why = limit_reason(self.fly, self.io.state.battery_v, since, self.timeout_s)
        if why is not None:
            raise LoopEnding("aborted", why)

    def _stale(self) -> bool:
        """Stale telemetry: True (no control step on old readings; the loop sends neutral); lost: abort."""
        telemetry, now_us = self.io.telemetry, self.io.now_us
        stale = telemetry.age_s(now_us)
        action = staleness(self.fly, stale)
        if action == "abort":
            names = [n for n, age in telemetry.ages(now_us).items() if age > self.fly.stale_abort_s]
            raise LoopEnding("aborted", f"telemetry lost: no {', '.join(names)} for {stale:.1f} s")
        if action == "neutral":
            if not self.io.events.last().startswith("telemetry stale"):
                self.io.events.add(f"telemetry stale ({stale:.2f} s): neutral")
            return True
        return False

    def _link_ok(self) -> bool:
        """The link within its limits (:func:`auvdock.fly.safety.link_problem`)?  Beyond them: False (the
        step holds neutral), an event when the hold starts and ends, and an abort once it has lasted
        ``fly.link_hold_s``."""
        link = self.io.figures()
        why = link_problem(self.fly, link)
        now = self.io.clock.now()
        if why is None:
            if self._link_bad_since is not None:
                self.io.events.add(f"link recovered ({link.describe()}): flying again")
                self._link_bad_since = None
            return True
        if self._link_bad_since is None:
            self._link_bad_since = now
            self.io.events.add(f"{why}: holding (neutral) for up to {self.fly.link_hold_s:g} s")
        elif now - self._link_bad_since >= self.fly.link_hold_s:
            raise LoopEnding("aborted", f"{why} for {now - self._link_bad_since:.1f} s (fly.link_hold_s)")
        return False

    def _geofence(self) -> None:
        """The geofence on measured values: the pressure sensor's depth, the vehicle's own position
        estimate's distance from the start.  A pressure reading older than ``fly.stale_abort_s`` aborts
        too (the depth limits cannot act without it)."""
        telemetry = self.io.telemetry
        measured = telemetry.measured_depth()
        if measured is None:
            raise LoopEnding("aborted", "telemetry lost: no pressure reading (the depth limits need it)")
        depth, source = measured
        age = self.io.age_s(telemetry.latest(source)[1])
        if age > self.fly.stale_abort_s:
            said = f"telemetry lost: no {source} for {age:.1f} s (the depth limits need it)"
            raise LoopEnding("aborted", said)
        fence = geofence_violation(self.fly.geofence, depth, telemetry.distance_from_start())
        if fence is not None:
            raise LoopEnding("aborted", f"{fence} ({source})" if "depth" in fence else fence)
