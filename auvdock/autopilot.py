"""The one controller-and-estimator step that serves ``sim``, ``compare`` and ``fly``.

Only where measurements come from (the truth simulator or the vehicle's telemetry) and
where thrust commands go (the simulator or MAVLink) differ between them; everything in
between is :meth:`Autopilot.step`.
"""

from __future__ import annotations

import time

import numpy as np

from .controllers import Controller, ControlOutput, Measurement, build_controller
from .dock import HeaveDock
from .mission import Mission
from .vehicle import Vehicle

__all__ = ["Measurement", "Autopilot", "build_autopilot"]


class Autopilot:
    """Controller (+ estimator) for one run.  Build once, call :meth:`step` every dt.

    Parameters
    ----------
    mission : Mission
        The mission (controller settings, estimator settings).
    vehicle, dock : Vehicle, HeaveDock
        The vehicle model and the dock whose motion is known (Assumption 2).
    controller : str, optional
        Override of ``mission.controller.type``.
    """

    def __init__(
        self, mission: Mission, vehicle: Vehicle, dock: HeaveDock, controller: str | None = None
    ) -> None:
        self.mission = mission
        self.vehicle = vehicle
        self.dock = dock
        self.controller: Controller = build_controller(mission, vehicle, dock, controller)
        self.name = self.controller.name
        self.dt = mission.controller.dt_s
        self.u_prev = np.zeros(8)

    @property
    def extra_series(self) -> dict[str, tuple[int, ...]]:
        """Extra per-step series this autopilot records (name -> per-row shape)."""
        return dict(getattr(self.controller, "extra_series", {}))

    def reset(self) -> None:
        """Start a new run."""
        self.controller.reset()
        self.u_prev = np.zeros(8)

    def step(self, meas: Measurement) -> ControlOutput:
        """One control step: estimate, solve, and return the thrust to hold for dt."""
        t0 = time.perf_counter()
        out = self.controller.step(meas, self.u_prev)
        out.solve_time_s = time.perf_counter() - t0
        self.u_prev = out.thrust.copy()
        return out


def build_autopilot(
    mission: Mission, vehicle: Vehicle, dock: HeaveDock, controller: str | None = None
) -> Autopilot:
    """The autopilot (controller + estimator step) a mission describes; ``controller`` overrides its type.

    The one way every command (sim, compare, sweep, fly, replay) builds its step.
    """
    return Autopilot(mission, vehicle, dock, controller)
