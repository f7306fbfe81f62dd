"""What a deployable controller knows of the dock's motion: a forecast from the dock's telemetry.

Under the paper's Assumption 2 every controller is told the dock's future motion.  A deployable
controller is not: with ``sensors.dock_telemetry`` it forecasts the motion from the dock's own motion
sensor (readings of kind ``dock_motion``: the docking point's displacement from its mean, NED m) with
:class:`auvdock.estimation.dock_forecast.DockForecaster`, and steers to :class:`TelemetryDock`, the
charted anchor plus that forecast.  Where the dock is (its anchor) is not in the telemetry: the
navigation filter estimates it from the camera's fixes (relative navigation) on top of this motion.

Oracle stays the upper bound: it is told the true motion (its definition; the run's idealisations say
so).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from auvdock.estimation.dock_forecast import DockForecaster, DockForecastSettings
from auvdock.world.dock import DockMotion, TranslatingDock

if TYPE_CHECKING:
    from auvdock.sensing.settings import DockTelemetrySettings

__all__ = ["TelemetryDock", "forecast_settings"]


def forecast_settings(unit: DockTelemetrySettings | None) -> DockForecastSettings:
    """The forecaster's settings for a dock's motion unit: for a data sheet's unit (``motion_unit: mru``) its
    slow heave error as a known covariance and its output's zero mean (a high-pass filter's: no level to fit);
    the defaults otherwise (the white unit: as the forecaster was designed on)."""
    if unit is None or unit.motion_unit != "mru":
        return DockForecastSettings()
    return DockForecastSettings(
        slow_error_std_m=unit.heave_error_std_m, slow_error_tau_s=unit.heave_error_tau_s, zero_mean=True
    )


class TelemetryDock(TranslatingDock):
    """The dock as a deployable controller knows it: the charted anchor plus the motion forecast from
    the dock's telemetry.

    ``position(t)`` and ``velocity(t)`` (shape ``t.shape + (3,)``, NED m and m/s) are the anchor plus
    the forecaster's expected displacement and its rate, given the telemetry so far; before any
    telemetry the dock is at rest at its anchor.  ``std(t)`` is the forecast's uncertainty (m).

    Parameters
    ----------
    chart : DockMotion
        The dock as the mission charts it: its anchor (``position_ned_m``) and heading; its motion is
        not used.
    settings : DockForecastSettings, optional
        The forecaster's settings.
    """

    def __init__(self, chart: DockMotion, settings: DockForecastSettings | None = None) -> None:
        self.anchor = np.asarray(chart.position_ned_m, dtype=float).copy()
        self.heading_rad = float(chart.heading_rad)
        self.forecaster = DockForecaster(settings)

    @property
    def position_ned_m(self) -> tuple[float, float, float]:
        """The dock's charted anchor, NED m (the forecast's displacements are about it)."""
        n, e, d = (float(v) for v in self.anchor)
        return n, e, d

    def reset(self) -> None:
        """Start a new run: no telemetry."""
        self.forecaster.reset()

    def update(self, t: float, displacement_ned_m: np.ndarray, std_m: np.ndarray) -> bool:
        """Add one telemetry sample: the displacement (3,) NED m from the dock's mean at time ``t`` (s),
        its noise std (3,) m.  False if the forecaster rejected it (an outlier, or not later than the
        previous sample)."""
        return self.forecaster.update(t, np.asarray(displacement_ned_m, dtype=float), std_m)

    def update_rate(self, t: float, rate_ned_m_s: np.ndarray, std_m_s: np.ndarray) -> bool:
        """Add one rate sample of the telemetry (a data sheet's unit sends the heave rate): (3,) NED m/s at
        time ``t`` (s), its noise std (3,) m/s.  False if the forecaster rejected it."""
        return self.forecaster.update_rate(t, np.asarray(rate_ned_m_s, dtype=float), std_m_s)

    def forecast(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position (NED, m), velocity (m/s) and std (m) at time(s) ``t`` (s), each shape ``t.shape + (3,)``,
        from one solve of the forecaster (what :meth:`position`, :meth:`velocity` and :meth:`std` each
        take one of)."""
        tt = np.asarray(t, dtype=float)
        shape = tt.shape + (3,)
        if self.forecaster.n_measurements == 0:
            return np.broadcast_to(self.anchor, shape).copy(), np.zeros(shape), np.full(shape, np.inf)
        f = self.forecaster.predict(tt.ravel())
        return (
            (self.anchor + f.position_ned_m).reshape(shape),
            f.velocity_ned_m_s.reshape(shape),
            f.std_m.reshape(shape),
        )

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Expected dock position (north, east, down), m, at time(s) t (s); shape (..., 3)."""
        return self.forecast(t)[0]

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        """Expected dock velocity (north, east, down), m/s, at time(s) t (s); shape (..., 3)."""
        return self.forecast(t)[1]

    def std(self, t: float | np.ndarray) -> np.ndarray:
        """Standard deviation of the forecast position per axis, m, at time(s) t (s); shape (..., 3)."""
        return self.forecast(t)[2]

    def trajectory(self, t0: float, dt: float, n_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Dock motion at ``t0 + k dt`` for k = 0..n_steps (one forecast for position and velocity):
        times (n_steps + 1,) s, positions and velocities (n_steps + 1, 3) NED m and m/s."""
        t = t0 + dt * np.arange(n_steps + 1)
        p, v, _ = self.forecast(t)
        return t, p, v
