"""The results file of a fly session: the ``auvdock sim`` layout plus the telemetry series.

:class:`FlyRecorder` creates the run (:class:`auvdock.results.store.RunWriter`), writes one row per
control step -- flown (the controller's thrust) or held (neutral thrust, no dock to steer
to) -- each whole even under Ctrl-C, keeps what the outcome needs, and writes the outcome.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from auvdock.controllers.status import STATUS_HOLD, STATUS_NAMES, STATUS_NO_STEP
from auvdock.loop.simulation import run_outcome
from auvdock.results.store import FLUSH_PERIOD_S, RunWriter, flush_steps
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.vehicle.geometry import rotation_zyx
from auvdock.vehicle.state import POS

__all__ = ["FlyRecorder", "TELEMETRY_SERIES"]

#: Per-step series of every fly session (name -> per-row shape).
TELEMETRY_SERIES = {
    "channels_us": (6,),
    "telemetry_age_s": (2,),
    "imu_specific_force_m_s2": (3,),
    "armed": (),
}


def _rotation(angles: np.ndarray) -> np.ndarray:
    return rotation_zyx(float(angles[0]), float(angles[1]), float(angles[2]))


class FlyRecorder:
    """One session's results file (:meth:`open` creates it).

    Parameters
    ----------
    path : Path
        The HDF5 file.
    mission, autopilot, vehicle, flow, dock :
        What the session flies (attributes and the per-step dock and flow columns).
    extra_series : dict
        Series beyond the autopilot's and :data:`TELEMETRY_SERIES` (the camera's).
    attrs : dict
        Run attributes (tolerance, timeout, dt, source, ...).
    """

    def __init__(
        self,
        path: Path,
        *,
        mission: Any,
        autopilot: Any,
        vehicle: Any,
        flow: Any,
        dock: Any,
        extra_series: dict[str, tuple[int, ...]],
        attrs: dict[str, Any],
    ) -> None:
        self.path = Path(path)
        self.vehicle, self.flow, self.dock = vehicle, flow, dock
        self.autopilot_series = dict(autopilot.extra_series)
        self.states: list[np.ndarray] = []
        self.distances: list[float] = []
        self.solve_times: list[float] = []
        self.statuses: list[int] = []
        self._wall0 = time.perf_counter()
        self._meta = dict(
            mission_yaml=mission.to_yaml(),
            mission_name=mission.name,
            controller=autopilot.name,
            extra_series={**self.autopilot_series, **TELEMETRY_SERIES, **extra_series},
            status_names=STATUS_NAMES,
            n_thrusters=vehicle.n_thrusters,
            attrs=attrs,
            flush_every=flush_steps(float(attrs.get("dt_s", FLUSH_PERIOD_S))),
        )
        self.writer: RunWriter | None = None

    def open(self) -> None:
        """Create the file (whole: a Ctrl-C meanwhile is raised after it, with :attr:`writer` set)."""
        self._wall0 = time.perf_counter()
        with SigintDeferred():
            self.writer = RunWriter(self.path, "/", **self._meta)

    def flown(
        self,
        t: float,
        x: np.ndarray,
        dist: float,
        out: Any,
        *,
        channels: np.ndarray,
        specific_force: np.ndarray,
        telemetry: dict[str, Any],
        series: dict[str, np.ndarray],
    ) -> None:
        """A step flown with the controller's thrust ``out`` (a ControlOutput)."""
        self._row(t, x, out.thrust, out.status, out.solve_time_s, channels, specific_force, telemetry, series)
        self.states.append(x)
        self.distances.append(dist)
        self.solve_times.append(out.solve_time_s)
        self.statuses.append(out.status)

    def held(
        self,
        t: float,
        x: np.ndarray,
        *,
        channels: np.ndarray,
        telemetry: dict[str, Any],
        series: dict,
        status: int = STATUS_HOLD,
        thrust: np.ndarray | None = None,
    ) -> None:
        """A step without a controller step: with ``status`` hold, the dock out of sight and
        ``thrust`` (N, default zero) the hold's; with no_step the final state of the session
        (the one in which docking is declared), as ``sim`` writes it."""
        nan_series = {name: np.full(shape, np.nan) for name, shape in self.autopilot_series.items()}
        applied = np.zeros(self.vehicle.n_thrusters) if thrust is None else np.asarray(thrust, dtype=float)
        self._row(
            t,
            x,
            applied,
            status,
            0.0 if status != STATUS_NO_STEP else float("nan"),
            channels,
            np.full(3, np.nan),
            telemetry,
            {**nan_series, **series},
        )

    def _row(
        self,
        t: float,
        x: np.ndarray,
        thrust: np.ndarray,
        status: int,
        solve_time_s: float,
        channels: np.ndarray,
        specific_force: np.ndarray,
        telemetry: dict[str, Any],
        series: dict[str, np.ndarray],
    ) -> None:
        p_dock = self.dock.position(t)
        with SigintDeferred():  # a row is written whole
            self.writer.append(
                time_s=t,
                state=x,
                thrust_N=thrust,
                wrench=self.vehicle.allocation @ thrust,
                flow_ned_m_s=self.flow.velocity(x[POS], t),
                dock_position_m=p_dock,
                dock_velocity_m_s=self.dock.velocity(t),
                distance_m=float(np.linalg.norm(x[POS] - p_dock)),
                solve_time_s=solve_time_s,
                solver_status=status,
                channels_us=channels,
                telemetry_age_s=telemetry["age_s"],
                imu_specific_force_m_s2=specific_force,
                armed=np.asarray(float(telemetry["armed"])),
                **series,
            )

    def outcome(
        self,
        reason: str,
        message: str,
        *,
        docked: bool,
        contact: np.ndarray | None,
        t_end: float,
        extra: dict,
    ) -> dict[str, Any]:
        """The outcome attributes of the session."""
        outcome: dict[str, Any] = {}
        if self.states:
            outcome = run_outcome(
                docked=docked,
                t_end=t_end,
                states=self.states,
                distances=self.distances,
                solve_times=self.solve_times,
                statuses=self.statuses,
                contact_state=contact,
                dock_velocity=self.dock.velocity(t_end) if docked else None,
                dock_heading=self.dock.heading_rad,
                rotation=_rotation,
                wall_time_s=time.perf_counter() - self._wall0,
                reason=reason,
            )
        outcome["reason"] = reason
        outcome["message"] = message
        outcome.update(extra)
        return outcome

    def finish(self, outcome: dict[str, Any]) -> None:
        """Write the outcome and close the file (call with SIGINT held back)."""
        try:
            self.writer.finish(outcome)
        finally:
            self.writer.close()

    def close(self) -> None:
        """Close without an outcome (the run stays ``complete = False``)."""
        self.writer.close()

    @staticmethod
    def events_json(events: list[tuple[float, str]]) -> str:
        return json.dumps(events)
