"""The plant of a simulated run: the truth model, the sea and the simulated sensors.

:class:`SimulatedPlant` is the :class:`~auvdock.loop.closed_loop.Plant` of ``sim``,
``compare`` and ``sweep``: the true state stepped by :class:`auvdock.world.plant.TruthPlant`
(RK4 through the mission's flow field and sea, the applied thrust held over the period),
observed through :class:`auvdock.sensing.simulated.SimulatedSensors`.  The state it reports to
the loop (recorded, and judged by the docking rule) is the truth; the water velocity it reports
is the current plus the waves' orbital velocity at the vehicle.

In a sea it records, per step (:attr:`SimulatedPlant.columns`): the orbital velocity and the
water's acceleration at the vehicle, the sea's elevation at the dock, and the dock's 6-DOF pose
and twist.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from auvdock.loop.closed_loop import Applied, Observation
from auvdock.sensing.simulated import SimulatedSensors
from auvdock.vehicle.actuators import ActuatorCommand
from auvdock.vehicle.state import POS
from auvdock.world.dock_body import classify_contact
from auvdock.world.plant import TruthPlant

if TYPE_CHECKING:
    from auvdock.config.mission import Mission
    from auvdock.controllers.base import ControlOutput
    from auvdock.vehicle import Vehicle
    from auvdock.world.dock import HeaveDock
    from auvdock.world.dock_body import CaptureLimits, DockBody, HullBox
    from auvdock.world.flow import FlowField
    from auvdock.world.waves import WaveComponents
    from auvdock.world.wec_dock import WecDock

#: The per-step columns of a run in a sea: name -> per-row shape.
SEA_COLUMNS: dict[str, tuple[int, ...]] = {
    "wave_velocity_ned_m_s": (3,),
    "water_acceleration_ned_m_s2": (3,),
    "sea_elevation_at_dock_m": (),
    "dock_pose": (6,),
    "dock_twist": (6,),
}

__all__ = ["SimulatedPlant"]


class SimulatedPlant:
    """The truth of one simulated run (see the module docstring).

    Parameters
    ----------
    mission : Mission
        Start state (the true one: :meth:`~auvdock.config.mission.Mission.true_start_state`),
        sensors, estimation, seed, RK4 substeps.
    vehicle : Vehicle
        The one model.
    flow : FlowField
        The true current.
    dt : float
        Control period, s.
    sea : WaveComponents, optional
        The realised sea (:meth:`~auvdock.config.mission.Mission.build_sea`); None: currents only.
    dock : HeaveDock or WecDock, optional
        The true dock (its pose and twist are recorded in a sea; its motion places the body).
    contact : (DockBody, HullBox, CaptureLimits), optional
        ``docking.criterion: capture`` (:meth:`~auvdock.config.mission.Mission.build_contact`):
        every observation classifies the truth's contact with the dock's body
        (:func:`auvdock.world.dock_body.classify_contact`) and records the nose in the dock frame.
    """

    columns: dict[str, tuple[int, ...]] = {}

    def __init__(
        self,
        mission: Mission,
        vehicle: Vehicle,
        flow: FlowField,
        dt: float,
        *,
        sea: WaveComponents | None = None,
        dock: HeaveDock | WecDock | None = None,
        contact: tuple[DockBody, HullBox, CaptureLimits] | None = None,
    ) -> None:
        self.flow = flow
        self.dt = float(dt)
        self.sea = sea
        self.dock = dock
        self.truth = TruthPlant(
            vehicle,
            flow,
            mission.true_start_state(),
            substeps=mission.simulation.substeps,
            dt=self.dt,
            keep_nonfinite=True,
            sea=sea,
        )
        if contact is not None and dock is None:
            raise ValueError("contact: needs the dock whose body it is")
        self.contact = contact
        self.columns = {}
        if sea is not None:
            self.columns.update(SEA_COLUMNS)
        if contact is not None:
            self.columns["nose_dock_m"] = (3,)
        camera_fix = None
        if mission.estimation == "filter" and mission.sensors.dock_camera.enabled:
            if dock is None:
                raise ValueError("sensors.dock_camera: the simulated camera needs the dock")
            camera_fix = mission.build_camera_fix()
        self.sensors = SimulatedSensors(
            mission.sensors, mission.estimation, vehicle, mission.seed, camera_fix=camera_fix, dock=dock
        )
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
        columns: dict[str, np.ndarray] = {}
        path_rate = water_accel = None
        if self.sea is not None:
            v_w, path_rate, a_w = self.truth.water_at(x, t)
            water_accel = a_w
            v_c = v_c + v_w
            columns = {"wave_velocity_ned_m_s": v_w, "water_acceleration_ned_m_s2": a_w}
            if self.dock is not None:
                pose, twist = self.dock.pose(t)
                n, e = pose[0], pose[1]
                columns.update(
                    sea_elevation_at_dock_m=np.asarray(self.sea.elevation(n, e, t)),
                    dock_pose=pose,
                    dock_twist=twist,
                )
        contact = None
        if self.contact is not None and self.dock is not None:
            body, hull, limits = self.contact
            contact = classify_contact(
                x, self.dock.position(t), self.dock.velocity(t), body, hull, limits,
                dock_heading_rad=self.dock.heading_rad,
            )
            columns["nose_dock_m"] = contact.nose_dock_m
        readings = self.sensors.read(t, x, self._x_prev, self.dt, self._applied, v_c, path_rate, water_accel)
        return Observation(t, x, v_c, readings, true_flow_ned=v_c, columns=columns, contact=contact)

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
