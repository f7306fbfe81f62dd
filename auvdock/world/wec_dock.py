"""The WEC dock moving with the sea: the buoy's heave from its linear hydrodynamics, per wave component.

The docking station hangs rigidly below a heaving buoy (the wave-energy converter).  The buoy's
heave answers each wave component of the realised sea (:class:`auvdock.world.waves.WaveComponents`)
with its response amplitude operator (RAO, :meth:`auvdock.world.wec_table.HeaveCoefficients.rao`)::

    eta_i(t) = Re[a_i e^{i th_i(t)}],  th_i(t) = k_i . x_b - w_i t + phi_i      (the wave at the buoy)
    z_up(t)  = sum_i Re[RAO(w_i) a_i e^{i th_i(t)}]                             (heave, up)

so that the water at the vehicle and the dock's motion come from the same components with the
same phases (they stay coherent).  In NED the docking point is at ``z0 - z_up(t)``; it does not
move horizontally and does not rotate (surge and pitch are not modelled: the committed table
has heave only).  The RAO uses the components' fixed-point frequencies: the buoy is moored, so it
meets the waves at the frequency a fixed probe measures; the current's effect on the radiation
and diffraction coefficients is neglected.

Same interface as :class:`auvdock.world.dock.HeaveDock` (``position``, ``velocity``, and from
:class:`auvdock.world.dock.TranslatingDock` ``trajectory``, ``reference_state``, ``pose``) so
every controller and the docking rule use it unchanged, plus ``acceleration``, ``elevation`` (the
sea at the buoy) and the record of what moved it.

References
----------
J. Falnes, *Ocean Waves and Oscillating Systems* (2002), ch. 5 (the heave RAO of a floating body);
W. E. Cummins (1962), the time-domain equivalent.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from auvdock.world.dock import TranslatingDock
from auvdock.world.waves import WaveComponents

__all__ = ["WecDock"]


class WecDock(TranslatingDock):
    """A docking point below a heaving WEC buoy in a realised sea (see the module docstring).

    Parameters
    ----------
    sea : WaveComponents
        The realised sea (the truth's).
    position_ned_m : tuple of 3 floats
        Mean position of the docking point (north, east, down), m; the buoy is above it.
    heading_rad : float
        Heading of a docked vehicle, rad.
    heave_rao : ndarray (n,) complex
        The buoy's heave RAO at each component's frequency (m of heave up per m of wave
        amplitude, e^{-i w t} convention); 1 everywhere is a dock that follows the surface.
    label : str
        What moves the dock, for messages.
    """

    def __init__(
        self,
        sea: WaveComponents,
        position_ned_m: tuple[float, float, float],
        heading_rad: float,
        heave_rao: np.ndarray,
        label: str = "WEC buoy",
    ) -> None:
        rao = np.asarray(heave_rao, dtype=complex).ravel()
        if rao.size != sea.n_components:
            raise ValueError(f"heave_rao: {rao.size} values for {sea.n_components} wave components")
        if not np.all(np.isfinite(rao)):
            raise ValueError("heave_rao: values must be finite")
        self.sea = sea
        n0, e0, d0 = (float(v) for v in position_ned_m)
        self.position_ned_m: tuple[float, float, float] = (n0, e0, d0)
        self.heading_rad = float(heading_rad)
        self.heave_rao = rao
        self.label = label
        #: The buoy's coefficients (:class:`auvdock.world.wec_table.HeaveCoefficients`) when built from them.
        self.coefficients: Any = None
        n, e, _ = self.position_ned_m
        k = sea.wavenumber_rad_m
        b = sea.direction_rad
        # the complex heave amplitude of each component and its phase at t = 0, at the buoy
        self._amp = np.abs(rao) * sea.amplitude_m
        self._phase0 = k * (n * np.cos(b) + e * np.sin(b)) + sea.phase_rad + np.angle(rao)
        self._w = sea.omega_rad_s

    @classmethod
    def from_coefficients(
        cls,
        sea: WaveComponents,
        coefficients: Any,
        position_ned_m: tuple[float, float, float],
        heading_rad: float,
        *,
        pto_damping_N_s_m: float = 0.0,
        viscous_damping_N_s_m: float = 0.0,
        mooring_stiffness_N_m: float = 0.0,
    ) -> WecDock:
        """The dock below the buoy whose coefficients are ``coefficients``
        (:class:`auvdock.world.wec_table.HeaveCoefficients`), in ``sea``.

        Components above the table's highest frequency take its short-wave extrapolation
        (``above="decay"``: the excitation decays as ``e^{-k draft}``; the buoy barely answers
        them)."""
        rao = coefficients.rao(
            sea.omega_rad_s,
            pto_damping_N_s_m=pto_damping_N_s_m,
            viscous_damping_N_s_m=viscous_damping_N_s_m,
            mooring_stiffness_N_m=mooring_stiffness_N_m,
            above="decay",
        )
        dock = cls(sea, position_ned_m, heading_rad, rao, label=f"{coefficients.name} buoy")
        dock.coefficients = coefficients
        return dock

    # --- heave -----------------------------------------------------------------------------
    def _theta(self, t: Any) -> np.ndarray:
        tt = np.asarray(t, dtype=float)
        return self._phase0 - self._w * tt[..., None]

    def heave_up(self, t: Any) -> np.ndarray:
        """Heave of the buoy above its mean, m (up), at time(s) t (s)."""
        return np.sum(self._amp * np.cos(self._theta(t)), axis=-1)

    def heave_rate_up(self, t: Any) -> np.ndarray:
        """Heave velocity, m/s (up)."""
        return np.sum(self._amp * self._w * np.sin(self._theta(t)), axis=-1)

    def heave_accel_up(self, t: Any) -> np.ndarray:
        """Heave acceleration, m/s^2 (up)."""
        return -np.sum(self._amp * self._w**2 * np.cos(self._theta(t)), axis=-1)

    @property
    def significant_heave_m(self) -> float:
        """``4 sqrt(m0)`` of the heave, m (the realised sea's components through the RAO)."""
        return float(4.0 * math.sqrt(0.5 * float(np.sum(self._amp**2))))

    def elevation(self, t: Any) -> np.ndarray:
        """The sea's elevation at the buoy, m (up), at time(s) t (s)."""
        n, e, _ = self.position_ned_m
        return self.sea.elevation(n, e, t)

    # --- the DockModel interface -----------------------------------------------------------------
    def position(self, t: float | np.ndarray) -> np.ndarray:
        """Docking point (north, east, down), m, at time(s) t (s); shape (..., 3)."""
        z = self.position_ned_m[2] - self.heave_up(t)
        return np.stack(
            [np.full_like(z, self.position_ned_m[0]), np.full_like(z, self.position_ned_m[1]), z], -1
        )

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        """Docking point velocity (north, east, down), m/s; shape (..., 3)."""
        zd = -self.heave_rate_up(t)
        return np.stack([np.zeros_like(zd), np.zeros_like(zd), zd], -1)

    def acceleration(self, t: float | np.ndarray) -> np.ndarray:
        """Docking point acceleration (north, east, down), m/s^2; shape (..., 3)."""
        zdd = -self.heave_accel_up(t)
        return np.stack([np.zeros_like(zdd), np.zeros_like(zdd), zdd], -1)

    def describe(self) -> str:
        """One line: what moves the dock and how much."""
        return (
            f"{self.label} heaving in the sea ({self.sea.label}): significant heave "
            f"{self.significant_heave_m:.3g} m, docking point at depth {self.position_ned_m[2]:g} m"
        )
