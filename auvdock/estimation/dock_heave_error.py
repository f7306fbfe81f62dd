"""The docking point's heave beyond the motion forecast from the dock's telemetry, as the navigation filter
models it (:class:`DockErrorModel`; ``navigation.dock_heave_error``)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["DockErrorModel"]


@dataclass
class DockErrorModel:
    """The dock's heave beyond the motion the filter is given (a forecast from the dock's telemetry): a
    damped oscillator driven by white acceleration, of stationary standard deviation ``std_m`` (what the
    forecast leaves unknown now;
    :meth:`auvdock.estimation.navigation_filter.NavigationFilter.set_dock_error_std` follows it), natural
    frequency ``omega_rad_s`` (the sea's) and damping ratio ``damping``; plus a slow part, a first-order
    Gauss-Markov process of standard deviation ``slow_std_m`` and correlation time ``slow_tau_s`` (the
    motion unit's slow heave error, which the forecast from its record carries: data sheet figures,
    :class:`auvdock.sensing.settings.DockTelemetrySettings`; zero for a unit without one).  With it the
    camera's fixes of the docking point correct the forecast at the wave's own time scale and hold its slow
    offset: near the dock its relative position and velocity come from the camera, not from the forecast
    (issue 40)."""

    omega_rad_s: float
    damping: float
    std_m: float
    slow_std_m: float = 0.0
    slow_tau_s: float = 20.0

    def slow_density(self) -> float:
        """The slow part's driving noise intensity, m^2/s (``2 std^2 / tau``)."""
        return 2.0 * self.slow_std_m**2 / self.slow_tau_s

    def accel_density(self) -> float:
        """The driving acceleration's intensity, m^2/s^3: ``4 zeta omega^3 std^2`` (the stationary variance
        ``std^2``)."""
        return 4.0 * self.damping * self.omega_rad_s**3 * self.std_m**2

    def transition(self, tau: float | np.ndarray) -> np.ndarray:
        """(..., 2, 2): the oscillator's exact transition over ``tau`` s (its mean run forward, or back for a
        negative ``tau``; underdamped)."""
        w, z = self.omega_rad_s, self.damping
        sig, wd = z * w, w * math.sqrt(max(1.0 - z * z, 1e-9))
        t = np.asarray(tau, dtype=float)
        e, c, sn = np.exp(-sig * t), np.cos(wd * t), np.sin(wd * t)
        out = np.empty(t.shape + (2, 2))
        out[..., 0, 0] = e * (c + sig / wd * sn)
        out[..., 0, 1] = e * sn / wd
        out[..., 1, 0] = -e * w * w / wd * sn
        out[..., 1, 1] = e * (c - sig / wd * sn)
        return out

    def ahead(self, state: np.ndarray, tau: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The expected heave error (the oscillator's and the slow part's) and its rate (each ``tau.shape``;
        m, m/s) ``tau`` s after ``state`` (3,: the oscillator's displacement and rate, the slow part)."""
        tt = np.maximum(np.asarray(tau, dtype=float), 0.0)
        st = np.asarray(state, dtype=float)
        x = self.transition(tt) @ st[0:2]
        slow = st[2] * np.exp(-tt / self.slow_tau_s)
        return x[..., 0] + slow, x[..., 1] - slow / self.slow_tau_s
