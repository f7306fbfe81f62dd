"""Units of ArduSub's telemetry, both ways: what a MAVLink field holds and what it means.

One place for the conversions the vehicle simulator encodes and ``fly`` / ``replay``
decode, so that both read the same numbers:

==================  ============================  ==========================================
message             field                          unit (MAVLink common.xml)
==================  ============================  ==========================================
SCALED_IMU2         xacc, yacc, zacc (int16)       mG, 1 mG = 9.80665e-3 m/s^2
RAW_IMU             xacc, yacc, zacc (int16)       raw; ArduPilot sends mG as SCALED_IMU
SCALED_IMU2         xgyro, ygyro, zgyro (int16)    mrad/s
SCALED_PRESSURE2    press_abs (float)              hPa
VFR_HUD             alt (float)                    m, up (ArduSub: minus the depth)
SIM_STATE           lat, lon, alt (float)          deg, deg, m up: a simulator's truth (:func:`sim_latlon`)
==================  ============================  ==========================================

Depth from pressure: ``(p - p_surface) 100 / (rho g)`` with sea water's density; ArduSub's
own depth uses its ``BARO_SPEC_GRAV`` (1.0 fresh, 1.024 salt water) and the pressure at its
boot as the surface.  ``fly`` only uses depth *differences* from the session's start, so the
surface pressure cancels.
"""

from __future__ import annotations

import math

from auvdock.sensing.measurements import GRAVITY

__all__ = [
    "SIM_EARTH_RADIUS_M",
    "sim_latlon",
    "sim_position_ned",
    "GRAVITY",
    "MG_M_S2",
    "MRAD_S",
    "WATER_DENSITY",
    "ATMOSPHERE_HPA",
    "ACCEL_LSB_STD_M_S2",
    "GYRO_LSB_STD_RAD_S",
    "pressure_hpa",
    "depth_from_pressure",
]

#: One mG in m/s^2 (SCALED_IMU* accelerations).
MG_M_S2 = GRAVITY / 1000.0
#: One mrad/s in rad/s (SCALED_IMU* rates).
MRAD_S = 1e-3
#: Sea water, kg/m^3.
WATER_DENSITY = 1025.0
#: Standard atmosphere at the surface, hPa.
ATMOSPHERE_HPA = 1013.25
#: The standard deviation of rounding to whole mG / mrad/s (uniform over one step: step / sqrt(12)).
ACCEL_LSB_STD_M_S2 = MG_M_S2 / math.sqrt(12.0)
GYRO_LSB_STD_RAD_S = MRAD_S / math.sqrt(12.0)


def pressure_hpa(depth_m: float) -> float:
    """Absolute pressure (hPa) at ``depth_m`` (m, down) under the standard atmosphere."""
    return ATMOSPHERE_HPA + WATER_DENSITY * GRAVITY * depth_m / 100.0


def depth_from_pressure(
    press_abs_hpa: float, surface_hpa: float = ATMOSPHERE_HPA, density_kg_m3: float = WATER_DENSITY
) -> float:
    """Depth (m, down) of an absolute pressure (hPa): ``(p - p_surface) 100 / (rho g)``; by
    default under the standard atmosphere in sea water (ArduSub: the surface pressure is
    ``BAROn_GND_PRESS``, Pa, and rho = 1000 ``BARO_SPEC_GRAV``)."""
    return (float(press_abs_hpa) - float(surface_hpa)) * 100.0 / (float(density_kg_m3) * GRAVITY)


#: The sphere on which a simulator's SIM_STATE places the mission's frame (WGS-84's equatorial radius), m.
SIM_EARTH_RADIUS_M = 6378137.0


def sim_latlon(north_m: float, east_m: float, down_m: float) -> tuple[float, float, float]:
    """SIM_STATE's (lat deg, lon deg, alt m) of a position in the mission's frame (NED, m), the frame's
    origin at latitude 0, longitude 0 (``lat = north / R``, ``lon = east / R``, ``alt = -down``; float
    degrees near 0 keep 1e-9 m)."""
    r = SIM_EARTH_RADIUS_M
    return math.degrees(north_m / r), math.degrees(east_m / r), -down_m


def sim_position_ned(lat_deg: float, lon_deg: float, alt_m: float) -> tuple[float, float, float]:
    """The position in the mission's frame (NED, m) of SIM_STATE's lat, lon (deg) and alt (m): the
    inverse of :func:`sim_latlon`."""
    r = SIM_EARTH_RADIUS_M
    return math.radians(lat_deg) * r, math.radians(lon_deg) * r, -alt_m
