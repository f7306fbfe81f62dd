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


def build_mpc(
    mission: Mission, vehicle: Vehicle, dock: HeaveDock, prediction: str, controller: str, **kw
) -> DockingMPC:
    """The mission's MPC (eq. 10) with the given prediction model, for ``controller``.

    ``controller`` (a name in :data:`CONTROLLER_NAMES`) decides what solver ``auto`` means.

    The input-rate weight R of the mission is on normalised thrust ``u_i / u_max,i``
    (dimensionless); in newtons it is ``R_i / u_max,i^2``.
    """
    c = mission.controller
    solver = resolve_solver(c.solver.name, controller)
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
    """The solver ``auto`` stands for: real-time iteration, except SQP for Sequential FSE-MPC.

    Chosen by docking all six paper cases with every controller x solver (``auvdock bench
    --case 1 ... --case 6 --solvers rti,sqp,ipopt``; README, Performance): ``rti`` docks
    exactly the cases IPOPT docks with Naive, Kinematic, Oracle and Optimized FSE-MPC, in
    a third of the time per step (a fifth for Optimized).  With Sequential FSE-MPC it
    times out in case 4, which IPOPT and SQP dock (at 41.6 s): the perception wrench,
    unknown to the MPC, moves the vehicle off the shifted plan every step, and one QP step
    per control step does not catch up; SQP iterated to convergence does.

    ``sqp`` (sqpmethod + qrqp, Gauss-Newton) is the exact method for the convex problems.
    For Optimized FSE-MPC it does not converge (the information term is convex in the
    angular rates, so the Gauss-Newton QPs miss its curvature and full SQP iterations
    cycle; with the exact Hessian the QPs are indefinite and qrqp stalls): use ``rti``
    (whose single steps track the optimum over time) or ``ipopt`` (inertia-corrected exact
    Newton, the reference).
    """
    if name != "auto":
        return name
    return "sqp" if controller == "sequential" else "rti"


class BaselineMPC:
    """Naive, Kinematic or Oracle MPC (paper section V.C)."""

    _PREDICTION = {"naive": "naive", "kinematic": "kinematic", "oracle": "full"}

    def __init__(self, name: str, mission: Mission, vehicle: Vehicle, dock: HeaveDock) -> None:
        if name not in self._PREDICTION:
            raise ValueError(f"not a baseline controller: {name!r}")
        self.name = name
        self.mpc = build_mpc(mission, vehicle, dock, self._PREDICTION[name], name)

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
