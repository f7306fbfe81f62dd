"""The closed-loop simulation: truth model + flow field + dock + :class:`Autopilot`.

Every control period dt the autopilot gets a :class:`Measurement` of the true state
(Assumption 1), the true flow at the vehicle (passed on only to the controllers whose
definition reads it: Kinematic and Oracle MPC, Assumption 3) and simulated sensors
(:mod:`auvdock.sensing.sensors`), and returns thrust, which is held for dt (zero-order hold) while
the truth model (eqs. 1-2 with the flow field evaluated at the vehicle's position and time)
is integrated with RK4 substeps.

The run ends when the vehicle is within ``docking.tolerance_m`` of the dock (docked) or at
``docking.timeout_s`` (failure, with the closest approach recorded).  Every step is
written to the results file as it happens (:mod:`auvdock.results.store`), and the final state --
the one in which docking is declared, or the last one -- is written as a last row with
status ``no_step``.  A run interrupted at any moment (Ctrl-C) leaves a readable file marked
``complete = False``; building the controller (compiling, on first use) is timed apart
(``setup_time_s``) from the run itself (``wall_time_s``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from auvdock.config.mission import Mission
from auvdock.controllers import Measurement
from auvdock.controllers.status import FAILURE_CODES, STATUS_NAMES, STATUS_NO_STEP
from auvdock.loop.autopilot import Autopilot, build_autopilot
from auvdock.results.store import RunWriter, flush_steps
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.sensing.sensors import SensorModel, SensorSuite
from auvdock.vehicle.geometry import wrap_angle
from auvdock.vehicle.state import ATT, LIN, POS, YAW

__all__ = ["Progress", "RunSummary", "simulate", "run_outcome"]


@dataclass
class Progress:
    """Progress of a running simulation, passed to the ``progress`` callback each step."""

    t: float
    timeout_s: float
    distance_m: float
    solve_time_s: float
    status: int
    step: int


@dataclass
class RunSummary:
    """Outcome of one run (also stored as attributes of the results group)."""

    mission: str
    controller: str
    outcome: dict[str, Any]
    path: Path | None = None
    solve_times_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: Where each step's time went (:mod:`auvdock.runtime.timing`): part name -> (steps,) s, zero
    #: where a step had no such part.
    time_parts_s: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def docked(self) -> bool:
        return bool(self.outcome.get("docked", False))


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
    """The outcome figures of a run (see the README's results layout).

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


def simulate(
    mission: Mission,
    *,
    controller: str | None = None,
    out: str | Path | Any | None = None,
    group: str = "/",
    progress: Callable[[Progress], None] | None = None,
    timeout_s: float | None = None,
    autopilot: Autopilot | None = None,
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
        :func:`auvdock.loop.autopilot.build_autopilot`; its ``build_time_s`` is the run's
        ``setup_time_s``.

    Returns
    -------
    RunSummary
        Outcome figures; the same figures are stored in the results file.
    """
    t_setup = time.perf_counter()
    vehicle = mission.build_vehicle()
    flow = mission.build_flow()
    dock = mission.build_dock()
    ap = autopilot or build_autopilot(mission, vehicle, dock, controller)
    setup_s = time.perf_counter() - t_setup if autopilot is None else ap.build_time_s
    ap.reset()
    dt = ap.dt
    timeout = mission.docking.timeout_s if timeout_s is None else float(timeout_s)
    tol = mission.docking.tolerance_m
    with SigintDeferred():  # CasADi would swallow a Ctrl-C landing in the construction
        truth_step = vehicle.stepper(dt, mission.simulation.substeps, flow)
    rotation = vehicle.model.function("rotation")

    def rot(angles: np.ndarray) -> np.ndarray:
        return np.asarray(rotation(angles))

    writer: RunWriter | None = None
    if out is not None:
        with SigintDeferred():  # the run group is created whole, or not at all
            writer = RunWriter(
                out if not isinstance(out, str) else Path(out),
                group,
                mission_yaml=mission.to_yaml(),
                mission_name=mission.name,
                controller=ap.name,
                extra_series=ap.extra_series,
                status_names=STATUS_NAMES,
                n_thrusters=vehicle.n_thrusters,
                attrs={
                    "tolerance_m": tol,
                    "timeout_s": timeout,
                    "dt_s": dt,
                    "flow": flow.describe(),
                    "vehicle": vehicle.name,
                    "solver": ap.solver,
                    "reads_true_flow": ap.reads_true_flow,
                    "estimation": mission.estimation,
                },
                flush_every=flush_steps(dt),
            )

    if ap.navigation is None:  # estimation: truth -- the paper's sensing of [eta; nu_r]
        sensors, suite = SensorModel(mission.sensors, mission.seed, rot), None
    else:  # estimation: filter -- the sensor suite, read by the navigation filter
        sensors, suite = None, SensorSuite(mission.sensors, vehicle, mission.seed)
    record_true_body_flow = "flow_body_true_m_s" in ap.extra_series
    no_step_extras = {name: np.full(shape, np.nan) for name, shape in ap.extra_series.items()}
    x = mission.start_state()
    x_prev: np.ndarray | None = None
    n_max = int(math.ceil(timeout / dt - 1e-9))
    states: list[np.ndarray] = []
    distances: list[float] = []
    solve_times: list[float] = []
    time_parts: list[dict[str, float]] = []
    statuses: list[int] = []
    flow_errors: list[float] = []
    docked = False
    contact_state = None
    t_end = 0.0
    reason = "timeout"
    zero_thrust = np.zeros(vehicle.n_thrusters)

    def final_row(t: float, x_end: np.ndarray, dist: float) -> None:
        """The state in which the run ends (docked, timed out or diverged): no control step."""
        if writer is None:
            return
        writer.append(
            time_s=t,
            state=x_end,
            thrust_N=zero_thrust,
            wrench=np.zeros(6),
            flow_ned_m_s=flow.velocity(x_end[POS], t) if np.all(np.isfinite(x_end)) else np.full(3, np.nan),
            dock_position_m=dock.position(t),
            dock_velocity_m_s=dock.velocity(t),
            distance_m=dist,
            solve_time_s=math.nan,
            solver_status=STATUS_NO_STEP,
            **no_step_extras,
        )

    wall0 = time.perf_counter()
    try:
        for k in range(n_max):
            t = k * dt
            p_dock = dock.position(t)
            v_dock = dock.velocity(t)
            dist = float(np.linalg.norm(x[POS] - p_dock))
            if dist <= tol:
                docked, contact_state, t_end, reason = True, x.copy(), t, "docked"
                distances.append(dist)
                final_row(t, x, dist)
                break
            v_c = flow.velocity(x[POS], t)
            if sensors is not None:  # estimation: truth (the paper's Assumption 1)
                meas = Measurement(
                    t=t, state=x.copy(), flow_ned=v_c, sensors=sensors.read(x, x_prev, dt, v_c)
                )
            else:  # estimation: filter -- the controllers see only what the sensor suite reads
                readings = suite.read(t, x, ap.u_prev, v_c)
                meas = Measurement(t=t, state=np.full_like(x, np.nan), flow_ned=v_c, readings=readings)
            out_k = ap.step(meas)
            if record_true_body_flow:
                f_true = rot(x[ATT]).T @ v_c
                out_k.series["flow_body_true_m_s"] = f_true
                flow_errors.append(float(np.linalg.norm(out_k.series["flow_estimate_m_s"] - f_true)))
            u = out_k.thrust
            states.append(x.copy())
            distances.append(dist)
            solve_times.append(out_k.solve_time_s)
            time_parts.append(out_k.time_parts)
            statuses.append(out_k.status)
            if writer is not None:
                writer.append(
                    time_s=t,
                    state=x,
                    thrust_N=u,
                    wrench=vehicle.allocation @ u,
                    flow_ned_m_s=v_c,
                    dock_position_m=p_dock,
                    dock_velocity_m_s=v_dock,
                    distance_m=dist,
                    solve_time_s=out_k.solve_time_s,
                    solver_status=out_k.status,
                    **out_k.series,
                )
            if progress is not None:
                progress(Progress(t, timeout, dist, out_k.solve_time_s, out_k.status, k))
            x_prev = x
            x = np.asarray(truth_step(x, u, t)).ravel()
            t_end = t + dt
            if not np.all(np.isfinite(x)):
                reason = "diverged"
                final_row(t_end, x, math.nan)
                break
        else:
            # last state after the final period
            dist = float(np.linalg.norm(x[POS] - dock.position(t_end)))
            distances.append(dist)
            if dist <= tol:
                docked, contact_state, reason = True, x.copy(), "docked"
            final_row(t_end, x, dist)
    except BaseException:  # Ctrl-C or an error: keep every finished step, complete = False
        if writer is not None:
            writer.close()
        raise
    wall = time.perf_counter() - wall0
    outcome = run_outcome(
        docked=docked,
        t_end=t_end,
        states=states,
        distances=distances,
        solve_times=solve_times,
        statuses=statuses,
        contact_state=contact_state,
        dock_velocity=dock.velocity(t_end) if docked else None,
        dock_heading=dock.heading_rad,
        rotation=rot,
        wall_time_s=wall,
        reason=reason,
        setup_time_s=setup_s,
    )
    if flow_errors:
        e = np.asarray(flow_errors)
        outcome["flow_rmse_m_s"] = float(np.sqrt(np.mean(e**2)))
        outcome["flow_final_error_m_s"] = float(e[-1])
    outcome["status_counts"] = ", ".join(
        f"{STATUS_NAMES[s]}: {statuses.count(s)}" for s in sorted(set(statuses))
    )
    path = None
    if writer is not None:
        try:
            with SigintDeferred():  # the outcome is written whole, or the run stays incomplete
                writer.finish(outcome)
        finally:
            path = Path(writer.filename)
            writer.close()
    names = sorted({name for parts in time_parts for name in parts})
    parts_s = {name: np.array([parts.get(name, 0.0) for parts in time_parts]) for name in names}
    return RunSummary(mission.name, ap.name, outcome, path, np.asarray(solve_times), parts_s)
