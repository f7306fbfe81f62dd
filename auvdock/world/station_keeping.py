"""Can the vehicle hold station in a sea?  The thrust the one model needs against the waves' orbital
drag and inertia, against what the thrusters can give.

A vehicle that holds its position and attitude (``nu = 0``, level, at a heading) in a sea needs, at every
instant, the body wrench that cancels what the water does to it: from the model's equations of motion
(:meth:`auvdock.vehicle.model.VehicleModel.accelerations`) with ``nu_dot = 0``,

    tau_req(t) = -(M nu_dot)|_(tau = 0) = -( C_A(nu_r) nu_r-terms + damping + restoring
                                             + M_A nu_c_dot + rho V R^T a_w )   with nu_r = -nu_c,

the water being the current plus the orbital velocity at the point (its rate and its material
acceleration drive the added-mass and Froude-Krylov forces).  The thrusters give it through the
allocation ``B``; the minimum-norm thrusts ``u = B^+ tau_req`` (what a thrust-penalising controller comes
close to) are compared with each thruster's limit in its direction: the *utilisation* ``max_i u_i /
limit_i`` (1: a thruster saturates).  The minimum-norm split is not the least-saturating one, so the
utilisation is an upper bound: a sea this says can be held, can.

Over a realisation of the sea (``duration_s``, sampled every ``dt_s``) the 99th percentile of the
utilisation is the figure; the vehicle *holds station with margin* when it is at most ``1 - margin``
(``margin`` 0.2: a fifth of the thrust left to move towards the dock, an assumption).  The current's
direction matters through the quadratic drag: :func:`station_keeping_limit` takes the worst of several.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from auvdock.vehicle.state import NX

if TYPE_CHECKING:
    from auvdock.vehicle import Vehicle
    from auvdock.world.waves import WaveComponents

__all__ = ["StationKeeping", "station_keeping", "station_keeping_limit", "DEFAULT_MARGIN"]

#: Share of the thrust left over at the 99th percentile for the approach itself (an assumption).
DEFAULT_MARGIN = 0.2


@dataclass(frozen=True)
class StationKeeping:
    """What holding station in one sea takes.

    Attributes
    ----------
    utilisation_p99, utilisation_max : float
        99th percentile and maximum over the realisation of the thrusters' utilisation (the largest
        minimum-norm thrust as a share of its limit; 1: saturated).
    wrench_p99_N : ndarray (6,)
        99th percentile of the absolute required body wrench per axis (N, N m).
    margin : float
        The share of the thrust that must be left over (``holds`` if ``utilisation_p99 <= 1 - margin``).
    """

    utilisation_p99: float
    utilisation_max: float
    wrench_p99_N: np.ndarray
    margin: float

    @property
    def holds(self) -> bool:
        """The vehicle holds station with the margin left over (at the 99th percentile)."""
        return self.utilisation_p99 <= 1.0 - self.margin


def _forcing(vehicle: Vehicle) -> ca.Function:
    """``(x[12], flow_ned[3], flow_ned_dot[3], water_accel_ned[3]) -> M nu_dot at zero thrust (6,)``."""
    m = vehicle.model
    x = ca.SX.sym("x", NX)
    vc = ca.SX.sym("flow_ned", 3)
    vd = ca.SX.sym("flow_ned_dot", 3)
    aw = ca.SX.sym("water_accel_ned", 3)
    nu_dot, _ = m.accelerations(x, ca.DM.zeros(6), vc, vd, aw)
    return ca.Function("station_forcing", [x, vc, vd, aw], [ca.mtimes(ca.DM(m.M), nu_dot)])


def required_wrench(
    vehicle: Vehicle,
    flow_ned: np.ndarray,
    flow_ned_dot: np.ndarray,
    water_accel_ned: np.ndarray,
    depth_m: float,
    heading_rad: float = 0.0,
) -> np.ndarray:
    """The body wrench (n, 6) (N, N m) that holds the vehicle still, level, at ``heading_rad`` and
    ``depth_m``, in the water of each row of ``flow_ned``, ``flow_ned_dot`` and ``water_accel_ned``
    (n, 3) (m/s, m/s^2, {n})."""
    f = _forcing(vehicle).map(int(np.atleast_2d(flow_ned).shape[0]))
    x = np.zeros(NX)
    x[2], x[5] = float(depth_m), float(heading_rad)
    n = np.atleast_2d(flow_ned).shape[0]
    X = np.tile(x[:, None], (1, n))
    out = f(X, np.atleast_2d(flow_ned).T, np.atleast_2d(flow_ned_dot).T, np.atleast_2d(water_accel_ned).T)
    return -np.asarray(out).T


def utilisation(vehicle: Vehicle, wrench: np.ndarray) -> np.ndarray:
    """The thrusters' utilisation (n,) for the body wrenches (n, 6): the largest minimum-norm thrust
    ``B^+ tau`` as a share of its limit in its direction (``thrust_max`` forwards, ``-thrust_min``
    backwards)."""
    u = np.atleast_2d(wrench) @ np.linalg.pinv(vehicle.allocation).T
    limit = np.where(u >= 0.0, np.asarray(vehicle.thrust_max), -np.asarray(vehicle.thrust_min))
    return np.max(np.abs(u) / limit, axis=1)


def station_keeping(
    vehicle: Vehicle,
    sea: WaveComponents,
    depth_m: float,
    *,
    current_ned_m_s: Sequence[float] = (0.0, 0.0),
    heading_rad: float = 0.0,
    duration_s: float = 600.0,
    dt_s: float = 0.25,
    margin: float = DEFAULT_MARGIN,
) -> StationKeeping:
    """What holding station at ``depth_m`` (m) in ``sea`` takes, over ``duration_s`` (s) of it sampled
    every ``dt_s`` (s), with a uniform ``current_ned_m_s`` (north, east; m/s) and the vehicle at
    ``heading_rad``; see the module docstring."""
    t = np.arange(0.0, float(duration_s), float(dt_s))
    p = np.tile([0.0, 0.0, float(depth_m)], (t.size, 1))
    kin = sea.kinematics(p, t)
    cur = np.array([float(current_ned_m_s[0]), float(current_ned_m_s[1]), 0.0])
    flow = kin.velocity_ned_m_s + cur
    # the vehicle does not move: the water's rate along its path is the local rate; its material
    # acceleration carries the current through the gradient (as the truth's, world.plant)
    accel = kin.acceleration_ned_m_s2
    material = accel + np.einsum("nij,j->ni", kin.gradient_ned_1_s, cur)
    tau = required_wrench(vehicle, flow, accel, material, depth_m, heading_rad)
    use = utilisation(vehicle, tau)
    return StationKeeping(
        utilisation_p99=float(np.percentile(use, 99)),
        utilisation_max=float(np.max(use)),
        wrench_p99_N=np.percentile(np.abs(tau), 99, axis=0),
        margin=float(margin),
    )


def station_keeping_limit(
    vehicle: Vehicle,
    sea: WaveComponents,
    depth_m: float,
    *,
    current_speed_m_s: float = 0.0,
    directions_deg: Sequence[float] = (0.0, 90.0, 180.0, 270.0),
    heading_rad: float = 0.0,
    duration_s: float = 600.0,
    dt_s: float = 0.25,
    margin: float = DEFAULT_MARGIN,
) -> StationKeeping:
    """:func:`station_keeping` for the worst of a current of ``current_speed_m_s`` towards each of
    ``directions_deg`` (clockwise from north): the one with the largest 99th-percentile utilisation."""
    worst: StationKeeping | None = None
    for d in directions_deg:
        a = math.radians(float(d))
        cur = (current_speed_m_s * math.cos(a), current_speed_m_s * math.sin(a))
        s = station_keeping(
            vehicle, sea, depth_m, current_ned_m_s=cur, heading_rad=heading_rad,
            duration_s=duration_s, dt_s=dt_s, margin=margin,
        )  # fmt: skip
        if worst is None or s.utilisation_p99 > worst.utilisation_p99:
            worst = s
    assert worst is not None
    return worst
