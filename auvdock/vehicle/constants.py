"""Physical constants of the world model, each defined once.

* ``GRAVITY_M_S2`` -- standard gravity, 9.80665 m/s^2 (CGPM 1901; the IMU's ``g_n``, the waves'
  dispersion relation and the vehicle's displaced mass ``rho V = B / g`` all use it);
* ``SEAWATER_DENSITY_KG_M3`` -- 1025 kg/m^3, sea water at the surface (the dock's hydrostatics).
"""

from __future__ import annotations

__all__ = ["GRAVITY_M_S2", "SEAWATER_DENSITY_KG_M3"]

GRAVITY_M_S2 = 9.80665
SEAWATER_DENSITY_KG_M3 = 1025.0
