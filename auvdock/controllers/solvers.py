"""The solvers of the docking MPC's NLP, registered in one place (:data:`SOLVERS`).

Each solver is a builder ``build(problem, max_iter, tol) -> NLPSolver`` for the problem
:class:`auvdock.controllers.mpc.DockingMPC` lays out (:class:`Problem`), and every built
solver answers :meth:`NLPSolver.solve` the same way, so the MPC never branches on which
one it has.  A new solver is one builder function and one line in :data:`SOLVERS`.

==========  ======================================================================
name        method
==========  ======================================================================
``ipopt``   IPOPT, interior point, warm-started with the previous multipliers
``sqp``     CasADi ``sqpmethod``, Gauss-Newton Hessian, iterated to convergence
``rti``     real-time iteration: one Gauss-Newton QP step per control step
            (:mod:`auvdock.controllers.rti`)
==========  ======================================================================

``sqp`` and ``rti`` solve their QPs with HPIPM (default) or qrqp (``Problem.qp``,
:data:`auvdock.controllers.rti.QP_SOLVERS`).  ``auto`` is resolved per controller by
:func:`auvdock.controllers.registry.resolve_solver`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import casadi as ca
import numpy as np

from auvdock.controllers.qp_stages import StageQP
from auvdock.controllers.rti import RealTimeIteration, conic_plugin, qp_options
from auvdock.controllers.settings import SOLVER_NAMES, solver_names
from auvdock.runtime import timing
from auvdock.runtime.codegen import compiled_nlpsol

__all__ = ["Problem", "SolveResult", "NLPSolver", "SolverEntry", "SOLVERS", "IPOPT_OPTIONS", "solver_names"]


@dataclass
class Problem:
    """A parametric NLP, ``min f(w, p)`` subject to ``g(w, p) = 0, lbx <= w <= ubx`` (CasADi SX).

    ``H_gn`` is the Gauss-Newton Hessian of ``f`` in ``w`` (positive semidefinite; None
    when the exact Hessian is wanted), ``hessian`` names which one is meant.  ``dims`` is
    the stage layout of ``w`` and ``g`` (HPIPM's ``N``, ``nx``, ``nu``, ``ng``) and ``qp`` the
    QP solver of ``sqp`` and ``rti``.
    """

    w: ca.SX
    p: ca.SX
    f: ca.SX
    g: ca.SX
    H_gn: ca.SX | None
    hessian: str = "gauss-newton"
    #: stage dimensions of a stage-ordered layout (HPIPM's N, nx, nu, ng)
    dims: dict | None = None
    #: the QP solver of rti (and sqp): qrqp, hpipm, ...
    qp: str = "qrqp"
    #: the QP's data stage by stage (rti with hpipm compiles it), None: from the whole problem
    stages: StageQP | None = None

    @property
    def nlp(self) -> dict[str, ca.SX]:
        return {"x": self.w, "f": self.f, "g": self.g, "p": self.p}


@dataclass
class SolveResult:
    """One solve: the iterate, whether it converged, the solver's words and multipliers."""

    w: np.ndarray | None
    success: bool
    return_status: str
    iterations: int
    cost: float
    lam_x: np.ndarray | None = None
    lam_g: np.ndarray | None = None


class NLPSolver(Protocol):
    """A built solver.  ``build`` says how it runs: ``"compiled"`` or ``"uncompiled"``."""

    build: str

    def solve(
        self,
        w0: np.ndarray,
        p: np.ndarray,
        lbx: np.ndarray,
        ubx: np.ndarray,
        *,
        lam_x0: np.ndarray | None,
        lam_g0: np.ndarray | None,
        cold: bool,
    ) -> SolveResult:
        """Solve from ``w0`` (with multipliers, if the solver uses them); ``cold``: no previous solve."""
        ...


class _Nlpsol:
    """An ``nlpsol`` (IPOPT or sqpmethod), compiled and cached where a compiler is found."""

    def __init__(self, plugin: str, problem: Problem, opts: dict) -> None:
        self._solver, self.build = compiled_nlpsol("mpc", plugin, problem.nlp, opts)

    def solve(self, w0, p, lbx, ubx, *, lam_x0, lam_g0, cold) -> SolveResult:
        args = {"x0": w0, "p": p, "lbx": lbx, "ubx": ubx, "lbg": 0.0, "ubg": 0.0}
        if lam_x0 is not None:
            args["lam_x0"] = lam_x0
            args["lam_g0"] = lam_g0
        t0 = time.perf_counter()
        sol = self._solver(**args)
        total = time.perf_counter() - t0
        stats = self._solver.stats()
        # the solver's own record of its function evaluations (CasADi's t_wall_nlp_*)
        walls = (v for k, v in stats.items() if k.startswith("t_wall_nlp_") and isinstance(v, int | float))
        fn = min(sum(float(v) for v in walls), total)
        timing.add("nlp functions", fn)
        timing.add("nlp solver", total - fn)
        return SolveResult(
            np.asarray(sol["x"]).ravel(),
            bool(stats.get("success", False)),
            str(stats.get("return_status", "")),
            int(stats.get("iter_count", -1)),
            float(sol["f"]),
            np.asarray(sol["lam_x"]).ravel(),
            np.asarray(sol["lam_g"]).ravel(),
        )


def _hess_lag(problem: Problem, upper: bool) -> ca.Function | None:
    """The Gauss-Newton Hessian as the solver's Hessian of the Lagrangian (no constraint curvature)."""
    if problem.H_gn is None:
        return None
    lam_f = ca.SX.sym("lam_f")
    lam_g = ca.SX.sym("lam_g", problem.g.shape[0])
    H = lam_f * (ca.triu(problem.H_gn) if upper else problem.H_gn)
    return ca.Function(
        "nlp_hess_l",
        [problem.w, problem.p, lam_f, lam_g],
        [H],
        ["x", "p", "lam_f", "lam_g"],
        ["hess_gamma_x_x"],
    )


_COMMON: dict[str, object] = {"expand": True, "print_time": False, "error_on_fail": False}

#: IPOPT's options in the ``ipopt`` solver (besides the mission's ``max_iter`` and ``tol``): quiet,
#: and warm-started from the previous primal-dual solution (the benchmarks give do-mpc the same).
IPOPT_OPTIONS: dict[str, object] = {
    "print_level": 0,
    "sb": "yes",
    "acceptable_tol": 1e-4,
    "warm_start_init_point": "yes",
    "mu_init": 1e-2,
    "warm_start_bound_push": 1e-6,
    "warm_start_mult_bound_push": 1e-6,
}


def build_ipopt(problem: Problem, max_iter: int, tol: float) -> NLPSolver:
    """IPOPT with a warm start from the previous primal-dual solution."""
    opts = dict(_COMMON)
    hess = _hess_lag(problem, upper=True)
    if hess is not None:
        opts["hess_lag"] = hess
    opts["ipopt"] = {**IPOPT_OPTIONS, "max_iter": int(max_iter), "tol": float(tol)}
    return _Nlpsol("ipopt", problem, opts)


def build_sqp(problem: Problem, max_iter: int, tol: float) -> NLPSolver:
    """CasADi's sqpmethod with the problem's QP solver, iterated to convergence."""
    opts = dict(_COMMON)
    hess = _hess_lag(problem, upper=False)
    if hess is not None:
        opts["hess_lag"] = hess
    opts.update(
        {
            "print_header": False,
            "print_iteration": False,
            "print_status": False,
            "max_iter": int(max_iter),
            "tol_pr": float(tol),
            "tol_du": float(tol) * 100,
            "hessian_approximation": "exact",
            "qpsol": conic_plugin(problem.qp),
            "qpsol_options": qp_options(problem.qp, problem.dims),
        }
    )
    if problem.hessian == "exact":
        opts["convexify_strategy"] = "regularize"
    return _Nlpsol("sqpmethod", problem, opts)


class _RTI:
    def __init__(self, problem: Problem, max_iter: int, tol: float) -> None:
        if problem.H_gn is None:
            raise ValueError("solver rti needs the gauss-newton Hessian")
        self._rti = RealTimeIteration(
            problem.w,
            problem.p,
            problem.f,
            problem.g,
            problem.H_gn,
            max_iter=int(max_iter),
            tol=tol,
            qp=problem.qp,
            dims=problem.dims,
            stages=problem.stages,
        )
        self.build = self._rti.build

    def solve(self, w0, p, lbx, ubx, *, lam_x0, lam_g0, cold) -> SolveResult:
        w, ok, ret, iters, cost = self._rti.solve(w0, p, lbx, ubx, 0.0, 0.0, cold=cold)
        return SolveResult(w, ok, ret, iters, cost)


def build_rti(problem: Problem, max_iter: int, tol: float) -> NLPSolver:
    """Real-time iteration (Diehl et al. 2005): one compiled Gauss-Newton QP step per solve."""
    return _RTI(problem, max_iter, tol)


@dataclass(frozen=True)
class SolverEntry:
    """One registered solver."""

    name: str
    build: Callable[[Problem, int, float], NLPSolver]
    summary: str


#: Every solver, by name: the one place to register a new one.
SOLVERS: dict[str, SolverEntry] = {
    e.name: e
    for e in (
        SolverEntry("ipopt", build_ipopt, "IPOPT interior point, warm-started"),
        SolverEntry("sqp", build_sqp, "sqpmethod, Gauss-Newton, iterated to convergence"),
        SolverEntry("rti", build_rti, "real-time iteration: one Gauss-Newton QP per step"),
    )
}


# reading a mission checks solver names against SOLVER_NAMES, which needs no CasADi: the same names
assert tuple(SOLVERS) == SOLVER_NAMES, "auvdock.controllers.settings.SOLVER_NAMES must list SOLVERS"
