"""The state-estimation stage between the sensors and the controllers.

``estimation: truth`` (the paper's Assumption 1): the controllers get the state the
measurement carries.  ``estimation: filter``: :class:`NavigationStage` runs the navigation
filter (:mod:`auvdock.estimation.navigation_filter`) on the sensor suite's readings and the thrust commanded
over the last period, and hands every controller the same estimate:

* ``state``: the filter's state (12), over-ground body velocity;
* ``sensors`` for the FSE controllers' flow filter (paper IV.A, whose gramian stays): the
  pose, the angular rate, the velocity through the water ``nu_1 - R^T v_c`` with the filter's
  current, the mean acceleration over the last period and the depth rate ``e3^T R nu_1``:
  never the true flow, never the mission's flow model.  The mean acceleration is the one
  model's prediction over the last period from the previous estimate, with the thrust
  applied and the stage's current, ``(nu_1_pred - nu_1_prev) / dt`` (gravity-free, as that
  filter's measurement model expects).  The change of the *estimate* itself is no
  accelerometer: it carries every correction of the filter (a position fix moving the
  velocity by centimetres per second reads as metres per second squared), which that
  filter, trusting an accelerometer's 0.0045 m/s^2, turned into a drifting current
  (measured in a loopback flight: its estimate 0.1 m/s off and moving while the stage's
  was within 0.01 m/s);
* ``series`` to record: ``estimated_state`` (12), ``estimated_flow_ned_m_s`` (3),
  ``estimated_state_std`` (12).

The same stage runs wherever the readings come from (``sim`` here; the vehicle's telemetry
mapped to the same readings on a vehicle).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from auvdock.controllers.base import Measurement
from auvdock.estimation.navigation_filter import NavEstimate, NavigationFilter, NavigationSettings
from auvdock.vehicle.model import rk4
from auvdock.vehicle.state import ANG, ATT, ETA, LIN, NX

__all__ = ["ESTIMATION_MODES", "ESTIMATION_SERIES", "NavigationStage"]

#: ``estimation:`` values.
ESTIMATION_MODES = ("truth", "filter")

#: What the filter stage records per step: name -> per-row shape.
ESTIMATION_SERIES: dict[str, tuple[int, ...]] = {
    "estimated_state": (NX,),
    "estimated_state_std": (NX,),
    "estimated_flow_ned_m_s": (3,),
}


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
    """

    def __init__(
        self, settings: NavigationSettings, vehicle: Any, dt: float, start_guess: np.ndarray
    ) -> None:
        self.filter = NavigationFilter(settings, vehicle, dt)
        self.settle_s = float(settings.settle_s)
        self.dt = float(dt)
        self.start_guess = np.asarray(start_guess, dtype=float).copy()
        rot = vehicle.model.function("rotation")
        self._rot = lambda angles: np.asarray(rot(angles))
        model = vehicle.model
        xs = ca.SX.sym("x", NX)
        us = ca.SX.sym("u", vehicle.n_thrusters)
        vc = ca.SX.sym("flow_ned", 3)
        zero = ca.DM.zeros(3)
        x_next = rk4(lambda x, u, c: model.dynamics(x, u, c, zero), xs, dt, 2, us, vc)
        self._predict = ca.Function("stage_predict", [xs, us, vc], [x_next])
        self.reset()

    def reset(self) -> None:
        """Start a new run: the filter from the start guess, no previous estimate."""
        self.filter.reset(self.start_guess.copy())
        self._prev: tuple[np.ndarray, np.ndarray] | None = None
        self.last: NavEstimate | None = None
        self._t0: float | None = None

    def settling(self, t: float) -> bool:
        """Whether the controllers should still hold zero thrust at time ``t`` (s): the filter
        has run for less than ``navigation.settle_s`` since the first reading."""
        return self._t0 is not None and t < self._t0 + self.settle_s

    def step(self, meas: Measurement, u_prev: np.ndarray) -> tuple[Measurement, dict[str, np.ndarray]]:
        """The controllers' measurement from this step's readings, and the series to record."""
        if self._t0 is None:
            self._t0 = float(meas.t)
        est = self.filter.step(meas.t, list(meas.readings), u_prev)
        self.last = est
        x = np.asarray(est.state, dtype=float)
        R = self._rot(x[ATT])
        lin = x[LIN]
        sensors: dict[str, np.ndarray] = {
            "pose": x[ETA].copy(),
            "gyro_rad_s": x[ANG].copy(),
            "relative_velocity_m_s": lin - R.T @ np.asarray(est.flow_ned, dtype=float),
            "depth_rate_m_s": np.asarray(float(R[2] @ lin)),
        }
        if self._prev is not None:
            x_prev, flow_prev = self._prev
            pred = np.asarray(self._predict(x_prev, u_prev, flow_prev)).ravel()
            sensors["accel_m_s2"] = (pred[LIN] - x_prev[LIN]) / self.dt
        self._prev = (x.copy(), np.asarray(est.flow_ned, dtype=float).copy())
        out = Measurement(meas.t, x.copy(), meas.flow_ned, sensors, [])
        series = {
            "estimated_state": x.copy(),
            "estimated_state_std": np.sqrt(np.clip(np.diag(est.state_cov), 0.0, None)),
            "estimated_flow_ned_m_s": np.asarray(est.flow_ned, dtype=float).copy(),
        }
        return out, series
