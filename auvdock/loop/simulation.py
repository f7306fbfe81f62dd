"""``sim``: one closed-loop docking simulation of a mission.

:func:`run_simulation` configures the one closed loop (:func:`auvdock.loop.closed_loop.run_closed_loop`)
with the simulated plant (:class:`~auvdock.loop.simulated_plant.SimulatedPlant`: the truth
model through the mission's flow field, observed by the simulated sensors), the mission's
actuator path (``simulation.actuators``: ideal, or ArduSub's channels, mixer and thruster
curve as ``fly`` flies them) and the autopilot (estimation stage + controller), and records
every row to the results file (:mod:`auvdock.results.store`) as it happens.

The run ends when the vehicle is within ``docking.tolerance_m`` of the dock (docked) or at
``docking.timeout_s`` (failure, with the closest approach recorded); the final state -- the
one in which docking is declared, or the last one -- is written as a last row with status
``no_step``.  A run interrupted at any moment (Ctrl-C) leaves a readable file marked
``complete = False``; building the controller (compiling, on first use) is timed apart
(``setup_time_s``) from the run itself (``wall_time_s``).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from auvdock.config.mission import Mission
from auvdock.controllers.status import STATUS_NAMES
from auvdock.loop import closed_loop
from auvdock.loop.assemble import build_autopilot, simulated_stages, simulated_world
from auvdock.loop.autopilot import Autopilot
from auvdock.loop.recorder import LoopRecorder
from auvdock.loop.stages import Progress
from auvdock.results.run import MemoryRecorder, Run
from auvdock.results.store import RunWriter, flush_steps
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.vehicle.actuators import ACTUATOR_PATHS

__all__ = ["RunSummary", "run_simulation", "idealisations"]


def idealisations(mission: Mission, reads_true_flow: bool) -> list[str]:
    """The idealisations a simulated run of ``mission`` keeps, one sentence each (empty: none).

    ``reads_true_flow``: the controller's definition reads the true flow (Kinematic, Oracle).
    """
    out = []
    if mission.estimation == "truth":
        out.append("Assumption 1: the controllers know the true state (estimation: truth)")
    camera = mission.estimation == "filter" and mission.sensors.dock_camera.enabled
    motion = "the WEC buoy's true heave in the realised sea" if mission.dock.wec else "the mission's heave"
    telemetry = mission.estimation == "filter" and mission.sensors.dock_telemetry.enabled
    if telemetry:  # the deployable controllers forecast the dock's motion from its telemetry
        if reads_true_flow:
            out.append(
                f"Assumption 2: the controller is told the dock's true motion ({motion}; its definition: "
                "the deployable controllers forecast it from the dock's telemetry)"
            )
    elif camera:
        out.append(
            f"part of Assumption 2: the controllers know the dock's motion about its anchor ({motion}); "
            "where the dock is they estimate from the camera's fixes"
        )
    elif mission.dock.wec is None:
        out.append("Assumption 2: the controllers know the dock's motion (the mission's dock trajectory)")
    else:
        out.append(f"Assumption 2: the controllers know the dock's motion ({motion})")
    if reads_true_flow:
        out.append("Assumption 3: the controller reads the true flow at the vehicle (its definition)")
    if mission.simulation.actuators == "ideal":
        out.append("ideal actuators: the commanded thrust is applied exactly (simulation.actuators: ideal)")
    if mission.sea.waves is None:
        out.append("calm sea: no waves act on the vehicle or the dock (no sea.waves)")
    return out


@dataclass
class RunSummary:
    """Outcome of one run (also stored as attributes of the results group)."""

    mission: str
    controller: str
    outcome: dict[str, Any]
    path: Path | None = None
    solve_times_s: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    #: Where each step's time went (:mod:`auvdock.runtime.timing`): part name -> (steps,) s, zero
    #: where a step had no such part.
    time_parts_s: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    #: The whole run in memory (``run_simulation(..., keep=True)``), else None.
    run: Run | None = field(default=None, repr=False)

    @property
    def docked(self) -> bool:
        return bool(self.outcome.get("docked", False))


def run_simulation(
    mission: Mission,
    *,
    controller: str | None = None,
    out: str | Path | h5py.File | None = None,
    group: str = "/",
    progress: Callable[[Progress], None] | None = None,
    timeout_s: float | None = None,
    autopilot: Autopilot | None = None,
    keep: bool = False,
) -> RunSummary:
    """Run one closed-loop docking simulation.

    Parameters
    ----------
    mission : Mission
        The validated mission.
    controller : str, optional
        Controller name overriding ``mission.controller.type`` (shared settings kept).
    out : path or h5py.File, optional
        Results file to write (created; an existing run there is replaced); None: no file.
    group : str
        Run group inside ``out`` (``"/"`` for one run per file).
    progress : callable, optional
        Called with a :class:`Progress` after every control step.
    timeout_s : float, optional
        Override of ``mission.docking.timeout_s``.
    autopilot : Autopilot, optional
        A prebuilt autopilot (e.g. with a nominal model that differs from the truth, or a
        modified solver), else built from the mission with
        :func:`auvdock.loop.assemble.build_autopilot`; its ``build_time_s`` is the run's
        ``setup_time_s``.
    keep : bool
        Also keep every row in memory: the summary's ``run`` is then the whole
        :class:`~auvdock.results.run.Run` (what :func:`auvdock.simulate` returns).

    Returns
    -------
    RunSummary
        Outcome figures; the same figures are stored in the results file.
    """
    t_setup = time.perf_counter()
    with SigintDeferred():  # CasADi would swallow a Ctrl-C landing in the construction
        world = simulated_world(mission)
        ap = autopilot or build_autopilot(mission, world.vehicle, world.chart, controller)
        stages = simulated_stages(mission, world, ap)
    setup_s = time.perf_counter() - t_setup if autopilot is None else ap.build_time_s
    ap.reset()
    dt = ap.dt
    vehicle, sea, dock, actuators = world.vehicle, world.sea, world.dock, stages.actuators
    recorder = stages.recorder
    assert isinstance(recorder, LoopRecorder)  # (the assembler's)
    timeout = mission.docking.timeout_s if timeout_s is None else float(timeout_s)
    tol = mission.docking.tolerance_m if world.contact is None else None
    meta: dict[str, Any] = dict(
        mission_yaml=mission.to_yaml(),
        mission_name=mission.name,
        controller=ap.name,
        extra_series=recorder.series,
        status_names=STATUS_NAMES,
        n_thrusters=vehicle.n_thrusters,
        attrs={
            "tolerance_m": math.nan if tol is None else tol,
            "criterion": mission.docking.criterion,
            "timeout_s": timeout,
            "dt_s": dt,
            "flow": world.flow.describe(),
            "vehicle": vehicle.name,
            "solver": ap.solver,
            "reads_true_flow": ap.reads_true_flow,
            "estimation": mission.estimation,
            "actuators": f"{actuators.name}: {ACTUATOR_PATHS[actuators.name]}",
            "idealisations": json.dumps(idealisations(mission, ap.reads_true_flow)),
            **(
                {}
                if sea is None
                else {"sea": sea.describe(), "dock": getattr(dock, "describe", lambda: "sinusoidal heave")()}
            ),
        },
        flush_every=flush_steps(dt),
    )
    writer: RunWriter | None = None
    memory: MemoryRecorder | None = MemoryRecorder(**meta) if keep else None
    if out is not None:
        with SigintDeferred():  # the run group is created whole, or not at all
            writer = RunWriter(out if not isinstance(out, str) else Path(out), group, **meta)
            if sea is not None:
                writer.write_sea(sea.to_arrays(), sea.attributes())
    recorder.sinks = [s for s in (writer, memory) if s is not None]
    try:
        result = closed_loop.run_closed_loop(stages, timeout_s=timeout, progress=progress)
    except BaseException:  # Ctrl-C or an error: keep every finished step, complete = False
        if writer is not None:
            writer.close()
        raise
    outcome = recorder.outcome(result, setup_s)
    run: Run | None = None
    if memory is not None:
        memory.finish(outcome)
        run = memory.run()
    path = None
    if writer is not None:
        try:
            with SigintDeferred():  # the outcome is written whole, or the run stays incomplete
                writer.finish(outcome)
        finally:
            path = Path(writer.filename)
            writer.close()
    return RunSummary(
        mission.name, ap.name, outcome, path, np.asarray(recorder.solve_times), recorder.parts_s(), run
    )
