"""The plant and the readings of a simulated run: the truth model, the sea and the simulated sensors.

:class:`SimulatedPlant` is the :class:`~auvdock.loop.stages.Plant` of ``sim``, ``compare`` and
``sweep``: the true state stepped by :class:`auvdock.world.plant.TruthPlant` (RK4 through the
mission's flow field and sea, the applied thrust held over the period).  The state it reports to
the loop (recorded, and judged by the docking rule) is the truth; the water velocity it reports
is the current plus the waves' orbital velocity at the vehicle.  :class:`SimulatedReadings` (the
:class:`~auvdock.loop.stages.ReadingsStage`) reads it through
:class:`auvdock.sensing.simulated.SimulatedSensors`.

In a sea it records, per step (:attr:`SimulatedPlant.columns`): the orbital velocity and the
water's acceleration at the vehicle, the sea's elevation at the dock, and the dock's 6-DOF pose
and twist.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from auvdock.loop.stages import Applied, Observation, Sensed, TruthSample
from auvdock.sensing.simulated import SimulatedSensors
from auvdock.vehicle.actuators import ActuatorCommand
from auvdock.vehicle.state import POS
from auvdock.world.dock_body import classify_contact
from auvdock.world.plant import TruthPlant

if TYPE_CHECKING:
    from auvdock.config.mission import Mission
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

__all__ = ["SimulatedPlant", "SimulatedReadings"]


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
            return Observation(t, x)
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
        truth = TruthSample(self._x_prev, self._applied, path_rate, water_accel)
        return Observation(t, x, v_c, columns, contact, truth)

    def apply(self, t: float, command: ActuatorCommand) -> Applied:
        """Hold the thrust the actuator path produces over the coming period."""
        self._applied = np.asarray(command.applied_N, dtype=float).copy()
        return Applied(command.channels_us, self._applied)

    def advance(self, t: float, t_next: float) -> bool:
        """Integrate the truth from ``t`` to ``t_next`` (s); False when it went non-finite."""
        self._x_prev = self.truth.state
        x = self.truth.step(self._applied, t)
        return bool(np.all(np.isfinite(x)))


class SimulatedReadings:
    """What the simulated sensors read of the truth (:class:`auvdock.sensing.simulated.SimulatedSensors`).

    Parameters
    ----------
    mission : Mission
        Sensors, estimation, seed; with ``sensors.dock_camera`` the camera's fix model
        (:meth:`~auvdock.config.mission.Mission.build_camera_fix`).
    vehicle : Vehicle
        The one model.
    dt : float
        Control period, s.
    dock : HeaveDock or WecDock, optional
        The true dock (the camera and the dock's telemetry read it).
    """

    columns: dict[str, tuple[int, ...]] = {}

    def __init__(
        self, mission: Mission, vehicle: Vehicle, dt: float, dock: HeaveDock | WecDock | None = None
    ) -> None:
        self.dt = float(dt)
        camera_fix = None
        if mission.estimation == "filter" and mission.sensors.dock_camera.enabled:
            if dock is None:
                raise ValueError("sensors.dock_camera: the simulated camera needs the dock")
            camera_fix = mission.build_camera_fix()
        self.sensors = SimulatedSensors(
            mission.sensors, mission.estimation, vehicle, mission.seed, camera_fix=camera_fix, dock=dock
        )

    def read(self, obs: Observation) -> Sensed:
        """The sensors' readings of the truth at ``obs.t``."""
        truth = obs.truth
        if truth is None or obs.true_water_ned is None:
            raise ValueError("simulated readings need a simulated plant's truth")
        readings = self.sensors.read(
            obs.t,
            obs.state,
            truth.state_prev,
            self.dt,
            truth.applied_N,
            obs.true_water_ned,
            truth.path_rate,
            truth.water_accel,
        )
        return Sensed(readings)
