"""What really happened in a rehearsal: a stand-in vehicle's truth, written to a results file.

``vehicle-sim --truth-out PATH`` and ``sitl-physics --truth-out PATH`` (``truth_out`` of
:class:`auvdock.standins.vehicle_sim.VehicleSim` and :class:`auvdock.standins.sitl_physics.SitlPhysics`)
write the vehicle's true trajectory, the true dock's and the motors' arming to an
auvdock results file (the format of ``auvdock sim``'s, :mod:`auvdock.results.store`; it reads back
with :func:`auvdock.results.store.read_run` and plots like any run): a row every :data:`TRUTH_PERIOD_S`
of the simulator's time (every 5th physics step of vehicle-sim at 100 Hz; of sitl-physics, the first
frame at or after each 0.05 s; with a capture mission also each physics step at which the truth's contact
with the dock changes, so a row's status holds until the next row), with the truth's ``state`` (mission
frame), ``dock_position_m``, ``distance_m`` (the vehicle's body origin to the docking point),
``channels_us`` (vehicle-sim) and ``armed`` (sitl-physics: the motors pushing).  ``time_s`` is the
vehicle's own clock (vehicle-sim's ``time_boot_ms``; sitl-physics' physics time, which SITL's clock
follows in lockstep), which a
flight records with each row (``vehicle_time_s``), so a flight is scored on the truth at the
instants it flew (:mod:`auvdock.standins.truth_check`).  The outcome, written when the simulator stops:
the closest approach while armed (m, and when), and the arming events.  A mission judged by capture
(``docking.criterion: capture``) has the truth's contact with the dock's body in every row
(``contact_status``: :data:`CONTACT_STATUSES`; ``nose_dock_m``), and the outcome the first instants the
truth was captured and collided while armed.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.results.store import RunWriter

if TYPE_CHECKING:
    from auvdock.config.mission import Mission
    from auvdock.loop.stages import DockModel

__all__ = ["TRUTH_PERIOD_S", "TRUTH_SOURCE", "CONTACT_STATUSES", "TruthContact", "TruthRecord"]

#: ``contact_status`` of a truth row (``docking.criterion: capture``): an index of this tuple
#: (:func:`auvdock.world.dock_body.classify_contact`).
CONTACT_STATUSES = ("free", "captured", "collided")


class TruthContact:
    """A stand-in's truth in contact with the dock's body (``docking.criterion: capture``), recorded
    per row, not judged (the flight it serves judges; ``truth-check`` scores it).

    Parameters
    ----------
    mission : Mission
        Its dock's body, the vehicle's hull and the capture limits
        (:meth:`~auvdock.config.mission.Mission.build_contact`).
    dock : DockModel
        The true dock (where the body is).
    built : optional
        The dock as the mission built it, where ``dock`` is moved from it (sitl-physics' camera offset):
        a WEC dock's buoy is part of the body.  Default: ``dock``.
    """

    #: The columns it adds to the truth's rows: name -> per-row shape.
    columns: dict[str, tuple[int, ...]] = {"contact_status": (), "nose_dock_m": (3,)}

    def __init__(self, mission: Mission, dock: DockModel, built: Any = None) -> None:
        contact = mission.build_contact(dock if built is None else built)
        if contact is None:
            raise ValueError("TruthContact: the mission is not judged by capture (docking.criterion)")
        self.body, self.hull, self.limits = contact
        self.dock = dock

    @classmethod
    def of(cls, mission: Mission, dock: DockModel, built: Any = None) -> TruthContact | None:
        """The recorder of a capture mission, else None."""
        return cls(mission, dock, built) if mission.docking.criterion == "capture" else None

    def at(self, x: np.ndarray, t: float) -> dict[str, np.ndarray]:
        """The columns at the true state ``x`` (12,) and instant ``t`` (s): the contact's status (an
        index of :data:`CONTACT_STATUSES`) and the nose in the dock frame (m)."""
        from auvdock.world.dock_body import classify_contact

        d = self.dock
        touch = classify_contact(
            x, d.position(t), d.velocity(t), self.body, self.hull, self.limits, dock_heading_rad=d.heading_rad
        )
        return {
            "contact_status": np.asarray(float(CONTACT_STATUSES.index(touch.status))),
            "nose_dock_m": np.asarray(touch.nose_dock_m, dtype=float),
        }


#: The ``source`` attribute of every truth file (read by :func:`auvdock.standins.truth_check.check_flight`).
TRUTH_SOURCE = "vehicle-sim truth"

#: A truth row every this long of the simulator's time, s.
TRUTH_PERIOD_S = 0.05


class TruthRecord:
    """A row sink of the stand-in's closed loop that keeps a row every :data:`TRUTH_PERIOD_S`, and every
    row whose ``contact_status`` differs from the last kept one's.

    Parameters
    ----------
    path : str or Path
        The results file to write (replaced if it is one).
    meta : dict
        :class:`RunWriter`'s keyword arguments (``mission_yaml``, ``mission_name``, ``controller``,
        ``extra_series``, ``attrs``, ``n_thrusters``).
    """

    def __init__(self, path: str | Path, **meta: Any) -> None:
        self.path = Path(path)
        self.writer = RunWriter(self.path, "/", overwrite=True, **meta)
        self._next_t = -math.inf
        self.closest_m = math.inf
        self.closest_t_s = math.nan
        #: The first instant (s) the truth was captured, and collided, while armed (capture missions).
        self.first_s = {"captured": math.nan, "collided": math.nan}
        self._status = math.nan  # the contact_status of the last row kept (capture missions)

    @classmethod
    def for_stand_in(
        cls,
        path: str | Path,
        stand_in: str,
        mission: Mission,
        series: dict[str, tuple[int, ...]],
        n_thrusters: int,
    ) -> TruthRecord:
        """The truth file of stand-in ``stand_in`` ("vehicle-sim", "sitl-physics") flying ``mission``, its
        rows carrying ``series`` (the loop recorder's) beyond the base datasets."""
        return cls(
            path,
            mission_yaml=mission.to_yaml(),
            mission_name=mission.name,
            controller=f"{stand_in} truth",
            extra_series=series,
            attrs={
                "source": TRUTH_SOURCE,
                "stand_in": stand_in,
                "tolerance_m": mission.docking.tolerance_m,
                "dt_s": TRUTH_PERIOD_S,
            },
            n_thrusters=n_thrusters,
        )

    def end(self, failed: bool, events: str, end_time_s: float) -> None:
        """Finish (reason "stopped", or "error" when the stand-in ``failed``; its ``events`` as text and
        its time at the end, s) and close, closed even if finishing raises."""
        try:
            reason = "error" if failed else "stopped"
            self.finish({"reason": reason, "events": events, "end_time_s": float(end_time_s)})
        finally:
            self.close()

    def append(self, **row: Any) -> None:
        """Keep the row if it is due; track the closest approach while armed."""
        armed = bool(np.asarray(row.get("armed", 0.0)) > 0.5)
        d = float(row["distance_m"])
        if armed and d < self.closest_m:
            self.closest_m, self.closest_t_s = d, float(row["time_s"])
        status = row.get("contact_status")
        if armed and status is not None:  # every row counts here, kept or not
            what = CONTACT_STATUSES[int(status)]
            if what in self.first_s and math.isnan(self.first_s[what]):
                self.first_s[what] = float(row["time_s"])
        t = float(row["time_s"])
        changed = False
        if status is not None and float(status) != self._status:  # a contact begins or ends: the row is
            changed, self._status = True, float(status)  # kept, so a row's status holds until the next
        if t >= self._next_t - 1e-9 or t < self._next_t - TRUTH_PERIOD_S:  # due, or time went back (SITL)
            self.writer.append(**row)
            self._next_t = t + TRUTH_PERIOD_S
        elif changed:  # between two due rows: the schedule kept
            self.writer.append(**row)

    def finish(self, outcome: dict[str, Any]) -> None:
        """Write the outcome (the closest approach while armed added) and mark the file complete."""
        self.writer.finish(
            {
                **outcome,
                "closest_approach_armed_m": self.closest_m if math.isfinite(self.closest_m) else math.nan,
                "closest_approach_armed_t_s": self.closest_t_s,
                "first_captured_armed_t_s": self.first_s["captured"],
                "first_collided_armed_t_s": self.first_s["collided"],
            }
        )

    def close(self) -> None:
        """Close the file (complete or not)."""
        self.writer.close()
