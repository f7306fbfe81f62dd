"""The estimation stage between the sensors and the controllers: readings in, an :class:`Estimate` out.

Every closed loop hands the stage one instant's :class:`~auvdock.sensing.readings.Readings`
and hands every controller the stage's :class:`~auvdock.estimation.estimate.Estimate`; no
controller reads a sensor.  Two stages, chosen by the mission's ``estimation``
(:func:`auvdock.loop.assemble.build_estimation`):

* :class:`TruthStage` (``estimation: truth``, the paper's Assumption 1): the state the
  readings carry (the truth in simulation, the autopilot's estimate on a vehicle) and the
  paper's simulated sensing of ``[eta; nu_r]`` for the FSE flow filter, passed on as they are.
* :class:`NavigationStage` (``estimation: filter``): the navigation filter
  (:mod:`auvdock.estimation.navigation_filter`) on the sensor suite's readings and the thrust
  really applied over the last period, and every controller gets the same estimate:

  - ``state``: the filter's state (12), over-ground body velocity, with its covariance;
  - ``flow_sensing`` for the FSE controllers' flow filter (paper IV.A, whose gramian stays):
    the pose, the angular rate, the velocity through the water ``nu_1 - R^T v_c`` with the
    filter's current, the mean acceleration over the last period and the depth rate
    ``e3^T R nu_1``: never the true flow, never the mission's flow model.  The mean
    acceleration is the one model's prediction over the last period from the previous
    estimate, with the thrust applied and the stage's current, ``(nu_1_pred - nu_1_prev) /
    dt`` (gravity-free, as that filter's measurement model expects).  The change of the
    *estimate* itself is no accelerometer: it carries every correction of the filter (a
    position fix moving the velocity by centimetres per second reads as metres per second
    squared), which that filter, trusting an accelerometer's 0.0045 m/s^2, turned into a
    drifting current (measured in a loopback flight: its estimate 0.1 m/s off and moving
    while the stage's was within 0.01 m/s);
  - ``dock_offset_ned``: where the filter places the dock (its anchor, a state of the filter
    anchored by the camera's fixes, ``sensors.dock_camera``) relative to the mission's dock, with
    the covariance of the vehicle's position relative to it and the time of the newest fix;
  - ``series`` to record: ``estimated_state`` (12), ``estimated_flow_ned_m_s`` (3),
    ``estimated_state_std`` (12), ``estimated_flow_std_m_s`` (3), ``estimated_dock_position_m``
    (3, where the filter places the docking point now) and ``relative_position_std_m`` (3).

The same stages run wherever the readings come from (``sim``, ``fly``, ``replay``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

import casadi as ca
import numpy as np

from auvdock.estimation.delay import ThrustSchedule, mean_thrust
from auvdock.estimation.dock_heave_error import DockErrorModel
from auvdock.estimation.estimate import Estimate, HeaveError
from auvdock.estimation.navigation_filter import NavEstimate, NavigationFilter
from auvdock.estimation.settings import FORECAST_HORIZONS_S, NavigationSettings
from auvdock.estimation.wave_model import WaveModel
from auvdock.sensing.readings import FlowSensing, Readings
from auvdock.vehicle.model import rk4
from auvdock.vehicle.state import ANG, ATT, ETA, LIN, NX

if TYPE_CHECKING:
    from auvdock.estimation.dock_knowledge import TelemetryDock
    from auvdock.sensing.settings import DockTelemetrySettings
    from auvdock.vehicle import Vehicle
    from auvdock.world.dock import DockMotion

__all__ = [
    "ESTIMATION_MODES",
    "ESTIMATION_SERIES",
    "FORECAST_HORIZONS_S",
    "FORECAST_SERIES",
    "WAVE_SERIES",
    "forecast_rmse_key",
    "EstimationStage",
    "TruthStage",
    "NavigationStage",
]

#: ``estimation:`` values.
ESTIMATION_MODES = ("truth", "filter")

#: The dock's heave error's frequency until the forecaster has estimated the heave's spectrum, without a wave
#: model to take the sea's mean frequency from, rad/s (an 8 s swell's).
_DEFAULT_HEAVE_OMEGA = 2.0 * math.pi / 8.0

#: What the filter stage records per step: name -> per-row shape.
ESTIMATION_SERIES: dict[str, tuple[int, ...]] = {
    "estimated_state": (NX,),
    "estimated_state_std": (NX,),
    "estimated_flow_ned_m_s": (3,),
    "estimated_flow_std_m_s": (3,),
    "estimated_dock_position_m": (3,),
    "relative_position_std_m": (3,),
}

#: What the filter stage also records with a wave model: the water's wave-frequency velocity at the
#: vehicle (NED, m/s) and its std.
WAVE_SERIES: dict[str, tuple[int, ...]] = {
    "estimated_wave_velocity_ned_m_s": (3,),
    "estimated_wave_velocity_std_m_s": (3,),
}


def forecast_rmse_key(horizon_s: float) -> str:
    """Outcome key of the dock forecast's RMS error ``horizon_s`` ahead: ``dock_forecast_rmse_0p5s_m``."""
    return "dock_forecast_rmse_" + f"{horizon_s:g}".replace(".", "p") + "s_m"


#: What the filter stage also records with the dock's telemetry: the forecast dock position (NED m) at
#: each of :data:`FORECAST_HORIZONS_S` ahead, and its std (m) there.
FORECAST_SERIES: dict[str, tuple[int, ...]] = {
    "dock_forecast_m": (len(FORECAST_HORIZONS_S), 3),
    "dock_forecast_std_m": (len(FORECAST_HORIZONS_S), 3),
}


class EstimationStage(Protocol):
    """What every estimation stage offers."""

    #: ``estimation:`` value it implements.
    mode: str
    #: Per-step series it records: name -> per-row shape.
    series_shapes: dict[str, tuple[int, ...]]

    def reset(self) -> None:
        """Start a new run."""
        ...

    def settling(self, t: float) -> bool:
        """Whether the controllers should still hold zero thrust at time ``t`` (s)."""
        ...

    def step(
        self, readings: Readings, u_applied: np.ndarray | ThrustSchedule
    ) -> tuple[Estimate, dict[str, np.ndarray]]:
        """The estimate from one instant's readings and the thrust (n,, N) really applied over
        the last period; and the series to record."""
        ...


class TruthStage:
    """``estimation: truth`` (the paper's Assumption 1): the state and the paper's sensing as given.

    The readings must carry ``state`` (a source that has none, such as a vehicle's telemetry
    without the autopilot's estimate, cannot run this stage).
    """

    mode = "truth"
    series_shapes: dict[str, tuple[int, ...]] = {}

    def reset(self) -> None:
        """Nothing to forget."""

    def settling(self, t: float) -> bool:
        """Never: the state is known from the first instant."""
        return False

    def step(
        self, readings: Readings, u_applied: np.ndarray | ThrustSchedule
    ) -> tuple[Estimate, dict[str, np.ndarray]]:
        """The state and the flow sensing the readings carry; nothing to record."""
        if readings.state is None:
            raise ValueError("estimation: truth needs the state in the readings (Assumption 1)")
        est = Estimate(
            readings.t if readings.state_t is None else readings.state_t,  # when the state was sampled
            np.asarray(readings.state, dtype=float).copy(),
            None,
            readings.flow_ned,
            readings.flow_sensing,
        )
        return est, {}


class NavigationStage:
    """The navigation filter as the estimation stage of one run.

    Parameters
    ----------
    settings : NavigationSettings
        The filter's settings (the mission's ``navigation`` section).
    vehicle : Vehicle
        The one model.
    dt : float
        Control period, s.
    start_guess : ndarray (12,)
        Where the vehicle is believed to start (the mission's start state, in the mission
        frame); the filter's prior is centred on it.
    dock : DockMotion, optional
        The dock as the mission charts it (its ``position_ned_m`` the anchor's prior mean, its
        motion about it known: the heave); default: a dock at rest at the origin.
    camera_mount : (R_bc, t_bc), optional
        The camera mount of the dock readings (default mount if omitted).
    telemetry : TelemetryDock, optional
        With ``sensors.dock_telemetry`` for a deployable controller: the dock whose motion is forecast
        from the telemetry readings (kind ``dock_motion``), which this stage feeds it; it must be
        ``dock`` too (the filter's dock moves as forecast).
    waves : WaveModel, optional
        The water's wave-frequency motion, as the filter models it
        (:func:`auvdock.loop.assemble.filter_wave_model`); None: a current only.
    telemetry_unit : DockTelemetrySettings, optional
        The dock's motion unit (``sensors.dock_telemetry``): its slow heave error, which the forecast from its
        record carries, is a state of the filter's heave error (:class:`DockErrorModel`).
    """

    mode = "filter"
    series_shapes = ESTIMATION_SERIES

    def __init__(
        self,
        settings: NavigationSettings,
        vehicle: Vehicle,
        dt: float,
        start_guess: np.ndarray,
        *,
        dock: DockMotion | None = None,
        camera_mount: tuple[np.ndarray, np.ndarray] | None = None,
        telemetry: TelemetryDock | None = None,
        waves: WaveModel | None = None,
        telemetry_unit: DockTelemetrySettings | None = None,
    ) -> None:
        if telemetry is not None and dock is not telemetry:
            raise ValueError("the telemetry's forecast dock must be the stage's dock")
        self.telemetry = telemetry
        self.series_shapes = {
            **ESTIMATION_SERIES,
            **(FORECAST_SERIES if telemetry is not None else {}),
            **(WAVE_SERIES if waves is not None else {}),
        }
        self.dock = dock
        self.dock_anchor = np.zeros(3) if dock is None else np.asarray(dock.position_ned_m, dtype=float)
        motion = None
        #: The forecast's std of the heave (m) at the last time the filter asked for the dock's motion.
        self._forecast_std = math.inf
        if telemetry is not None:
            anchor = self.dock_anchor

            def motion(t: float) -> tuple[np.ndarray, np.ndarray]:
                p, v, sd = telemetry.forecast(t)  # one solve for all three
                self._forecast_std = float(sd[2])
                return np.asarray(p, dtype=float) - anchor, np.asarray(v, dtype=float)

        elif dock is not None:
            anchor = self.dock_anchor

            def motion(t: float) -> tuple[np.ndarray, np.ndarray]:
                _, p, v = dock.trajectory(t, 0.0, 0)  # one evaluation for both
                return np.asarray(p[0], dtype=float) - anchor, np.asarray(v[0], dtype=float)

        # where the dock's motion is a forecast, the filter also carries what the forecast leaves unknown; its
        # frequency the sea's mean (the wave model's) until the forecaster has the heave's spectrum
        self._heave_omega0 = float(waves.omega_rad_s) if waves is not None else _DEFAULT_HEAVE_OMEGA
        error = None
        if telemetry is not None and settings.dock_heave_error == "auto":
            slow = 0.0
            tau = 20.0
            if telemetry_unit is not None and telemetry_unit.motion_unit == "mru":
                slow, tau = telemetry_unit.heave_error_std_m, telemetry_unit.heave_error_tau_s
            error = DockErrorModel(
                self._heave_omega0, settings.dock_heave_error_damping, settings.prior_dock_std_m, slow, tau
            )
        self.filter = NavigationFilter(
            settings,
            vehicle,
            dt,
            camera_mount=camera_mount,
            dock_motion=motion,
            waves=waves,
            dock_error=error,
        )
        self.settle_s = float(settings.settle_s)
        self.dt = float(dt)
        self.start_guess = np.asarray(start_guess, dtype=float).copy()
        rot = vehicle.model.function("rotation")
        self._rot = lambda angles: np.asarray(rot(angles))
        model = vehicle.model

        def predict() -> ca.Function:
            xs = ca.SX.sym("x", NX)
            us = ca.SX.sym("u", vehicle.n_thrusters)
            vc = ca.SX.sym("flow_ned", 3)
            zero = ca.DM.zeros(3)
            x_next = rk4(lambda x, u, c: model.dynamics(x, u, c, zero), xs, self.dt, 2, us, vc)
            return ca.Function("stage_predict", [xs, us, vc], [x_next])

        self._predict = vehicle.built("stage_predict", (self.dt,), predict)
        self.reset()

    def reset(self) -> None:
        """Start a new run: the filter from the start guess, no previous estimate."""
        self.filter.reset(self.start_guess.copy(), dock_anchor=self.dock_anchor)
        if self.telemetry is not None:
            self.telemetry.reset()
        self._prev: tuple[np.ndarray, np.ndarray] | None = None
        self._forecast_std = math.inf
        self._heave_omega_set = False
        if self.filter.dock_error is not None:
            self.filter.set_dock_error_frequency(self._heave_omega0)
        self.last: NavEstimate | None = None
        self._t0: float | None = None
        self.dock_fix_t: float | None = None

    def _follow_forecast(self, t: float) -> None:
        """The dock's heave error follows the forecast: as large as what it left unknown at the previous
        step (its std; the climatology's before it has learnt the sea), at the heave's mean frequency once the
        forecaster has estimated its spectrum."""
        assert self.telemetry is not None
        f = self.telemetry.forecaster
        std = self._forecast_std
        if not math.isfinite(std):
            sig = float(f.signal_std_m[2]) if f.n_measurements > 1 else math.nan
            std = sig if math.isfinite(sig) else self.filter.settings.prior_dock_std_m
        self.filter.set_dock_error_std(std)
        spectrum = f.spectrum
        if not self._heave_omega_set and spectrum is not None:
            omega, S = spectrum
            m0 = float(np.sum(S[2]))
            if m0 > 0.0:
                w = float(np.sum(omega * S[2]) / m0)
                self.filter.set_dock_error_frequency(w)
                self.filter.set_dock_error_std(std)
                self._heave_omega_set = True

    def settling(self, t: float) -> bool:
        """Whether the controllers should still hold zero thrust at time ``t`` (s): the filter
        has run for less than ``navigation.settle_s`` since the first reading."""
        return self._t0 is not None and t < self._t0 + self.settle_s

    def step(
        self, readings: Readings, u_applied: np.ndarray | ThrustSchedule
    ) -> tuple[Estimate, dict[str, np.ndarray]]:
        """The controllers' estimate from this instant's readings (``readings.suite``) and the
        thrust (n,, N) really applied over the last period; and the series to record."""
        if self._t0 is None:
            self._t0 = float(readings.t)
        navigation = []
        for r in readings.suite:
            if r.kind == "dock_motion":  # the dock's telemetry: its forecaster's, not the filter's
                if self.telemetry is not None:
                    self.telemetry.update(r.t, r.value, r.std)
                continue
            if r.kind == "dock_motion_rate":  # the motion unit's heave rate: the forecaster's too
                if self.telemetry is not None:
                    self.telemetry.update_rate(r.t, r.value, r.std)
                continue
            if r.kind == "dock":
                self.dock_fix_t = max(float(r.t), self.dock_fix_t or -math.inf)
            navigation.append(r)
        error = self.filter.dock_error
        if error is not None:
            self._follow_forecast(float(readings.t))
        est = self.filter.step(readings.t, navigation, u_applied)
        self.last = est
        x = np.asarray(est.state, dtype=float)
        R = self._rot(x[ATT])
        lin = x[LIN]
        flow_ned = np.asarray(est.flow_ned, dtype=float)
        accel = None
        if self._prev is not None:
            x_prev, flow_prev = self._prev
            pred = np.asarray(self._predict(x_prev, mean_thrust(u_applied), flow_prev)).ravel()
            accel = (pred[LIN] - x_prev[LIN]) / self.dt
        self._prev = (x.copy(), flow_ned.copy())
        # Two estimators of one current, kept with their reason: the FSE controllers run their own flow
        # filter (the paper's, IV.A) after this one, on this filter's estimate handed over as their
        # sensing of [eta; nu_r], because their exploration term (the gramian's information) and the
        # robust variant's weight are defined on that filter.  The two errors are correlated: the
        # information term is scaled by the share of the current's uncertainty this filter has left
        # (``current_uncertainty``).  One estimator per run (the FSE information computed on this
        # filter's covariance) would change the outcome of every filter mission; it is not done here.
        sensing = FlowSensing(
            pose=x[ETA].copy(),
            gyro_rad_s=x[ANG].copy(),
            relative_velocity_m_s=lin - R.T @ flow_ned,
            depth_rate_m_s=float(R[2] @ lin),
            accel_m_s2=accel,
        )
        assert est.dock_anchor_ned is not None and est.relative_cov is not None
        offset = est.dock_anchor_ned - self.dock_anchor
        lam = float(np.max(np.linalg.eigvalsh(est.flow_cov[0:2, 0:2])))
        share = min(1.0, math.sqrt(max(lam, 0.0)) / self.filter.settings.prior_current_std_m_s)
        dock_now = (np.zeros(3) if self.dock is None else np.asarray(self.dock.position(readings.t))) + offset
        heave_error = None
        if est.dock_heave_error is not None and self.filter.dock_error is not None:
            heave_error = HeaveError(float(readings.t), est.dock_heave_error.copy(), self.filter.dock_error)
            dock_now[2] += float(est.dock_heave_error[0])
        out = Estimate(
            readings.t,
            x.copy(),
            np.asarray(est.state_cov, dtype=float)[:NX, :NX].copy(),
            readings.flow_ned,
            sensing,
            flow_ned.copy(),
            dock_offset_ned=offset,
            relative_cov=est.relative_cov.copy(),
            dock_position_ned=dock_now.copy(),
            dock_fix_t=self.dock_fix_t,
            current_uncertainty=share,
            wave_velocity_ned=None if est.wave_velocity_ned is None else est.wave_velocity_ned.copy(),
            wave_accel_ned=None if est.wave_accel_ned is None else est.wave_accel_ned.copy(),
            wave_model=self.filter.waves,
            dock_heave_error=heave_error,
        )
        series = {
            "estimated_state": x.copy(),
            "estimated_state_std": np.sqrt(np.clip(np.diag(est.state_cov), 0.0, None)),
            "estimated_flow_ned_m_s": flow_ned.copy(),
            "estimated_flow_std_m_s": np.sqrt(np.clip(np.diag(est.flow_cov), 0.0, None)),
            "estimated_dock_position_m": dock_now,
            "relative_position_std_m": np.sqrt(np.clip(np.diag(est.relative_cov), 0.0, None)),
        }
        if est.wave_velocity_ned is not None and est.wave_cov is not None:
            series["estimated_wave_velocity_ned_m_s"] = est.wave_velocity_ned.copy()
            series["estimated_wave_velocity_std_m_s"] = np.sqrt(np.clip(np.diag(est.wave_cov), 0.0, None))
        if self.telemetry is not None:
            ahead = readings.t + np.asarray(FORECAST_HORIZONS_S)
            position, _, std = self.telemetry.forecast(ahead)
            series["dock_forecast_m"] = position + offset
            if heave_error is not None:
                series["dock_forecast_m"][:, 2] += heave_error.ahead(ahead)[0]
            series["dock_forecast_std_m"] = std
        return out, series
