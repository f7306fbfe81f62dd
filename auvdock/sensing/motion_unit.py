"""The dock's motion unit, simulated from the truth: what ``sensors.dock_telemetry`` sends.

One sample of the unit at time ``t`` is one or two readings (:class:`auvdock.sensing.readings.Reading`):
``dock_motion`` (the docking point's displacement from its mean, NED m) and, for a data sheet's unit
(``motion_unit: mru``), ``dock_motion_rate`` (its rate, NED m/s).  The errors are the settings'
(:class:`auvdock.sensing.settings.DockTelemetrySettings`, each figure with its source): for ``mru`` a slow
heave error (first-order Gauss-Markov, exact in discrete time whatever the step) plus white noise, for
``white`` white noise alone.  The reading's ``std`` is the white part only: the slow error is the
unit's known character (the navigation filter models it as a state), not a per-sample noise.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from auvdock.sensing.readings import Reading

if TYPE_CHECKING:
    from auvdock.sensing.settings import DockTelemetrySettings

__all__ = ["MotionUnit"]


class MotionUnit:
    """A dock's motion unit (see the module docstring).

    Parameters
    ----------
    settings : DockTelemetrySettings
        The unit and its link.
    rng : numpy.random.Generator
        Its draws (the slow error's start and steps, the white noise).
    """

    def __init__(self, settings: DockTelemetrySettings, rng: np.random.Generator) -> None:
        self.settings = settings
        self.rng = rng
        self.mru = settings.motion_unit == "mru"
        s = settings
        self.noise = np.full(3, float(s.heave_noise_m if self.mru else s.std_m))
        self.rate_noise = np.full(3, float(s.rate_noise_m_s))
        self._error = 0.0
        self._t: float | None = None

    def heave_error(self, t: float) -> float:
        """The slow heave error (m, down) at ``t`` (s), advanced from the previous sample (times must not
        decrease); 0 for the white unit."""
        s = self.settings
        if not self.mru or s.heave_error_std_m <= 0.0:
            return 0.0
        sig = float(s.heave_error_std_m)
        if self._t is None:
            self._error = sig * float(self.rng.standard_normal())
        else:
            a = math.exp(-max(t - self._t, 0.0) / float(s.heave_error_tau_s))
            self._error = a * self._error + sig * math.sqrt(max(1.0 - a * a, 0.0)) * float(
                self.rng.standard_normal()
            )
        self._t = float(t)
        return self._error

    def sample(self, t: float, displacement_ned_m: np.ndarray, velocity_ned_m_s: np.ndarray) -> list[Reading]:
        """The readings of one sample at ``t`` (s) of the true displacement (3,, NED m, from the dock's mean)
        and velocity (3,, NED m/s)."""
        value = np.asarray(displacement_ned_m, dtype=float) + self.noise * self.rng.standard_normal(3)
        value[2] += self.heave_error(t)
        out = [Reading("dock_motion", t, value, self.noise.copy())]
        if self.mru:
            rate = np.asarray(velocity_ned_m_s, dtype=float) + self.rate_noise * self.rng.standard_normal(3)
            out.append(Reading("dock_motion_rate", t, rate, self.rate_noise.copy()))
        return out
