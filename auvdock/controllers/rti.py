"""Real-time iteration (RTI): one convex QP per control step instead of a converged NLP.

Diehl, Bock and Schloeder (2005), "A real-time iteration scheme for nonlinear optimization
in optimal feedback control", SIAM J. Control Optim. 43(5).  Each control step takes ONE
full Gauss-Newton SQP step from the previous solution shifted by a step (with the
measured state put in its first node), instead of iterating to convergence: since the
problem changes little between steps, the iterates track the moving optimum, and the
step costs one evaluation of the derivatives and one QP.

The QP at the linearisation point ``w_bar`` is, for ``min f(w) s.t. g(w) = 0,
lbx <= w <= ubx``::

    min_dw  1/2 dw' H dw + grad f(w_bar)' dw
    s.t.    lbg - g(w_bar) <= J_g(w_bar) dw <= ubg - g(w_bar),   lbx - w_bar <= dw <= ubx - w_bar

with ``H`` the Gauss-Newton matrix of the cost (positive semidefinite, no constraint
curvature, so no multipliers are needed).  Its data (H, gradient, constraint Jacobian and
residual) come from one compiled, cached CasADi function.  The QP is solved by HPIPM (the
default: the MPC lays its variables out stage by stage, so the QP is an optimal-control QP
that HPIPM solves by Riccati recursion in time linear in the horizon) or by CasADi's qrqp
(``qp``, :data:`QP_SOLVERS`).

The first solve of a run has no previous solution to start from, so it iterates the same
step until it converges (step infinity norm below ``tol``) or ``max_iter`` steps (at most
10: with the Optimized FSE-MPC's information term, whose curvature the Gauss-Newton matrix
leaves out, full steps may cycle instead of converging, and a first step of 100 QPs would
take 0.4 s; the following steps go on improving the plan anyway).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from auvdock.runtime import timing
from auvdock.runtime.codegen import compile_mode, compiled_function

if TYPE_CHECKING:
    from auvdock.controllers.ocp_qp import OcpQpStep
    from auvdock.controllers.qp_stages import StageQP

__all__ = [
    "RealTimeIteration",
    "QRQP_OPTIONS",
    "HPIPM_OPTIONS",
    "QP_SOLVERS",
    "COLD_START_MAX_ITER",
    "qp_options",
    "conic_plugin",
]

#: Most steps the first solve of a run takes.
COLD_START_MAX_ITER = 10

QRQP_OPTIONS = {"print_iter": False, "print_header": False, "print_info": False, "error_on_fail": False}


#: The QP solvers an MPC can use (``solver.qp``), with what they are.
QP_SOLVERS = {
    "hpipm": "HPIPM, an interior-point method that solves the stage-wise QP by Riccati recursion; rti's "
    "step compiled whole: the QP's data generated stage by stage (auvdock.controllers.qp_stages) and "
    "HPIPM's OCP-QP interface in one call, its memory made once (auvdock.controllers.ocp_qp); until it "
    "is compiled the plugin solves the same data (the same bits)",
    "hpipm_casadi": "HPIPM through CasADi's conic plugin on the whole problem's derivatives (the "
    "reference of hpipm: the same QP, to rounding)",
    "qrqp": "CasADi's qrqp, an active-set method on the sparse QP (sparse QR)",
}


def conic_plugin(qp: str) -> str:
    """CasADi's conic plugin of the QP solver ``qp`` (:data:`QP_SOLVERS`)."""
    return "hpipm" if qp in ("hpipm", "hpipm_casadi") else qp


#: HPIPM's settings: its "speed" mode (Frison and Diehl 2020, HPIPM: a high-performance quadratic
#: programming framework for model predictive control, IFAC-PapersOnLine 53(2)) with its own
#: default tolerances (1e-8 on the residuals); 50 iterations at most.
HPIPM_OPTIONS = {"mode": "speed", "iter_max": 50, "warm_start": 0}


def qp_options(qp: str, dims: dict | None) -> dict:
    """Options of the QP solver ``qp`` (quiet, no exception on failure).

    ``dims`` (``{"N", "nx", "nu", "ng"}``, lists of N + 1 stage sizes) is the stage layout of
    the QP's variables and constraints, which HPIPM needs (:class:`auvdock.controllers.mpc.DockingMPC`
    lays the problem out stage by stage).
    """
    if qp == "qrqp":
        return dict(QRQP_OPTIONS)
    if qp in ("hpipm", "hpipm_casadi"):
        if dims is None:
            raise ValueError("the hpipm QP solver needs the problem's stage dimensions")
        return {**dims, "error_on_fail": False, "hpipm": dict(HPIPM_OPTIONS)}
    raise ValueError(f"unknown QP solver {qp!r} (known: {', '.join(QP_SOLVERS)})")


class RealTimeIteration:
    """One Gauss-Newton SQP step per call, for ``min f(w, p)`` subject to ``g(w, p) = 0`` and bounds.

    Parameters
    ----------
    w, p : SX column vectors
        Decision variables and parameters.
    f, g : SX
        Objective (scalar) and equality constraints (column).
    H : SX
        Positive semidefinite Hessian approximation of ``f`` in ``w`` (Gauss-Newton).
    max_iter : int
        Steps of the first (cold-start) solve at most (capped at :data:`COLD_START_MAX_ITER`).
    tol : float
        Step size (infinity norm) at which the cold start stops.
    qp : {"hpipm", "qrqp"}
        The QP solver (:data:`QP_SOLVERS`).
    dims : dict, optional
        Stage layout of ``w`` and ``g`` (:func:`qp_options`); needed by HPIPM.
    stages : StageQP, optional
        The QP's data stage by stage (:mod:`auvdock.controllers.qp_stages`), which ``qp: hpipm``
        compiles; without it, the blocks come from the whole problem's derivatives.
    """

    def __init__(
        self,
        w: ca.SX,
        p: ca.SX,
        f: ca.SX,
        g: ca.SX,
        H: ca.SX,
        *,
        max_iter: int = 20,
        tol: float = 1e-6,
        qp: str = "qrqp",
        dims: dict | None = None,
        stages: StageQP | None = None,
    ) -> None:
        #: The whole step compiled (``qp: hpipm``, once the library is built), else None.
        self.ocp: OcpQpStep | None = None
        #: The QP's data stage by stage, as the problem describes them (None: from the whole problem).
        self.stages = stages
        opts = qp_options(qp, dims)
        if qp == "hpipm" and dims is not None:
            self._build_whole(w, p, f, g, H, dims, opts, stages)
        else:
            grad = ca.gradient(f, w)
            Jg = ca.jacobian(g, w)
            names = ["H", "grad", "A", "g", "f"]
            fn = ca.Function("rti_qp_data", [w, p], [H, grad, Jg, g, f], ["w", "p"], names)
            self._data: Any = None  # (w, p) -> (H, grad, A, g, f)
            self._data, self.build = compiled_function(fn)
            self._qp = ca.conic("rti_qp", conic_plugin(qp), {"h": H.sparsity(), "a": Jg.sparsity()}, opts)
        self.max_iter = min(int(max_iter), COLD_START_MAX_ITER)
        self.tol = float(tol)

    def _build_whole(
        self, w: ca.SX, p: ca.SX, f: ca.SX, g: ca.SX, H: ca.SX, dims: dict, opts: dict, stages: StageQP | None
    ) -> None:
        """``qp: hpipm``: the blocks stage by stage (``stages``) or, for a problem that does not describe
        its stages, from the whole problem's derivatives (:func:`auvdock.controllers.ocp_qp.stage_blocks`);
        compiled with HPIPM's OCP-QP into one call, or the plugin on the same blocks until then."""
        from auvdock.controllers.ocp_qp import build_ocp_step, stage_blocks
        from auvdock.controllers.qp_stages import SparseAssembly, blocks_function

        if stages is not None:
            blocks = blocks_function(stages)
        else:
            grad = ca.gradient(f, w)
            Jg = ca.jacobian(g, w)
            blocks = stage_blocks(w, p, f, g, H, grad, Jg, dims["nx"], dims["nu"])
        built = None
        if compile_mode() != "never":  # (the key serialises the functions: not for nothing)
            key: list[bytes | str] = stages.key_parts() if stages is not None else [blocks.serialize()]
            built = build_ocp_step(blocks, dims, opts["hpipm"], key)
        if built is not None:
            self.ocp, self.build = built
            return
        # until the step is compiled: the same blocks uncompiled (compiling them alone would build a
        # library the next run does not use), laid out for the plugin
        assembly = SparseAssembly(int(dims["nx"][0]), int(dims["nu"][0]), int(dims["N"]))
        self._data, self.build = assembly.data_function(blocks), "uncompiled"
        self._qp = ca.conic("rti_qp", "hpipm", {"h": assembly.h_sparsity, "a": assembly.a_sparsity}, opts)

    def step(
        self, w_bar: np.ndarray, p: np.ndarray, lbx: np.ndarray, ubx: np.ndarray, lbg: float, ubg: float
    ) -> tuple[np.ndarray, bool, str, float, float]:
        """One QP step from ``w_bar``.

        Returns ``(w_new, success, return_status, model cost, step infinity norm)``; the
        model cost is the QP's prediction ``f(w_bar) + q(dw)`` of the objective at ``w_new``.
        """
        if self.ocp is not None:  # (the gaps' bounds are 0: the layout's)
            return self.ocp.step(w_bar, p, lbx, ubx)
        with timing.part("qp data"):
            H, grad, A, gval, f0 = self._data(w_bar, p)
        gv = np.asarray(gval).ravel()
        with timing.part("qp"):
            sol = self._qp(h=H, g=grad, a=A, lba=lbg - gv, uba=ubg - gv, lbx=lbx - w_bar, ubx=ubx - w_bar)
        stats = self._qp.stats()
        dw = np.asarray(sol["x"]).ravel()
        cost = float(f0) + float(sol["cost"])
        return (
            w_bar + dw,
            bool(stats.get("success", False)),
            str(stats.get("return_status", "")),
            cost,
            float(np.max(np.abs(dw)) if dw.size else 0.0),
        )

    def solve(
        self,
        w_bar: np.ndarray,
        p: np.ndarray,
        lbx: np.ndarray,
        ubx: np.ndarray,
        lbg: float,
        ubg: float,
        *,
        cold: bool,
    ) -> tuple[np.ndarray, bool, str, int, float]:
        """One step (``cold=False``), or steps until converged (``cold=True``).

        Returns ``(w, success, return_status, steps, model cost)``.
        """
        w, ok, ret, cost, size = self.step(w_bar, p, lbx, ubx, lbg, ubg)
        n = 1
        while cold and ok and size > self.tol and n < self.max_iter:
            w, ok, ret, cost, size = self.step(w, p, lbx, ubx, lbg, ubg)
            n += 1
        return w, ok, ret, n, cost
