"""The plant of a simulated run: the truth model, the sea and the simulated sensors.

:class:`SimulatedPlant` is the :class:`~auvdock.loop.closed_loop.Plant` of ``sim``,
``compare`` and ``sweep``: the true state stepped by :class:`auvdock.world.plant.TruthPlant`
(RK4 through the mission's flow field, the applied thrust held over the period), observed
through :class:`auvdock.sensing.simulated.SimulatedSensors`.  The state it reports to the loop
(recorded, and judged by the docking rule) is the truth.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from auvdock.loop.closed_loop import Applied, Observation
from auvdock.sensing.simulated import SimulatedSensors
from auvdock.vehicle.actuators import ActuatorCommand
from auvdock.vehicle.state import POS
from auvdock.world.plant import TruthPlant

if TYPE_CHECKING:
    from auvdock.config.mission import Mission
    from auvdock.controllers.base import ControlOutput
    from auvdock.vehicle import Vehicle
    from auvdock.world.flow import FlowField

__all__ = ["SimulatedPlant"]


class SimulatedPlant:
    """The truth of one simulated run (see the module docstring).

    Parameters
    ----------
    mission : Mission
        Start state, sensors, estimation, seed, RK4 substeps.
    vehicle : Vehicle
        The one model.
    flow : FlowField
        The true current.
    dt : float
        Control period, s.
    """

    columns: dict[str, tuple[int, ...]] = {}

    def __init__(self, mission: Mission, vehicle: Vehicle, flow: FlowField, dt: float) -> None:
        self.flow = flow
        self.dt = float(dt)
        self.truth = TruthPlant(
            vehicle,
            flow,
            mission.start_state(),
            substeps=mission.simulation.substeps,
            dt=self.dt,
            keep_nonfinite=True,
        )
        self.sensors = SimulatedSensors(mission.sensors, mission.estimation, vehicle, mission.seed)
        self._zero = np.zeros(vehicle.n_thrusters)
        self.start()

    def start(self) -> None:
        """Back at the start state, nothing applied yet."""
        self.truth.reset()
        self._x_prev: np.ndarray | None = None
        self._applied = self._zero.copy()

    @property
    def state(self) -> np.ndarray:
        """The true state (12,) (a copy)."""
        return self.truth.state

    def observe(self, t: float) -> Observation:
        """The truth at ``t`` (s) and what the sensors read of it."""
        x = self.truth.state
        if not np.all(np.isfinite(x)):
            return Observation(t, x, np.full(3, np.nan), None)
        v_c = self.flow.velocity(x[POS], t)
        readings = self.sensors.read(t, x, self._x_prev, self.dt, self._applied, v_c)
        return Observation(t, x, v_c, readings, true_flow_ned=v_c)

    def apply(self, t: float, command: ActuatorCommand) -> Applied:
        """Hold the thrust the actuator path produces over the coming period."""
        self._applied = np.asarray(command.applied_N, dtype=float).copy()
        return Applied(command.channels_us, self._applied)

    def advance(self, t: float, t_next: float) -> bool:
        """Integrate the truth from ``t`` to ``t_next`` (s); False when it went non-finite."""
        self._x_prev = self.truth.state
        x = self.truth.step(self._applied, t)
        return bool(np.all(np.isfinite(x)))

    def after_step(self, out: ControlOutput) -> None:
        """Nothing to monitor in simulation."""
