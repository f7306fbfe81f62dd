"""The one closed loop: plant -> sensors -> estimation and control -> actuators -> plant.

Every command that flies the controller runs :func:`run_closed_loop` (``sim``, the ``compare``
and ``sweep`` workers, ``fly`` on a vehicle, ``replay`` of a flight); they differ only in the
stages they hand it, as do-mpc's ``y = plant.step(u); x = estimator.step(y); u =
controller.step(x)``::

    for k in 0, 1, ...:                       t = k dt, on the plant's clock
        obs = plant.observe(t)                the state judged, the readings, the water
        docked?  -> final row, end            (the docking rule: on obs.state, or a vehicle's
                                              verdict on its estimate, auvdock.loop.verdict)
        no readings (stale)? -> neutral, next
        no dock to steer to? -> hold wrench   (DepthAttitudeHold through the actuators)
        else: out = autopilot.step(readings)  estimation stage + controller
              cmd = actuators.command(out.thrust)
        applied = plant.apply(t, cmd)         what the thrusters push (channels sent)
        autopilot.set_applied(applied)        the estimation stage predicts with it
        recorder.row(...)                     one results row
        plant.advance(t, t + dt)              integrate the truth / wait on the clock
    after the last period: the final state judged as at a step (docked or timed out)

A step runs whole: a Ctrl-C inside it is raised when it ends (after its row), so CasADi
never swallows one and no row is cut in two (:class:`auvdock.runtime.interrupts.SigintDeferred`).
A plant ends a run early by raising :class:`LoopEnding` (fly's safety aborts and takeovers);
every other exception, Ctrl-C included, propagates with every finished row recorded.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from auvdock.controllers.status import (
    FAILURE_CODES,
    STATUS_HOLD,
    STATUS_LOST_TARGET,
    STATUS_NAMES,
    STATUS_NO_STEP,
)
from auvdock.estimation.stage import FORECAST_HORIZONS_S, forecast_rmse_key
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.sensing.readings import Readings
from auvdock.vehicle.actuators import ActuatorCommand, ActuatorPath
from auvdock.vehicle.geometry import rotation_of, wrap_angle
from auvdock.vehicle.state import ATT, LIN, POS, YAW

if TYPE_CHECKING:
    from auvdock.controllers.base import ControlOutput
    from auvdock.controllers.hold import DepthAttitudeHold
    from auvdock.loop.guidance import LostTrack
    from auvdock.loop.verdict import CaptureVerdict, MarginVerdict, Verdict
    from auvdock.vehicle import Vehicle
    from auvdock.world.dock_body import Contact

__all__ = [
    "Observation",
    "Applied",
    "Plant",
    "ControlStage",
    "DockModel",
    "RowSink",
    "LoopEnding",
    "LoopResult",
    "Progress",
    "LoopRecorder",
    "run_closed_loop",
    "run_outcome",
]


@dataclass
class Observation:
    """What the plant tells the loop at one control instant.

    Attributes
    ----------
    t : float
        The instant, s (mission clock).
    state : ndarray (12,)
        The state recorded (the ``state`` column) and judged by the docking rule: the truth
        in simulation, the vehicle's own estimate on a vehicle.
    flow_ned : ndarray (3,)
        The water velocity at the vehicle recorded (``flow_ned_m_s``), m/s in {n}: the truth
        in simulation, the mission's flow model on a vehicle.
    readings : Readings or None
        What the sensors deliver for the estimation stage; None when nothing fresh arrived
        (stale telemetry): the loop then commands neutral and records no row.
    steer : bool
        False when there is no dock to steer to (a camera that has not seen it): the loop
        holds depth and attitude.
    true_flow_ned : ndarray (3,) or None
        The true flow at the vehicle where the plant knows it (simulation), for the FSE
        controllers' ``flow_body_true_m_s`` and the flow-error figures.
    columns : dict
        The plant's own per-step columns (name -> array), declared by ``Plant.columns``.
    contact : Contact or None
        The truth's contact with the dock's body (``docking.criterion: capture`` in simulation):
        captured or collided ends the run.
    """

    t: float
    state: np.ndarray
    flow_ned: np.ndarray
    readings: Readings | None
    steer: bool = True
    true_flow_ned: np.ndarray | None = None
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    contact: Contact | None = None


@dataclass
class Applied:
    """What the plant did with one command: the channels it sent (None for ideal actuators)
    and the thrust (n,, N) the thrusters push over the coming period."""

    channels_us: np.ndarray | None
    thrust_N: np.ndarray


class Plant(Protocol):
    """Where the vehicle is: the truth model (:class:`auvdock.loop.simulated_plant.SimulatedPlant`)
    or a vehicle over MAVLink (:class:`auvdock.fly.plant.MavlinkPlant`)."""

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

    def after_step(self, out: ControlOutput) -> None:
        """A controller step was taken (a safety monitor may raise :class:`LoopEnding`)."""
        ...


class ControlStage(Protocol):
    """What turns readings into a command: the autopilot (:class:`~auvdock.loop.autopilot.Autopilot`:
    estimation stage + controller), or a stand-in vehicle's pilot on the link."""

    #: Control period, s.
    dt: float
    vehicle: Vehicle

    @property
    def extra_series(self) -> dict[str, tuple[int, ...]]:
        """Per-step series it records: name -> per-row shape."""
        ...

    def step(self, readings: Readings) -> ControlOutput: ...

    def set_applied(self, thrust: np.ndarray) -> None: ...


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
    """Raised by a plant to end the run now: ``reason`` (aborted, takeover, ...) and a message."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason
        self.message = message


@dataclass
class LoopResult:
    """How a closed loop ended.

    ``reason``: docked, captured, collided, timeout, diverged, lost_target (the guidance gave up
    finding the dock), or a :class:`LoopEnding`'s; ``t_end`` the last instant, s; ``contact`` the
    state (12,) in which docking (or the collision) was declared; ``touch`` the contact with the
    dock's body that ended the run; ``lost_tracks`` the camera's losses of the dock
    (:class:`auvdock.loop.guidance.LostTrack`; None without a dock camera) and
    ``dock_first_seen_s`` the instant of its first fix of the dock, s (None: never seen).
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


def run_outcome(
    *,
    docked: bool,
    t_end: float,
    states: list[np.ndarray],
    distances: list[float],
    solve_times: list[float],
    statuses: list[int],
    contact_state: np.ndarray | None,
    dock_velocity: np.ndarray | None,
    dock_heading: float,
    rotation: Callable[[np.ndarray], np.ndarray],
    wall_time_s: float,
    reason: str,
    setup_time_s: float = 0.0,
) -> dict[str, Any]:
    """The outcome figures of a run (see the docs' results layout).

    ``wall_time_s`` is the run's own wall time (the loop); ``setup_time_s`` the time spent
    building the controller before it (compiling on first use), reported on its own.
    """
    pos = np.array([s[POS] for s in states]) if states else np.zeros((0, 3))
    if contact_state is not None:
        pos = np.vstack([pos, contact_state[POS]])
    path_length = float(np.sum(np.linalg.norm(np.diff(pos, axis=0), axis=1))) if len(pos) > 1 else 0.0
    st = np.asarray(solve_times, dtype=float)
    contact_speed = heading_err = math.nan
    if docked and contact_state is not None and dock_velocity is not None:
        v_ned = rotation(contact_state[ATT]) @ contact_state[LIN]
        contact_speed = float(np.linalg.norm(v_ned - dock_velocity))
        heading_err = wrap_angle(float(contact_state[YAW]) - dock_heading)
    return {
        "docked": bool(docked),
        "reason": reason,
        "time_to_dock_s": float(t_end) if docked else math.nan,
        "end_time_s": float(t_end),
        "contact_speed_m_s": contact_speed,
        "heading_error_rad": heading_err,
        "closest_approach_m": float(min(distances)) if distances else math.nan,
        "path_length_m": path_length,
        "n_steps": len(states),
        "solver_failures": int(np.sum(np.isin(statuses, FAILURE_CODES))) if statuses else 0,
        "solve_time_median_s": float(np.median(st)) if st.size else math.nan,
        "solve_time_p95_s": float(np.percentile(st, 95)) if st.size else math.nan,
        "solve_time_p99_s": float(np.percentile(st, 99)) if st.size else math.nan,
        "solve_time_max_s": float(np.max(st)) if st.size else math.nan,
        "wall_time_s": float(wall_time_s),
        "setup_time_s": float(setup_time_s),
        "real_time_factor": float(t_end / wall_time_s) if wall_time_s > 0 else math.nan,
    }


class LoopRecorder:
    """Rows of one run into its sinks, and the figures its outcome is computed from.

    Parameters
    ----------
    sinks : list of RowSink
        Where every row goes (a results file, memory; none for a run kept nowhere).
    vehicle : Vehicle
        The model (the wrench column ``B u``, the thruster count).
    dock : DockModel
        The dock recorded (position, velocity) and judged against.
    extra_series : dict
        The autopilot's series (name -> per-row shape): NaN in rows without a controller step.
    plant_columns : dict
        The plant's own columns (name -> per-row shape).
    channels : bool
        Record ``channels_us`` (6,): the RC override channels of the ArduSub actuator path.
    keep : bool
        Keep the per-step figures the outcome is computed from (False for a stand-in vehicle
        that runs until stopped: its memory stays flat).
    capture : bool
        The run is judged on contact with the dock's body (``docking.criterion: capture``): the
        outcome has ``captured``, ``collided``, ``impact_speed_m_s``, ``contact_what``,
        ``contact_point_ned_m`` and ``nose_dock_m``.
    """

    def __init__(
        self,
        sinks: list[RowSink],
        *,
        vehicle: Vehicle,
        dock: DockModel,
        extra_series: dict[str, tuple[int, ...]],
        plant_columns: dict[str, tuple[int, ...]],
        channels: bool,
        keep: bool = True,
        capture: bool = False,
    ) -> None:
        self.sinks = list(sinks)
        self.keep = bool(keep)
        self.vehicle = vehicle
        self.dock = dock
        self.extra_series = dict(extra_series)
        self.plant_columns = dict(plant_columns)
        self.channels = bool(channels)
        self.capture = bool(capture)
        self.states: list[np.ndarray] = []
        self.distances: list[float] = []
        self.solve_times: list[float] = []
        self.statuses: list[int] = []
        self.time_parts: list[dict[str, float]] = []
        self.flow_errors: list[float] = []
        #: The navigation filter's errors (``estimation: filter``): the vehicle's position relative
        #: to the dock (m) and the horizontal current (m/s), against the truth, per controller step.
        self.relative_errors: list[float] = []
        self.current_errors: list[float] = []
        #: The dock's motion forecast from its telemetry (``dock_forecast_m``): per controller step, the
        #: error (m, norm) of the displacement forecast over each of its horizons against the truth's.
        self.forecast_errors: list[np.ndarray] = []
        rotation = vehicle.model.function("rotation")
        self._rotation = lambda angles: np.asarray(rotation(angles))
        self._nan_series = {name: np.full(shape, np.nan) for name, shape in self.extra_series.items()}
        self._nan_columns = {name: np.full(shape, np.nan) for name, shape in self.plant_columns.items()}

    @property
    def series(self) -> dict[str, tuple[int, ...]]:
        """Every series beyond the base datasets (for a sink's ``extra_series``)."""
        out = {**self.extra_series, **self.plant_columns}
        if self.channels:
            out["channels_us"] = (6,)
        return out

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
    ) -> None:
        """One row: the observation, the thrust recorded, the step's figures and series."""
        if not self.sinks:
            return
        t, x = obs.t, obs.state
        u = np.asarray(thrust_N, dtype=float)
        row: dict[str, Any] = dict(
            time_s=t,
            state=x,
            thrust_N=u,
            wrench=self.vehicle.allocation @ u,
            flow_ned_m_s=obs.flow_ned,
            dock_position_m=self.dock.position(t),
            dock_velocity_m_s=self.dock.velocity(t),
            distance_m=distance_m,
            solve_time_s=solve_time_s,
            solver_status=status,
            **{**self._nan_series, **series},
            **{**self._nan_columns, **obs.columns},
        )
        if self.channels:
            row["channels_us"] = np.full(6, np.nan) if channels_us is None else channels_us
        for sink in self.sinks:
            sink.append(**row)

    def stepped(self, obs: Observation, distance_m: float, out: ControlOutput) -> None:
        """Count a controller step into the outcome figures."""
        if not self.keep:
            return
        x_est = out.series.get("estimated_state")
        dock_est = out.series.get("estimated_dock_position_m")
        if x_est is not None and dock_est is not None and np.all(np.isfinite(x_est)):
            rel_true = obs.state[POS] - self.dock.position(obs.t)
            self.relative_errors.append(float(np.linalg.norm(rel_true - (x_est[POS] - dock_est))))
            cur = out.series.get("estimated_flow_ned_m_s")
            if cur is not None and obs.true_flow_ned is not None:
                self.current_errors.append(float(np.linalg.norm(cur[0:2] - obs.true_flow_ned[0:2])))
        forecast = out.series.get("dock_forecast_m")
        if forecast is not None and dock_est is not None and np.all(np.isfinite(forecast)):
            now = self.dock.position(obs.t)
            moved_true = np.array([self.dock.position(obs.t + h) - now for h in FORECAST_HORIZONS_S])
            moved_forecast = np.asarray(forecast) - dock_est
            self.forecast_errors.append(np.linalg.norm(moved_forecast - moved_true, axis=1))
        self.states.append(obs.state.copy())
        self.distances.append(distance_m)
        self.solve_times.append(out.solve_time_s)
        self.time_parts.append(out.time_parts)
        self.statuses.append(out.status)

    def outcome(self, result: LoopResult, setup_time_s: float = 0.0) -> dict[str, Any]:
        """The outcome figures of the run that ended with ``result``."""
        outcome = run_outcome(
            docked=result.docked,
            t_end=result.t_end,
            states=self.states,
            distances=self.distances,
            solve_times=self.solve_times,
            statuses=self.statuses,
            contact_state=result.contact,
            dock_velocity=self.dock.velocity(result.t_end) if result.docked else None,
            dock_heading=self.dock.heading_rad,
            rotation=self._rotation,
            wall_time_s=result.wall_time_s,
            reason=result.reason,
            setup_time_s=setup_time_s,
        )
        if self.capture:
            touch = result.touch
            nan3 = np.full(3, np.nan)
            collided = touch is not None and touch.status == "collided"
            outcome.update(
                captured=bool(result.docked),
                collided=bool(collided),
                impact_speed_m_s=math.nan,
                contact_what="",
                contact_point_ned_m=nan3,
                nose_dock_m=nan3,
            )
            if touch is not None:
                outcome.update(
                    impact_speed_m_s=float(touch.impact_speed_m_s) if collided else math.nan,
                    contact_what=touch.what,
                    contact_point_ned_m=np.asarray(touch.contact_point_ned, dtype=float),
                    nose_dock_m=np.asarray(touch.nose_dock_m, dtype=float),
                )
                outcome["contact_speed_m_s"] = float(touch.relative_speed_m_s)
                outcome["heading_error_rad"] = float(touch.heading_error_rad)
        if result.lost_tracks is not None:
            from auvdock.loop.guidance import lost_track_summary

            outcome.update(lost_track_summary(result.lost_tracks, result.dock_first_seen_s))
        if self.relative_errors:
            e = np.asarray(self.relative_errors)
            outcome["relative_position_rmse_m"] = float(np.sqrt(np.mean(e**2)))
            outcome["relative_position_final_error_m"] = float(e[-1])
        if self.current_errors:
            e = np.asarray(self.current_errors)
            outcome["navigation_current_rmse_m_s"] = float(np.sqrt(np.mean(e**2)))
        if self.forecast_errors:
            rms = np.sqrt(np.mean(np.square(self.forecast_errors), axis=0))
            for h, v in zip(FORECAST_HORIZONS_S, rms, strict=True):
                outcome[forecast_rmse_key(h)] = float(v)
        if self.flow_errors:
            e = np.asarray(self.flow_errors)
            outcome["flow_rmse_m_s"] = float(np.sqrt(np.mean(e**2)))
            outcome["flow_final_error_m_s"] = float(e[-1])
        statuses = self.statuses
        outcome["status_counts"] = ", ".join(
            f"{STATUS_NAMES[s]}: {statuses.count(s)}" for s in sorted(set(statuses))
        )
        return outcome

    def parts_s(self) -> dict[str, np.ndarray]:
        """Where each step's time went: part name -> (steps,) s, zero where a step had none."""
        names = sorted({name for parts in self.time_parts for name in parts})
        return {name: np.array([parts.get(name, 0.0) for parts in self.time_parts]) for name in names}


@contextlib.contextmanager
def _whole() -> Iterator[None]:
    with SigintDeferred():
        yield


def run_closed_loop(
    *,
    plant: Plant,
    autopilot: ControlStage,
    actuators: ActuatorPath,
    recorder: LoopRecorder,
    dock: DockModel,
    tolerance_m: float | None,
    timeout_s: float,
    hold: DepthAttitudeHold | None = None,
    progress: Callable[[Progress], None] | None = None,
    on_event: Callable[[str], None] | None = None,
    step_guard: Callable[[], contextlib.AbstractContextManager[Any]] = _whole,
    control_guard: Callable[[], contextlib.AbstractContextManager[Any]] = contextlib.nullcontext,
    verdict: MarginVerdict | CaptureVerdict | None = None,
) -> LoopResult:
    """Run one closed loop to its ending (see the module docstring).

    Parameters
    ----------
    plant : Plant
        The truth model or a vehicle.
    autopilot : ControlStage
        The estimation stage and the controller (reset by the caller), or a stand-in vehicle's
        pilot on the link.
    actuators : ActuatorPath
        The controller's thrust -> what the thrusters push.
    recorder : LoopRecorder
        Rows and outcome figures.
    dock : DockModel
        The dock the docking rule judges against.
    tolerance_m : float or None
        Docked within ``tolerance_m`` (m) of the dock; None: no verdict (a stand-in vehicle:
        the flight it serves decides).
    timeout_s : float
        The run ends at ``timeout_s`` (s); ``math.inf``: when the plant ends it.
    hold : DepthAttitudeHold, optional
        The controller for instants with no dock to steer to (``Observation.steer`` False);
        required by plants that can report that.
    progress : callable, optional
        Called with a :class:`Progress` after every controller step.
    on_event : callable, optional
        Called with a line of text when something happens (a hold starts).
    step_guard : callable
        Context for one whole step (default: Ctrl-C held back to the step's end).
    control_guard : callable
        Context for the autopilot's step alone (fly: what CasADi prints is counted, not shown).
    verdict : MarginVerdict or CaptureVerdict, optional
        A vehicle's docking rule on its newest estimate (the autopilot's ``last_estimate``): the 95 %
        bound of its distance from the dock within ``tolerance_m``, or (``docking.criterion: capture``)
        captured with a 95 % margin; None: ``obs.state`` within ``tolerance_m`` (the truth, in simulation).

    Returns
    -------
    LoopResult
        docked, timeout or diverged; a plant's :class:`LoopEnding` becomes the result too.
    """
    dt = autopilot.dt
    n_max = int(math.ceil(timeout_s / dt - 1e-9)) if math.isfinite(timeout_s) else -1
    wall0 = time.perf_counter()
    result: LoopResult | None = None
    zero = np.zeros(autopilot.vehicle.n_thrusters)
    true_flow_series = "flow_body_true_m_s" in autopilot.extra_series

    def final(obs: Observation, dist: float) -> None:
        neutral = actuators.neutral()
        recorder.row(
            obs,
            thrust_N=zero,
            channels_us=neutral.channels_us,
            distance_m=dist,
            solve_time_s=math.nan,
            status=STATUS_NO_STEP,
            series={},
        )

    try:
        plant.start()
        t_end = 0.0
        for k in range(n_max + 1) if n_max >= 0 else itertools.count():
            t = k * dt
            with step_guard():
                obs = plant.observe(t)
                x = obs.state
                if not np.all(np.isfinite(x)):
                    final(obs, math.nan)
                    result = LoopResult("diverged", f"the state went non-finite at t = {t:.2f} s", t)
                    break
                dist = float(np.linalg.norm(x[POS] - dock.position(obs.t)))  # the plant's instant
                touch = obs.contact
                if touch is not None and touch.status != "free":
                    recorder.distances.append(dist)
                    final(obs, dist)
                    captured = touch.status == "captured"
                    what = f"{touch.describe()} at t = {t:.2f} s"
                    result = LoopResult(touch.status, what, t, captured, x.copy(), touch=touch)
                    break
                judged = None
                if verdict is not None and tolerance_m is not None:
                    est = getattr(autopilot, "last_estimate", None)
                    stepped = getattr(autopilot, "last_step_t", None)  # the step that made it (not its age)
                    fresh = est is not None and stepped is not None and obs.t - stepped <= 2.0 * dt + 1e-9
                    judged = verdict.judge(est if fresh else None)
                    inside = judged is not None and judged.docked
                else:
                    inside = tolerance_m is not None and dist <= tolerance_m
                if inside and obs.steer:  # (not out of sight)
                    recorder.distances.append(dist)
                    final(obs, dist)
                    said = f"docked at t = {t:.2f} s" + ("" if judged is None else f" ({judged.describe()})")
                    result = LoopResult("docked", said, t, True, x.copy(), verdict=judged)
                    break
                if k == n_max:  # the state after the last period: judged, not flown
                    recorder.distances.append(dist)
                    final(obs, dist)
                    break
                if obs.readings is None:  # nothing fresh to estimate on: neutral, no row
                    plant.apply(t, actuators.neutral())
                    if not plant.advance(t, t + dt):
                        break
                    t_end = t + dt
                    continue
                if not obs.steer:
                    if hold is None:
                        raise ValueError("the plant has no dock to steer to, and the loop no hold controller")
                    if not hold.active:
                        hold.start(x)
                        if on_event is not None:
                            on_event(
                                f"holding depth {x[2]:.2f} m and heading {np.degrees(x[5]):.1f} deg "
                                "until the dock is seen"
                            )
                    applied = plant.apply(t, actuators.command_wrench(hold.wrench(x)))
                    recorder.row(
                        obs,
                        thrust_N=applied.thrust_N,
                        channels_us=applied.channels_us,
                        distance_m=dist,
                        solve_time_s=0.0,
                        status=STATUS_HOLD,
                        series={},
                    )
                else:
                    if hold is not None:
                        hold.stop()
                    with control_guard():
                        out = autopilot.step(obs.readings)
                    cmd = (
                        actuators.command(out.thrust)
                        if out.channels_us is None
                        else actuators.from_channels(out.channels_us)
                    )
                    applied = plant.apply(t, cmd)
                    autopilot.set_applied(applied.thrust_N)
                    series = dict(out.series)
                    if true_flow_series:
                        if obs.true_flow_ned is None:  # unknown on a vehicle
                            series["flow_body_true_m_s"] = np.full(3, np.nan)
                        else:
                            f_true = rotation_of(x[ATT]).T @ obs.true_flow_ned
                            series["flow_body_true_m_s"] = f_true
                            err = float(np.linalg.norm(out.series["flow_estimate_m_s"] - f_true))
                            if math.isfinite(err):  # (no estimate while the filter settles)
                                recorder.flow_errors.append(err)
                    recorder.stepped(obs, dist, out)
                    recorder.row(
                        obs,
                        thrust_N=out.thrust,
                        channels_us=applied.channels_us,
                        distance_m=dist,
                        solve_time_s=out.solve_time_s,
                        status=out.status,
                        series=series,
                    )
                    if progress is not None:
                        progress(Progress(t, timeout_s, dist, out.solve_time_s, out.status, k))
                    plant.after_step(out)
                    if out.status == STATUS_LOST_TARGET:  # the guidance gave up: neutral, the end
                        plant.apply(t, actuators.neutral())
                        result = LoopResult("lost_target", f"gave up finding the dock at t = {t:.2f} s", t)
                        break
                ok = plant.advance(t, t + dt)
                t_end = t + dt
                if not ok:
                    continue  # the next observation shows the non-finite state
        if result is None:
            result = LoopResult("timeout", f"not docked within {timeout_s:g} s", t_end)
    except LoopEnding as e:
        result = LoopResult(e.reason, e.message, t_end)
    result.wall_time_s = time.perf_counter() - wall0
    if verdict is not None and result.verdict is None:
        result.verdict = verdict.closest
    guidance = getattr(autopilot, "guidance", None)
    if guidance is not None and guidance.camera:
        guidance.finish(result.t_end, result.reason)
        result.lost_tracks = list(guidance.events)
        result.dock_first_seen_s = guidance.first_fix_t
    return result
