"""The QP's data stage by stage: each kind of stage's functions generated once, and called per stage.

The real-time iteration's QP (:mod:`auvdock.controllers.rti`) for a stage-ordered problem ``w = [x_0,
u_0, ..., x_N]`` with the gaps ``g_k = F_k(x_k, u_k) - x_(k+1)`` and a cost that is a sum of stage
costs is, per stage, the linearised gap (``A_k``, ``B_k``, ``b_k``) and the stage's Gauss-Newton blocks
(``Q_k``, ``S_k``, ``R_k``, ``q_k``, ``r_k``).  Differentiating the whole problem at once (CasADi's
``jacobian`` of every gap and residual in ``w``) writes one straight-line function whose size grows with
the horizon: megabytes of C for N = 10, minutes of compilation for N = 40.  :class:`StageQP` instead
describes the problem by the functions of its kinds of stage (a first stage, the running ones, a
coarse one, the last) with, per stage, where its parameters are in the problem's parameter vector;
:func:`blocks_function` calls each kind's function once per stage (a CasADi ``map``: one loop in the
generated C), so that the code, and the time to compile it, does not depend on N, and a step costs
in proportion to N.

A cost term that couples the stages (the Optimized FSE-MPC's information reward: the filter's
information along the whole path) is one further function ``(w, p) -> (J, dJ/dw)``; its gradient is
added to the stage gradients (its curvature is not in the Gauss-Newton Hessian, as in the whole
problem's).

:class:`SparseAssembly` lays the same blocks out as the sparse matrices CasADi's conic plugins take,
so the plugin solves exactly the QP the compiled step (:mod:`auvdock.controllers.ocp_qp`) solves: the
reference the compiled step is checked against, and what runs until it is compiled.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

__all__ = ["Stage", "StageQP", "blocks_function", "SparseAssembly", "BLOCKS_FUNCTION"]

#: The name of the generated blocks function (the C symbol ``ocp_qp.c`` calls).
BLOCKS_FUNCTION = "auvdock_qp_blocks"


@dataclass(frozen=True)
class Stage:
    """One stage of a :class:`StageQP`.

    ``gap`` is ``(x_k (nx,), u_k (nu,), x_(k+1) (nx,), s) -> (A (nx, nx), B (nx, nu), b (nx,))`` with
    ``b = F_k(x_k, u_k) - x_(k+1)`` (None for the last stage); ``cost`` is ``(x_k, u_k, s) -> (Q (nx, nx),
    S (nu, nx), R (nu, nu), q (nx,), r (nu,), c)``: the Hessian's and gradient's blocks of the stage's
    cost ``c`` (the last stage's ``u_k`` has no rows).  ``gap_params`` and ``cost_params`` are the
    indices of ``s`` in ``[p; consts]`` (:class:`StageQP`).  Stages whose functions are the same object
    are evaluated together (one ``map``)."""

    gap: ca.Function | None
    gap_params: np.ndarray
    cost: ca.Function
    cost_params: np.ndarray


@dataclass(frozen=True)
class StageQP:
    """A stage-wise QP's data: ``N + 1`` :class:`Stage` s of ``nx`` states and ``nu`` inputs (none in
    the last), parameters ``p`` of ``n_params`` values followed by ``consts`` (fixed values a stage may
    take as a parameter: a weight's scale, a zero), and ``extra``, a cost of the whole path ``(w, p) ->
    (J, dJ/dw (nw,))`` (None: the cost is the stages' sum)."""

    nx: int
    nu: int
    n_params: int
    stages: list[Stage]
    consts: np.ndarray = field(default_factory=lambda: np.zeros(0))
    extra: ca.Function | None = None

    @property
    def N(self) -> int:
        return len(self.stages) - 1

    @property
    def nw(self) -> int:
        return (self.nx + self.nu) * self.N + self.nx

    def key_parts(self) -> list[bytes | str]:
        """What defines the data, for a cache key: each distinct function once (serialised), then the
        stages by function and parameter indices, the constants and the sizes."""
        fns: dict[int, int] = {}
        parts: list[bytes | str] = [f"{self.nx} {self.nu} {self.n_params} {self.N}"]

        def ref(fn: ca.Function | None) -> str:
            if fn is None:
                return "-"
            if id(fn) not in fns:
                fns[id(fn)] = len(fns)
                parts.append(fn.serialize())
            return str(fns[id(fn)])

        for st in self.stages:
            gap, cost = ref(st.gap), ref(st.cost)
            gp, cp = np.asarray(st.gap_params).tolist(), np.asarray(st.cost_params).tolist()
            parts.append(f"{gap}:{gp} {cost}:{cp}")
        parts.append(np.asarray(self.consts, dtype=float).tobytes())
        parts.append(ref(self.extra))
        return parts


def _groups(stages: list[Stage], attr: str) -> list[tuple[ca.Function, list[int]]]:
    """Runs of consecutive stages with the same function ``attr`` (``gap`` or ``cost``)."""
    out: list[tuple[ca.Function, list[int]]] = []
    for k, st in enumerate(stages):
        fn = getattr(st, attr)
        if fn is None:
            continue
        if out and out[-1][0] is fn and out[-1][1][-1] == k - 1:
            out[-1][1].append(k)
        else:
            out.append((fn, [k]))
    return out


def _gather(v: ca.MX, index: np.ndarray) -> ca.MX:
    """``v`` at the integer matrix ``index`` (its shape)."""
    idx = np.asarray(index, dtype=int)
    if idx.size == 0:
        return ca.MX(idx.shape[0], idx.shape[1] if idx.ndim > 1 else 1)
    return v[ca.DM(idx)]


def blocks_function(qp: StageQP) -> ca.Function:
    """The QP's blocks as one function ``(w (nw,), p (n_params,)) -> (blocks, f)``, in the order
    ``ocp_qp.c`` reads them: every ``A_k`` (k < N, column-major), every ``B_k``, every ``b_k``, then for
    k <= N every ``Q_k``, ``S_k``, ``R_k``, ``q_k``, ``r_k``; ``f`` the cost at ``w``."""
    nx, nu, N = qp.nx, qp.nu, qp.N
    if N < 1:
        raise ValueError("a stage-wise QP needs at least one stage before the last")
    for k, st in enumerate(qp.stages):
        if (st.gap is None) != (k == N):
            raise ValueError(f"stage {k}: every stage but the last has a gap function, the last none")
    w = ca.MX.sym("w", qp.nw)
    p = ca.MX.sym("p", qp.n_params)
    pe = ca.vertcat(p, ca.DM(np.asarray(qp.consts, dtype=float))) if len(qp.consts) else p
    stage = nx + nu
    ix = stage * np.arange(N + 1)[None, :] + np.arange(nx)[:, None]  # (nx, N + 1)
    iu = stage * np.arange(N)[None, :] + nx + np.arange(nu)[:, None]  # (nu, N)

    def stage_params(ks: list[int], attr: str) -> np.ndarray:
        rows = [np.asarray(getattr(qp.stages[k], attr), dtype=int) for k in ks]
        if len({r.shape for r in rows}) != 1:
            raise ValueError(f"stages {ks[0]}..{ks[-1]} share a function, not the number of its parameters")
        return np.stack(rows, axis=1)

    A: list[ca.MX] = []
    B: list[ca.MX] = []
    b: list[ca.MX] = []
    for fn, ks in _groups(qp.stages, "gap"):
        kk = np.array(ks)
        out = fn.map(len(ks))(
            _gather(w, ix[:, kk]), _gather(w, iu[:, kk]), _gather(w, ix[:, kk + 1]),
            _gather(pe, stage_params(ks, "gap_params")),
        )  # fmt: skip
        A.append(out[0])
        B.append(out[1])
        b.append(out[2])
    Q: list[ca.MX] = []
    S: list[ca.MX] = []
    R: list[ca.MX] = []
    q: list[ca.MX] = []
    r: list[ca.MX] = []
    c: list[ca.MX] = []
    for fn, ks in _groups(qp.stages, "cost"):
        kk = np.array(ks)
        u = _gather(w, iu[:, kk]) if ks[-1] < N else ca.MX(0, len(ks))
        out = fn.map(len(ks))(_gather(w, ix[:, kk]), u, _gather(pe, stage_params(ks, "cost_params")))
        for lst, o in zip((Q, S, R, q, r, c), out, strict=True):
            lst.append(o)

    def running(ms: list[ca.MX]) -> ca.MX:  # the stages' with inputs (the last has none)
        return ca.horzcat(*[m for m in ms if m.shape[0] > 0])

    q_all, r_all = ca.horzcat(*q), running(r)
    f = ca.sum2(ca.horzcat(*c))
    if qp.extra is not None:
        J, dJ = qp.extra(w, p)
        f = f + J
        q_all = q_all + _gather(dJ, ix)
        r_all = r_all + _gather(dJ, iu)
    pieces: list[ca.MX] = [ca.horzcat(*A), ca.horzcat(*B), ca.horzcat(*b), ca.horzcat(*Q), running(S)]
    pieces += [running(R), q_all, r_all]
    blocks = ca.vertcat(*[ca.vec(ca.densify(m)) for m in pieces])
    return ca.Function(BLOCKS_FUNCTION, [w, p], [blocks, f], ["w", "p"], ["blocks", "f"])


class SparseAssembly:
    """The blocks of :func:`blocks_function` as the sparse QP data CasADi's conic plugins take: the
    Hessian (the stages' ``[Q S'; S R]``, both triangles), the gradient, the gaps' Jacobian ``[A_k B_k
    -I]`` and their values (:meth:`data_function`).  Placing numbers, no arithmetic: the plugin gets
    exactly the compiled step's numbers."""

    def __init__(self, nx: int, nu: int, N: int) -> None:
        stage = nx + nu
        nw = stage * N + nx
        pos = 0
        names: dict[str, list[np.ndarray]] = {n: [] for n in ("A", "B", "b", "Q", "S", "R", "q", "r")}
        for name, rows, cols, count in (("A", nx, nx, N), ("B", nx, nu, N), ("b", nx, 1, N)):
            for _ in range(count):
                names[name].append(np.arange(pos, pos + rows * cols).reshape(rows, cols, order="F"))
                pos += rows * cols
        sizes = {"Q": (nx, nx), "S": (nu, nx), "R": (nu, nu), "q": (nx, 1), "r": (nu, 1)}
        for name in ("Q", "S", "R", "q", "r"):
            for k in range(N + 1):
                rows, cols = sizes[name]
                if k == N and name in ("S", "R", "r"):
                    rows = 0
                names[name].append(np.arange(pos, pos + rows * cols).reshape(rows, cols, order="F"))
                pos += rows * cols
        self.n_blocks = pos
        # the Hessian: per stage its variables [x_k; u_k] (contiguous), the block [Q S'; S R]
        h_rows, h_cols, h_src = [], [], []
        for k in range(N + 1):
            m = nx + (nu if k < N else 0)
            src = np.empty((m, m), dtype=int)
            src[:nx, :nx] = names["Q"][k]
            if k < N:
                src[nx:, :nx] = names["S"][k]
                src[:nx, nx:] = names["S"][k].T
                src[nx:, nx:] = names["R"][k]
            r0 = stage * k
            rr, cc = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
            h_rows.append((r0 + rr).ravel())
            h_cols.append((r0 + cc).ravel())
            h_src.append(src.ravel())
        hr, hc, hs = np.concatenate(h_rows), np.concatenate(h_cols), np.concatenate(h_src)
        self.h_sparsity, to_nz = ca.Sparsity.triplet(nw, nw, hr.tolist(), hc.tolist(), True)
        self._h_src = np.empty(len(hs), dtype=int)
        self._h_src[np.asarray(to_nz, dtype=int)] = hs
        # the gaps' Jacobian: rows of gap k, columns x_k (A), u_k (B), x_(k+1) (-I)
        a_rows, a_cols, a_src = [], [], []
        for k in range(N):
            r0, c0 = nx * k, stage * k
            rr, cc = np.meshgrid(np.arange(nx), np.arange(nx), indexing="ij")
            a_rows.append((r0 + rr).ravel())
            a_cols.append((c0 + cc).ravel())
            a_src.append(names["A"][k].ravel())
            rr, cc = np.meshgrid(np.arange(nx), np.arange(nu), indexing="ij")
            a_rows.append((r0 + rr).ravel())
            a_cols.append((c0 + nx + cc).ravel())
            a_src.append(names["B"][k].ravel())
            a_rows.append(r0 + np.arange(nx))
            a_cols.append(c0 + stage + np.arange(nx))
            a_src.append(np.full(nx, -1))  # -1: the next state's -I
        ar, ac, asrc = np.concatenate(a_rows), np.concatenate(a_cols), np.concatenate(a_src)
        self.a_sparsity, to_nz = ca.Sparsity.triplet(nx * N, nw, ar.tolist(), ac.tolist(), True)
        self._a_src = np.empty(len(asrc), dtype=int)
        self._a_src[np.asarray(to_nz, dtype=int)] = asrc
        self._grad_src = np.empty(nw, dtype=int)
        for k in range(N + 1):
            self._grad_src[stage * k + np.arange(nx)] = names["q"][k].ravel()
            if k < N:
                self._grad_src[stage * k + nx + np.arange(nu)] = names["r"][k].ravel()
        self._g_src = np.concatenate([names["b"][k].ravel() for k in range(N)])

    def data_function(self, blocks: ca.Function) -> ca.Function:
        """The QP's data as the plugin takes them, ``(w, p) -> (H, grad, Jg, g, f)`` (H and Jg sparse), from
        the blocks function ``blocks`` (:func:`blocks_function`): the blocks' own values, copied into
        place (no arithmetic), in CasADi's virtual machine."""
        w, p = ca.MX.sym("w", blocks.size1_in(0)), ca.MX.sym("p", blocks.size1_in(1))
        bl, f = blocks(w, p)
        v = ca.vertcat(bl, -1)  # the last: the -I's value (index -1)
        n = v.shape[0]

        def pick(idx: np.ndarray) -> ca.MX:
            return v[[int(i) % n for i in idx]]

        H = ca.MX(self.h_sparsity, pick(self._h_src))
        Jg = ca.MX(self.a_sparsity, pick(self._a_src))
        outs = [H, pick(self._grad_src), Jg, pick(self._g_src), f]
        return ca.Function("rti_qp_stage_data", [w, p], outs, ["w", "p"], ["H", "grad", "A", "g", "f"])
