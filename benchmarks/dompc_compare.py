"""auvdock's Oracle MPC against the same problem in do-mpc: closed loop, interleaved, one process.

What is compared
----------------
The Oracle MPC of auvdock (:class:`auvdock.controllers.mpc.DockingMPC`, prediction "full",
the true flow at the vehicle held constant over the horizon) and the same optimal control
problem built with do-mpc (https://www.do-mpc.com), all flown closed loop on the same paper
case by auvdock's own simulator (:func:`auvdock.loop.simulation.run_simulation`): same truth model,
flow field, dock, start state, control period and timeout.  A do-mpc MPC is wrapped in a
controller with auvdock's interface (``name``, ``reset()``, ``step(estimate, u_prev)``) and put
in place of the controller of an :class:`auvdock.loop.autopilot.Autopilot`.

auvdock's Oracle MPC is flown in its ``paper`` variant (``oracle@paper``): the default
``robust`` variant adds an offset-free disturbance observer and a predicted disturbance
wrench, which the do-mpc problem does not have.  The observer's cost is therefore not
measured here.

Contenders (``--contenders``, default all but ``auvdock-sqp``)
---------------------------------------------------------------
* ``auvdock-rti`` -- auvdock's default solver for Oracle MPC: ``auto`` resolves to ``rti``
  (:func:`auvdock.controllers.registry.resolve_solver`): real-time iteration, one
  Gauss-Newton QP per control step (the output names the QP solver, the mission's
  ``controller.solver.qp``), its QP data compiled to C and cached.
* ``auvdock-ipopt`` -- auvdock's IPOPT: Gauss-Newton Hessian of the Lagrangian, compiled to C
  and cached, warm-started from the previous solution shifted by one step and the previous
  multipliers (unshifted), with the options of ``build_ipopt`` in
  :mod:`auvdock.controllers.solvers` (``IPOPT_OPTIONS`` there, imported here).
* ``auvdock-sqp`` -- (optional) CasADi's ``sqpmethod`` on the same QPs, iterated to convergence.
* ``dompc-default`` -- do-mpc as shipped, for reference: IPOPT (MUMPS), exact Hessian in
  CasADi's SX virtual machine (not compiled), IPOPT's default options (tol 1e-8, max_iter
  3000) with only the output switched off (do-mpc's ``settings.supress_ipopt_output()``),
  do-mpc's own warm start (the previous solution, unshifted; the previous multipliers are
  passed but IPOPT ignores them without ``warm_start_init_point``), do-mpc's default data
  logging, the velocity box re-centred through do-mpc's ``bounds`` API.
* ``dompc-tuned`` -- do-mpc tuned with its own API: ``compile_nlp`` (the NLP's functions,
  exact Hessian included, compiled to C with do-mpc's shipped command ``gcc -fPIC -shared
  -O1``, the flags auvdock compiles with), exactly auvdock's IPOPT options through
  ``settings.nlpsol_opts`` (with the mission's ``max_iter`` and ``tol``), the warm start
  auvdock's IPOPT gets (the previous solution shifted by one step written into
  ``mpc.opt_x_num`` -- do-mpc's documented way to set the initial guess -- and the previous
  multipliers, which do-mpc passes unshifted after its first solve, as auvdock does), the
  velocity box re-centred through ``lb_opt_x``/``ub_opt_x`` (do-mpc's advanced bounds API:
  one slice assignment each, where ``bounds`` rebuilds every bound of the NLP), and less
  logging (``store_lagr_multiplier=False``, ``store_solver_stats=[]``).
* ``dompc-gn`` -- ``dompc-tuned`` with auvdock's Gauss-Newton Hessian: do-mpc has no such
  setting, but its documented manual route (``prepare_nlp()``, change the NLP, then
  ``create_nlp()``) lets this script read the NLP's variables (``opt_x``, ``opt_p``) and hand
  IPOPT CasADi's ``hess_lag`` option through ``nlpsol_opts``: ``lam_f 2 J_r^T J_r`` of the
  cost's weighted residuals (checked to reproduce do-mpc's objective exactly), its upper
  triangle as auvdock's IPOPT gets it.  ``compile_nlp`` does not compile a ``hess_lag``
  function, so the script compiles it with the same command into a library of its own and
  passes it as ``ca.external`` before ``compile_nlp`` loads the solver.

``compile_nlp`` of do-mpc 5.1.2 calls ``nlpsol`` without importing it (``NameError``); the
script sets ``do_mpc.optimizer.nlpsol = casadi.nlpsol`` first (the one-line workaround) and
compiles into a temporary directory (removed at exit; never the working directory).

Pairings printed: **same algorithm** -- ``auvdock-ipopt`` against ``dompc-tuned`` (IPOPT with
the same options and warm start; do-mpc with the exact Hessian) and against ``dompc-gn``
(IPOPT with the same Hessian too); **best against best** -- auvdock's default for Oracle
(``auvdock-rti``) against the do-mpc contender with the lowest pooled median step time.

Timing
------
Every contender is timed on the WHOLE controller step as ``simulate`` measures it: the wall
time of :meth:`Autopilot.step` around the controller's ``step``.  For auvdock that is
parameter packing, bounds, warm start and the solve; for do-mpc the wrapper's whole step:
filling the time-varying parameters, re-centring the velocity box, the warm start,
``make_step`` (do-mpc's parameter handling, IPOPT, its data logging) and reading the plan
back.  The first solve of a run (cold, from x_0 repeated and zero thrust) is included.
Building (auvdock: loading or compiling its cached solver; do-mpc: ``setup`` and
``compile_nlp``) is done for every contender before any run and reported apart.  Then
``--rounds`` rounds each fly every contender once, closed loop, in a rotated order (round r
starts with contender r), in one process; the step times are pooled over the rounds (median,
p95, p99, max) and the per-round medians printed.  The do-mpc rows also give where the
whole step's median went (``make_step``, of it CasADi's function evaluations, the bounds).

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
  do-mpc's ``u_prev`` (set to the input applied last before every step, as auvdock does).
  auvdock sums Q over k = 1..N-1 only: do-mpc has no way to leave the k = 0 stage cost out;
  it depends on the fixed x_0 alone, a constant, so the minimiser is the same (the objective
  values differ by it).  do-mpc fixes x_0 by 12 equality constraints, auvdock by equal
  bounds (IPOPT removes fixed variables), so do-mpc's NLP has 12 more constraints.
  The error e_k (position - dock position, roll, pitch, heading - psi_ref,
  nu_1 - R(Theta_k)^T v_dock, nu_2) is the same expression as auvdock's.
* Bounds: thrust limits on ``u``; |nu_2| <= w_max as state bounds on ``nu2`` at k = 1..N
  (``use_terminal_bounds=True`` so x_N is bounded too; do-mpc never bounds x_0, nor does
  auvdock).  auvdock bounds the relative velocity with a box on nu_1 centred on the flow in
  {b} at the CURRENT attitude, R(Theta_0)^T v_c, at k = 1..N; by default the do-mpc
  contenders express that box exactly, re-centred before every step (do-mpc allows changing
  bounds after ``setup``).  ``--vrel-constraint nonlinear`` uses do-mpc's natural
  alternative instead, a nonlinear constraint |nu_1 - R(Theta_k)^T v_c| <= v_rel_max on the
  predicted states (``set_nl_cons``): not the same constraint (predicted vs current
  attitude; do-mpc evaluates it at k = 0..N-1).  On case 2 neither state bound is ever
  active (measured: predicted |nu_r1| <= 0.50 m/s against 2.5, |nu_2| <= 0.003 rad/s
  against 0.25); the thrust limits can be.
* auvdock's decision vector also carries the previous input of every stage (a stage-wise
  layout for its QP solvers); that is a change of variables, not of the problem.

What still differs
------------------
* Hessian: ``auvdock-ipopt``, ``auvdock-rti`` and ``dompc-gn`` use the Gauss-Newton Hessian,
  ``dompc-default`` and ``dompc-tuned`` the exact Hessian of the Lagrangian (the dynamics'
  curvature included: more work per iteration, possibly fewer iterations).
* Algorithm of ``auvdock-rti``: one QP per step (not converged; the first solve of a run
  iterates up to 10 QPs) against IPOPT solving each NLP to its tolerance.
* The k = 0 stage cost (above).
* do-mpc's ``make_step`` logs every step in its ``Data`` object (``np.append``, so the cost
  grows slowly with the run length; the history is cleared at the start of every run);
  there is no setting to switch it off short of bypassing ``make_step``.
* do-mpc's parameters are CasADi structures filled through power indexing, auvdock's one
  numpy vector; that overhead is part of do-mpc as it is used.
* Multipliers: auvdock's IPOPT keeps those of its last converged solve, do-mpc those of its
  last solve, converged or not (the same on runs where every solve converges).
* A solve that does not converge: auvdock applies the next input of the last good plan (for
  at most ``fallback_steps`` steps, then zero thrust); the do-mpc wrapper applies do-mpc's
  returned input clipped to the thrust limits; status ``not_converged`` in both.
* ``dompc-default`` runs IPOPT's default tolerance and iteration limit (1e-8, 3000); the
  others the mission's (``controller.solver``).

Usage::

    python benchmarks/dompc_compare.py                      # case 2, the mission's timeout, 3 rounds
    python benchmarks/dompc_compare.py --case 1 --timeout 20 --rounds 1 --json
    python benchmarks/dompc_compare.py --contenders auvdock-ipopt,dompc-tuned,dompc-gn

Needs ``do-mpc`` (``pip install -e ".[bench]"``) for its contenders; the figures are
measured, never asserted.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from auvdock.campaign.bench import PAPER_MISSIONS, default_missions_dir, machine_line
from auvdock.config.mission import Mission, load_mission
from auvdock.controllers import ControlOutput, Estimate, Plan, resolve_solver
from auvdock.controllers.mpc import DockingMPC, shift_solution
from auvdock.controllers.solvers import IPOPT_OPTIONS
from auvdock.controllers.status import STATUS_FAILED, STATUS_NAMES, STATUS_NOT_CONVERGED, STATUS_OK
from auvdock.loop.autopilot import Autopilot
from auvdock.loop.simulation import RunSummary, run_simulation
from auvdock.sensing.readings import Readings
from auvdock.vehicle.model import rk4

#: The IPOPT options of auvdock's ``ipopt`` solver, without ``max_iter`` and ``tol`` (the mission's);
#: ``dompc-tuned`` and ``dompc-gn`` get exactly these.
AUVDOCK_IPOPT_OPTIONS: dict[str, Any] = dict(IPOPT_OPTIONS)
#: auvdock's nlpsol options besides IPOPT's (``_COMMON`` there; ``expand`` is moot: do-mpc's NLP is SX).
AUVDOCK_NLPSOL_OPTIONS: dict[str, Any] = {"print_time": False, "error_on_fail": False}

AUVDOCK_CONTENDERS = ("auvdock-rti", "auvdock-sqp", "auvdock-ipopt")
DOMPC_CONTENDERS = ("dompc-default", "dompc-tuned", "dompc-gn")
DEFAULT_CONTENDERS = ("auvdock-rti", "auvdock-ipopt", "dompc-default", "dompc-tuned", "dompc-gn")
#: do-mpc's shipped compiler command (``Optimizer.compile_nlp``), also used for the GN Hessian.
COMPILE_COMMAND = "gcc -fPIC -shared -O1 {cname} -o {libname}"


def import_do_mpc() -> Any:
    """do-mpc, without its warnings about optional features, with ``compile_nlp`` working.

    do-mpc 5.1.2's ``Optimizer.compile_nlp`` calls ``nlpsol`` that its module never imports
    (a ``NameError`` after compiling); the one-line workaround puts CasADi's there.
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import do_mpc
            import do_mpc.optimizer
    except ImportError:
        sys.exit('do-mpc is not installed: python -m pip install "do-mpc>=5.1.2"')
    if not hasattr(do_mpc.optimizer, "nlpsol"):
        do_mpc.optimizer.nlpsol = ca.nlpsol  # do-mpc 5.1.2: missing `from casadi import nlpsol`
    return do_mpc


@contextlib.contextmanager
def working_directory(path: Path) -> Iterator[None]:
    """Run inside ``path`` (CasADi's and do-mpc's code generators write into the working directory)."""
    cwd = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(cwd)


def median_ms(times_s: list[float]) -> float:
    return float(np.median(times_s) * 1e3) if len(times_s) else math.nan


class DoMPCController:
    """auvdock's Oracle MPC problem solved by do-mpc, with auvdock's controller interface.

    Parameters
    ----------
    ref : DockingMPC
        The auvdock MPC (prediction "full", not offset-free) whose problem is rebuilt here:
        every number (N, dt, Q, R, P, bounds) is read from it.
    config : {"default", "tuned", "gn"}
        do-mpc as shipped, tuned, or tuned with the Gauss-Newton Hessian (module docstring).
    max_iter, tol : int, float
        IPOPT's iteration limit and tolerance (``tuned`` and ``gn``; ``default`` keeps IPOPT's).
    vrel_constraint : {"box", "nonlinear"}
        The relative velocity bound as auvdock's box re-centred every step, or as do-mpc's
        nonlinear constraint on the predicted states (see the module docstring).
    workdir : Path, optional
        Where ``tuned`` and ``gn`` compile (a temporary directory); required for them.
    """

    name = "do-mpc"

    def __init__(
        self,
        ref: DockingMPC,
        *,
        config: str,
        max_iter: int,
        tol: float,
        vrel_constraint: str = "box",
        workdir: Path | None = None,
    ) -> None:
        if ref.prediction != "full":
            raise ValueError("DoMPCController rebuilds the Oracle MPC (prediction 'full')")
        if getattr(ref, "offset_free", False):
            raise ValueError(
                "DoMPCController rebuilds the paper's Oracle MPC (variant 'paper', not offset-free)"
            )
        if config not in ("default", "tuned", "gn"):
            raise ValueError(f"unknown do-mpc configuration {config!r} (known: default, tuned, gn)")
        if vrel_constraint not in ("box", "nonlinear"):
            raise ValueError(f"unknown vrel_constraint {vrel_constraint!r} (known: box, nonlinear)")
        if config != "default" and workdir is None:
            raise ValueError(f"do-mpc configuration {config!r} compiles: give it a workdir")
        do_mpc = import_do_mpc()
        self.version = do_mpc.__version__
        self.config = config
        self.tuned = config != "default"
        self.dock = ref.dock
        self.N, self.dt = ref.N, ref.dt
        self.u_min, self.u_max = ref.u_min.copy(), ref.u_max.copy()
        self.v_rel_max, self.w_max = ref.v_rel_max.copy(), ref.w_max.copy()
        self.vrel_constraint = vrel_constraint
        vm = ref.vehicle.model
        rot = vm.function("rotation")
        self._R = lambda angles: np.asarray(rot(angles))

        # the tracking error e(x, dock_p, dock_v, psi_ref) of auvdock's cost, as one SX function
        xs, dps, dvs, psis = (
            ca.SX.sym("x", 12),
            ca.SX.sym("dock_p", 3),
            ca.SX.sym("dock_v", 3),
            ca.SX.sym("psi"),
        )
        R_nb = vm.rotation(xs[0:6])
        e = ca.vertcat(xs[0:3] - dps, xs[3], xs[4], xs[5] - psis, xs[6:9] - ca.mtimes(R_nb.T, dvs), xs[9:12])
        error_fn = ca.Function("tracking_error", [xs, dps, dvs, psis], [e])

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
        x_next = rk4(lambda xk, uk: vm.dynamics(xk, uk, flow, zero), x, self.dt, 1, u)
        model.set_rhs("eta", x_next[0:6])
        model.set_rhs("nu1", x_next[6:9])
        model.set_rhs("nu2", x_next[9:12])
        model.setup()
        # the cost and constraints use the model's own symbols as they are after setup()
        x = ca.vertcat(model.x["eta"], model.x["nu1"], model.x["nu2"])
        dock_p, dock_v = model.tvp["dock_p"], model.tvp["dock_v"]
        psi_ref, flow = model.tvp["psi_ref"], model.tvp["flow_ned"]
        e = error_fn(x, dock_p, dock_v, psi_ref)
        v_rel = model.x["nu1"] - ca.mtimes(vm.rotation(model.x["eta"]).T, flow)

        mpc = do_mpc.controller.MPC(model)
        s = mpc.settings
        s.n_horizon = self.N
        s.t_step = self.dt
        s.n_robust = 0
        s.use_terminal_bounds = True
        s.store_full_solution = False
        if self.tuned:
            s.store_lagr_multiplier = False
            s.store_solver_stats = []
            s.nlpsol_opts = {
                **AUVDOCK_NLPSOL_OPTIONS,
                **{f"ipopt.{k}": v for k, v in AUVDOCK_IPOPT_OPTIONS.items()},
                "ipopt.max_iter": int(max_iter),
                "ipopt.tol": float(tol),
            }
        else:
            s.supress_ipopt_output()  # do-mpc's own: print_level 0, sb yes, print_time 0
        self.nlpsol_opts = dict(s.nlpsol_opts)
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
        else:
            mpc.set_nl_cons("v_rel_upper", v_rel, ub=self.v_rel_max)
            mpc.set_nl_cons("v_rel_lower", -v_rel, ub=self.v_rel_max)
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
            mpc.prepare_nlp()
            self.hessian = "exact"
            self.hess_compile_s = 0.0
            if config == "gn":
                assert workdir is not None
                self._set_gauss_newton(mpc, error_fn, ref, workdir)
            mpc.create_nlp()
        self.setup_time_s = time.perf_counter() - t0 - self.hess_compile_s
        self.compile_time_s = 0.0
        if self.tuned:
            assert workdir is not None
            t0 = time.perf_counter()
            lib = workdir / f"dompc_{config}_nlp.so"
            # compile_nlp prints; keep stdout for the report (--json)
            with working_directory(workdir), contextlib.redirect_stdout(sys.stderr):
                mpc.compile_nlp(overwrite=True, cname=f"dompc_{config}_nlp.c", libname=str(lib))
            self.compile_time_s = time.perf_counter() - t0 + self.hess_compile_s
        self.mpc = mpc
        # where the states and inputs of node k sit in do-mpc's decision vector
        f = mpc.opt_x_num.f
        self._ix = np.array([np.asarray(f["_x", k, 0, -1]).ravel() for k in range(self.N + 1)])
        self._iu = np.array([np.asarray(f["_u", k, 0]).ravel() for k in range(self.N)])
        self.reset()

    # ------------------------------------------------------------------------------------
    def _set_gauss_newton(self, mpc: Any, error_fn: ca.Function, ref: DockingMPC, workdir: Path) -> None:
        """Give IPOPT the Gauss-Newton Hessian of do-mpc's objective (between prepare_nlp and create_nlp)."""
        w, p = ca.vertcat(mpc.opt_x), ca.vertcat(mpc.opt_p)
        fx, fp = mpc.opt_x.f, mpc.opt_p.f

        def ix(*index: Any) -> list[int]:
            return [int(i) for i in np.asarray(fx[index]).ravel()]

        def ip(*index: Any) -> list[int]:
            return [int(i) for i in np.asarray(fp[index]).ravel()]

        sq = {name: ca.DM(np.sqrt(np.asarray(v, dtype=float))) for name, v in (("Q", ref.Q), ("P", ref.P))}
        sqR = ca.DM(np.sqrt(np.asarray(ref.R, dtype=float)))
        res = []
        for k in range(self.N + 1):
            e_k = error_fn(
                w[ix("_x", k, 0, -1)],
                p[ip("_tvp", k, "dock_p")],
                p[ip("_tvp", k, "dock_v")],
                p[ip("_tvp", k, "psi_ref")],
            )
            res.append((sq["Q"] if k < self.N else sq["P"]) * e_k)
            if k < self.N:
                u_before = p[ip("_u_prev")] if k == 0 else w[ix("_u", k - 1, 0)]
                res.append(sqR * (w[ix("_u", k, 0)] - u_before))
        r = ca.vertcat(*res)
        # the residuals must reproduce do-mpc's objective exactly (else its layout has changed)
        check = ca.Function("check", [w, p], [mpc.nlp_obj, ca.dot(r, r)])
        rng = np.random.default_rng(0)
        f_dompc, f_res = (
            float(v) for v in check(rng.standard_normal(w.shape[0]), rng.standard_normal(p.shape[0]))
        )
        if abs(f_dompc - f_res) > 1e-9 * max(1.0, abs(f_dompc)):
            raise RuntimeError(f"the Gauss-Newton residuals give {f_res:g}, do-mpc's objective {f_dompc:g}")
        n_g = sum(int(c.shape[0]) for c in mpc.nlp_cons)
        Jr = ca.jacobian(r, w)
        H = 2 * ca.mtimes(Jr.T, Jr)
        lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", n_g)
        hess = ca.Function(
            "nlp_hess_l",
            [w, p, lam_f, lam_g],
            [lam_f * ca.triu(H)],
            ["x", "p", "lam_f", "lam_g"],
            ["hess_gamma_x_x"],
        )
        t0 = time.perf_counter()
        lib = workdir / "dompc_gn_hess.so"
        with working_directory(workdir):
            cg = ca.CodeGenerator("dompc_gn_hess.c")
            cg.add(hess)
            cg.generate()
            cmd = COMPILE_COMMAND.format(cname="dompc_gn_hess.c", libname=str(lib))
            subprocess.run(cmd, shell=True, check=True)
        self.hess_compile_s = time.perf_counter() - t0
        mpc.settings.nlpsol_opts["hess_lag"] = ca.external("nlp_hess_l", str(lib))
        self.hessian = "gauss-newton"

    def reset(self) -> None:
        """Forget the warm start; the next step starts cold (x_0 repeated, zero thrust)."""
        self._cold = True
        self.parts: dict[str, list[float]] = {"make_step": [], "nlp functions": [], "bounds": []}

    def _set_vrel_box(self, x: np.ndarray, flow_ned: np.ndarray) -> None:
        centre = self._R(x[3:6]).T @ flow_ned
        lo, hi = centre - self.v_rel_max, centre + self.v_rel_max
        if self.tuned:  # do-mpc's advanced bounds API: k = 1..N in one slice each
            # (CasADi's structures index a sliced right-hand side by node, so it has N + 1 entries)
            nodes = slice(1, None)
            self.mpc.lb_opt_x["_x", nodes, 0, -1, "nu1"] = [ca.DM(lo)] * (self.N + 1)
            self.mpc.ub_opt_x["_x", nodes, 0, -1, "nu1"] = [ca.DM(hi)] * (self.N + 1)
        else:  # do-mpc's bounds API: each assignment rebuilds every bound of the NLP
            self.mpc.bounds["lower", "_x", "nu1"] = lo
            self.mpc.bounds["upper", "_x", "nu1"] = hi

    def step(self, meas: Estimate, u_prev: np.ndarray) -> ControlOutput:
        t_start = time.perf_counter()
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
        t0 = time.perf_counter()
        if self.vrel_constraint == "box":
            self._set_vrel_box(x, flow)
        self.parts["bounds"].append(time.perf_counter() - t0)
        u_last = np.clip(u_prev, self.u_min, self.u_max)
        if self._cold:
            mpc.reset_history()
            mpc.x0 = x
            mpc.u0 = u_last
            mpc.set_initial_guess()
            mpc.flags["initial_run"] = False  # no multipliers from an earlier run
            self._cold = False
        elif self.tuned:  # auvdock's warm start: the previous solution shifted by one step
            w0 = shift_solution(np.asarray(mpc.opt_x_num.master).ravel(), self._ix, self._iu)
            w0[self._ix[0]] = x
            mpc.opt_x_num.master = ca.DM(w0)
        mpc.u0 = u_last  # u_{-1} of the input-rate cost: the input applied last

        t0 = time.perf_counter()
        try:
            u0 = np.asarray(mpc.make_step(x), dtype=float).ravel()
            stats = mpc.solver_stats
        except RuntimeError:  # a CasADi evaluation error: no solution
            u0, stats = np.full(u_last.shape, np.nan), {}
        self.parts["make_step"].append(time.perf_counter() - t0)
        # wall time IPOPT spent in CasADi's evaluations of the NLP functions and derivatives
        self.parts["nlp functions"].append(
            sum(
                float(t)
                for k, t in stats.items()
                if k.startswith("t_wall_nlp_") and isinstance(t, int | float)
            )
        )
        ok = bool(stats.get("success", False))
        w = np.asarray(mpc.opt_x_num_unscaled.master).ravel()
        plan_x, plan_u = w[self._ix], w[self._iu]
        if not np.all(np.isfinite(u0)):
            status, thrust = STATUS_FAILED, u_last.copy()
            self._cold = True  # a non-finite iterate is no warm start
        else:
            status = STATUS_OK if ok else STATUS_NOT_CONVERGED
            thrust = np.clip(u0, self.u_min, self.u_max)
        return ControlOutput(thrust, status, time.perf_counter() - t_start, Plan(plan_x, plan_u))


class RecordingAutopilot(Autopilot):
    """An :class:`Autopilot` that remembers the first and the last step (outside the timing)."""

    first: tuple[float, np.ndarray, np.ndarray] | None = None
    last: tuple[float, np.ndarray, np.ndarray] | None = None

    def reset(self) -> None:
        super().reset()
        self.first = None
        self.last = None

    def step(self, readings: Readings) -> ControlOutput:
        out = super().step(readings)
        assert readings.state is not None  # estimation: truth (Assumption 1), as the comparison runs
        rec = (float(readings.t), np.asarray(readings.state, dtype=float).copy(), out.thrust.copy())
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


@dataclass
class Contender:
    """One controller under test: built once, flown once per round."""

    key: str
    description: str
    autopilot: RecordingAutopilot
    build: str
    build_s: float
    compile_s: float = 0.0
    dm: DoMPCController | None = None
    times_s: list[np.ndarray] = field(default_factory=list)
    parts_s: dict[str, list[float]] = field(default_factory=dict)
    outcomes: list[dict[str, Any]] = field(default_factory=list)
    first_move: np.ndarray | None = None


def build_auvdock(key: str, mission: Mission) -> Contender:
    solver = key.split("-", 1)[1]
    m = mission.with_updates(**{"controller.solver.name": solver})
    ap = RecordingAutopilot(m.controller, m.build_vehicle(), m.build_dock())
    build = str(getattr(ap.controller.mpc, "build", "?"))
    default = resolve_solver("auto", "oracle@paper")
    if solver in ("rti", "sqp"):
        what = f"{solver} (QP {getattr(m.controller.solver, 'qp', 'qrqp')})"
    else:
        what = "IPOPT, Gauss-Newton Hessian, shifted warm start + multipliers"
    if solver == default:
        what += ", auvdock's default for Oracle"
    return Contender(key, f"auvdock {what}; compiled solver: {build}", ap, build, ap.build_time_s)


def build_dompc(key: str, mission: Mission, vrel_constraint: str, workdir: Path) -> Contender:
    config = key.split("-", 1)[1]
    m = mission.with_updates(**{"controller.solver.name": resolve_solver("auto", "oracle@paper")})
    ap = RecordingAutopilot(m.controller, m.build_vehicle(), m.build_dock())
    c = m.controller
    dm = DoMPCController(
        ap.controller.mpc,
        config=config,
        max_iter=c.solver.max_iter,
        tol=c.solver.tol,
        vrel_constraint=vrel_constraint,
        workdir=workdir,
    )
    ap.controller = dm
    ap.name = dm.name
    ap.solver = "ipopt"
    if config == "default":
        what = "as shipped: IPOPT exact Hessian, uncompiled, IPOPT's default options, its warm start"
    else:
        hess = "exact Hessian" if dm.hessian == "exact" else "Gauss-Newton Hessian (hess_lag)"
        what = f"tuned: IPOPT {hess}, compile_nlp, auvdock's IPOPT options, shifted warm start"
    build = "uncompiled" if config == "default" else "compiled"
    desc = f"do-mpc {dm.version} {what}"
    return Contender(key, desc, ap, build, dm.setup_time_s, dm.compile_time_s, dm)


def run_round(mission: Mission, c: Contender, timeout: float) -> None:
    s = run_simulation(mission, autopilot=c.autopilot, timeout_s=timeout)
    o = s.outcome
    ap = c.autopilot
    c.times_s.append(np.asarray(s.solve_times_s, dtype=float))
    c.outcomes.append(
        {
            "docked": bool(o["docked"]),
            "time_to_dock_s": float(o["time_to_dock_s"]),
            "final_distance_m": final_distance(mission, ap, s),
            "reason": str(o["reason"]),
            "solver_failures": int(o["solver_failures"]),
            "status_counts": str(o["status_counts"]),
            "steps": int(len(s.solve_times_s)),
        }
    )
    if ap.first is not None:
        c.first_move = ap.first[2].copy()
    if c.dm is not None:
        for name, vals in c.dm.parts.items():
            c.parts_s.setdefault(name, []).extend(vals)


def contender_row(c: Contender) -> dict[str, Any]:
    pooled = np.concatenate(c.times_s) if c.times_s else np.zeros(0)
    last = c.outcomes[-1] if c.outcomes else {}
    same = len({(o["docked"], str(o["time_to_dock_s"]), o["solver_failures"]) for o in c.outcomes}) <= 1
    row: dict[str, Any] = {
        "contender": c.key,
        "description": c.description,
        "build": c.build,
        "build_s": c.build_s,
        "compile_s": c.compile_s,
        **time_stats(pooled),
        "steps": int(pooled.size),
        "round_medians_ms": [float(np.median(t) * 1e3) if t.size else math.nan for t in c.times_s],
        **last,
        "outcome_same_every_round": bool(same),
        "first_move_N": c.first_move.tolist() if c.first_move is not None else None,
    }
    if c.dm is not None:
        row["step_parts_median_ms"] = {k: median_ms(v) for k, v in c.parts_s.items()}
        row["nlpsol_opts"] = {k: v for k, v in c.dm.nlpsol_opts.items() if isinstance(v, int | float | str)}
        row["hessian"] = c.dm.hessian
    return row


def pairing(rows: dict[str, dict[str, Any]], what: str, auv: str, dm: str | None) -> dict[str, Any] | None:
    if dm is None or auv not in rows or dm not in rows:
        return None
    a, d = rows[auv], rows[dm]
    return {
        "pairing": what,
        "auvdock": auv,
        "do_mpc": dm,
        "median_ratio": d["median_ms"] / a["median_ms"],
        "p99_ratio": d["p99_ms"] / a["p99_ms"],
        "max_ratio": d["max_ms"] / a["max_ms"],
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


def fmt(v: float | None, spec: str = ".2f") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, spec)


def print_report(r: dict[str, Any]) -> None:
    print(
        f"Oracle MPC (paper variant): auvdock vs do-mpc {r['do_mpc_version']}, case {r['case']} "
        f"({r['mission']}), N = {r['horizon']}, dt = {r['dt_s']} s, simulated up to {r['timeout_s']} s, "
        f"{r['rounds']} interleaved round(s) (order rotated each round)"
    )
    print(r["machine"])
    print(f"relative velocity bound in do-mpc: {r['vrel_constraint']}")
    print()
    print("contenders (all built before the first run; build and compile time not in the step times):")
    for row in r["runs"]:
        if row["contender"] in DOMPC_CONTENDERS:
            took = f"setup {row['build_s']:.1f} s" + (
                f", compile {row['compile_s']:.1f} s" if row["compile_s"] else ""
            )
        else:
            took = f"build {row['build_s']:.1f} s"
        print(f"  {row['contender']:<14} {row['description']} ({took})")
    head = (
        f"{'contender':<14} {'median':>7} {'p95':>7} {'p99':>7} {'max':>7} {'steps':>6}  "
        f"{'per-round medians':<23} {'docked':>6} {'t_dock s':>8} {'final m':>7} {'fail':>4}"
    )
    print()
    print("whole controller step (ms), pooled over the rounds")
    print(head)
    print("-" * len(head))
    for row in r["runs"]:
        rounds = " ".join(fmt(v) for v in row["round_medians_ms"])
        flag = "" if row["outcome_same_every_round"] else "  (outcome differs between rounds)"
        print(
            f"{row['contender']:<14} {fmt(row['median_ms']):>7} {fmt(row['p95_ms']):>7} "
            f"{fmt(row['p99_ms']):>7} {fmt(row['max_ms']):>7} {row['steps']:>6}  {rounds:<23} "
            f"{'yes' if row.get('docked') else 'no':>6} {fmt(row.get('time_to_dock_s')):>8} "
            f"{fmt(row.get('final_distance_m'), '.3f'):>7} {row.get('solver_failures', 0):>4}{flag}"
        )
    dms = [row for row in r["runs"] if "step_parts_median_ms" in row]
    if dms:
        print()
        print("do-mpc: medians (ms) of the parts of its whole step")
        for row in dms:
            p = row["step_parts_median_ms"]
            print(
                f"  {row['contender']:<14} whole {fmt(row['median_ms'])}: make_step {fmt(p['make_step'])} "
                f"(CasADi's NLP function evaluations {fmt(p['nlp functions'])}), "
                f"bound re-centring {fmt(p['bounds'])}"
            )
    if r["pairings"]:
        print()
        print("pairings (do-mpc / auvdock, whole step):")
        for pr in r["pairings"]:
            print(
                f"  {pr['pairing']:<44} {pr['do_mpc']:<14} / {pr['auvdock']:<14} median "
                f"{fmt(pr['median_ratio'], '.1f')}x, p99 {fmt(pr['p99_ratio'], '.1f')}x, "
                f"max {fmt(pr['max_ratio'], '.1f')}x"
            )
    print()
    print(f"first move (thrust at t = 0, N), max |difference| to {r['first_move_reference']}:")
    for row in r["runs"]:
        fm = row["first_move_N"]
        moves = " ".join(f"{v:8.3f}" for v in fm) if fm else "-"
        print(f"  {row['contender']:<14} {moves}   {fmt(row.get('first_move_max_diff_N'), '.1e')}")


def main(argv: list[str] | None = None) -> int:
    ap_ = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap_.add_argument("--case", type=int, default=2, help="paper case 1..6 (default 2)")
    ap_.add_argument("--timeout", type=float, default=None, help="simulated seconds (default: the mission's)")
    ap_.add_argument("--rounds", type=int, default=3, help="interleaved rounds (default 3)")
    known = AUVDOCK_CONTENDERS + DOMPC_CONTENDERS
    ap_.add_argument(
        "--contenders",
        default=",".join(DEFAULT_CONTENDERS),
        help=f"comma-separated, from {', '.join(known)} (default: {','.join(DEFAULT_CONTENDERS)})",
    )
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
    if args.rounds < 1:
        ap_.error("--rounds must be at least 1")
    keys = [k.strip() for k in args.contenders.split(",") if k.strip()]
    unknown = [k for k in keys if k not in known]
    if unknown or not keys or len(set(keys)) != len(keys):
        ap_.error(f"--contenders: give distinct names from {', '.join(known)}")

    base = load_mission(default_missions_dir() / f"{PAPER_MISSIONS[args.case - 1]}.yaml")
    mission = base.with_updates(**{"controller.type": "oracle@paper"})
    if mission.estimation != "truth":
        sys.exit(f"case {args.case}: the comparison needs estimation: truth")
    timeout = mission.docking.timeout_s if args.timeout is None else float(args.timeout)
    c = mission.controller

    def log(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    version = import_do_mpc().__version__ if any(k in DOMPC_CONTENDERS for k in keys) else "-"
    if any(k in ("dompc-tuned", "dompc-gn") for k in keys) and shutil.which("gcc") is None:
        sys.exit("dompc-tuned and dompc-gn compile with gcc (do-mpc's compile_nlp): none found")
    with tempfile.TemporaryDirectory(prefix="dompc_compare_") as tmp:
        contenders: list[Contender] = []
        for key in keys:
            log(f"building {key} ...")
            if key in AUVDOCK_CONTENDERS:
                contenders.append(build_auvdock(key, mission))
            else:
                contenders.append(build_dompc(key, mission, args.vrel_constraint, Path(tmp)))
        for r in range(args.rounds):
            order = contenders[r % len(contenders) :] + contenders[: r % len(contenders)]
            for ct in order:
                log(f"round {r + 1}/{args.rounds}: {ct.key} for up to {timeout} s ...")
                run_round(mission, ct, timeout)

    rows = {ct.key: contender_row(ct) for ct in contenders}
    ref_key = "auvdock-ipopt" if "auvdock-ipopt" in rows else keys[0]
    ref_move = rows[ref_key]["first_move_N"]
    for row in rows.values():
        fm = row["first_move_N"]
        row["first_move_max_diff_N"] = (
            float(np.max(np.abs(np.asarray(fm) - np.asarray(ref_move)))) if fm and ref_move else math.nan
        )
    dm_keys = [k for k in keys if k in DOMPC_CONTENDERS]
    fastest = min(dm_keys, key=lambda k: rows[k]["median_ms"]) if dm_keys else None
    default_key = f"auvdock-{resolve_solver('auto', 'oracle@paper')}"
    pairs = [
        pairing(rows, "same algorithm (IPOPT; do-mpc exact Hessian)", "auvdock-ipopt", "dompc-tuned"),
        pairing(rows, "same algorithm and Hessian (IPOPT, GN)", "auvdock-ipopt", "dompc-gn"),
        pairing(rows, "best against best (default vs fastest do-mpc)", default_key, fastest),
    ]
    report = {
        "case": args.case,
        "mission": mission.name,
        "horizon": c.horizon_steps,
        "dt_s": c.dt_s,
        "timeout_s": timeout,
        "rounds": args.rounds,
        "machine": machine_line(),
        "do_mpc_version": version,
        "auvdock_default_solver": resolve_solver("auto", "oracle@paper"),
        "vrel_constraint": args.vrel_constraint,
        "runs": list(rows.values()),
        "pairings": [p for p in pairs if p is not None],
        "first_move_reference": ref_key,
        "status_names": {str(k): v for k, v in STATUS_NAMES.items()},
    }
    if args.json:
        print(json.dumps(clean(report), indent=2, allow_nan=False))
    else:
        print_report(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
