"""The loop's recorder: every row of a run into its sinks, and the figures of its outcome.

:class:`LoopRecorder` is the last stage of the one closed loop (:mod:`auvdock.loop.stages`): a row per
period (the observation, the command, the controller's series, the plant's and the readings' columns),
and per controller step the figures the outcome is computed from (:func:`run_outcome`; errors of the
estimates against the truth where the plant knows it).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.controllers.status import FAILURE_CODES, STATUS_NAMES, STATUS_NO_STEP
from auvdock.estimation.stage import FORECAST_HORIZONS_S, forecast_rmse_key
from auvdock.vehicle.geometry import rotation_of, wrap_angle
from auvdock.vehicle.state import ATT, LIN, POS, YAW

if TYPE_CHECKING:
    from auvdock.controllers.base import ControlOutput
    from auvdock.loop.stages import DockModel, LoopResult, Observation, RowSink
    from auvdock.vehicle import Vehicle

__all__ = ["LoopRecorder", "run_outcome"]


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
        v_ned = rotation_of(contact_state[ATT]) @ contact_state[LIN]
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
        The plant's and the readings stage's own columns (name -> per-row shape).
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
        self._nan_series = {name: np.full(shape, np.nan) for name, shape in self.extra_series.items()}
        self._nan_columns = {name: np.full(shape, np.nan) for name, shape in self.plant_columns.items()}
        self._nan3 = np.full(3, np.nan)
        self._true_flow_series = "flow_body_true_m_s" in self.extra_series

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
        columns: dict[str, np.ndarray] | None = None,
    ) -> None:
        """One row: the observation, the thrust recorded (commanded by the controller's step, applied
        by the hold), the step's figures and series, and the readings stage's ``columns``."""
        if not self.sinks:
            return
        t, x = obs.t, obs.state
        u = np.asarray(thrust_N, dtype=float)
        row: dict[str, Any] = dict(
            time_s=t,
            state=x,
            thrust_N=u,
            wrench=self.vehicle.allocation @ u,
            flow_ned_m_s=self._nan3 if obs.true_water_ned is None else obs.true_water_ned,
            dock_position_m=self.dock.position(t),
            dock_velocity_m_s=self.dock.velocity(t),
            distance_m=distance_m,
            solve_time_s=solve_time_s,
            solver_status=status,
            **{**self._nan_series, **series},
            **{**self._nan_columns, **obs.columns, **(columns or {})},
        )
        if self.channels:
            row["channels_us"] = np.full(6, np.nan) if channels_us is None else channels_us
        for sink in self.sinks:
            sink.append(**row)

    def final(self, obs: Observation, distance_m: float, channels_us: np.ndarray | None) -> None:
        """The last row: the state judged (docked, ended or timed out; NaN distance: diverged), no step."""
        if math.isfinite(distance_m):
            self.distances.append(distance_m)
        zero = np.zeros(self.vehicle.n_thrusters)
        self.row(
            obs,
            thrust_N=zero,
            channels_us=channels_us,
            distance_m=distance_m,
            solve_time_s=math.nan,
            status=STATUS_NO_STEP,
            series={},
        )

    def controlled(
        self,
        obs: Observation,
        out: ControlOutput,
        *,
        distance_m: float,
        channels_us: np.ndarray | None,
        columns: dict[str, np.ndarray],
    ) -> None:
        """A controller step: its row (with the true flow in the body frame where the controller
        records its flow estimate), and its figures for the outcome."""
        series = dict(out.series)
        if self._true_flow_series:
            if obs.true_water_ned is None:  # unknown on a vehicle
                series["flow_body_true_m_s"] = self._nan3
            else:
                f_true = rotation_of(obs.state[ATT]).T @ obs.true_water_ned
                series["flow_body_true_m_s"] = f_true
                err = float(np.linalg.norm(out.series["flow_estimate_m_s"] - f_true))
                if math.isfinite(err) and self.keep:  # (no estimate while the filter settles)
                    self.flow_errors.append(err)
        self._figures(obs, distance_m, out)
        self.row(
            obs,
            thrust_N=out.thrust,
            channels_us=channels_us,
            distance_m=distance_m,
            solve_time_s=out.solve_time_s,
            status=out.status,
            series=series,
            columns=columns,
        )

    def _figures(self, obs: Observation, distance_m: float, out: ControlOutput) -> None:
        """Count a controller step into the outcome figures."""
        if not self.keep:
            return
        x_est = out.series.get("estimated_state")
        dock_est = out.series.get("estimated_dock_position_m")
        if x_est is not None and dock_est is not None and np.all(np.isfinite(x_est)):
            rel_true = obs.state[POS] - self.dock.position(obs.t)
            self.relative_errors.append(float(np.linalg.norm(rel_true - (x_est[POS] - dock_est))))
            cur = out.series.get("estimated_flow_ned_m_s")
            if cur is not None and obs.true_water_ned is not None:
                self.current_errors.append(float(np.linalg.norm(cur[0:2] - obs.true_water_ned[0:2])))
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
        if result.entry_aborts is not None:
            outcome["entry_aborts"] = int(result.entry_aborts)
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
