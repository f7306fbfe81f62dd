"""Docking controllers (paper section V): one MPC builder, five controllers.

=============  ==========================================  ========================
name           prediction model                            flow it is given
=============  ==========================================  ========================
``naive``      eqs. (1)-(2) with no current                none
``kinematic``  current in the kinematics only, eq. (6)     true flow (Assumption 3)
``oracle``     eqs. (1)-(2), full                          true flow (Assumption 3)
``sequential`` eqs. (1)-(2), full + law (9) offset         estimated flow
``optimized``  eqs. (1)-(2), full, cost (10) - alpha F     estimated flow
=============  ==========================================  ========================

:func:`build_controller` makes the mission's controller; every controller has
``step(meas, u_prev) -> ControlOutput`` and is driven by :class:`auvdock.autopilot.Autopilot`.
"""

from __future__ import annotations

import numpy as np

from ..dock import HeaveDock
from ..mission import Mission
from ..vehicle import Vehicle
from .base import Controller, ControlOutput, Measurement
from .mpc import DockingMPC

__all__ = [
    "Measurement",
    "ControlOutput",
    "Controller",
    "BaselineMPC",
    "build_controller",
    "build_mpc",
    "resolve_solver",
    "CONTROLLER_NAMES",
]

CONTROLLER_NAMES = ("naive", "kinematic", "oracle", "sequential", "optimized")


def build_mpc(mission: Mission, vehicle: Vehicle, dock: HeaveDock, prediction: str, **kw) -> DockingMPC:
    """The mission's MPC (eq. 10) with the given prediction model.

    The input-rate weight R of the mission is on normalised thrust ``u_i / u_max,i``
    (dimensionless); in newtons it is ``R_i / u_max,i^2``.
    """
    c = mission.controller
    solver = resolve_solver(c.solver.name, c.type if kw.get("objective_extra") is None else "optimized")
    u_max = vehicle.thrust_max
    R_newton = np.asarray(c.weights.R, dtype=float) / u_max**2
    return DockingMPC(
        vehicle,
        dock,
        horizon=c.horizon_steps,
        dt=c.dt_s,
        Q=c.weights.Q,
        R=R_newton,
        P=c.weights.P,
        v_rel_max=c.bounds.relative_velocity_max_m_s,
        w_max=c.bounds.angular_rate_max_rad_s,
        prediction=prediction,  # type: ignore[arg-type]
        solver=solver,
        max_iter=c.solver.max_iter,
        tol=c.solver.tol,
        **kw,
    )


def resolve_solver(name: str, controller: str) -> str:
    """The solver ``auto`` stands for: IPOPT for Optimized FSE-MPC, SQP otherwise.

    Cost (10) alone is a sum of squares, so SQP with its Gauss-Newton Hessian solves convex
    QPs and is the fastest.  Optimized FSE-MPC subtracts ``alpha F``, which is convex in the
    angular rates (information grows with the square of the rate), so its Hessian is
    indefinite: qrqp then stalls on non-convex QPs (measured 1-25 s per solve, case 2), and
    convexifying the Hessian removes exactly the curvature that makes turning pay.  IPOPT's
    inertia-corrected regularisation handles it (measured all solves converged, case 2).
    """
    if name != "auto":
        return name
    return "ipopt" if controller == "optimized" else "sqp"


class BaselineMPC:
    """Naive, Kinematic or Oracle MPC (paper section V.C)."""

    _PREDICTION = {"naive": "naive", "kinematic": "kinematic", "oracle": "full"}

    def __init__(self, name: str, mission: Mission, vehicle: Vehicle, dock: HeaveDock) -> None:
        if name not in self._PREDICTION:
            raise ValueError(f"not a baseline controller: {name!r}")
        self.name = name
        self.mpc = build_mpc(mission, vehicle, dock, self._PREDICTION[name])

    @property
    def needs_true_flow(self) -> bool:
        """Kinematic and Oracle MPC are given the true flow (Assumption 3)."""
        return self.name != "naive"

    def reset(self) -> None:
        self.mpc.reset()

    def step(self, meas: Measurement, u_prev: np.ndarray) -> ControlOutput:
        if self.needs_true_flow and meas.flow_ned is None:
            raise ValueError(f"{self.name} MPC needs the true flow at the vehicle (Assumption 3)")
        r = self.mpc.solve(meas.t, meas.state, u_prev, None if self.name == "naive" else meas.flow_ned)
        return ControlOutput(r.thrust, r.status, r.solve_time_s, r)


def build_controller(
    mission: Mission, vehicle: Vehicle, dock: HeaveDock, name: str | None = None
) -> Controller:
    """The controller the mission names (or ``name``), built once for a run."""
    name = name or mission.controller.type
    if name in BaselineMPC._PREDICTION:
        return BaselineMPC(name, mission, vehicle, dock)
    if name in ("sequential", "optimized"):
        from .fse import FSEMPC

        return FSEMPC(name, mission, vehicle, dock)
    raise ValueError(f"unknown controller {name!r} (known: {', '.join(CONTROLLER_NAMES)})")
