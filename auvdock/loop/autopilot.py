"""The one estimation-and-control step that serves every command: readings in, thrust out.

:meth:`Autopilot.step` runs the estimation stage (:mod:`auvdock.estimation.stage`) on one
instant's :class:`~auvdock.sensing.readings.Readings` and the controller on its
:class:`~auvdock.estimation.estimate.Estimate`.  Where the readings come from (the simulated
sensors or a vehicle's telemetry) and where the thrust goes (the actuator path into the truth
model or MAVLink) are the closed loop's business (:mod:`auvdock.loop.closed_loop`).
:func:`auvdock.loop.assemble.build_autopilot` builds the step from a mission.
"""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING

import numpy as np

from auvdock.config.guidance import GuidanceSettings
from auvdock.controllers import Controller, ControlOutput, build_controller, resolve_solver
from auvdock.controllers.registry import CONTROLLERS
from auvdock.controllers.settings import MPCSettings
from auvdock.controllers.status import STATUS_LOST_TARGET, STATUS_SETTLING
from auvdock.controllers.world import ControllerWorld
from auvdock.estimation.settings import EstimatorSettings
from auvdock.estimation.stage import EstimationStage, TruthStage
from auvdock.loop.guidance import GUIDANCE_SERIES, Guidance
from auvdock.runtime import timing
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.sensing.readings import Reading, Readings
from auvdock.sensing.settings import SensorSettings
from auvdock.vehicle import Vehicle

if TYPE_CHECKING:
    from auvdock.estimation.delay import DelayCompensation, ThrustSchedule
    from auvdock.estimation.estimate import Estimate
    from auvdock.loop.stages import LoopResult
    from auvdock.world.dock import DockMotion

__all__ = ["Autopilot"]


class Autopilot:
    """Controller (+ estimator) for one run.  Build once, call :meth:`step` every period.

    Parameters
    ----------
    settings : MPCSettings
        The controller's settings (its ``type`` picks it from the registry).
    vehicle, dock : Vehicle, DockMotion
        The vehicle model and the dock whose motion is known (Assumption 2).
    estimator, sensors : EstimatorSettings, SensorSettings, optional
        The flow estimator's settings and the sensor noise it accounts for.
    estimation : EstimationStage, optional
        The estimation stage (:func:`auvdock.loop.assemble.build_estimation`); default
        :class:`~auvdock.estimation.stage.TruthStage` (``estimation: truth``).
    guidance : Guidance, optional
        What the controllers steer to (:mod:`auvdock.loop.guidance`: the dock where the estimate
        places it; with a dock camera, the approach and the lost-target policy); default: the
        dock, always.
    world : ControllerWorld, optional
        What the controller is told beyond its estimate: the dock's entry corridor, the true sea
        (Oracle); default: neither.

    Attributes
    ----------
    delay : DelayCompensation or None
        Delay-aware estimation (``fly``: :mod:`auvdock.estimation.delay`): the estimate predicted to
        the instant the command acts, the estimation stage given the thrust that acted; None: none.
    last_estimate : Estimate or None
        The estimation stage's newest estimate (what a vehicle's docking verdict judges,
        :mod:`auvdock.loop.verdict`); None before the first step.  Its ``t`` is the instant it
        estimates (with :attr:`delay`, its newest reading's sample time).
    last_step_t : float or None
        The step (s, mission clock) that made it.
    build_time_s : float
        Wall time spent building the controller (solver construction and, on first use
        of a problem, compiling it), s.  Kept out of a run's ``wall_time_s``.
    """

    def __init__(
        self,
        settings: MPCSettings,
        vehicle: Vehicle,
        dock: DockMotion,
        estimator: EstimatorSettings | None = None,
        sensors: SensorSettings | None = None,
        estimation: EstimationStage | None = None,
        guidance: Guidance | None = None,
        world: ControllerWorld | None = None,
    ) -> None:
        t0 = time.perf_counter()
        self.estimation: EstimationStage = TruthStage() if estimation is None else estimation
        self.settings = settings
        self.vehicle = vehicle
        self.dock = dock
        self.guidance = Guidance(GuidanceSettings(), dock, camera=False) if guidance is None else guidance
        # built whole: CasADi's argument checks clear a KeyboardInterrupt raised inside them
        with SigintDeferred():
            self.controller: Controller = build_controller(
                settings, vehicle, self.guidance.target, estimator, sensors, world
            )
        self.world = world or ControllerWorld()
        self.name = self.controller.name
        self.dt = settings.dt_s
        self.solver = resolve_solver(settings.solver.name, self.name, settings.variant)
        self.reads_true_flow = CONTROLLERS[self.name].reads_true_flow
        self.u_prev = np.zeros(vehicle.n_thrusters)
        self.u_applied = np.zeros(vehicle.n_thrusters)
        self.last_estimate: Estimate | None = None
        self.delay: DelayCompensation | None = None
        self._t_last: float | None = None
        self._t_info: float | None = None
        self._held: list[Reading] = []
        self.build_time_s = time.perf_counter() - t0

    @property
    def last_step_t(self) -> float | None:
        """The step instant (s) of :attr:`last_estimate` (None before the first step)."""
        return self._t_last

    @property
    def extra_series(self) -> dict[str, tuple[int, ...]]:
        """Extra per-step series this autopilot records (name -> per-row shape)."""
        series = dict(getattr(self.controller, "extra_series", {}))
        series.update(self.estimation.series_shapes)
        if self.guidance.records:
            series.update(GUIDANCE_SERIES)
        if self.delay is not None:
            series["estimate_lead_s"] = ()  # how far the estimate was predicted (its age + the command delay)
        return series

    @property
    def navigation(self) -> EstimationStage | None:
        """The estimation stage where it is a filter (``estimation: filter``), else None."""
        return None if self.estimation.mode == "truth" else self.estimation

    def reset(self) -> None:
        """Start a new run."""
        self.controller.reset()
        self.estimation.reset()
        self.guidance.reset()
        self.u_prev = np.zeros(self.vehicle.n_thrusters)
        self.u_applied = np.zeros(self.vehicle.n_thrusters)
        self.last_estimate = None
        self._t_last = None
        self._t_info = None
        self._held = []
        if self.delay is not None:
            self.delay.reset()

    def set_applied(self, thrust: np.ndarray) -> None:
        """The thrust (n,, N) the thrusters really produce over the coming period, where the
        actuator path changes the command (``fly``: ArduSub's six override channels, its mixer
        and the thrusters' dead band; zero while disarmed).  The estimation stage predicts with
        it; by default it is the command (``sim``).  With :attr:`delay` it is remembered as sent at
        this step, to act the command delay later."""
        self.u_applied = np.asarray(thrust, dtype=float).copy()
        if self.delay is not None and self._t_last is not None:
            self.delay.history.sent(self._t_last, self.u_applied)

    def finish(self, result: LoopResult) -> None:
        """The run ended with ``result``: with a dock camera, the guidance's record of its losses of the
        dock and its first fix go into the result; with the entry gate, its aborted entries."""
        g = self.guidance
        if g.camera:
            g.finish(result.t_end, result.reason)
            result.lost_tracks = list(g.events)
            result.dock_first_seen_s = g.first_fix_t
        if g.corridor is not None:  # the entry timed to the sea: how often it backed out
            result.entry_aborts = g.aborts

    def step(self, readings: Readings) -> ControlOutput:
        """One control step: estimate from the readings, solve, and return the thrust to hold
        for one period (the controller's command; the actuator path may change it, see
        :meth:`set_applied`)."""
        t0 = time.perf_counter()
        timing.begin()
        u_acted: np.ndarray | ThrustSchedule = self.u_applied
        delay = self.delay
        t_step = readings.t
        to_estimate = readings
        if delay is not None:
            # the stage estimates the instant of its newest reading (a link makes every one late); the
            # forward prediction takes it on from there, under the thrust that acted meanwhile
            suite = self._held + list(readings.suite)
            sampled = [r.t for r in suite]
            if readings.state_t is not None:
                sampled.append(readings.state_t)
            if sampled:
                t_info = min(t_step, max(sampled))
            else:  # nothing new (a burst of losses): the estimate stays where its readings are
                t_info = t_step if self._t_info is None else self._t_info
            if suite and delay.hold_back_s > 0:  # wait for the readings the jitter delays
                t_info -= delay.hold_back_s
            if self._t_info is not None:
                t_info = max(t_info, self._t_info)
                u_acted = delay.acted(self._t_info, t_info)
            self._t_info = t_info
            self._held = [r for r in suite if r.t > t_info + 1e-9]
            due = [r for r in suite if r.t <= t_info + 1e-9]
            to_estimate = dataclasses.replace(readings, t=t_info, suite=due)
        self._t_last = t_step
        if self.estimation.mode == "truth":  # the state as given: nothing to time
            est, recorded = self.estimation.step(to_estimate, u_acted)
        else:
            with timing.part("estimation"):
                est, recorded = self.estimation.step(to_estimate, u_acted)
        self.last_estimate = est
        if delay is not None:
            with timing.part("delay prediction"):
                est = delay.forward(est, t_step, self.reads_true_flow)
            recorded = {**recorded, "estimate_lead_s": np.asarray(delay.last_horizon_s)}
        steering = self.guidance.update(est)
        if self.guidance.records:
            recorded = {**recorded, **steering}
        lost = self.guidance.phase == "given_up"
        if lost or self.estimation.settling(readings.t):  # no control on a filter that has not settled
            nan = {k: np.full(s, np.nan) for k, s in self.extra_series.items() if k not in recorded}
            out = ControlOutput(
                np.zeros(self.vehicle.n_thrusters),
                STATUS_LOST_TARGET if lost else STATUS_SETTLING,
                series={**nan, **recorded},
            )
            out.solve_time_s = time.perf_counter() - t0
            out.time_parts = timing.end()
            self.u_prev = out.thrust.copy()
            self.u_applied = out.thrust.copy()
            return out
        if not self.reads_true_flow:
            est = est.without_flow()
        out = self.controller.step(est, self.u_prev)
        out.series.update(recorded)
        out.solve_time_s = time.perf_counter() - t0
        out.time_parts = timing.end()
        self.u_prev = out.thrust.copy()
        self.u_applied = out.thrust.copy()
        return out
