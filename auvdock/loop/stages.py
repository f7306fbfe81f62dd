"""The stages of the one closed loop, and what passes between them.

Every command flies the same loop (:func:`auvdock.loop.closed_loop.run_closed_loop`); they differ
only in the plant, the readings and the supervisor they plug in (:class:`Stages`)::

    stage        sim, compare, sweep               fly, replay                     a stand-in vehicle
    plant        the truth model (SimulatedPlant)  a vehicle over MAVLink          its truth, its link
    readings     simulated sensors of the truth    telemetry, camera, dock link    none (its pilot is remote)
    supervisor   none                              takeover, limits, link, fence   none
    autopilot    estimation + guidance + controller (:class:`auvdock.loop.autopilot.Autopilot`)
    actuators    the mission's path (ideal or ArduSub's channels, mixer and thruster curve)
    rule         the docking rule (:class:`auvdock.loop.verdict.DockingRule`): the truth, or the estimate
    recorder     rows and outcome figures (:class:`auvdock.loop.recorder.LoopRecorder`)

This module holds the stages' protocols and the values they hand each other; it imports no stage.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from auvdock.sensing.readings import Readings

if TYPE_CHECKING:
    from auvdock.controllers.base import ControlOutput
    from auvdock.controllers.hold import DepthAttitudeHold
    from auvdock.estimation.estimate import Estimate
    from auvdock.loop.guidance import LostTrack
    from auvdock.vehicle import Vehicle
    from auvdock.vehicle.actuators import ActuatorCommand, ActuatorPath
    from auvdock.world.dock_body import Contact

__all__ = [
    "Observation",
    "TruthSample",
    "Sensed",
    "Applied",
    "Plant",
    "ReadingsStage",
    "Supervisor",
    "ControlStage",
    "DockModel",
    "RowSink",
    "LoopEnding",
    "Verdict",
    "LoopResult",
    "Progress",
    "Rule",
    "Recorder",
    "Stages",
    "NoReadings",
    "Unsupervised",
]


@dataclass
class TruthSample:
    """What a simulated plant hands its simulated sensors beside the state (none on a vehicle).

    Attributes
    ----------
    state_prev : ndarray (12,) or None
        The true state one period earlier (None at the start).
    applied_N : ndarray (n,)
        The thrust held over the period that ended, N.
    path_rate : ndarray (3,) or None
        The orbital velocity's rate along the vehicle's path, m/s^2 in {n} (a sea), else None.
    water_accel : ndarray (3,) or None
        The water's acceleration at the vehicle, m/s^2 in {n} (a sea), else None.
    """

    state_prev: np.ndarray | None
    applied_N: np.ndarray
    path_rate: np.ndarray | None = None
    water_accel: np.ndarray | None = None


@dataclass
class Observation:
    """What the plant tells the loop at one control instant.

    Attributes
    ----------
    t : float
        The instant, s (mission clock).
    state : ndarray (12,)
        The state recorded (the ``state`` column) and judged by a docking rule on the state: the truth
        in simulation, the vehicle's own estimate on a vehicle.
    true_water_ned : ndarray (3,) or None
        The true water velocity at the vehicle, m/s in {n} (current plus the waves' orbital velocity),
        where the plant knows it (simulation): the ``flow_ned_m_s`` column (NaN on a vehicle, whose
        plant records the mission's flow model as ``flow_model_ned_m_s``), the FSE controllers'
        ``flow_body_true_m_s`` and the flow-error figures.
    columns : dict
        The plant's own per-step columns (name -> array), declared by ``Plant.columns``.
    contact : Contact or None
        The truth's contact with the dock's body (``docking.criterion: capture`` in simulation):
        captured or collided ends the run.
    truth : TruthSample or None
        What the simulated sensors read besides the state (simulation only).
    """

    t: float
    state: np.ndarray
    true_water_ned: np.ndarray | None = None
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    contact: Contact | None = None
    truth: TruthSample | None = None


@dataclass
class Sensed:
    """What the readings stage makes of one observation.

    Attributes
    ----------
    readings : Readings
        What the sensors deliver for the estimation stage.
    steer : bool
        False when there is no dock to steer to (a camera that has not seen it): the loop holds depth
        and attitude.
    columns : dict
        The stage's own per-step columns (name -> array), declared by ``ReadingsStage.columns``.
    """

    readings: Readings
    steer: bool = True
    columns: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class Applied:
    """What the plant did with one command: the channels it sent (None for ideal actuators)
    and the thrust (n,, N) the thrusters push over the coming period."""

    channels_us: np.ndarray | None
    thrust_N: np.ndarray


class Plant(Protocol):
    """Where the vehicle is: the truth model (:class:`auvdock.loop.simulated_plant.SimulatedPlant`),
    a vehicle over MAVLink (:class:`auvdock.fly.plant.MavlinkPlant`) or a stand-in's truth."""

    #: The plant's own per-step columns: name -> per-row shape.
    columns: dict[str, tuple[int, ...]]

    def start(self) -> None:
        """The loop starts now (t = 0 on the plant's clock)."""
        ...

    def observe(self, t: float) -> Observation:
        """The observation at instant ``t`` (s); may raise :class:`LoopEnding`."""
        ...

    def apply(self, t: float, command: ActuatorCommand) -> Applied:
        """Apply one period's command from ``t`` (s)."""
        ...

    def advance(self, t: float, t_next: float) -> bool:
        """Move on from ``t`` to ``t_next`` (s): integrate the truth, or wait on the clock.
        False when the plant can go no further (a simulation that diverged)."""
        ...


class ReadingsStage(Protocol):
    """What the sensors read of an observation: simulated sensors of the truth
    (:class:`auvdock.sensing.simulated.SimulatedReadings`), or a vehicle's telemetry, camera and dock
    link (:class:`auvdock.fly.readings.FlyReadings`)."""

    #: The stage's own per-step columns: name -> per-row shape.
    columns: dict[str, tuple[int, ...]]

    def read(self, obs: Observation) -> Sensed:
        """The readings at ``obs.t``; may raise :class:`LoopEnding` (a sensor the flight needs lost)."""
        ...


class Supervisor(Protocol):
    """Whether a step may fly: a vehicle's safety rules (:class:`auvdock.fly.supervisor.FlySupervisor`),
    or none (:class:`Unsupervised`)."""

    def check(self, obs: Observation) -> bool:
        """True: the step flies; False: neutral this period, no row (stale telemetry, a bad link).
        Raises :class:`LoopEnding` to end the run now (an abort, a takeover)."""
        ...

    def after_step(self, out: ControlOutput) -> None:
        """A controller step was taken (too many failed solves may raise :class:`LoopEnding`)."""
        ...


class ControlStage(Protocol):
    """What turns readings into a command: the autopilot (:class:`~auvdock.loop.autopilot.Autopilot`:
    estimation stage + guidance + controller), or a stand-in vehicle's pilot on the link."""

    #: Control period, s.
    dt: float
    vehicle: Vehicle

    @property
    def last_estimate(self) -> Estimate | None:
        """The newest estimate (None without an estimator, or before its first step)."""
        ...

    @property
    def last_step_t(self) -> float | None:
        """The step instant (s) that made :attr:`last_estimate`."""
        ...

    @property
    def extra_series(self) -> dict[str, tuple[int, ...]]:
        """Per-step series it records: name -> per-row shape."""
        ...

    def step(self, readings: Readings) -> ControlOutput: ...

    def set_applied(self, thrust: np.ndarray) -> None: ...

    def finish(self, result: LoopResult) -> None:
        """The run ended with ``result``: add what the stage knows of it (the camera's losses)."""
        ...


class DockModel(Protocol):
    """The dock the docking rule judges against (the mission's, or a tracked one)."""

    @property
    def heading_rad(self) -> float: ...

    def position(self, t: float) -> np.ndarray: ...

    def velocity(self, t: float) -> np.ndarray: ...


class RowSink(Protocol):
    """Where rows go: :class:`auvdock.results.store.RunWriter` (HDF5) or an in-memory recorder."""

    def append(self, **row: Any) -> None: ...

    def finish(self, outcome: dict[str, Any]) -> None: ...

    def close(self) -> None: ...


class LoopEnding(Exception):  # noqa: N818 -- an ending, not an error
    """Raised by a stage to end the run now: ``reason`` (aborted, takeover, ...) and a message."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason
        self.message = message


@dataclass(frozen=True)
class Verdict:
    """One judgement of the docking rule.

    Attributes
    ----------
    t : float
        The instant judged, s (mission clock): the estimate's.
    basis : str
        What was judged: ``"navigation filter's estimate"``, ``"navigation filter's position"``,
        ``"position telemetry"`` (``estimation:
        truth``), ``"position telemetry and the camera's dock"`` (see the module docstring).
    distance_m : float
        The estimated distance of the vehicle from the dock, m.
    bound_m : float
        Its 95 % bound, m.
    tolerance_m : float
        The docking tolerance, m.
    """

    t: float
    basis: str
    distance_m: float
    bound_m: float
    tolerance_m: float
    #: ``docking.criterion: capture``: whether the estimate, moved back out of the cradle by its 95 %
    #: radius, is still captured (:class:`auvdock.loop.verdict.CaptureVerdict`); None: the point rule.
    captured: bool | None = None

    @property
    def docked(self) -> bool:
        """The 95 % bound is inside the tolerance (the capture rule: the estimate is captured with margin)."""
        if self.captured is not None:
            return self.captured
        return self.bound_m <= self.tolerance_m

    def describe(self) -> str:
        """One line: ``"on the estimate: 0.021 m from the dock, 95 % bound 0.049 m <= 0.05 m"``."""
        if self.captured is not None:
            said = "captured" if self.captured else "not captured"
            return (
                f"on the {self.basis}: {said} with a 95 % margin of {self.bound_m - self.distance_m:.3f} m, "
                f"{self.distance_m:.3f} m from the docking point"
            )
        rel = "<=" if self.docked else ">"
        return (
            f"on the {self.basis}: {self.distance_m:.3f} m from the dock, 95 % bound "
            f"{self.bound_m:.3f} m {rel} {self.tolerance_m:g} m"
        )


@dataclass
class LoopResult:
    """How a closed loop ended.

    ``reason``: docked, captured, collided, timeout, diverged, lost_target (the guidance gave up
    finding the dock), or a :class:`LoopEnding`'s; ``t_end`` the last instant, s; ``contact`` the
    state (12,) in which docking (or the collision) was declared; ``touch`` the contact with the
    dock's body that ended the run; ``lost_tracks`` the camera's losses of the dock
    (:class:`auvdock.loop.guidance.LostTrack`; None without a dock camera) and
    ``dock_first_seen_s`` the instant of its first fix of the dock, s (None: never seen);
    ``entry_aborts`` the entries aborted back to the hold point (``guidance.entry_gate``; None without it).
    """

    reason: str
    message: str
    t_end: float
    docked: bool = False
    contact: np.ndarray | None = None
    wall_time_s: float = 0.0
    touch: Contact | None = None
    lost_tracks: list[LostTrack] | None = None
    dock_first_seen_s: float | None = None
    entry_aborts: int | None = None
    verdict: Verdict | None = None


@dataclass
class Progress:
    """Progress of a running loop, passed to the ``progress`` callback after every step."""

    t: float
    timeout_s: float
    distance_m: float
    solve_time_s: float
    status: int
    step: int


class Rule(Protocol):
    """The docking rule (:class:`auvdock.loop.verdict.DockingRule`)."""

    def judge(self, obs: Observation, stage: ControlStage, seeing: bool) -> tuple[float, LoopResult | None]:
        """(distance from the dock (m), the ending or None) at ``obs``; ``seeing``: the dock in sight."""
        ...

    def finish(self, result: LoopResult) -> None: ...


class Recorder(Protocol):
    """Rows and outcome figures (:class:`auvdock.loop.recorder.LoopRecorder`)."""

    def row(
        self,
        obs: Observation,
        *,
        thrust_N: np.ndarray,
        channels_us: np.ndarray | None,
        distance_m: float,
        solve_time_s: float,
        status: int,
        series: dict[str, np.ndarray],
        columns: dict[str, np.ndarray] | None = None,
    ) -> None: ...

    def final(self, obs: Observation, distance_m: float, channels_us: np.ndarray | None) -> None: ...

    def controlled(
        self,
        obs: Observation,
        out: ControlOutput,
        *,
        distance_m: float,
        channels_us: np.ndarray | None,
        columns: dict[str, np.ndarray],
    ) -> None: ...


@dataclass
class Stages:
    """The stages of one closed loop, as a command plugs them in (see the module docstring).

    ``hold`` flies the instants with no dock to steer to (``Sensed.steer`` False); required where the
    readings can report that."""

    plant: Plant
    readings: ReadingsStage
    supervisor: Supervisor
    autopilot: ControlStage
    actuators: ActuatorPath
    rule: Rule
    recorder: Recorder
    hold: DepthAttitudeHold | None = None


class NoReadings:
    """The readings of a stage that reads none (a stand-in vehicle, whose pilot is on the link)."""

    columns: dict[str, tuple[int, ...]] = {}

    def read(self, obs: Observation) -> Sensed:
        return Sensed(Readings(obs.t))


class Unsupervised:
    """No supervisor: every step flies (simulation; a stand-in's own failsafe is its plant's)."""

    def check(self, obs: Observation) -> bool:
        return True

    def after_step(self, out: ControlOutput) -> None:
        """Nothing to watch."""
