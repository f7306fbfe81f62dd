"""Flow-state-estimating MPCs (paper sections V.A-B, Algorithm 1), and their baseline without exploration.

All three controllers estimate the current with :class:`auvdock.estimation.flow_filter.FlowEstimator`
from inertial measurements (never the true flow) and predict with the full model (eqs. 1-2)
driven by the ESTIMATED flow.

* **Certainty-equivalent MPC** (``ce``; not in the paper): the same flow filter and the same MPC,
  with no exploration at all -- neither the perception law nor the information reward.  It is
  what the FSE-MPCs are measured against: whatever they do better, their exploration did.

* **Sequential FSE-MPC**: each step first solves the active-perception law (9),
  ``tau* = argmax_tau lambda_min(G_(k+1)(tau))`` over a bounded body wrench, one step
  ahead (:class:`PerceptionLaw`: best corner of the wrench box by default); ``tau*`` is
  mapped to thrusts with the allocation's pseudo-inverse and added to the MPC's input
  (alpha = 0) before it is applied.  The MPC does not see the offset: an offset known to
  the MPC is simply cancelled by it (its optimum shifts by minus the offset), which is
  what adding it inside the optimisation variable, as the authors' code does, amounts to.
* **Optimized FSE-MPC**: one MPC whose cost is eq. (10) minus ``alpha * sum_k F_k``, with
  the gramian propagated along the predicted horizon symbolically,
  ``G_k = F_k^-T G_(k-1) F_k^-1 + H_k^T R^-1 H_k`` (``F_k`` and the accelerometer rows of
  ``H_k`` from the predicted angular rate), so the optimiser sees how its motion improves
  observability.  The depth-rate row ``e3^T R`` depends on roll and pitch only, which the
  restoring moments hold near zero, so it is taken at the measured attitude for the whole
  horizon: this keeps the term a function of the 3N predicted rates alone (its Hessian has
  174k instead of 274k operations).  The term is convex in the rates (information grows
  with their square), so the problem is non-convex.  With solver ``rti`` (``auto``) the
  term enters each QP through its gradient only (the Gauss-Newton matrix of cost (10)
  keeps the QP convex) and the one step per control period tracks the optimum over time;
  with ``ipopt`` its exact Hessian is used (inertia correction copes with the negative
  curvature).  Iterated SQP with qrqp does not converge here (docs/performance.md).
  In the optimiser ``F_k`` is the smooth lower bound
  :func:`auvdock.estimation.flow_filter.information_lower_bound` ``1/tr(G_k^-1)``, within a factor 3 of
  ``lambda_min(G_k)`` and tight when the smallest eigenvalue is separated (the docstring
  says why not the guarded closed form).  The objective uses ``F_k - F_0`` (same
  minimiser, moderate values).  The recorded metric F is the exact ``lambda_min``.

Scaling of alpha: each step adds ``H^T R^-1 H`` to G, about ``|nu_2|^2 / sigma_a^2`` per
axis (``sigma_a^2 = 2.029e-5 (m/s^2)^2``), so yawing at 0.1 rad/s for the 0.5 s horizon
raises F by about 5e3; alpha = 1e-3 (the default) makes that worth about 5 units of cost
(10), the size of the tracking cost at a few decimetres of error.  The paper's
alpha = 1e-15 belongs to its own (unstated) scaling of G.  ``benchmarks/alpha_sweep.py``
measures the trade-off on case 2 (docs/performance.md): below 1e-3 the vehicle does not turn enough to
learn the current and, predicting with a wrong flow, never closes the last centimetres;
from 2e-3 on it estimates twice as well but keeps turning and does not dock in 75 s.
"""

from __future__ import annotations

import itertools
import time

import casadi as ca
import numpy as np

from auvdock.controllers.base import ControlOutput, Estimate, Plan
from auvdock.controllers.baseline import build_mpc
from auvdock.controllers.rti import QRQP_OPTIONS
from auvdock.controllers.settings import (
    CertaintyEquivalentSettings,
    OptimizedSettings,
    SequentialSettings,
)
from auvdock.controllers.world import ControllerWorld
from auvdock.estimation.flow_filter import (
    EstimatorSettings,
    FlowEstimator,
    gramian_step,
    information_lower_bound,
)
from auvdock.runtime import timing
from auvdock.runtime.codegen import compiled_function, compiled_nlpsol
from auvdock.runtime.fastcall import BufferedFunction
from auvdock.runtime.interrupts import SigintDeferred
from auvdock.sensing.settings import SensorSettings
from auvdock.vehicle import Vehicle
from auvdock.vehicle.state import ANG, ATT, ETA
from auvdock.world.dock import DockMotion

__all__ = ["FSEMPC", "PerceptionLaw"]


#: Gate probability of the robust FSE filter's innovation test (chi-square, per update).
INNOVATION_GATE = 0.999
#: Relative error of the model's predicted acceleration in the robust FSE filter: 20 %, the
#: uncertainty of an ROV's identified added mass and damping (Wu 2018 gives no error bars; the
#: BlueROV2 parameter sets in the literature differ by 20-50 % per coefficient) and of the T200
#: curve over battery voltage.
MODEL_ACCEL_ERROR = 0.2


def _sym_from6(g: ca.SX) -> ca.SX:
    return ca.vertcat(
        ca.horzcat(g[0], g[1], g[2]),
        ca.horzcat(g[1], g[3], g[4]),
        ca.horzcat(g[2], g[4], g[5]),
    )


def _six(G: np.ndarray) -> np.ndarray:
    return np.array([G[0, 0], G[0, 1], G[0, 2], G[1, 1], G[1, 2], G[2, 2]])


class PerceptionLaw:
    """Active-perception law (9): the bounded wrench that maximises F one step ahead.

    F is the smooth bound ``1/tr(G^-1)`` (see :func:`auvdock.estimation.flow_filter.information_lower_bound`).
    Two ways to solve it (``method``):

    * ``"corners"`` (default): evaluate F at the 64 corners of the wrench box in one
      compiled call and take the best.  The information a step adds grows with the square
      of the angular rate, which is affine in the wrench, so F is (close to) convex in the
      wrench and its maximum over a box lies at a corner.  Measured over 150 states of a
      case-2 run: the best corner's objective is within 1e-4 (relative) of IPOPT's local
      optimum in every state, and better than it by up to 1e-2 where IPOPT stopped at a
      worse local maximum; 0.1 ms instead of 1.4 ms.
    * ``"ipopt"``: IPOPT from a deterministic start (the previous solution, else a yaw
      moment at its bound: at zero rate the gain of F is quadratic in the wrench, so a
      start at zero would be a stationary point).  A solve that stops at its iteration
      limit with a finite wrench is used (its value is at least as good as the start's).
    """

    METHODS = ("corners", "sqp", "ipopt")

    def __init__(
        self,
        vehicle: Vehicle,
        dt: float,
        wrench_max: np.ndarray,
        R_inv: np.ndarray,
        gamma: float,
        method: str = "corners",
    ) -> None:
        if method not in self.METHODS:
            raise ValueError(f"unknown perception-law method {method!r} (known: {', '.join(self.METHODS)})")
        self.method = method
        self.wrench_max = np.asarray(wrench_max, dtype=float)
        signs = np.array(list(itertools.product((-1.0, 1.0), repeat=6)))
        self._corners = signs * self.wrench_max  # (64, 6)
        defining = (dt, self.wrench_max, np.asarray(R_inv, dtype=float), float(gamma), method)
        built, self.build = vehicle.built(
            "perception_law", defining, lambda: self._make(vehicle, dt, R_inv, gamma, method)
        )
        if method == "corners":
            self._corner_values = BufferedFunction(built)
        else:
            self._solver = built
        self._B_pinv = np.linalg.pinv(vehicle.allocation)
        self._prev = np.zeros(6)

    def _make(
        self, vehicle: Vehicle, dt: float, R_inv: np.ndarray, gamma: float, method: str
    ) -> tuple[ca.Function, str]:
        """The law's function (``corners``: the objective at every corner at once) or solver, and how it
        runs (compiled or not): nothing of a run's state."""
        m = vehicle.model
        tau = ca.SX.sym("tau", 6)
        x = ca.SX.sym("x", vehicle.nx)
        f_ned = ca.SX.sym("flow_ned", 3)
        g6 = ca.SX.sym("G", 6)
        nu_dot, _ = m.accelerations(x, tau, f_ned, ca.DM.zeros(3))
        nu2_next = x[ANG] + dt * nu_dot[3:6]
        R_nb = m.rotation(x[ETA])
        G_next = gramian_step(_sym_from6(g6), nu2_next, R_nb[2, :], dt, R_inv, gamma, ca)
        # scale by the current F so the objective is O(1)
        scale = ca.SX.sym("scale")
        obj = -information_lower_bound(G_next) / scale
        params = ca.vertcat(x, f_ned, g6, scale)
        if method == "corners":
            f_obj = ca.Function("perception_obj", [tau, params], [obj])
            n = self._corners.shape[0]
            values = f_obj.map(n)(ca.DM(self._corners.T), ca.repmat(params, 1, n))
            return compiled_function(ca.Function("perception_corners", [params], [values]))
        if method == "sqp":
            return compiled_nlpsol(
                "perception",
                "sqpmethod",
                {"x": tau, "f": obj, "p": params},
                {
                    "print_time": False,
                    "error_on_fail": False,
                    "print_header": False,
                    "print_iteration": False,
                    "print_status": False,
                    "qpsol": "qrqp",
                    "qpsol_options": QRQP_OPTIONS,
                    "convexify_strategy": "eigen-clip",
                    "max_iter": 50,
                    "tol_pr": 1e-8,
                    "tol_du": 1e-8,
                },
            )
        return compiled_nlpsol(
            "perception",
            "ipopt",
            {"x": tau, "f": obj, "p": params},
            {
                "print_time": False,
                "error_on_fail": False,
                "ipopt": {"print_level": 0, "sb": "yes", "max_iter": 50, "tol": 1e-8},
            },
        )

    def reset(self) -> None:
        self._prev = np.zeros(6)

    def solve(
        self, x: np.ndarray, flow_ned: np.ndarray, G: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, bool]:
        """Return (wrench tau* (6,), thrust offset B^+ tau* (n,), success)."""
        F0 = max(float(information_lower_bound(G)), 1e-12)
        p = np.concatenate([x, flow_ned, _six(G), [F0]])
        if self.method == "corners":
            values = self._corner_values(p)[0].copy()
            ok = bool(np.any(np.isfinite(values)))
            tau = self._corners[int(np.nanargmin(values))].copy() if ok else np.zeros(6)
            return tau, self._B_pinv @ tau, ok
        start = self._prev.copy()
        if not np.any(start):
            start[5] = self.wrench_max[5]
        with SigintDeferred():
            sol = self._solver(x0=start, lbx=-self.wrench_max, ubx=self.wrench_max, p=p)
        ok = bool(self._solver.stats().get("success", False))
        tau = np.clip(np.asarray(sol["x"]).ravel(), -self.wrench_max, self.wrench_max)
        if not np.all(np.isfinite(tau)):
            tau, ok = np.zeros(6), False
        self._prev = tau
        return tau, self._B_pinv @ tau, ok


class FSEMPC:
    """Sequential or Optimized FSE-MPC: estimator + MPC, one step per control period."""

    extra_series = {
        "flow_estimate_m_s": (3,),
        "flow_covariance": (3, 3),
        "flow_body_true_m_s": (3,),
        "flow_estimate_ned_m_s": (3,),
        "information": (),
        "perception_wrench": (6,),
        "innovation": (4,),
    }

    def __init__(
        self,
        settings: SequentialSettings | OptimizedSettings | CertaintyEquivalentSettings,
        vehicle: Vehicle,
        dock: DockMotion,
        solver: str,
        estimator: EstimatorSettings,
        sensors: SensorSettings,
        world: ControllerWorld | None = None,
    ) -> None:
        if settings.type not in ("sequential", "optimized", "ce"):
            raise ValueError(f"not a flow-estimating controller: {settings.type!r}")
        self.name: str = settings.type  # Controller.name (the settings' literal type)
        self.variant = settings.variant
        e = estimator
        dt = settings.dt_s
        self.vehicle = vehicle
        self.estimator = FlowEstimator(
            vehicle,
            dt,
            np.asarray(e.prior_flow_ned_m_s),
            e.prior_std_m_s,
            e.process_noise_m2_s2,
            e.accel_noise_var,
            e.depth_rate_noise_var,
            e.forgetting_factor,
            gyro_std=sensors.gyro_std_rad_s,
            attitude_std=sensors.attitude_std_rad,
            relative_velocity_std=sensors.relative_velocity_std_m_s,
            # robust: an accelerometer residual the flow cannot explain at this turn rate (a model
            # error of 0.3 m/s^2 read at 1 mrad/s would be a 300 m/s current) is not taken
            innovation_gate=INNOVATION_GATE if settings.variant == "robust" else None,
            # robust: the pose's motion too (model-free: a thruster or drag error does not move it)
            position_std=sensors.position_std_m if settings.variant == "robust" else None,
            model_accel_error=MODEL_ACCEL_ERROR if settings.variant == "robust" else 0.0,
        )
        R_inv = np.diag(1.0 / np.array([e.accel_noise_var] * 3 + [e.depth_rate_noise_var]))
        gamma = e.forgetting_factor
        self.law: PerceptionLaw | None = None
        entry = None if world is None else world.entry
        self.explores = not isinstance(settings, CertaintyEquivalentSettings)
        if isinstance(settings, CertaintyEquivalentSettings):  # no information term, no law
            self.mpc = build_mpc(settings, vehicle, dock, "full", solver, state_from_flow=True, entry=entry)
        elif isinstance(settings, SequentialSettings):
            self.law = PerceptionLaw(
                vehicle,
                dt,
                np.asarray(settings.perception_wrench_max),
                R_inv,
                gamma,
                settings.perception_solver,
            )
            self.mpc = build_mpc(settings, vehicle, dock, "full", solver, state_from_flow=True, entry=entry)
        else:
            alpha = float(settings.alpha)

            def info_term(X, U, params, extra, stage_dt):
                G = _sym_from6(extra[0:6])
                F0 = extra[6]
                depth_row = extra[7:10]
                weight = extra[10]  # 1 (paper); robust: the share of the prior uncertainty left
                J = 0
                for k in range(1, X.shape[1]):
                    # the filter reads every control period: a coarse stage's periods at its end's rate
                    for _ in range(round(float(stage_dt[k - 1]) / dt)):
                        G = gramian_step(G, X[ANG, k], depth_row, dt, R_inv, gamma, ca)
                        J += information_lower_bound(G) - F0
                return -alpha * weight * J

            self.mpc = build_mpc(
                settings,
                vehicle,
                dock,
                "full",
                solver,
                objective_extra=info_term,
                objective_key=("information reward", alpha, dt, R_inv, gamma),
                extra_params=11,
                extra_hessian=solver == "ipopt",
                state_from_flow=True,
                entry=entry,
            )

    def _info_weight(self, P: np.ndarray, meas: Estimate) -> float:
        """The weight of exploration (the information reward, the perception wrench): 1 in the paper;
        robust: the share of the prior's standard deviation still left in the estimate of the
        current, so that a vehicle that knows the current stops turning for it.  Measured on the
        filter really run: the navigation filter's current (``meas.current_uncertainty``) where
        there is one (``estimation: filter``), else this controller's flow filter,
        ``sqrt(lambda_max(P) / prior_var)`` (capped at 1)."""
        if self.variant == "paper":
            return 1.0
        if meas.current_uncertainty is not None:
            return float(meas.current_uncertainty)
        lam = float(np.max(np.linalg.eigvalsh(0.5 * (P + P.T))))
        return float(min(1.0, np.sqrt(max(lam, 0.0) / self.estimator.prior_var)))

    def reset(self) -> None:
        self.estimator.reset()
        self.mpc.reset()
        if self.law is not None:
            self.law.reset()

    def step(self, meas: Estimate, u_prev: np.ndarray) -> ControlOutput:
        s = meas.flow_sensing
        if s is None:
            raise ValueError(f"{self.name}: the estimate carries no flow sensing (paper IV.A)")
        eta = np.asarray(s.pose, dtype=float)
        nu_r = np.concatenate(
            [np.asarray(s.relative_velocity_m_s, dtype=float), np.asarray(s.gyro_rad_s, dtype=float)]
        )
        with timing.part("flow filter"):
            est = self.estimator.step(eta, nu_r, s.accel_m_s2, float(s.depth_rate_m_s), u_prev)
        tau = np.zeros(6)
        t0 = time.perf_counter()
        # the slow current held, plus the waves' velocity run forward on the filter's wave model
        water = meas.water_ahead(est.flow_ned, self.mpc.offsets_s)
        # the estimator's state is [eta; nu_r + f; nu_2] (ETA, LIN, ANG)
        if self.law is not None:
            with timing.part("perception"):
                tau, u_off, _ = self.law.solve(est.state, est.flow_ned, self.estimator.gramian())
            # the perception input is added after the solve (paper V.B: the MPC does not plan with it;
            # one it plans with is an input offset it simply cancels, a change of variables).  Robust:
            # scaled by the share of the current's uncertainty still left in the filter really run,
            # so that it fades once the current is known (and the dock can be closed); the robust
            # MPC's disturbance observer predicts with the thrust really applied, this input included
            w = self._info_weight(est.covariance, meas)
            tau, u_off = w * tau, w * u_off
            r = self.mpc.solve(meas.t, est.state, u_prev, water=water)
            r.thrust = np.clip(r.thrust + u_off, self.vehicle.thrust_min, self.vehicle.thrust_max)
        elif not self.explores:
            r = self.mpc.solve(meas.t, est.state, u_prev, water=water)
        else:
            G = self.estimator.gramian()
            depth_row = self.estimator.R(est.state[ATT])[2, :]
            weight = self._info_weight(est.covariance, meas)
            extra = np.concatenate([_six(G), [float(information_lower_bound(G))], depth_row, [weight]])
            r = self.mpc.solve(meas.t, est.state, u_prev, extra=extra, water=water)
        series = {
            "flow_estimate_m_s": est.flow_body,
            "flow_covariance": est.covariance,
            "flow_estimate_ned_m_s": est.flow_ned,
            "information": np.asarray(est.information),
            "perception_wrench": tau,
            "innovation": est.innovation,
        }
        return ControlOutput(
            r.thrust, r.status, time.perf_counter() - t0, Plan(r.plan_state, r.plan_thrust), series
        )
