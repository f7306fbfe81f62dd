"""Naive, Kinematic and Oracle MPC (paper section V.C), with their settings classes.

=============  ==========================================  ========================
name           prediction model                            flow it is given
=============  ==========================================  ========================
``naive``      eqs. (1)-(2) with no current                none
``kinematic``  current in the kinematics only, eq. (6)     true flow (Assumption 3)
``oracle``     eqs. (1)-(2), full                          true flow (Assumption 3)
=============  ==========================================  ========================
"""

from __future__ import annotations

import numpy as np

from auvdock.controllers.base import ControlOutput, Estimate, Plan
from auvdock.controllers.mpc import DockingMPC
from auvdock.controllers.settings import MPCSettings
from auvdock.controllers.world import ControllerWorld
from auvdock.estimation.water_ahead import WaterAhead
from auvdock.vehicle import Vehicle
from auvdock.world.dock import DockMotion

__all__ = ["BaselineMPC", "build_mpc"]


def build_mpc(
    settings: MPCSettings,
    vehicle: Vehicle,
    dock: DockMotion,
    prediction: str,
    solver: str,
    **kw,
) -> DockingMPC:
    """The MPC of eq. (10) with the given prediction model and (resolved) solver name.

    The input-rate weight R of the settings is on normalised thrust ``u_i / u_max,i``
    (dimensionless); in newtons it is ``R_i / u_max,i^2``.
    """
    u_max = vehicle.thrust_max
    R_newton = np.asarray(settings.weights.R_for(vehicle.n_thrusters), dtype=float) / u_max**2
    return DockingMPC(
        vehicle,
        dock,
        horizon=settings.horizon_steps,
        dt=settings.dt_s,
        coarse_steps=settings.coarse.steps,
        coarse_dt=settings.coarse.dt_s,
        Q=settings.weights.Q,
        R=R_newton,
        P=settings.weights.P,
        v_rel_max=settings.bounds.relative_velocity_max_m_s,
        w_max=settings.bounds.angular_rate_max_rad_s,
        prediction=prediction,  # type: ignore[arg-type]
        solver=solver,
        max_iter=settings.solver.max_iter,
        tol=settings.solver.tol,
        fallback_steps=settings.solver.fallback_steps,
        offset_free=settings.variant == "robust",
        disturbance_time_constant_s=settings.disturbance_time_constant_s,
        qp=settings.solver.qp,
        **kw,
    )


class BaselineMPC:
    """Naive, Kinematic or Oracle MPC: one :class:`DockingMPC` solve per step."""

    _PREDICTION = {"naive": "naive", "kinematic": "kinematic", "oracle": "full"}
    extra_series: dict[str, tuple[int, ...]] = {}

    def __init__(
        self,
        settings: MPCSettings,
        vehicle: Vehicle,
        dock: DockMotion,
        solver: str,
        world: ControllerWorld | None = None,
    ) -> None:
        if settings.type not in self._PREDICTION:
            raise ValueError(f"not a baseline controller: {settings.type!r}")
        self.name = settings.type
        world = world or ControllerWorld()
        # the true sea ahead: Oracle's (the full model); Kinematic's prediction holds its flow
        self.sea = world.sea if self._PREDICTION[self.name] == "full" and self.needs_true_flow else None
        self.mpc = build_mpc(settings, vehicle, dock, self._PREDICTION[self.name], solver, entry=world.entry)

    @property
    def needs_true_flow(self) -> bool:
        """Kinematic and Oracle MPC are given the true flow (Assumption 3)."""
        return self.name != "naive"

    def reset(self) -> None:
        self.mpc.reset()

    def step(self, est: Estimate, u_prev: np.ndarray) -> ControlOutput:
        if self.needs_true_flow and est.flow_ned is None:
            raise ValueError(f"{self.name} MPC needs the true flow at the vehicle (Assumption 3)")
        water = None
        if self.sea is not None and est.flow_ned is not None:
            # told the true sea: the true current held plus the sea's water ahead at the vehicle
            p = np.asarray(est.state[0:3], dtype=float)
            waves = WaterAhead.from_sea(np.zeros(3), self.sea, p, est.t, self.mpc.offsets_s)
            current = np.asarray(est.flow_ned, dtype=float) - waves.velocity_ned[0]  # the true water now
            water = WaterAhead(waves.velocity_ned + current, waves.accel_ned)
        r = self.mpc.solve(
            est.t, est.state, u_prev, None if self.name == "naive" else est.flow_ned, water=water
        )
        return ControlOutput(r.thrust, r.status, r.solve_time_s, Plan(r.plan_state, r.plan_thrust))
