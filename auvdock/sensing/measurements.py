"""One definition of each measurement: noise-free ``y = h(x, u, flow_ned)`` for every sensor kind.

The simulator's sensors (numpy, :func:`measure`) and the navigation filter's Jacobians
(CasADi, :func:`h` / :func:`expression`) read the SAME formulas, written once here on top of
the one vehicle model (:class:`auvdock.vehicle.model.VehicleModel`).

Frames and arguments: NED world {n}, body FRD {b}; ``x`` (12) is the state ``[eta; nu]`` with
the body velocity over ground; ``u`` (n) the thrust (N) held over the last control period;
``flow_ned`` (3) the water velocity at the vehicle in {n} (m/s).

==========  ===  ==========================================================================
kind        dim  value
==========  ===  ==========================================================================
attitude    3    x[ATT]: roll, pitch, yaw (ZYX Euler) from the autopilot's AHRS, rad
gyro        3    x[ANG]: body angular rate p, q, r, rad/s
accel       3    specific force in {b} as an IMU measures it, m/s^2:
                 ``f = nu1_dot + nu2 x nu1 - R(Theta)^T g_n``, ``g_n = (0, 0, g)``;
                 ``nu1_dot`` from ``model.accelerations(x, B u, flow_ned, 0)``.
                 At rest and level ``f = (0, 0, -g)`` (ArduPilot convention).
depth       1    x[POS][2], the pressure sensor's depth (NED down), m
position    3    x[POS] in the mission's NED frame (acoustic positioning, camera, motion capture), m
dvl         3    x[LIN]: velocity over ground in {b} (bottom lock), m/s
dock        3    the dock's docking point in the camera frame (x right, y down, z along the
                 optical axis), m: ``R_bc^T (R(Theta)^T (p_dock - x[POS]) - t_bc)`` with the
                 camera mount ``(R_bc, t_bc)`` (:func:`auvdock.vehicle.geometry.point_in_sensor_frame`);
                 the camera's fix of the dock's markers (:mod:`auvdock.sensing.camera_fix`)
==========  ===  ==========================================================================

``dock`` needs the dock's position and the camera mount besides the state
(:func:`expression`'s ``dock``); the simulated camera computes it with the same formula in
numpy.

The IMU sits at the body origin (no lever arm); the flow's rate of change along the path is
taken as zero in ``accel`` (a current constant in {n}).
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from auvdock.vehicle.constants import GRAVITY_M_S2
from auvdock.vehicle.geometry import point_in_sensor_frame
from auvdock.vehicle.model import Smtrx, Sym, VehicleModel
from auvdock.vehicle.state import ANG, ATT, LIN, NX, POS

if TYPE_CHECKING:
    from auvdock.vehicle import Vehicle

__all__ = ["KINDS", "GRAVITY", "ANGLE_ROWS", "expression", "h", "measure"]

#: Standard gravity, m/s^2 (the IMU's g_n = (0, 0, GRAVITY) in NED).
GRAVITY = GRAVITY_M_S2

#: Every measurement kind and its dimension.
KINDS: dict[str, int] = {
    "attitude": 3,
    "gyro": 3,
    "accel": 3,
    "depth": 1,
    "position": 3,
    "dvl": 3,
    "dock": 3,
}

#: Per kind, the rows of its value that are angles (residuals wrapped to [-pi, pi)).
ANGLE_ROWS: dict[str, tuple[int, ...]] = {"attitude": (0, 1, 2)}

_CACHE: weakref.WeakKeyDictionary[Vehicle, dict[str, ca.Function]] = weakref.WeakKeyDictionary()


def _check_kind(kind: str) -> None:
    if kind not in KINDS:
        raise KeyError(f"unknown measurement kind {kind!r} (known: {', '.join(KINDS)})")


def expression(
    kind: str,
    model: VehicleModel,
    x: Sym,
    u: Sym,
    flow_ned: Sym,
    dock: tuple[Sym, np.ndarray, np.ndarray] | None = None,
    flow_ned_dot: Sym | None = None,
    water_accel_ned: Sym | None = None,
) -> Sym:
    """Symbolic value of measurement ``kind`` (``KINDS[kind]`` x 1) from CasADi ``x``, ``u``, ``flow_ned``.

    ``model`` is the :class:`~auvdock.vehicle.model.VehicleModel`.  Works on SX and MX.
    ``dock`` = ``(p_dock (3, NED m), R_bc (3, 3), t_bc (3,, m))``: the dock's docking point and the
    camera mount, for kind ``dock`` (required there, ignored elsewhere).  For ``accel``, the water's
    velocity changing along the vehicle's path (``flow_ned_dot``, m/s^2, {n}) and the water's
    acceleration (``water_accel_ned``, its Froude-Krylov force: waves) push the vehicle, and the
    accelerometer feels it; both zero if omitted (a steady current).
    """
    _check_kind(kind)
    if kind == "dock":
        if dock is None:
            raise ValueError("measurement dock: needs the dock's position and the camera mount")
        p_dock, R_bc, t_bc = dock
        return point_in_sensor_frame(model.rotation(x[0:6]), x[POS], p_dock, ca.DM(R_bc), ca.DM(t_bc))
    if kind == "attitude":
        return x[ATT]
    if kind == "gyro":
        return x[ANG]
    if kind == "depth":
        return x[POS][2]
    if kind == "position":
        return x[POS]
    if kind == "dvl":
        return x[LIN]
    # accel: specific force in {b}
    if flow_ned_dot is None:
        flow_ned_dot = ca.DM.zeros(3)
    nu_dot, _ = model.accelerations(x, model.wrench(u), flow_ned, flow_ned_dot, water_accel_ned)
    nu1, nu2 = x[LIN], x[ANG]
    R = model.rotation(x[0:6])
    g_n = ca.DM([0.0, 0.0, GRAVITY])
    return nu_dot[0:3] + ca.mtimes(Smtrx(nu2), nu1) - ca.mtimes(R.T, g_n)


def h(kind: str, vehicle: Vehicle) -> ca.Function:
    """``h_kind``: (x[12], u[n], flow_ned[3]) -> y[KINDS[kind]], a CasADi SX function, cached per vehicle
    (not for ``dock``, which needs the dock and the camera mount: :func:`expression`)."""
    _check_kind(kind)
    if kind == "dock":
        raise ValueError("measurement dock: needs the dock's position and the camera mount (use expression)")
    per_vehicle = _CACHE.setdefault(vehicle, {})
    if kind not in per_vehicle:
        x = ca.SX.sym("x", NX)
        u = ca.SX.sym("u", vehicle.n_thrusters)
        vc = ca.SX.sym("flow_ned", 3)
        vc_dot = ca.SX.sym("flow_ned_dot", 3)
        a_w = ca.SX.sym("water_accel_ned", 3)
        y = expression(kind, vehicle.model, x, u, vc, None, vc_dot, a_w)
        per_vehicle[kind] = ca.Function(
            f"h_{kind}",
            [x, u, vc, vc_dot, a_w],
            [y],
            ["x", "u", "flow_ned", "flow_ned_dot", "water_accel_ned"],
            ["y"],
        )
    return per_vehicle[kind]


def measure(
    kind: str,
    vehicle: Vehicle,
    x: np.ndarray,
    u: np.ndarray | None = None,
    flow_ned: np.ndarray | None = None,
    flow_ned_dot: np.ndarray | None = None,
    water_accel_ned: np.ndarray | None = None,
) -> np.ndarray:
    """Noise-free measurement ``kind`` (``(KINDS[kind],)`` ndarray) at state ``x`` (12,).

    ``u``: thrust (n,, N) held over the last period (default zero); ``flow_ned``: water velocity
    in {n} (3,, m/s; default still water); ``flow_ned_dot``: its rate along the vehicle's path and
    ``water_accel_ned``: the water's acceleration (3,, m/s^2, {n}; waves; default zero).  Only
    ``accel`` depends on ``u`` and the water.
    """
    fn = h(kind, vehicle)
    uu = np.zeros(vehicle.n_thrusters) if u is None else np.asarray(u, dtype=float)
    vc = np.zeros(3) if flow_ned is None else np.asarray(flow_ned, dtype=float)
    vd = np.zeros(3) if flow_ned_dot is None else np.asarray(flow_ned_dot, dtype=float)
    aw = np.zeros(3) if water_accel_ned is None else np.asarray(water_accel_ned, dtype=float)
    return np.asarray(fn(np.asarray(x, dtype=float), uu, vc, vd, aw)).reshape(-1)
