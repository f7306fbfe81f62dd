"""The results file of a fly session: the ``auvdock sim`` layout plus the telemetry columns.

:class:`FlyRecorder` creates the run (:class:`auvdock.results.store.RunWriter`) whole even under
Ctrl-C, hands the closed loop its :class:`~auvdock.loop.closed_loop.LoopRecorder` (which writes
every row, as in ``sim``), and writes the session's outcome with what only a flight has (its
events, who armed, the vehicle's parameters).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from auvdock.controllers.status import STATUS_NAMES
from auvdock.loop.recorder import LoopRecorder
from auvdock.loop.stages import LoopResult
from auvdock.results.store import RunWriter, flush_steps
from auvdock.runtime.interrupts import SigintDeferred

if TYPE_CHECKING:
    from auvdock.config.mission import Mission
    from auvdock.loop.autopilot import Autopilot
    from auvdock.loop.stages import DockModel
    from auvdock.vehicle import Vehicle

__all__ = ["FlyRecorder"]


class FlyRecorder:
    """One session's results file (:meth:`open` creates it).

    Parameters
    ----------
    path : Path
        The HDF5 file.
    mission, autopilot, vehicle, dock :
        What the session flies (attributes, the per-step dock columns).
    plant_columns : dict
        The plant's own columns (:class:`auvdock.fly.plant.MavlinkPlant`: telemetry, camera).
    attrs : dict
        Run attributes (tolerance, timeout, dt, source, ...).
    """

    def __init__(
        self,
        path: Path,
        *,
        mission: Mission,
        autopilot: Autopilot,
        vehicle: Vehicle,
        dock: DockModel,
        plant_columns: dict[str, tuple[int, ...]],
        attrs: dict[str, Any],
    ) -> None:
        self.path = Path(path)
        self.loop = LoopRecorder(
            [],
            vehicle=vehicle,
            dock=dock,
            extra_series=autopilot.extra_series,
            plant_columns=plant_columns,
            channels=True,
        )
        self._meta = dict(
            mission_yaml=mission.to_yaml(),
            mission_name=mission.name,
            controller=autopilot.name,
            extra_series=self.loop.series,
            status_names=STATUS_NAMES,
            n_thrusters=vehicle.n_thrusters,
            attrs=attrs,
            flush_every=flush_steps(float(attrs["dt_s"])),
        )
        self.writer: RunWriter | None = None

    def open(self) -> None:
        """Create the file (whole: a Ctrl-C meanwhile is raised after it, with :attr:`writer` set)."""
        with SigintDeferred():
            self.writer = RunWriter(self.path, "/", **self._meta)  # type: ignore[arg-type]
            self.loop.sinks = [self.writer]

    def outcome(
        self, reason: str, message: str, *, result: LoopResult | None, extra: dict[str, Any]
    ) -> dict[str, Any]:
        """The outcome attributes of the session (the loop's figures where it took a step)."""
        outcome: dict[str, Any] = {}
        if self.loop.states and result is not None:
            outcome = self.loop.outcome(result)
        outcome["reason"] = reason
        outcome["message"] = message
        outcome.update(extra)
        return outcome

    def finish(self, outcome: dict[str, Any]) -> None:
        """Write the outcome and close the file (call with SIGINT held back)."""
        assert self.writer is not None
        try:
            self.writer.finish(outcome)
        finally:
            self.writer.close()

    def close(self) -> None:
        """Close without an outcome (the run stays ``complete = False``)."""
        if self.writer is not None:
            self.writer.close()

    @staticmethod
    def events_json(events: list[tuple[float, str]]) -> str:
        return json.dumps(events)
