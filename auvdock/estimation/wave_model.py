"""The water's wave-frequency motion as the navigation filter models it: damped oscillators.

Its own module because three places share it: the navigation filter
(:mod:`auvdock.estimation.navigation_filter`, whose state carries the oscillators), the estimate it hands on
(:mod:`auvdock.estimation.estimate`) and the water ahead of the vehicle
(:mod:`auvdock.estimation.water_ahead`), which runs them forward.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["WaveModel"]


@dataclass(frozen=True)
class WaveModel:
    """The water's wave-frequency motion as the filter models it (a dynamic-positioning wave filter).

    Each axis of the orbital velocity ``w`` at the vehicle (NED, m/s) is a damped oscillator driven by
    white noise, ``w'' + 2 zeta omega w' + omega^2 w = xi`` (Fossen 2011, Handbook of Marine Craft
    Hydrodynamics and Motion Control, 8.2: the linear wave response model, relative damping 0.05-0.1),
    whose stationary standard deviation is ``velocity_std_m_s``: the noise density is
    ``velocity_std * sqrt(4 zeta omega^3)``.  The current stays a random walk (slow): what oscillates at
    the wave frequency goes into ``w``, so the current's estimate does not.

    Attributes
    ----------
    omega_rad_s : float
        The oscillators' natural frequency, rad/s: the sea's (encounter) frequency at the vehicle.
    damping_ratio : float
        ``zeta``: the spectral peak's half-power width is about ``2 zeta omega``.
    velocity_std_m_s : tuple of 3 floats
        Stationary standard deviation of each axis (north, east, down) of the orbital velocity, m/s.
    """

    omega_rad_s: float
    damping_ratio: float = 0.1
    velocity_std_m_s: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if not (self.omega_rad_s > 0 and math.isfinite(self.omega_rad_s)):
            raise ValueError(f"WaveModel: omega_rad_s must be positive, got {self.omega_rad_s}")
        if not 0 < self.damping_ratio < 1:
            raise ValueError(f"WaveModel: damping_ratio must be in (0, 1), got {self.damping_ratio}")
        if len(self.velocity_std_m_s) != 3 or min(self.velocity_std_m_s) < 0:
            raise ValueError("WaveModel: velocity_std_m_s must be 3 values >= 0")

    def propagate(
        self, velocity: np.ndarray, accel: np.ndarray, tau_s: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The oscillators' expected motion ``tau_s`` (m,) seconds ahead from velocity ``velocity`` (3,)
        and its rate ``accel`` (3,) now: the free response of ``w'' + 2 zeta omega w' + omega^2 w = 0``
        (the driving noise has zero mean), ``w(tau) = exp(-zeta omega tau) [w0 cos(omega_d tau) +
        (a0 + zeta omega w0) / omega_d sin(omega_d tau)]``, ``omega_d = omega sqrt(1 - zeta^2)``, and
        its derivative.  Returns (velocity (m, 3) m/s, acceleration (m, 3) m/s^2), NED."""
        w0 = np.asarray(velocity, dtype=float)
        a0 = np.asarray(accel, dtype=float)
        tau = np.asarray(tau_s, dtype=float)[:, None]
        w, zeta = self.omega_rad_s, self.damping_ratio
        wd = w * math.sqrt(1.0 - zeta * zeta)
        decay = np.exp(-zeta * w * tau)
        c, s = np.cos(wd * tau), np.sin(wd * tau)
        vel = decay * (w0 * c + (a0 + zeta * w * w0) / wd * s)
        acc = decay * (a0 * c - (w * w * w0 + zeta * w * a0) / wd * s)
        return vel, acc

    def accel_density(self) -> np.ndarray:
        """Density (3,) of the white noise driving each axis's rate, m/s^2/sqrt(s)."""
        w, zeta = self.omega_rad_s, self.damping_ratio
        return np.asarray(self.velocity_std_m_s, dtype=float) * math.sqrt(4.0 * zeta * w**3)
