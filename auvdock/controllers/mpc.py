"""The docking MPC of paper eq. (10), built once per run from the one vehicle model.

Problem (multiple shooting, horizon N, step dt)::

    min  sum_{k=1}^{N-1} ||e_k||_Q^2 + sum_{k=0}^{N-1} ||u_k - u_{k-1}||_R^2 + ||e_N||_P^2  [- alpha F]
    s.t. x_0 = x(t),  x_{k+1} = RK4(f_pred, x_k, u_k + u_off, dt),
         u_min - u_off <= u_k <= u_max - u_off,
         |nu_r,1| <= v_max,  |nu_2| <= w_max          (k = 1..N)

where ``u_{-1}`` is the input applied last, ``e_k = [p_k - p_W(t_k); Theta_k - (0, 0, psi_W);
nu_k - nu_W(t_k)]`` compares the vehicle with the dock's predicted state (Assumption 2; the
velocity reference is the dock's velocity over ground expressed in {b}, equivalently the
dock's velocity minus the flow for the relative velocity) and ``u_off`` is an optional
fixed input offset (the active-perception input of Sequential FSE-MPC).

Offset-free tracking (``offset_free=True``; the paper's formulation has none): a lumped
disturbance ``d = [f_n (3, N, in {n}); m_b (3, N m, in {b})]`` enters every prediction as the
extra wrench ``[R^T f_n; m_b]``, held over the horizon.  Before each solve it is updated from
the last step's prediction error of the MPC's own one-step model (same discretisation, so
that with the updated ``d`` its prediction of the measured velocity is right)::

    e = nu_k - nu_hat_k(x_(k-1), u_(k-1), flow_(k-1), d),   delta = M e / dt   ({b})
    d <- clip(d + (dt / T_d) [R delta_(1:3); delta_(4:6)], -d_max, d_max)

(a first-order filter of time constant ``T_d`` on the wrench that explains the error;
``d_max`` the vehicle's largest wrench per axis, ``|B| u_max``).  The position's prediction
error updates a velocity offset the same way, ``v <- clip(v + (dt / T_d) e_p / dt)`` in {n}
(``|v| <=`` :data:`VELOCITY_OFFSET_MAX`), added to the state's velocity before the wrench update and
the solve: an FSE controller's velocity ``nu_r + R^T v_c_hat`` is biased by its estimate's error,
which no force explains.  With ``state_from_flow`` a new flow estimate re-expresses the previous
state instead of reading as a force.  A steady model error, a
steady current-estimate error or an unmodelled buoyancy then leaves no steady position
error: at a steady state the prediction is exact and the cost's minimum is on the reference
(Pannocchia and Rawlings, AIChE J. 49(2), 2003; Maeder, Borrelli and Morari, Automatica 45(6), 2009).

Prediction models (``prediction``), all from :class:`auvdock.vehicle.model.VehicleModel`:

* ``"naive"`` -- eqs. (1)-(2) with no current (nu_c = 0);
* ``"kinematic"`` -- state [eta; nu_r], current only in the kinematics
  (eta_dot = J(nu_r + nu_c)), dynamics eq. (6) with no flow terms;
* ``"full"`` -- eqs. (1)-(2) with the water given each solve for every step of the horizon
  (:class:`auvdock.estimation.water_ahead.WaterAhead`: its velocity and acceleration, the latter
  also the Froude-Krylov force's): the true flow held (Oracle MPC, the paper) or the true sea ahead
  (Oracle in a sea); the estimated current held plus the estimated waves run forward (the FSE-MPCs
  with a wave filter).  Without a profile the flow is held constant in {n} (the paper's formulation).

With an entry corridor (``entry``, :mod:`auvdock.controllers.entry`) each predicted state
k = 1..N adds the corridor's three soft-constraint residuals (the funnel's cone, the closing
speed, the heading) to the cost, about the docking point: the target's position plus its
``standoff_m`` along the dock's heading.

The problem is built ONCE; everything that changes between solves (state, last input,
dock trajectory, heading reference, flow, input offset) is a parameter packed in one
vector.  Each solve is warm-started from the previous solution shifted by one step.  A
solve that fails or does not converge never raises; the fallback is bounded
(:data:`FALLBACK_RULE`): for at most ``fallback_steps`` steps in a row the input the last good
plan scheduled for that instant, then zero thrust (neutral) until a solve succeeds, with a
status code saying which.  An old input is never repeated.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import casadi as ca
import numpy as np

from auvdock.controllers.entry import EntryCorridor, entry_residuals
from auvdock.controllers.qp_stages import Stage, StageQP
from auvdock.controllers.solvers import SOLVERS, NLPSolver, Problem, SolveResult
from auvdock.controllers.status import STATUS_FAILED, STATUS_FALLBACK_ZERO, STATUS_NOT_CONVERGED, STATUS_OK
from auvdock.estimation.water_ahead import WaterAhead
from auvdock.runtime.codegen import compiled_function
from auvdock.runtime.fastcall import BufferedFunction
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.vehicle import Vehicle
from auvdock.vehicle.model import rk4
from auvdock.vehicle.state import ANG, ATT, ETA, LIN, NU, POS, YAW
from auvdock.world.dock import DockMotion

__all__ = ["DockingMPC", "MPCResult", "shift_solution"]

Prediction = Literal["naive", "kinematic", "full"]

#: ``return_status`` of a solve skipped because its parameters were not finite.
NON_FINITE_INPUT = "non-finite input (state, flow estimate or dock)"

#: Largest velocity offset of the offset-free observer, m/s per axis.
VELOCITY_OFFSET_MAX = 0.5

#: The fallback after failed solves, in words (results files and the docs quote it).
FALLBACK_RULE = (
    "after a failed or unconverged solve, the last good plan's input for that instant, for at most "
    "fallback_steps steps in a row; then zero thrust (neutral) until a solve succeeds"
)


@dataclass
class MPCResult:
    """Outcome of one MPC solve.

    Attributes
    ----------
    thrust : ndarray (n,)
        Thrust to apply now (N), including the input offset; within the thruster limits.
    status : int
        One of the ``STATUS_*`` codes.
    solve_time_s : float
        Wall time of the solve (s).
    iterations : int
        Solver iterations.
    plan_state : ndarray (N+1, 12)
        Predicted states of the plan that is being followed (over-ground velocities).
    plan_thrust : ndarray (N, n)
        Planned thrusts (N), including the offset.
    cost : float
        Objective value (NaN on failure).
    """

    thrust: np.ndarray
    status: int
    solve_time_s: float
    iterations: int
    plan_state: np.ndarray
    plan_thrust: np.ndarray
    cost: float = math.nan
    return_status: str = ""
    extras: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class _Functions:
    """What :class:`DockingMPC` builds from its settings, with nothing of a run's state: the parameter
    vector's and the decision vector's lengths, the gaps' count, the stage layout, the one-step prediction
    (CasADi), the solver and the index arrays of the states, previous inputs and inputs in ``w``."""

    n_params: int
    nw: int
    ng: int
    dims: dict
    step: ca.Function
    solver: NLPSolver
    ix: np.ndarray
    iv: np.ndarray
    iu: np.ndarray


class DockingMPC:
    """Paper eq. (10) MPC for docking with a heaving dock.

    Parameters
    ----------
    vehicle : Vehicle
        The vehicle (its symbolic model is the prediction model's source).
    dock : DockMotion
        The dock whose motion is known over the horizon (Assumption 2).
    horizon : int
        Steps of ``dt`` (the horizon's fine part).
    dt : float
        Step, s: the control period.
    coarse_steps, coarse_dt : int, float
        The horizon's coarse tail: ``coarse_steps`` more steps of ``coarse_dt`` s each (a whole multiple
        of ``dt``, integrated in RK4 steps of ``dt``); N = ``horizon + coarse_steps`` stages.  The running
        cost of a stage is weighted by its length over ``dt`` (the same integral of the errors over
        time); the warm start shifts the last plan by ``dt`` (interpolated inside a coarse step).
    Q, R, P : array_like
        Diagonals of the stage (12), input-rate (n, one per thruster, 1/N^2) and terminal
        (12) weights.
    v_rel_max : array_like (3,)
        Bound on ``|nu_r,1|`` (m/s), relative velocity in {b}.
    w_max : array_like (3,)
        Bound on ``|nu_2|`` (rad/s).
    prediction : {"naive", "kinematic", "full"}
        Prediction model, see the module docstring.
    solver : str
        A solver registered in :data:`auvdock.controllers.solvers.SOLVERS` ("ipopt",
        "sqp", "rti").
    max_iter, tol : int, float
        Solver iteration limit and tolerance.
    hessian : {"gauss-newton", "exact"}
        Hessian of the Lagrangian given to the solver.  Cost (10) is a weighted sum of
        squared residuals, so the Gauss-Newton matrix ``2 J_r^T W J_r`` (no constraint
        curvature) is cheap, positive semidefinite and close to the exact Hessian near
        the reference; "exact" differentiates the model twice (several ms per evaluation
        without compiled code).
    objective_extra : callable, optional
        ``f(X, U, params, extra, stage_lengths_s) -> SX`` added to the objective (Optimized FSE-MPC's
        ``-alpha F``); ``extra_params`` is then the number of extra parameters it reads.
    objective_key : optional
        What defines ``objective_extra`` (numbers, arrays: :func:`auvdock.runtime.fingerprint.digest`):
        with it, or without an extra objective, the problem's functions are built once per vehicle and
        problem and shared by every run (:meth:`auvdock.vehicle.Vehicle.built`); without it, an extra
        objective is built for this controller alone.
    extra_hessian : bool
        Add the exact Hessian of ``objective_extra`` to the Gauss-Newton matrix.  False
        gives it zero curvature (the QP stays convex; the term acts through its gradient).
    fallback_steps : int
        Most consecutive failed solves bridged with the last good plan (:data:`FALLBACK_RULE`);
        0: zero thrust at the first failure.
    offset_free : bool
        Estimate and predict with the lumped disturbance (module docstring).
    disturbance_time_constant_s : float
        ``T_d``, s.
    state_from_flow : bool
        The state's over-ground velocity is built from the flow it is given (FSE-MPC:
        ``nu_r + R^T v_c_hat``), so a new flow estimate moves it without a force; the
        disturbance update then predicts from the previous state re-expressed with it.
    qp : {"hpipm", "qrqp"}
        QP solver of ``sqp`` and ``rti`` (:data:`auvdock.controllers.rti.QP_SOLVERS`).
    entry : EntryCorridor, optional
        The dock's entry corridor in the cost (:mod:`auvdock.controllers.entry`); None: none
        (the paper's cost).

    Attributes
    ----------
    dims : dict
        The stage layout of the decision variables ``w = [x~_0, u_0, ..., x~_N]`` (augmented
        state ``x~_k = [x_k; u_(k-1)]``, 12 + n; input n) and of the constraints (the gaps,
        12 + n per stage): HPIPM's ``N``, ``nx``, ``nu``, ``ng``.
    """

    def __init__(
        self,
        vehicle: Vehicle,
        dock: DockMotion,
        *,
        horizon: int = 10,
        dt: float = 0.05,
        coarse_steps: int = 0,
        coarse_dt: float = 0.25,
        Q: np.ndarray | list[float],
        R: np.ndarray | list[float],
        P: np.ndarray | list[float],
        v_rel_max: np.ndarray | Sequence[float] = (2.5, 2.5, 2.5),
        w_max: np.ndarray | Sequence[float] = (0.25, 0.25, 0.25),
        prediction: Prediction = "full",
        solver: str = "ipopt",
        max_iter: int = 100,
        tol: float = 1e-6,
        hessian: str = "gauss-newton",
        objective_extra=None,
        objective_key: Any = None,
        extra_params: int = 0,
        extra_hessian: bool = True,
        fallback_steps: int = 2,
        offset_free: bool = False,
        disturbance_time_constant_s: float = 1.0,
        state_from_flow: bool = False,
        qp: str = "hpipm",
        entry: EntryCorridor | None = None,
    ) -> None:
        if prediction not in ("naive", "kinematic", "full"):
            raise ValueError(f"unknown prediction model {prediction!r}")
        self.vehicle = vehicle
        self.dock = dock
        self.dt = float(dt)
        n_fine, n_coarse = int(horizon), int(coarse_steps)
        sub = round(float(coarse_dt) / self.dt) if n_coarse > 0 else 1
        if n_coarse < 0 or (n_coarse > 0 and (sub < 1 or abs(sub * self.dt - float(coarse_dt)) > 1e-9)):
            raise ValueError(f"coarse_dt {coarse_dt:g} s is not a whole multiple of dt {self.dt:g} s")
        self.N = n_fine + n_coarse
        #: The stages' lengths (N,), s: ``horizon`` of ``dt``, then ``coarse_steps`` of ``coarse_dt``.
        self.stage_dt = np.array([self.dt] * n_fine + [sub * self.dt] * n_coarse)
        #: RK4 steps of ``dt`` per stage (N,): 1 in the fine part.
        self.stage_substeps = np.array([1] * n_fine + [sub] * n_coarse)
        #: The stages' starts after now (N,), s (``k dt`` in the fine part, as a uniform grid has them).
        self.offsets_s = np.concatenate(
            [self.dt * np.arange(n_fine), n_fine * self.dt + sub * self.dt * np.arange(n_coarse)]
        )
        self.uniform = n_coarse == 0 or sub == 1
        self.prediction = prediction
        self.solver_name = solver
        self.Q = np.asarray(Q, dtype=float)
        self.R = np.asarray(R, dtype=float)
        self.P = np.asarray(P, dtype=float)
        self.v_rel_max = np.asarray(v_rel_max, dtype=float)
        self.w_max = np.asarray(w_max, dtype=float)
        self.u_min = vehicle.thrust_min
        self.u_max = vehicle.thrust_max
        self.n_extra = int(extra_params)
        self.nx, self.nu = vehicle.nx, vehicle.n_thrusters
        if self.R.shape != (self.nu,):
            raise ValueError(f"R must have {self.nu} values (one per thruster), got {self.R.shape}")
        rot = vehicle.model.function("rotation")
        rot_fast = BufferedFunction(rot)
        self._R = lambda angles: rot_fast(angles)[0].reshape(3, 3, order="F").copy()  # R(Theta), {b} -> {n}
        self._rot_map = rot.map(self.N + 1)
        self._extra_hessian = bool(extra_hessian)
        if fallback_steps < 0:
            raise ValueError("fallback_steps must be >= 0")
        self.fallback_steps = int(fallback_steps)
        self.offset_free = bool(offset_free)
        self.state_from_flow = bool(state_from_flow)
        if not disturbance_time_constant_s > 0:
            raise ValueError("disturbance_time_constant_s must be positive")
        self.dist_gain = min(1.0, self.dt / float(disturbance_time_constant_s))
        B = np.asarray(vehicle.allocation, dtype=float)
        self.dist_max = np.abs(B) @ np.maximum(np.abs(vehicle.thrust_min), np.abs(vehicle.thrust_max))
        self.entry = entry
        if solver not in SOLVERS:
            raise ValueError(f"unknown solver {solver!r} (known: {', '.join(SOLVERS)})")
        if hessian not in ("gauss-newton", "exact"):
            raise ValueError(f"unknown hessian {hessian!r} (known: gauss-newton, exact)")

        def build() -> _Functions:
            return self._build(objective_extra, solver, max_iter, tol, hessian, qp)

        if objective_extra is not None and objective_key is None:
            f = build()  # an extra objective nothing names: built for this controller alone
        else:  # the same functions for every run of this vehicle and problem (Vehicle.built)
            defining = (
                self.N, self.dt, self.stage_substeps, self.prediction, self.Q, self.R, self.P,
                self.n_extra, self._extra_hessian, self.entry, objective_key,
                solver, int(max_iter), float(tol), hessian, qp,
            )  # fmt: skip
            f = vehicle.built("docking_mpc", defining, build)
        self._n_params, self._nw, self._ng, self.dims = f.n_params, f.nw, f.ng, f.dims
        self._step_fn = BufferedFunction(f.step)
        self._solver, self.build = f.solver, f.solver.build
        self._ix, self._iv, self._iu = f.ix, f.iv, f.iu
        self._lb_static, self._ub_static = self._bound_template()
        self.reset()

    # ------------------------------------------------------------------------------------
    def _build(
        self, objective_extra, solver: str, max_iter: int, tol: float, hessian: str, qp: str
    ) -> _Functions:
        """The problem's functions and solver, from the controller's settings (nothing of a run's state)."""
        N, dt = self.N, self.dt
        model = self.vehicle.model
        nx, nu = self.nx, self.nu

        # parameters, packed in one vector
        x0 = ca.SX.sym("x0", nx)
        u_prev = ca.SX.sym("u_prev", nu)
        dock_p = ca.SX.sym("dock_p", 3, N + 1)
        dock_v = ca.SX.sym("dock_v", 3, N + 1)
        psi_ref = ca.SX.sym("psi_ref")
        flow = ca.SX.sym("flow_ned", 3)
        u_off = ca.SX.sym("u_off", nu)
        extra = ca.SX.sym("extra", self.n_extra)
        dist = ca.SX.sym("disturbance", 6)
        water_v = ca.SX.sym("water_v", 3, N)  # the water over the horizon (full prediction)
        water_a = ca.SX.sym("water_a", 3, N)
        entry_p = ca.SX.sym("entry", 3)  # [dock heading (rad, near the vehicle's), standoff (m), active]
        parts = [x0, u_prev, dock_p, dock_v, psi_ref, flow, u_off, extra, dist, water_v, water_a, entry_p]
        params = ca.vertcat(*[ca.vec(v) for v in parts])
        n_params = params.shape[0]
        # where each parameter's first value is in the vector (matrices by column)
        names = ("x0", "u_prev", "dock_p", "dock_v", "psi_ref", "flow", "u_off", "extra", "dist", "water_v",
                 "water_a", "entry")  # fmt: skip
        at = dict(zip(names, (int(v) for v in np.cumsum([0] + [v.numel() for v in parts[:-1]])), strict=True))

        # one-step prediction, with the lumped disturbance [R^T f_n; m_b] (zero: the paper's model)
        xs = ca.SX.sym("xs", nx)
        us = ca.SX.sym("us", nu)
        acc = ca.SX.sym("water_accel", 3)
        zero = ca.DM.zeros(3)

        def tau_d(x: ca.SX) -> ca.SX:
            return ca.vertcat(ca.mtimes(model.rotation(x[ETA]).T, dist[0:3]), dist[3:6])

        if self.prediction == "naive":
            f_pred = lambda x, u: model.dynamics(x, u, zero, zero, tau_d(x))  # noqa: E731
        elif self.prediction == "kinematic":
            f_pred = lambda x, u: model.relative_dynamics(x, u, flow, tau_d(x))  # noqa: E731
        else:  # the water's acceleration: its rate along the path and the Froude-Krylov force's
            f_pred = lambda x, u: model.dynamics(x, u, flow, acc, tau_d(x), acc)  # noqa: E731
        step = ca.Function("mpc_model_step", [xs, us, flow, acc, dist], [rk4(f_pred, xs, dt, 1, us)])
        # the offset-free observer's one-step prediction, evaluated every control step: compiled
        step_fn = compiled_function(step)[0]
        # a coarse stage: the same RK4 step of dt, m times (the thrust and the water held over it)
        steps = {1: step}
        for m in sorted(set(int(v) for v in self.stage_substeps) - {1}):
            steps[m] = ca.Function(
                f"mpc_model_step_{m}", [xs, us, flow, acc, dist], [rk4(f_pred, xs, m * dt, m, us)]
            )

        # stage-structured layout: w = [x~_0, u_0, x~_1, u_1, ..., x~_N] with the augmented state
        # x~_k = [x_k; v_k], v_k the input of the step before (v_0 = u_prev, fixed by bounds), so
        # the input-rate cost ||u_k - v_k||_R^2 is a function of one stage and the constraints are
        # the stage-to-stage gaps F(x~_k, u_k) - x~_(k+1) = 0 in stage order (a block-diagonal
        # Hessian and the banded Jacobian structure-exploiting QP solvers such as HPIPM expect)
        X = ca.SX.sym("X", nx, N + 1)
        V = ca.SX.sym("V", nu, N + 1)
        U = ca.SX.sym("U", nu, N)

        def over_ground(xk: ca.SX, fl: ca.SX) -> ca.SX:
            if self.prediction == "kinematic":
                return xk[NU] + ca.vertcat(model.body_flow(xk[ETA], fl), 0, 0, 0)
            return xk[NU]

        def error(xk: ca.SX, dpk: ca.SX, dvk: ca.SX, psi: ca.SX, fl: ca.SX) -> ca.SX:
            """e_k of the state ``xk`` against the dock at ``dpk``, moving at ``dvk``, heading ``psi``."""
            R_nb = model.rotation(xk[ETA])
            v_ref = ca.mtimes(R_nb.T, dvk)
            return ca.vertcat(
                xk[POS] - dpk,
                xk[ATT][0:2],
                xk[YAW] - psi,
                over_ground(xk, fl) - ca.vertcat(v_ref, 0, 0, 0),
            )

        def entry_error(xk: ca.SX, dpk: ca.SX, dvk: ca.SX, fl: ca.SX, ent: ca.SX) -> ca.SX:
            """The entry corridor's residuals of ``xk``; ``ent`` = [heading, standoff, active]."""
            assert self.entry is not None
            heading, standoff, active = ent[0], ent[1], ent[2]
            axis = ca.vertcat(ca.cos(heading), ca.sin(heading), 0)
            v_ned = ca.mtimes(model.rotation(xk[ETA]), over_ground(xk, fl)[0:3])
            return entry_residuals(
                self.entry, xk[POS], v_ned, xk[YAW], dpk + standoff * axis, dvk, heading, active
            )

        # cost (10) as weighted residuals: J = sum_i wts_i r_i^2 (Gauss-Newton Hessian 2 J_r^T W J_r)
        # a stage's running cost weighs as long as it lasts (the fine stages' by 1: the paper's sum)
        lasts = self.stage_dt / dt
        res, wts = [], []
        g = []
        for k in range(N):
            if k >= 1:
                res.append(error(X[:, k], dock_p[:, k], dock_v[:, k], psi_ref, flow))
                wts.append(self.Q * lasts[k - 1] if lasts[k - 1] != 1.0 else self.Q)
            res.append(U[:, k] - V[:, k])
            wts.append(self.R)
            step_k = steps[int(self.stage_substeps[k])]
            if self.prediction == "full":
                g.append(step_k(X[:, k], U[:, k] + u_off, water_v[:, k], water_a[:, k], dist) - X[:, k + 1])
            else:
                g.append(step_k(X[:, k], U[:, k] + u_off, flow, zero, dist) - X[:, k + 1])
            g.append(U[:, k] - V[:, k + 1])
        res.append(error(X[:, N], dock_p[:, N], dock_v[:, N], psi_ref, flow))
        wts.append(self.P)
        w_entry = np.zeros(0)
        if self.entry is not None:
            w_entry = np.asarray(self.entry.weights, dtype=float)
            for k in range(1, N + 1):
                res.append(entry_error(X[:, k], dock_p[:, k], dock_v[:, k], flow, entry_p))
                wts.append(w_entry * lasts[k - 1] if lasts[k - 1] != 1.0 else w_entry)
        r = ca.vertcat(*res)
        W = ca.DM(np.concatenate(wts))
        J = ca.dot(W * r, r)
        J_extra = 0
        if objective_extra is not None:
            J_extra = objective_extra(X, U + ca.repmat(u_off, 1, N), params, extra, self.stage_dt)
        J = J + J_extra

        blocks = []
        for k in range(N + 1):
            blocks += [X[:, k], V[:, k]] + ([U[:, k]] if k < N else [])
        w = ca.vertcat(*blocks)
        dims = {"N": N, "nx": [nx + nu] * (N + 1), "nu": [nu] * N + [0], "ng": [0] * (N + 1)}
        H_gn = None
        if hessian == "gauss-newton":
            Jr = ca.jacobian(r, w)
            H_gn = 2 * ca.mtimes(Jr.T, ca.mtimes(ca.diag(W), Jr))
            if objective_extra is not None and self._extra_hessian:
                H_gn = H_gn + ca.hessian(J_extra, w)[0]
        stages = None
        if solver == "rti" and qp == "hpipm" and H_gn is not None:
            if not (objective_extra is not None and self._extra_hessian):  # (its curvature couples stages)
                J_fn = None
                if objective_extra is not None:
                    J_fn = ca.Function("mpc_path_cost", [w, params], [J_extra, ca.gradient(J_extra, w)])
                stages = self._stage_qp(step, error, entry_error, at, n_params, w_entry, J_fn)
        problem = Problem(w, params, J, ca.vertcat(*g), H_gn, hessian, dims, qp, stages)
        # index helpers into w
        stage = nx + 2 * nu
        starts = stage * np.arange(N + 1)[:, None]
        ix, iv, iu = starts + np.arange(nx), starts + nx + np.arange(nu), starts[:N] + nx + nu + np.arange(nu)
        for a in (ix, iv, iu):
            a.flags.writeable = False  # shared by every controller built on them
        return _Functions(
            n_params=n_params,
            nw=w.shape[0],
            ng=(nx + nu) * N,
            dims=dims,
            step=step_fn,
            solver=SOLVERS[solver].build(problem, max_iter, tol),
            ix=ix,
            iv=iv,
            iu=iu,
        )

    # ------------------------------------------------------------------------------------
    def _stage_qp(
        self,
        step: ca.Function,
        error: Any,
        entry_error: Any,
        at: dict[str, int],
        n_params: int,
        w_entry: np.ndarray,
        path_cost: ca.Function | None,
    ) -> StageQP:
        """The problem of :meth:`_build` stage by stage (:mod:`auvdock.controllers.qp_stages`): the same
        prediction, residuals and weights, each kind of stage's functions built once.

        ``step`` is the one-step prediction ``(x, u, flow, accel, disturbance) -> x+`` (RK4 over ``dt``);
        ``error`` and ``entry_error`` the residuals of a state; ``at`` where each parameter begins in the
        parameter vector; ``path_cost`` the whole path's extra cost and its gradient, or None."""
        N, nx, nu = self.N, self.nx, self.nu
        nt = nx + nu  # the augmented state [x; previous input]
        # the one step and its derivatives, generated once; a stage of m steps chains it m times
        xs, ua = ca.SX.sym("x", nx), ca.SX.sym("u", nu)
        fl, ac, d6 = ca.SX.sym("flow", 3), ca.SX.sym("accel", 3), ca.SX.sym("disturbance", 6)
        xn = step(xs, ua, fl, ac, d6)
        dyn = ca.Function(
            "mpc_stage_dynamics", [xs, ua, fl, ac, d6], [xn, ca.jacobian(xn, xs), ca.jacobian(xn, ua)]
        )
        gaps: dict[int, ca.Function] = {}
        for m in sorted(set(int(v) for v in self.stage_substeps)):
            gt, gu, gt1 = ca.MX.sym("xt", nt), ca.MX.sym("u", nu), ca.MX.sym("xt1", nt)
            sg = ca.MX.sym("s", 12 + nu)  # flow (3), accel (3), disturbance (6), input offset (nu)
            gx: Any = gt[:nx]
            applied = gu + sg[12:]
            Phi: Any = None
            Psi: Any = None
            for _ in range(m):
                gx, Ax, Bu = dyn(gx, applied, sg[0:3], sg[3:6], sg[6:12])
                Phi = Ax if Phi is None else ca.mtimes(Ax, Phi)
                Psi = Bu if Psi is None else ca.mtimes(Ax, Psi) + Bu
            A = ca.blockcat([[Phi, ca.MX(nx, nu)], [ca.MX(nu, nx), ca.MX(nu, nu)]])
            B = ca.vertcat(Psi, ca.MX.eye(nu))
            gaps[m] = ca.Function(f"mpc_stage_gap_{m}", [gt, gu, gt1, sg], [A, B, ca.vertcat(gx, gu) - gt1])

        # the stage costs: the weighted residuals' Gauss-Newton blocks (2 J^T W J, 2 J^T W r, r^T W r)
        xt, ut = ca.SX.sym("xt", nt), ca.SX.sym("u", nu)
        sc = ca.SX.sym("s", 14)  # dock position (3), velocity (3), heading, flow (3), entry (3), weight scale
        dpk, dvk, psi, flk, ent, scale = sc[0:3], sc[3:6], sc[6], sc[7:10], sc[10:13], sc[13]

        def cost(name: str, res: list[Any], wts: list[Any], last: bool = False) -> ca.Function:
            r, W = ca.vertcat(*res), ca.vertcat(*wts)
            u = ca.SX(0, 1) if last else ut
            z = ca.vertcat(xt, u)
            Jr = ca.jacobian(r, z)
            H = 2 * ca.mtimes(Jr.T, ca.mtimes(ca.diag(W), Jr))
            grad = 2 * ca.mtimes(Jr.T, W * r)
            m = z.shape[0]
            outs = [H[:nt, :nt], H[nt:m, :nt], H[nt:m, nt:m], grad[:nt], grad[nt:m], ca.dot(W * r, r)]
            return ca.Function(name, [xt, u, sc], [ca.densify(o) for o in outs])

        x = xt[:nx]
        rate = [ut - xt[nx:]]
        rate_w = [ca.SX(ca.DM(self.R))]
        corridor = [entry_error(x, dpk, dvk, flk, ent)] if self.entry is not None else []
        corridor_w = [scale * ca.DM(w_entry)] if self.entry is not None else []
        first = cost("mpc_stage_cost_first", rate, rate_w)
        running = cost(
            "mpc_stage_cost", [error(x, dpk, dvk, psi, flk), *rate, *corridor],
            [scale * ca.DM(self.Q), *rate_w, *corridor_w],
        )  # fmt: skip
        terminal = [ca.SX(ca.DM(self.P)), *corridor_w]
        last = cost("mpc_stage_cost_last", [error(x, dpk, dvk, psi, flk), *corridor], terminal, last=True)

        # where each stage's parameters are in [p; consts] (consts: 0, then the stages' weight scales)
        lasts = self.stage_dt / self.dt
        consts = np.concatenate([[0.0], lasts])
        zero = n_params

        def cost_params(k: int) -> np.ndarray:
            scale_at = n_params + 1 + (k - 1 if k >= 1 else 0)
            return np.concatenate([
                at["dock_p"] + 3 * k + np.arange(3), at["dock_v"] + 3 * k + np.arange(3), [at["psi_ref"]],
                at["flow"] + np.arange(3), at["entry"] + np.arange(3), [scale_at],
            ])  # fmt: skip

        def gap_params(k: int) -> np.ndarray:
            if self.prediction == "full":
                water = [at["water_v"] + 3 * k + np.arange(3), at["water_a"] + 3 * k + np.arange(3)]
            else:
                water = [at["flow"] + np.arange(3), np.full(3, zero)]
            return np.concatenate([*water, at["dist"] + np.arange(6), at["u_off"] + np.arange(nu)])

        out = [
            Stage(
                gaps[int(self.stage_substeps[k])] if k < N else None,
                gap_params(k) if k < N else np.zeros(0, dtype=int),
                first if k == 0 else (last if k == N else running),
                cost_params(k),
            )
            for k in range(N + 1)
        ]
        return StageQP(nt, nu, n_params, out, consts, path_cost)

    # ------------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget the previous solution (warm start and fallback plan)."""
        self._w_prev: np.ndarray | None = None
        self._lam_x: np.ndarray | None = None
        self._lam_g: np.ndarray | None = None
        self._plan_u: np.ndarray | None = None
        self._plan_x: np.ndarray | None = None
        self._plan_age = 0
        self.disturbance = np.zeros(6)
        self.velocity_offset = np.zeros(3)
        self._obs_prev: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def _observe(
        self, xm: np.ndarray, u_applied: np.ndarray, flow: np.ndarray, accel: np.ndarray, R: np.ndarray
    ) -> np.ndarray:
        """Update the disturbances from the last step's prediction error (module docstring);
        returns the state corrected by the velocity offset.  ``R`` is R(Theta) at ``xm``; ``flow``
        and ``accel`` the water's velocity and acceleration now (3, each; NED)."""
        if not np.all(np.isfinite(xm)):
            self._obs_prev = None
            return xm
        prev = self._obs_prev
        if prev is not None:
            xm_prev, flow_prev, accel_prev = prev
            if self.state_from_flow:
                # a new flow estimate moves the over-ground velocity an FSE controller is given
                # (nu_r + R^T v_c) without any force: predict from the state as it is now understood
                xm_prev = xm_prev.copy()
                xm_prev[LIN] += self._R(xm_prev[ATT]).T @ (flow - flow_prev)
                flow_prev = flow
            pred = self._step_fn(xm_prev, u_applied, flow_prev, accel_prev, self.disturbance)[0].copy()
            e_p = xm[POS] - pred[POS]  # {n}: a velocity the state does not show
            v = self.velocity_offset + self.dist_gain * e_p / self.dt
            if np.all(np.isfinite(v)):
                self.velocity_offset = np.clip(v, -VELOCITY_OFFSET_MAX, VELOCITY_OFFSET_MAX)
        xc = xm.copy()
        xc[LIN] += R.T @ self.velocity_offset
        if prev is not None:
            delta = self.vehicle.model.M @ (xc[NU] - pred[NU]) / self.dt
            delta_n = np.concatenate([R @ delta[0:3], delta[3:6]])
            if np.all(np.isfinite(delta_n)):
                d = self.disturbance + self.dist_gain * delta_n
                self.disturbance = np.clip(d, -self.dist_max, self.dist_max)
        self._obs_prev = (xc.copy(), flow.copy(), accel.copy())
        return xc

    def _to_model_state(self, x: np.ndarray, flow_ned: np.ndarray, R: np.ndarray) -> np.ndarray:
        """The measured state in the prediction model's coordinates (``R`` = R(Theta) at ``x``)."""
        if self.prediction != "kinematic":
            return x
        xr = x.copy()
        xr[LIN] -= R.T @ flow_ned
        return xr

    def _bound_template(self) -> tuple[np.ndarray, np.ndarray]:
        """The bounds that never change: |nu_2| <= w_max at k = 1..N, the rest unbounded."""
        lbx = np.full(self._nw, -np.inf)
        ubx = np.full(self._nw, np.inf)
        lbx[self._ix[1:, ANG]] = -self.w_max
        ubx[self._ix[1:, ANG]] = self.w_max
        return lbx, ubx

    def _bounds(
        self, xm: np.ndarray, u_prev_m: np.ndarray, flow_ned: np.ndarray, u_off: np.ndarray, R: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        lbx, ubx = self._lb_static.copy(), self._ub_static.copy()
        lbx[self._ix[0]] = xm
        ubx[self._ix[0]] = xm
        # relative velocity box, centred on the body-frame flow at the current attitude
        centre = R.T @ flow_ned if self.prediction == "full" else np.zeros(3)
        lbx[self._ix[1:, LIN]] = centre - self.v_rel_max
        ubx[self._ix[1:, LIN]] = centre + self.v_rel_max
        lbx[self._iu] = self.u_min - u_off
        ubx[self._iu] = self.u_max - u_off
        lbx[self._iv[1:]] = self.u_min - u_off  # v_k = u_(k-1): the same box (never active)
        ubx[self._iv[1:]] = self.u_max - u_off
        lbx[self._iv[0]] = ubx[self._iv[0]] = u_prev_m
        return lbx, ubx

    def solve(
        self,
        t: float,
        x: np.ndarray,
        u_prev: np.ndarray,
        flow_ned: np.ndarray | None = None,
        u_offset: np.ndarray | None = None,
        extra: np.ndarray | None = None,
        water: WaterAhead | None = None,
    ) -> MPCResult:
        """Solve once at time ``t`` (s) from state ``x`` (12, over-ground velocities).

        Parameters
        ----------
        u_prev : ndarray (n,)
            Thrust applied during the last period (N), for the input-rate cost.
        flow_ned : ndarray (3,), optional
            Flow used by the prediction (m/s, NED): the true flow for Oracle/Kinematic,
            the estimate for FSE-MPC; ignored by Naive.
        u_offset : ndarray (n,), optional
            Fixed input added to every planned input (N).
        extra : ndarray, optional
            Extra parameters of ``objective_extra``.
        water : WaterAhead, optional
            The water over the horizon (``"full"`` prediction; N steps); ``flow_ned`` is then its first
            velocity.  Default: ``flow_ned`` held, no acceleration.
        """
        x = np.asarray(x, dtype=float)
        if water is not None:
            if water.steps != self.N:
                raise ValueError(f"water: {water.steps} steps for a horizon of {self.N}")
            flow_ned = water.velocity_ned[0]
        flow = np.zeros(3) if flow_ned is None else np.asarray(flow_ned, dtype=float)
        if water is None:
            water = WaterAhead.held(flow, self.N)
        u_off = np.zeros(self.nu) if u_offset is None else np.asarray(u_offset, dtype=float)
        ex = np.zeros(self.n_extra) if extra is None else np.asarray(extra, dtype=float)
        R = self._R(x[ATT])  # the model states below share x's attitude
        xm = self._to_model_state(x, flow, R)
        accel = water.accel_ned[0] if self.prediction == "full" else np.zeros(3)
        if self.offset_free:
            xm = self._observe(xm, np.asarray(u_prev, dtype=float), flow, accel, R)
        if self.uniform:
            _, dp, dv = self.dock.trajectory(t, self.dt, self.N)
        else:  # at the grid's nodes
            nodes = t + np.append(self.offsets_s, self.offsets_s[-1] + self.stage_dt[-1])
            dp, dv = self.dock.position(nodes), self.dock.velocity(nodes)
        psi_d = self.dock.heading_rad
        psi_ref = psi_d + 2 * math.pi * round((x[YAW] - psi_d) / (2 * math.pi))
        # the dock's entry: its heading (within pi of the vehicle's), where the target stands off it
        psi_e = float(getattr(self.dock, "entry_heading_rad", psi_d))
        psi_e += 2 * math.pi * round((x[YAW] - psi_e) / (2 * math.pi))
        entry = [psi_e, float(getattr(self.dock, "standoff_m", 0.0)), 1.0 if self.entry is not None else 0.0]
        p = np.concatenate(
            [
                xm, u_prev - u_off, dp.ravel(), dv.ravel(), [psi_ref], flow, u_off, ex, self.disturbance,
                np.ravel(water.velocity_ned), np.ravel(water.accel_ned), entry,
            ]
        )  # fmt: skip
        u_prev_m = np.clip(u_prev - u_off, self.u_min - u_off, self.u_max - u_off)
        lbx, ubx = self._bounds(xm, u_prev_m, flow, u_off, R)

        if self._w_prev is None:
            w0 = np.zeros(self._nw)
            w0[self._ix] = xm
            w0[self._iu] = u_prev_m
            w0[self._iv] = u_prev_m
        else:
            if self.uniform:
                w0 = shift_solution(self._w_prev, self._ix, self._iv, self._iu)
            else:
                w0 = shift_on_grid(
                    self._w_prev, self._ix, self._iv, self._iu, self.offsets_s, self.stage_dt, self.dt
                )
            w0[self._ix[0]] = xm
            w0[self._iv[0]] = u_prev_m
        t0 = time.perf_counter()
        if not np.all(np.isfinite(p)):
            # a diverged estimate (or state) would make every solver iteration fail on NaN
            res = SolveResult(None, False, NON_FINITE_INPUT, 0, math.nan)
        else:
            try:
                with SigintDeferred():
                    res = self._solver.solve(
                        w0, p, lbx, ubx, lam_x0=self._lam_x, lam_g0=self._lam_g, cold=self._w_prev is None
                    )
            except RuntimeError as e:  # CasADi evaluation errors
                res = SolveResult(None, False, f"error: {e}", -1, math.nan)
        finite = res.w is not None and bool(np.all(np.isfinite(res.w)))
        ok, ret, iters, w_opt, fval = res.success, res.return_status, res.iterations, res.w, res.cost
        lam_x, lam_g = res.lam_x, res.lam_g
        solve_time = time.perf_counter() - t0

        if ok and finite and w_opt is not None:
            self._w_prev = w_opt
            self._lam_x, self._lam_g = lam_x, lam_g
            self._plan_u = w_opt[self._iu] + u_off
            self._plan_x = self._from_model_states(w_opt[self._ix], flow)
            self._plan_age = 0
            thrust = np.clip(self._plan_u[0], self.u_min, self.u_max)
            return MPCResult(thrust, STATUS_OK, solve_time, iters, self._plan_x, self._plan_u, fval, ret)

        # bounded fallback (FALLBACK_RULE): the last good plan's input for this instant for at
        # most fallback_steps steps, then neutral; never an old input repeated
        status = STATUS_NOT_CONVERGED if finite else STATUS_FAILED
        if self._plan_u is not None:
            self._plan_age += 1
        k = self._plan_age
        # the plan's stage at k control periods after it was made
        stage = k if self.uniform else int(np.searchsorted(self.offsets_s, k * self.dt + 1e-9) - 1)
        if (
            self._plan_u is not None
            and self._plan_x is not None
            and k <= self.fallback_steps
            and stage <= self.N - 1
        ):
            thrust = np.clip(self._plan_u[stage], self.u_min, self.u_max)
            plan_x, plan_u = self._plan_x, self._plan_u
        else:
            status = STATUS_FALLBACK_ZERO
            thrust = np.zeros(self.nu)
            plan_x = np.tile(x, (self.N + 1, 1))
            plan_u = np.zeros((self.N, self.nu))
        if finite and w_opt is not None:
            # keep the (unconverged) iterate as the next warm start: usually closer than the old one
            self._w_prev = w_opt
        return MPCResult(thrust, status, solve_time, iters, plan_x, plan_u, math.nan, ret)

    def _from_model_states(self, Xm: np.ndarray, flow_ned: np.ndarray) -> np.ndarray:
        if self.prediction != "kinematic":
            return Xm.copy()
        X = Xm.copy()
        # R(Theta_k)^T flow for every node in one call (columns: R_k, stacked 3 x 3(N+1))
        R_all = np.asarray(self._rot_map(Xm[:, ATT].T)).reshape(3, -1, 3)  # [i, k, j] = R_k[i, j]
        X[:, LIN] += np.einsum("ikj,i->kj", R_all, flow_ned)
        return X


def shift_on_grid(
    w: np.ndarray,
    ix: np.ndarray,
    iv: np.ndarray,
    iu: np.ndarray,
    offsets_s: np.ndarray,
    stage_dt: np.ndarray,
    dt: float,
) -> np.ndarray:
    """A solution on a non-uniform grid (stages starting ``offsets_s`` (N,) after now, lasting
    ``stage_dt`` (N,), s) moved ``dt`` later: each node's state interpolated linearly at its time plus
    ``dt`` along the old plan (the last node held past its end), each stage's input the old plan's input
    at that time (inputs are held over a stage), the previous inputs following.  On a uniform grid of
    ``dt`` it is :func:`shift_solution`."""
    out = w.copy()
    nodes = np.append(offsets_s, offsets_s[-1] + stage_dt[-1])  # (N + 1,)
    X = w[ix]  # (N + 1, nx)
    later = nodes + dt
    for i in range(X.shape[1]):
        out[ix[:, i]] = np.interp(later, nodes, X[:, i])
    U = w[iu]  # (N, nu)
    stage = np.clip(np.searchsorted(nodes, offsets_s + dt + 1e-9) - 1, 0, len(offsets_s) - 1)
    out[iu] = U[stage]
    # each stage's previous input: the input of the stage before it (the first is set by the caller)
    out[iv[1:]] = out[iu]
    return out


def shift_solution(w: np.ndarray, *index: np.ndarray) -> np.ndarray:
    """Shift a solution one step forward in time, repeating the last node of each index array."""
    out = w.copy()
    for ix in index:
        out[ix[:-1]] = w[ix[1:]]
        out[ix[-1]] = w[ix[-1]]
    return out
