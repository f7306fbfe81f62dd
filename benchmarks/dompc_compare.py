"""auvdock's Oracle MPC against the same problem written in do-mpc, closed loop, one process.

What is compared
----------------
The Oracle MPC of auvdock (:class:`auvdock.controllers.mpc.DockingMPC`, prediction "full",
the true flow at the vehicle held constant over the horizon) and the same optimal control
problem built with do-mpc (https://www.do-mpc.com), both flown closed loop on the same paper
case by auvdock's own simulator (:func:`auvdock.simulation.simulate`): same truth model,
flow field, dock, start state, control period and timeout.  The do-mpc MPC is wrapped in a
controller with auvdock's interface (``name``, ``reset()``, ``step(meas, u_prev)``) and put
in place of the controller of an :class:`auvdock.autopilot.Autopilot`.

Printed per controller: the per-step solve time (median, p95, p99, max, ms), the outcome
(docked, time to dock, final distance to the dock), the ratio of the median solve times
(do-mpc / auvdock), and both controllers' first move (thrust at t = 0 from the same state)
with their largest difference, a check that the two problems are the same.

Timing: for auvdock the wall time of the whole controller step as ``simulate`` measures it
(parameter packing, bounds, the solve), including the very first solve -- the controller is
not warmed; the output says whether its compiled solver came from the cache.  For do-mpc
only ``mpc.make_step(x0)`` is timed (do-mpc's own parameter handling, IPOPT, its data
logging); the wrapper's work around it (filling the time-varying parameters, re-centring
the velocity box, reading the plan back) is not: the whole wrapper step, as ``simulate``
measures it, is reported separately.  Re-centring the box through do-mpc's ``bounds`` setter
alone costs several ms per step (each assignment rebuilds every bound of the NLP).

The same problem
----------------
Everything is taken from the auvdock MPC object that the do-mpc one replaces, so the
numbers cannot drift apart: horizon N, step dt, the diagonal weights Q, P and R (R in
newtons, i.e. the mission's normalised R divided by u_max^2, as ``build_mpc`` gives it),
thrust limits, ``v_rel_max`` and ``w_max``.

* Model: a do-mpc *discrete* model whose right-hand side is one RK4 step of length dt of
  ``vehicle.model.dynamics(x, u, flow_ned, 0)`` built with ``auvdock.vehicle.model.rk4`` --
  the very expression auvdock's MPC uses (the dynamics are not re-written here).  States
  ``eta`` (6), ``nu1`` (3), ``nu2`` (3) in auvdock's order, input ``u`` (8 thrusts, N).
* Time-varying parameters per horizon node k = 0..N: the dock position and NED velocity
  from ``dock.trajectory(t, dt, N)``, the heading reference (dock heading unwrapped to the
  vehicle's heading) and the flow (the true flow at the vehicle, constant over the horizon).
* Cost: do-mpc's ``lterm`` = ||e_k||_Q^2 summed over k = 0..N-1, ``mterm`` = ||e_N||_P^2 and
  ``set_rterm(u=R)`` = sum_{k=0}^{N-1} (u_k - u_{k-1})^T diag(R) (u_k - u_{k-1}) with u_{-1}
  do-mpc's ``u_prev`` (set to the input actually applied last before every step, as auvdock
  does).  auvdock sums Q over k = 1..N-1 only: the k = 0 term depends on the fixed x_0 alone,
  a constant, so the minimiser is the same (the objective values differ by it).  The error
  e_k (position - dock position, roll, pitch, heading - psi_ref, nu_1 - R(Theta_k)^T v_dock,
  nu_2) is the same expression as auvdock's.
* Bounds: thrust limits on ``u``; |nu_2| <= w_max as state bounds on ``nu2`` at k = 1..N
  (``use_terminal_bounds=True`` so x_N is bounded too; do-mpc never bounds x_0, nor does
  auvdock).  auvdock bounds the relative velocity with a box on nu_1 centred on the flow in
  {b} at the CURRENT attitude, R(Theta_0)^T v_c, at k = 1..N.  The natural do-mpc equivalent
  is a nonlinear constraint |nu_1 - R(Theta_k)^T v_c| <= v_rel_max on the predicted states
  (``set_nl_cons``); it is not the same constraint (predicted vs current attitude) and do-mpc
  evaluates it at k = 0..N-1 (x_0 included, x_N not).  By default this script therefore
  expresses auvdock's box exactly, through do-mpc's ``bounds`` API re-centred before every
  step (do-mpc allows changing bounds after ``setup``); ``--vrel-constraint nonlinear``
  uses the nonlinear constraint instead.  On case 2 neither state bound is ever active
  (measured: predicted |nu_r1| <= 0.50 m/s against 2.5, |nu_2| <= 0.003 rad/s against
  0.25), so there the choice does not change the solution; the thrust limits can be.

What differs (not removed)
--------------------------
* Solver: auvdock's default ("auto") for Oracle MPC is ``rti`` (one QP per control step,
  real-time iteration, CasADi's qrqp on a Gauss-Newton Hessian; ``auvdock.controllers.registry.
  resolve_solver``), its QP data compiled to C and cached; ``--solver sqp`` iterates the same QPs
  to convergence (CasADi's ``sqpmethod``) (``--solver ipopt`` gives
  auvdock's IPOPT, also compiled, Gauss-Newton Hessian, tuned warm start).  do-mpc uses IPOPT
  (MUMPS) with the exact Hessian through CasADi's SX virtual machine, not compiled; its
  ``compile_nlp`` is not used (experimental; it writes into the working directory).  Both get
  the mission's iteration limit and tolerance (``ipopt.max_iter``, ``ipopt.tol``), though
  the stopping tests differ (IPOPT's scaled NLP error vs sqpmethod's primal tolerance tol
  and dual tolerance 100 tol).
* Warm start: auvdock shifts the previous solution by one step and passes its multipliers
  (IPOPT warm-start options on); do-mpc starts from the previous solution unshifted (its
  default) and IPOPT ignores the multipliers it is given.  The first solve of both starts
  from x_0 repeated and zero thrust.
* A solve that does not converge: auvdock applies the next input of the last good plan;
  the do-mpc wrapper applies do-mpc's returned input (what ``make_step`` gives), clipped to
  the thrust limits; status ``not_converged`` in both.
* do-mpc's ``make_step`` logs every step in its ``Data`` object (``np.append``, so the cost
  grows slowly with the run length); Lagrange multipliers are not stored
  (``store_lagr_multiplier=False``), the full solution is not (``store_full_solution=False``).

Usage::

    python benchmarks/dompc_compare.py                    # case 2, 75 s simulated, solver auto
    python benchmarks/dompc_compare.py --case 1 --timeout 20 --solver ipopt --json

Needs ``do-mpc`` (``pip install do-mpc``); the figures are measured, never asserted.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from typing import Any

import casadi as ca
import numpy as np

from auvdock.autopilot import Autopilot
from auvdock.bench import PAPER_MISSIONS, default_missions_dir, machine_line
from auvdock.controllers import ControlOutput, Measurement, Plan, resolve_solver
from auvdock.controllers.mpc import DockingMPC, MPCResult
from auvdock.controllers.status import STATUS_FAILED, STATUS_NAMES, STATUS_NOT_CONVERGED, STATUS_OK
from auvdock.mission import Mission, load_mission
from auvdock.simulation import RunSummary, simulate
from auvdock.vehicle.model import rk4


def import_do_mpc() -> Any:
    """do-mpc, without its warnings about optional features (ONNX, OPC UA, PyTorch)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import do_mpc
    except ImportError:
        sys.exit("do-mpc is not installed: python -m pip install do-mpc")
    return do_mpc


class DoMPCController:
    """auvdock's Oracle MPC problem solved by do-mpc, with auvdock's controller interface.

    Parameters
    ----------
    ref : DockingMPC
        The auvdock MPC (prediction "full") whose problem is rebuilt here: every number
        (N, dt, Q, R, P, bounds) is read from it.
    max_iter, tol : int, float
        IPOPT's iteration limit and tolerance.
    vrel_constraint : {"box", "nonlinear"}
        The relative velocity bound as auvdock's box re-centred every step, or as do-mpc's
        nonlinear constraint on the predicted states (see the module docstring).
    """

    name = "do-mpc"

    def __init__(self, ref: DockingMPC, *, max_iter: int, tol: float, vrel_constraint: str = "box") -> None:
        if ref.prediction != "full":
            raise ValueError("DoMPCController rebuilds the Oracle MPC (prediction 'full')")
        do_mpc = import_do_mpc()
        self.version = do_mpc.__version__
        self.dock = ref.dock
        self.N, self.dt = ref.N, ref.dt
        self.u_min, self.u_max = ref.u_min.copy(), ref.u_max.copy()
        self.v_rel_max, self.w_max = ref.v_rel_max.copy(), ref.w_max.copy()
        self.vrel_constraint = vrel_constraint
        vm = ref.vehicle.model
        rot = vm.function("rotation")
        self._R = lambda angles: np.asarray(rot(angles))

        model = do_mpc.model.Model("discrete", "SX")
        eta = model.set_variable("_x", "eta", (6, 1))
        nu1 = model.set_variable("_x", "nu1", (3, 1))
        nu2 = model.set_variable("_x", "nu2", (3, 1))
        u = model.set_variable("_u", "u", (8, 1))
        model.set_variable("_tvp", "dock_p", (3, 1))
        model.set_variable("_tvp", "dock_v", (3, 1))
        model.set_variable("_tvp", "psi_ref")
        flow = model.set_variable("_tvp", "flow_ned", (3, 1))
        x = ca.vertcat(eta, nu1, nu2)
        zero = ca.DM.zeros(3)
        x_next = rk4(lambda xs, us: vm.dynamics(xs, us, flow, zero), x, self.dt, 1, u)
        model.set_rhs("eta", x_next[0:6])
        model.set_rhs("nu1", x_next[6:9])
        model.set_rhs("nu2", x_next[9:12])
        model.setup()
        # the cost and constraints use the model's own symbols as they are after setup()
        eta, nu1, nu2 = model.x["eta"], model.x["nu1"], model.x["nu2"]
        dock_p, dock_v = model.tvp["dock_p"], model.tvp["dock_v"]
        psi_ref, flow = model.tvp["psi_ref"], model.tvp["flow_ned"]
        R_nb = vm.rotation(eta)
        e = ca.vertcat(
            eta[0:3] - dock_p,
            eta[3],
            eta[4],
            eta[5] - psi_ref,
            nu1 - ca.mtimes(R_nb.T, dock_v),
            nu2,
        )
        v_rel = nu1 - ca.mtimes(R_nb.T, flow)

        mpc = do_mpc.controller.MPC(model)
        s = mpc.settings
        s.n_horizon = self.N
        s.t_step = self.dt
        s.n_robust = 0
        s.use_terminal_bounds = True
        s.store_full_solution = False
        s.store_lagr_multiplier = False
        s.nlpsol_opts = {
            "ipopt.print_level": 0,
            "print_time": 0,
            "ipopt.sb": "yes",
            "ipopt.max_iter": int(max_iter),
            "ipopt.tol": float(tol),
        }
        lterm = ca.sum1(ca.DM(ref.Q) * e**2)
        mterm = ca.sum1(ca.DM(ref.P) * e**2)
        mpc.set_objective(lterm=lterm, mterm=mterm)
        mpc.set_rterm(u=np.asarray(ref.R, dtype=float))
        mpc.bounds["lower", "_u", "u"] = self.u_min
        mpc.bounds["upper", "_u", "u"] = self.u_max
        mpc.bounds["lower", "_x", "nu2"] = -self.w_max
        mpc.bounds["upper", "_x", "nu2"] = self.w_max
        if vrel_constraint == "box":
            mpc.bounds["lower", "_x", "nu1"] = -self.v_rel_max
            mpc.bounds["upper", "_x", "nu1"] = self.v_rel_max
        elif vrel_constraint == "nonlinear":
            mpc.set_nl_cons("v_rel_upper", v_rel, ub=self.v_rel_max)
            mpc.set_nl_cons("v_rel_lower", -v_rel, ub=self.v_rel_max)
        else:
            raise ValueError(f"unknown vrel_constraint {vrel_constraint!r} (known: box, nonlinear)")
        self._tvp = mpc.get_tvp_template()
        mpc.set_tvp_fun(lambda t_now: self._tvp)
        # where each time-varying parameter of node k sits in the template (filled in one go)
        self._itvp = {
            name: np.array([np.asarray(self._tvp.f["_tvp", k, name]).ravel() for k in range(self.N + 1)])
            for name in ("dock_p", "dock_v", "psi_ref", "flow_ned")
        }
        self._tvp_vec = np.zeros(self._tvp.shape[0])
        t0 = time.perf_counter()
        with warnings.catch_warnings():  # do-mpc calls numpy on CasADi values (CasADi 3.8 FutureWarning)
            warnings.simplefilter("ignore", FutureWarning)
            mpc.setup()
        self.setup_time_s = time.perf_counter() - t0
        self.mpc = mpc
        # where the states and inputs of node k sit in do-mpc's decision vector
        f = mpc.opt_x_num.f
        self._ix = np.array([np.asarray(f["_x", k, 0, -1]).ravel() for k in range(self.N + 1)])
        self._iu = np.array([np.asarray(f["_u", k, 0]).ravel() for k in range(self.N)])
        self.make_step_times_s: list[float] = []
        self.eval_times_s: list[float] = []
        self.reset()

    def reset(self) -> None:
        """Forget the warm start; the next step starts cold (x_0 repeated, zero thrust)."""
        self._cold = True
        self.make_step_times_s = []
        self.eval_times_s = []

    def _set_vrel_box(self, x: np.ndarray, flow_ned: np.ndarray) -> None:
        centre = self._R(x[3:6]).T @ flow_ned
        self.mpc.bounds["lower", "_x", "nu1"] = centre - self.v_rel_max
        self.mpc.bounds["upper", "_x", "nu1"] = centre + self.v_rel_max

    def step(self, meas: Measurement, u_prev: np.ndarray) -> ControlOutput:
        if meas.flow_ned is None:
            raise ValueError("the Oracle MPC needs the true flow at the vehicle (Assumption 3)")
        mpc = self.mpc
        x = np.asarray(meas.state, dtype=float)
        flow = np.asarray(meas.flow_ned, dtype=float)
        _, dp, dv = self.dock.trajectory(meas.t, self.dt, self.N)
        psi_d = self.dock.heading_rad
        psi_ref = psi_d + 2 * math.pi * round((x[5] - psi_d) / (2 * math.pi))
        v = self._tvp_vec
        v[self._itvp["dock_p"]] = dp
        v[self._itvp["dock_v"]] = dv
        v[self._itvp["psi_ref"]] = psi_ref
        v[self._itvp["flow_ned"]] = flow
        self._tvp.master = ca.DM(v)
        if self.vrel_constraint == "box":
            self._set_vrel_box(x, flow)
        u_last = np.clip(u_prev, self.u_min, self.u_max)
        if self._cold:
            mpc.reset_history()
            mpc.x0 = x
            mpc.u0 = u_last
            mpc.set_initial_guess()
            mpc.flags["initial_run"] = False  # no multipliers from an earlier run
            self._cold = False
        mpc.u0 = u_prev  # u_{-1} of the input-rate cost: the input applied last

        t0 = time.perf_counter()
        u0 = mpc.make_step(x)
        solve_time = time.perf_counter() - t0

        stats = mpc.solver_stats
        self.make_step_times_s.append(solve_time)
        # wall time IPOPT spent in CasADi's evaluations of the NLP functions and derivatives
        self.eval_times_s.append(sum(float(v) for k, v in stats.items() if k.startswith("t_wall_nlp_")))
        ok = bool(stats.get("success", False))
        iters = int(stats.get("iter_count", -1))
        ret = str(stats.get("return_status", ""))
        w = np.asarray(mpc.opt_x_num_unscaled.master).ravel()
        plan_x, plan_u = w[self._ix], w[self._iu]
        u0 = np.asarray(u0, dtype=float).ravel()
        if not np.all(np.isfinite(u0)):
            status, thrust = STATUS_FAILED, u_last.copy()
            self._cold = True  # a non-finite iterate is no warm start
        else:
            status = STATUS_OK if ok else STATUS_NOT_CONVERGED
            thrust = np.clip(u0, self.u_min, self.u_max)
        obj = (stats.get("iterations") or {}).get("obj") or [math.nan]
        cost = float(obj[-1]) if ok else math.nan  # includes the constant ||e_0||_Q^2 (module docstring)
        res = MPCResult(thrust, status, solve_time, iters, plan_x, plan_u, cost, ret)
        return ControlOutput(thrust, status, solve_time, Plan(res.plan_state, res.plan_thrust))


class RecordingAutopilot(Autopilot):
    """An :class:`Autopilot` that remembers the first and the last step (outside the timing)."""

    first: tuple[float, np.ndarray, np.ndarray] | None = None
    last: tuple[float, np.ndarray, np.ndarray] | None = None

    def reset(self) -> None:
        super().reset()
        self.first = None
        self.last = None

    def step(self, meas: Measurement) -> ControlOutput:
        out = super().step(meas)
        rec = (float(meas.t), np.asarray(meas.state, dtype=float).copy(), out.thrust.copy())
        if self.first is None:
            self.first = rec
        self.last = rec
        return out


def final_distance(mission: Mission, ap: RecordingAutopilot, summary: RunSummary) -> float:
    """Distance to the dock at the end of the run (m), as ``simulate`` computes it."""
    o = summary.outcome
    if o["docked"]:
        return float(o["closest_approach_m"])  # the contact distance: every earlier one is larger
    if ap.last is None or o["reason"] != "timeout":
        return math.nan
    # replay the last period of the truth model (deterministic) to get the final state
    vehicle, flow, dock = mission.build_vehicle(), mission.build_flow(), mission.build_dock()
    step = vehicle.stepper(mission.controller.dt_s, mission.simulation.substeps, flow)
    t, x, u = ap.last
    x_end = np.asarray(step(x, u, t)).ravel()
    return float(np.linalg.norm(x_end[0:3] - dock.position(o["end_time_s"])))


def time_stats(times_s: Any) -> dict[str, float]:
    ms = np.asarray(times_s, dtype=float) * 1e3
    if ms.size == 0:
        return {"median_ms": math.nan, "p95_ms": math.nan, "p99_ms": math.nan, "max_ms": math.nan}
    return {
        "median_ms": float(np.median(ms)),
        "p95_ms": float(np.percentile(ms, 95)),
        "p99_ms": float(np.percentile(ms, 99)),
        "max_ms": float(ms.max()),
    }


def run_row(
    label: str, solver: str, mission: Mission, ap: RecordingAutopilot, summary: RunSummary, times_s: Any
) -> dict[str, Any]:
    o = summary.outcome
    return {
        "controller": label,
        "solver": solver,
        **time_stats(times_s),
        "steps": int(len(times_s)),
        "docked": bool(o["docked"]),
        "time_to_dock_s": float(o["time_to_dock_s"]),
        "final_distance_m": final_distance(mission, ap, summary),
        "closest_approach_m": float(o["closest_approach_m"]),
        "reason": str(o["reason"]),
        "solver_failures": int(o["solver_failures"]),
        "status_counts": str(o["status_counts"]),
        "wall_time_s": float(o["wall_time_s"]),
        "first_move_N": ap.first[2].tolist() if ap.first is not None else None,
    }


def clean(v: Any) -> Any:
    """NaN and infinities as null, for strict JSON."""
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [clean(x) for x in v]
    return v


def fmt(v: float, spec: str = ".2f") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, spec)


def print_report(r: dict[str, Any]) -> None:
    print(
        f"Oracle MPC: auvdock vs do-mpc {r['do_mpc_version']}, case {r['case']} ({r['mission']}), "
        f"N = {r['horizon']}, dt = {r['dt_s']} s, simulated up to {r['timeout_s']} s"
    )
    print(r["machine"])
    print(
        f"auvdock solver: {r['auvdock_solver']} (compiled solver: {r['auvdock_solver_build']}); "
        f"do-mpc: IPOPT, exact Hessian, uncompiled (setup {r['do_mpc_setup_s']:.1f} s); "
        f"relative velocity bound in do-mpc: {r['vrel_constraint']}"
    )
    head = (
        f"{'controller':<22} {'median':>8} {'p95':>8} {'p99':>8} {'max':>8}  {'steps':>5}  "
        f"{'docked':>6} {'t_dock s':>8} {'final m':>8}  {'failures':>8}"
    )
    print()
    print("per-step solve time (ms)".rjust(57))
    print(head)
    print("-" * len(head))
    for row in r["runs"]:
        name = f"{row['controller']} ({row['solver']})"
        print(
            f"{name:<22} {fmt(row['median_ms']):>8} {fmt(row['p95_ms']):>8} {fmt(row['p99_ms']):>8} "
            f"{fmt(row['max_ms']):>8}  {row['steps']:>5}  {'yes' if row['docked'] else 'no':>6} "
            f"{fmt(row['time_to_dock_s']):>8} {fmt(row['final_distance_m'], '.3f'):>8}  "
            f"{row['solver_failures']:>8}"
        )
    print()
    print(f"ratio of median solve times (do-mpc / auvdock): {fmt(r['median_ratio'], '.1f')}")
    dm = r["runs"][1]
    print(
        f"do-mpc: median {fmt(dm['eval_median_ms'])} ms of make_step's {fmt(dm['median_ms'])} ms in CasADi's "
        f"evaluations of the NLP functions; whole wrapper step median {fmt(dm['wrapper_step_median_ms'])} ms"
    )
    print()
    print("first move (thrust at t = 0, N):")
    for row in r["runs"]:
        fm = row["first_move_N"]
        print(f"  {row['controller']:<8} " + " ".join(f"{v:8.3f}" for v in fm) if fm else "  -")
    print(f"  max |difference| = {fmt(r['first_move_max_diff_N'], '.4f')} N")


def main(argv: list[str] | None = None) -> int:
    ap_ = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap_.add_argument("--case", type=int, default=2, help="paper case 1..6 (default 2)")
    ap_.add_argument("--timeout", type=float, default=None, help="simulated seconds (default: the mission's)")
    solvers = ("auto", "rti", "sqp", "ipopt")
    ap_.add_argument("--solver", default="auto", choices=solvers, help="auvdock's solver")
    ap_.add_argument(
        "--vrel-constraint",
        default="box",
        choices=("box", "nonlinear"),
        help="do-mpc's relative velocity bound: auvdock's box (default) or a nonlinear constraint",
    )
    ap_.add_argument("--json", action="store_true", help="strict JSON on stdout")
    args = ap_.parse_args(argv)
    if not 1 <= args.case <= len(PAPER_MISSIONS):
        ap_.error(f"--case: the paper's cases are 1..{len(PAPER_MISSIONS)}")

    base = load_mission(default_missions_dir() / f"{PAPER_MISSIONS[args.case - 1]}.yaml")
    mission = base.with_updates(**{"controller.type": "oracle", "controller.solver.name": args.solver})
    timeout = mission.docking.timeout_s if args.timeout is None else float(args.timeout)
    c = mission.controller

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    # auvdock's Oracle MPC, as `auvdock sim` runs it
    log("building auvdock's Oracle MPC (first build compiles the solver, ~1 min) ...")
    oracle = mission.with_controller("oracle")
    ap_auv = RecordingAutopilot(oracle.controller, mission.build_vehicle(), mission.build_dock())
    build = str(getattr(ap_auv.controller.mpc, "build", "?"))
    log(f"running auvdock ({resolve_solver(c.solver.name, 'oracle')}, {build}) for up to {timeout} s ...")
    s_auv = simulate(mission, autopilot=ap_auv, timeout_s=timeout)

    # the same problem in do-mpc, in place of the controller of an Oracle autopilot
    log("building the do-mpc MPC ...")
    ap_dm = RecordingAutopilot(oracle.controller, mission.build_vehicle(), mission.build_dock())
    dm = DoMPCController(
        ap_dm.controller.mpc,
        max_iter=c.solver.max_iter,
        tol=c.solver.tol,
        vrel_constraint=args.vrel_constraint,
    )
    ap_dm.controller = dm
    ap_dm.name = dm.name
    log(f"running do-mpc {dm.version} (IPOPT) for up to {timeout} s ...")
    s_dm = simulate(mission, autopilot=ap_dm, timeout_s=timeout)

    row_auv = run_row(
        "auvdock", resolve_solver(c.solver.name, "oracle"), mission, ap_auv, s_auv, s_auv.solve_times_s
    )
    row_dm = run_row("do-mpc", "ipopt", mission, ap_dm, s_dm, dm.make_step_times_s)
    row_dm["eval_median_ms"] = time_stats(dm.eval_times_s)["median_ms"]
    row_dm["wrapper_step_median_ms"] = time_stats(s_dm.solve_times_s)["median_ms"]
    diff = math.nan
    if ap_auv.first is not None and ap_dm.first is not None:
        diff = float(np.max(np.abs(ap_auv.first[2] - ap_dm.first[2])))
    report = {
        "case": args.case,
        "mission": mission.name,
        "horizon": c.horizon_steps,
        "dt_s": c.dt_s,
        "timeout_s": timeout,
        "machine": machine_line(),
        "do_mpc_version": dm.version,
        "do_mpc_setup_s": dm.setup_time_s,
        "auvdock_solver": resolve_solver(c.solver.name, "oracle"),
        "auvdock_solver_build": build,
        "vrel_constraint": args.vrel_constraint,
        "runs": [row_auv, row_dm],
        "median_ratio": row_dm["median_ms"] / row_auv["median_ms"],
        "first_move_max_diff_N": diff,
        "status_names": {str(k): v for k, v in STATUS_NAMES.items()},
    }
    if args.json:
        print(json.dumps(clean(report), indent=2, allow_nan=False))
    else:
        print_report(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
