"""The one assembler: a mission's stages, built the same way for every command.

``sim``, ``compare``, ``sweep``, ``fly``, ``replay`` and the stand-ins build what they share here: the
autopilot (:func:`build_autopilot`: the estimation stage, the guidance and the controller with what it is
told of the world), and for a simulated run its whole set of stages (:func:`simulated_stages`: the truth,
the simulated sensors, no supervisor, the mission's actuator path, the docking rule on the truth and the
recorder).  A vehicle's session plugs its own plant, readings and supervisor in
(:class:`auvdock.fly.session.FlySession`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from auvdock.config.mission import Mission
from auvdock.controllers.entry import EntryCorridor
from auvdock.controllers.hold import DepthAttitudeHold
from auvdock.controllers.registry import CONTROLLERS
from auvdock.controllers.world import ControllerWorld
from auvdock.estimation.dock_knowledge import TelemetryDock, forecast_settings
from auvdock.estimation.stage import EstimationStage, NavigationStage, TruthStage
from auvdock.estimation.wave_model import WaveModel
from auvdock.loop.autopilot import Autopilot
from auvdock.loop.guidance import Guidance
from auvdock.loop.recorder import LoopRecorder
from auvdock.loop.simulated_plant import SimulatedPlant, SimulatedReadings
from auvdock.loop.stages import Stages, Unsupervised
from auvdock.loop.verdict import DockingRule
from auvdock.vehicle.actuators import build_actuators

if TYPE_CHECKING:
    from auvdock.vehicle import Vehicle
    from auvdock.world.dock import DockMotion, HeaveDock
    from auvdock.world.flow import FlowField
    from auvdock.world.waves import WaveComponents
    from auvdock.world.wec_dock import WecDock

__all__ = [
    "SimulatedWorld",
    "build_autopilot",
    "build_estimation",
    "controller_world",
    "filter_wave_model",
    "knows_dock_from_telemetry",
    "simulated_stages",
    "simulated_world",
]


@dataclass
class SimulatedWorld:
    """What a simulated run of a mission is made of, built once: the model, the true current and sea,
    the dock as charted (what the controllers know, Assumption 2) and where it really is (the truth of
    the seed), and the dock's body (``docking.criterion: capture``)."""

    vehicle: Vehicle
    flow: FlowField
    sea: WaveComponents | None
    chart: HeaveDock | WecDock
    dock: HeaveDock | WecDock
    contact: tuple | None


def simulated_world(mission: Mission) -> SimulatedWorld:
    """The world of a simulated run of ``mission`` (:class:`SimulatedWorld`)."""
    vehicle = mission.build_vehicle()
    sea = mission.build_sea()
    dock = mission.build_dock(sea, truth=True)  # where it really is (dock.position_std_m)
    return SimulatedWorld(
        vehicle,
        mission.build_flow(),
        sea,
        mission.build_dock(sea),  # the dock the controllers know (Assumption 2: its motion)
        dock,
        mission.build_contact(dock),
    )


def simulated_stages(mission: Mission, world: SimulatedWorld, autopilot: Autopilot) -> Stages:
    """The stages of a simulated run: the truth (:class:`~auvdock.loop.simulated_plant.SimulatedPlant`),
    its simulated sensors, no supervisor, ``autopilot``, the mission's actuator path, the docking rule on
    the truth (within ``docking.tolerance_m``, or the truth's contact with the dock's body) and a recorder
    with no sink yet."""
    w = world
    dt = autopilot.dt
    plant = SimulatedPlant(mission, w.vehicle, w.flow, dt, sea=w.sea, dock=w.dock, contact=w.contact)
    readings = SimulatedReadings(mission, w.vehicle, dt, w.dock)
    actuators = build_actuators(mission.simulation.actuators, w.vehicle)
    tolerance = mission.docking.tolerance_m if w.contact is None else None
    recorder = LoopRecorder(
        [],
        vehicle=w.vehicle,
        dock=w.dock,
        extra_series=autopilot.extra_series,
        plant_columns={**plant.columns, **readings.columns},
        channels=actuators.name != "ideal",
        capture=w.contact is not None,
    )
    return Stages(
        plant,
        readings,
        Unsupervised(),
        autopilot,
        actuators,
        DockingRule(w.dock, tolerance),
        recorder,
        DepthAttitudeHold(w.vehicle, mission.fly.hold_bandwidth_rad_s),
    )


def build_autopilot(
    mission: Mission, vehicle: Vehicle, dock: DockMotion, controller: str | None = None
) -> Autopilot:
    """The autopilot a mission describes; ``controller`` overrides its type (shared settings kept).

    The one way every command (sim, compare, sweep, fly, replay) builds its step.
    """
    m = mission if controller is None else mission.with_controller(controller)
    camera = m.estimation == "filter" and m.sensors.dock_camera.enabled
    known: DockMotion = dock
    telemetry = None
    if knows_dock_from_telemetry(m, m.controller.type):
        # the chart's anchor, the motion forecast from the telemetry (with its unit's slow error and rate)
        telemetry = TelemetryDock(dock, forecast_settings(m.sensors.dock_telemetry))
        known = telemetry
    world = controller_world(m, dock)
    return Autopilot(
        m.controller,
        vehicle,
        known,
        m.estimator,
        m.sensors,
        build_estimation(m, vehicle, known, telemetry),
        Guidance(m.guidance, known, camera, entry=world.entry is not None, corridor=world.entry),
        world,
    )


def controller_world(mission: Mission, dock: DockMotion) -> ControllerWorld:
    """What the mission's controller is told beyond its estimate (:class:`ControllerWorld`): the dock's
    entry corridor where :meth:`~auvdock.controllers.settings.MPCSettings.entry_enabled` (from the dock's
    body, ``docking.criterion: capture``), and the realised sea for a controller that reads the truth
    (Oracle).  ``dock``: the dock as built for the run (a WEC dock's buoy is part of its body)."""
    settings = mission.controller
    entry = None
    contact = mission.build_contact(dock) if mission.docking.criterion == "capture" else None
    if contact is not None and settings.entry_enabled(True):
        body, hull, _ = contact
        entry = EntryCorridor.for_dock(settings.entry, body, hull)
    elif settings.entry.enabled and contact is None:
        raise ValueError(
            "controller.entry.enabled: the entry corridor needs the dock's body (docking.criterion: capture)"
        )
    sea = mission.build_sea() if CONTROLLERS[settings.type].reads_true_flow else None
    return ControllerWorld(entry, sea)


def knows_dock_from_telemetry(mission: Mission, controller: str) -> bool:
    """Whether ``controller`` forecasts the dock's motion from the dock's telemetry in ``mission``
    (``sensors.dock_telemetry``, ``estimation: filter``; every controller but one that reads the truth
    by definition, Oracle) rather than being told it (Assumption 2)."""
    return (
        mission.estimation == "filter"
        and mission.sensors.dock_telemetry.enabled
        and not CONTROLLERS[controller].reads_true_flow
    )


def filter_wave_model(mission: Mission) -> WaveModel | None:
    """The wave model of a mission's navigation filter (``navigation.waves``): with ``auto`` and waves in
    the sea, oscillators at the sea's mean frequency with its orbital spread at the start depth
    (:meth:`auvdock.world.waves.WaveComponents.orbital_statistics`); else None."""
    if mission.navigation.waves == "off" or mission.sea.waves is None:
        return None
    sea = mission.build_sea()
    if sea is None:
        return None
    omega, std = sea.orbital_statistics(float(mission.start.state[2]))
    if not math.isfinite(omega) or not float(np.max(std)) > 0:
        return None
    n, e, d = (float(v) for v in std)
    return WaveModel(omega, mission.navigation.wave_damping_ratio, (n, e, d))


def build_estimation(
    mission: Mission, vehicle: Vehicle, dock: DockMotion | None = None, telemetry: TelemetryDock | None = None
) -> EstimationStage:
    """The estimation stage a mission's ``estimation`` names (one of :data:`ESTIMATION_MODES`);
    ``dock`` the dock as the controller knows it (for the filter's dock states): the mission's chart,
    or ``telemetry``, the dock forecast from its telemetry, which the stage then feeds."""
    if mission.estimation == "filter":
        mount = mission.camera.mount.build()
        return NavigationStage(
            mission.navigation,
            vehicle,
            mission.controller.dt_s,
            mission.start_state(),
            dock=dock,
            camera_mount=(mount.R_bc(), mount.t_bc()),
            telemetry=telemetry,
            waves=filter_wave_model(mission),
            telemetry_unit=mission.sensors.dock_telemetry,
        )
    if telemetry is not None:
        raise ValueError("sensors.dock_telemetry: the dock's forecast needs estimation: filter")
    return TruthStage()
