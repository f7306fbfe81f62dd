"""The one closed loop: plant -> readings -> estimation, guidance and control -> actuators -> plant.

Every command that flies the controller runs :func:`run_closed_loop` (``sim``, the ``compare``
and ``sweep`` workers, ``fly`` on a vehicle, ``replay`` of a flight, the stand-in vehicles); they
differ only in the stages they plug in (:class:`auvdock.loop.stages.Stages`), as do-mpc's
``y = plant.step(u); x = estimator.step(y); u = controller.step(x)``::

    for k in 0, 1, ...:                      t = k dt, on the plant's clock
        obs = plant.observe(t)               the state judged, the truth where known
        supervisor.check(obs)?               (fly) may the step fly? False: neutral, no row
        sensed = readings.read(obs)          what the sensors deliver
        rule.judge(obs)                      docked, captured, collided, diverged? -> final row, end
        no dock in sight? -> hold            (depth and attitude, through the actuators)
        else: out = autopilot.step(...)      estimation + guidance + controller
              plant.apply(actuators(out))    what the thrusters push
              recorder.controlled(...)       one results row
        plant.advance(t, t + dt)             integrate the truth / wait on the clock
    after the last period: the state judged, recorded, not flown (timeout)

A step runs whole: a Ctrl-C inside it is raised when it ends (after its row), so CasADi never
swallows one and no row is cut in two (:class:`auvdock.runtime.interrupts.SigintDeferred`).  A stage
ends a run early by raising :class:`~auvdock.loop.stages.LoopEnding` (fly's safety aborts and
takeovers); every other exception, Ctrl-C included, propagates with every finished row recorded.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import time
from collections.abc import Callable, Iterable, Iterator
from typing import Any

import numpy as np

from auvdock.controllers.status import STATUS_HOLD, STATUS_LOST_TARGET
from auvdock.loop.stages import LoopEnding, LoopResult, Observation, Progress, Sensed, Stages
from auvdock.runtime.interrupts import SigintDeferred

__all__ = ["run_closed_loop"]

Guard = Callable[[], contextlib.AbstractContextManager[Any]]


@contextlib.contextmanager
def _whole() -> Iterator[None]:
    with SigintDeferred():
        yield


def run_closed_loop(
    stages: Stages,
    *,
    timeout_s: float,
    progress: Callable[[Progress], None] | None = None,
    on_event: Callable[[str], None] | None = None,
    step_guard: Guard = _whole,
    control_guard: Guard = contextlib.nullcontext,
) -> LoopResult:
    """Run one closed loop to its ending (see the module docstring).

    Parameters
    ----------
    stages : Stages
        The plant, readings, supervisor, autopilot (reset by the caller), actuators, docking rule,
        recorder and hold controller.
    timeout_s : float
        The run ends at ``timeout_s`` (s); ``math.inf``: when a stage ends it.
    progress : callable, optional
        Called with a :class:`~auvdock.loop.stages.Progress` after every controller step.
    on_event : callable, optional
        Called with a line of text when something happens (a hold starts).
    step_guard : callable
        Context for one whole step (default: Ctrl-C held back to the step's end).
    control_guard : callable
        Context for the autopilot's step alone (fly: what CasADi prints is counted, not shown).

    Returns
    -------
    LoopResult
        docked, captured, collided, timeout, diverged or lost_target; a stage's
        :class:`~auvdock.loop.stages.LoopEnding` becomes the result too.
    """
    s = stages
    dt = s.autopilot.dt
    n_max = int(math.ceil(timeout_s / dt - 1e-9)) if math.isfinite(timeout_s) else -1
    steps: Iterable[int] = range(n_max + 1) if n_max >= 0 else itertools.count()
    wall0 = time.perf_counter()
    result: LoopResult | None = None
    t_end = 0.0
    try:
        s.plant.start()
        for k in steps:
            t = k * dt
            with step_guard():
                obs = s.plant.observe(t)
                sensed = _sense(s, obs)
                dist, result = s.rule.judge(obs, s.autopilot, seeing=sensed is None or sensed.steer)
                if result is not None or k == n_max:  # the state after the last period: judged, not flown
                    s.recorder.final(obs, dist, s.actuators.neutral().channels_us)
                    break
                if sensed is None:  # the supervisor holds (stale telemetry, a bad link): neutral, no row
                    s.plant.apply(t, s.actuators.neutral())
                elif not sensed.steer:
                    _hold(s, obs, sensed, dist, on_event)
                else:
                    result = _control(s, obs, sensed, dist, k, timeout_s, progress, control_guard)
                    if result is not None:
                        break
                s.plant.advance(t, t + dt)  # (a non-finite truth: the next observation ends the run)
                t_end = t + dt
        if result is None:
            result = LoopResult("timeout", f"not docked within {timeout_s:g} s", t_end)
    except LoopEnding as e:
        result = LoopResult(e.reason, e.message, t_end)
    result.wall_time_s = time.perf_counter() - wall0
    s.rule.finish(result)
    s.autopilot.finish(result)
    return result


def _sense(s: Stages, obs: Observation) -> Sensed | None:
    """The readings of a finite state the supervisor lets fly, else None."""
    if not np.all(np.isfinite(obs.state)) or not s.supervisor.check(obs):
        return None
    return s.readings.read(obs)


def _hold(
    s: Stages, obs: Observation, sensed: Sensed, dist: float, on_event: Callable[[str], None] | None
) -> None:
    """No dock in sight: hold depth and attitude (:class:`auvdock.controllers.hold.DepthAttitudeHold`)."""
    x = obs.state
    if s.hold is None:
        raise ValueError("the readings have no dock to steer to, and the loop no hold controller")
    if not s.hold.active:
        s.hold.start(x)
        if on_event is not None:
            on_event(
                f"holding depth {x[2]:.2f} m and heading {np.degrees(x[5]):.1f} deg until the dock is seen"
            )
    cmd = s.actuators.command_wrench(s.hold.wrench(x))
    applied = s.plant.apply(obs.t, cmd)
    s.recorder.row(
        obs,
        thrust_N=cmd.thrust_N,
        channels_us=applied.channels_us,
        distance_m=dist,
        solve_time_s=0.0,
        status=STATUS_HOLD,
        series={},
        columns=sensed.columns,
    )


def _control(
    s: Stages,
    obs: Observation,
    sensed: Sensed,
    dist: float,
    k: int,
    timeout_s: float,
    progress: Callable[[Progress], None] | None,
    control_guard: Guard,
) -> LoopResult | None:
    """One controller step through the actuators; the guidance giving up ends the run."""
    t = obs.t
    if s.hold is not None:
        s.hold.stop()
    with control_guard():
        out = s.autopilot.step(sensed.readings)
    if out.channels_us is None:
        cmd = s.actuators.command(out.thrust)
    else:
        cmd = s.actuators.from_channels(out.channels_us)
    applied = s.plant.apply(t, cmd)
    s.autopilot.set_applied(applied.thrust_N)
    s.recorder.controlled(obs, out, distance_m=dist, channels_us=applied.channels_us, columns=sensed.columns)
    if progress is not None:
        progress(Progress(t, timeout_s, dist, out.solve_time_s, out.status, k))
    s.supervisor.after_step(out)
    if out.status == STATUS_LOST_TARGET:  # the guidance gave up: neutral, the end
        s.plant.apply(t, s.actuators.neutral())
        return LoopResult("lost_target", f"gave up finding the dock at t = {t:.2f} s", t)
    return None
