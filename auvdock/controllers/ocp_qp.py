"""The real-time iteration's step as one compiled call: the QP's data and HPIPM's OCP-QP solve in C.

:class:`auvdock.controllers.rti.RealTimeIteration` steps the docking MPC by one QP per control period.
Through CasADi (the reference) that step is three Python-level calls: the QP data function, the
``hpipm`` conic plugin (which projects the sparse data into HPIPM's stage blocks and creates HPIPM's
dimensions, QP, solution, arguments and workspace on every call, with a ``malloc`` each) and the
plugin's statistics.  :class:`OcpQpStep` is the same step in one call into one shared library: the
QP's stage blocks from a CasADi-generated function, and HPIPM's OCP-QP interface from the library the
casadi wheel ships (``libhpipm``, ``libblasfeo`` and their headers in ``casadi/include``), its memory
created once, when the step is built (``auvdock/controllers/ocp_qp.c``).

It poses HPIPM the plugin's QP, operation for operation: every variable boxed, infinite bounds as
``+-1e8`` (the plugin's ``inf``), the Hessian and gradient halved, a zero first guess, the same mode
and options.  So both give the same bits on the same data (``tests/test_ocp_qp.py`` checks it on random
states and along closed-loop runs), and a run's outcome does not depend on which one ran: the plugin,
on the same data uncompiled, runs while the library is being compiled (``AUVDOCK_COMPILE=auto``) or
without a compiler.  The data come stage by stage for the docking MPC
(:mod:`auvdock.controllers.qp_stages`), or from the whole problem's derivatives (:func:`stage_blocks`)
for a problem that does not describe its stages.

Layout: the MPC's stage order ``w = [x_0, u_0, ..., x_N]`` with the gaps ``g_k = F_k(x_k, u_k) -
x_(k+1)`` (:class:`auvdock.controllers.mpc.DockingMPC`); :func:`stage_blocks` checks that the problem
has that structure (the Jacobian's ``-I`` on the next state, nothing else outside the stage blocks, a
stage-wise Hessian) and raises ValueError when it does not.
"""

from __future__ import annotations

import ctypes
import os
import threading
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from auvdock.controllers.qp_stages import BLOCKS_FUNCTION
from auvdock.runtime import timing
from auvdock.runtime.codegen import compiled_library

__all__ = ["OcpQpStep", "stage_blocks", "build_ocp_step", "HPIPM_MODES", "INF"]

#: HPIPM's modes, by the plugin's names (``enum hpipm_mode``).
HPIPM_MODES = {"speed_abs": 0, "speed": 1, "balance": 2, "robust": 3}
#: What the plugin replaces an infinite bound by (its ``inf`` option's default).
INF = 1e8
_SOURCE = Path(__file__).with_name("ocp_qp.c")


def _casadi_dir() -> Path:
    return Path(ca.__file__).resolve().parent


def stage_blocks(
    w: ca.SX, p: ca.SX, f: ca.SX, g: ca.SX, H: ca.SX, grad: ca.SX, Jg: ca.SX, nx: list[int], nu: list[int]
) -> ca.Function:
    """The QP's stage blocks as one function ``(w, p) -> (blocks, f)`` (column-major, dense; the order
    of ``ocp_qp.c``): every A_k, B_k, b_k = g_k(w) (k < N), then every Q_k, S_k, R_k, q_k, r_k (k <= N)
    of the Hessian ``H`` and gradient ``grad``.  Raises ValueError naming what breaks the stage structure."""
    N = len(nx) - 1
    if len(nu) != N + 1 or nu[N] != 0:
        raise ValueError("stage_blocks: nu must have N + 1 entries, the last 0")
    xs, us, offset = [], [], 0
    for k in range(N + 1):
        xs.append(list(range(offset, offset + nx[k])))
        offset += nx[k]
        us.append(list(range(offset, offset + nu[k])))
        offset += nu[k]
    if offset != w.shape[0]:
        raise ValueError(f"stage_blocks: the stages hold {offset} variables, w has {w.shape[0]}")
    rows, r0 = [], 0
    for k in range(N):
        rows.append(list(range(r0, r0 + nx[k + 1])))
        r0 += nx[k + 1]
    if r0 != g.shape[0]:
        raise ValueError(f"stage_blocks: the gaps hold {r0} rows, g has {g.shape[0]} (no other constraints)")
    # the structure: Jg in [A B -I] blocks, H in stage blocks
    allowed_j = np.zeros(Jg.shape, dtype=bool)
    for k in range(N):
        allowed_j[np.ix_(rows[k], xs[k] + us[k] + xs[k + 1])] = True
    allowed_h = np.zeros(H.shape, dtype=bool)
    for k in range(N + 1):
        allowed_h[np.ix_(xs[k] + us[k], xs[k] + us[k])] = True
    for name, M, allowed in (("the constraint Jacobian", Jg, allowed_j), ("the Hessian", H, allowed_h)):
        r, c = M.sparsity().get_triplet()
        if not np.all(allowed[np.asarray(r, dtype=int), np.asarray(c, dtype=int)]):
            raise ValueError(f"stage_blocks: {name} has entries outside the stage blocks")
    for k in range(N):
        eye = Jg[rows[k], xs[k + 1]]
        if not (eye.is_constant() and np.array_equal(np.array(ca.DM(eye)), -np.eye(nx[k + 1]))):
            raise ValueError(f"stage_blocks: the gap of stage {k} is not F_k - x_(k+1)")
    out = [Jg[rows[k], xs[k]] for k in range(N)] + [Jg[rows[k], us[k]] for k in range(N)]
    out += [g[rows[k]] for k in range(N)]
    out += [H[xs[k], xs[k]] for k in range(N + 1)] + [H[us[k], xs[k]] for k in range(N + 1)]
    out += [H[us[k], us[k]] for k in range(N + 1)] + [grad[xs[k]] for k in range(N + 1)]
    out += [grad[us[k]] for k in range(N + 1)]
    blocks = ca.vertcat(*[ca.vec(ca.densify(b)) for b in out if b.numel() > 0])
    return ca.Function(BLOCKS_FUNCTION, [w, p], [blocks, f], ["w", "p"], ["blocks", "f"])


class OcpQpStep:
    """The compiled step (see the module docstring); built by :func:`build_ocp_step`.

    Parameters
    ----------
    lib : ctypes.CDLL
        The library of ``ocp_qp.c`` and the generated blocks function.
    nx, nu : list of int
        The stages' state and input sizes (N + 1 each; ``nu[N] = 0``).
    options : dict
        HPIPM's ``mode`` (:data:`HPIPM_MODES`), ``iter_max`` and ``warm_start``.
    """

    def __init__(self, lib: ctypes.CDLL, nx: list[int], nu: list[int], options: dict[str, Any]) -> None:
        self._lib = lib
        lib.auvdock_ocp_create.restype = ctypes.c_void_p
        lib.auvdock_ocp_create.argtypes = [
            ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_double, ctypes.c_int, ctypes.c_int,
            ctypes.c_int,
        ]  # fmt: skip
        lib.auvdock_ocp_free.argtypes = [ctypes.c_void_p]
        lib.auvdock_ocp_free.restype = None
        lib.auvdock_ocp_step.argtypes = [ctypes.c_void_p] * 7
        lib.auvdock_ocp_step.restype = ctypes.c_int
        self._nx = np.ascontiguousarray(nx, dtype=np.intc)
        self._nu = np.ascontiguousarray(nu, dtype=np.intc)
        self.nw = int(self._nx.sum() + self._nu.sum())
        handle = lib.auvdock_ocp_create(
            len(nx) - 1,
            self._nx.ctypes.data,
            self._nu.ctypes.data,
            INF,
            HPIPM_MODES[str(options.get("mode", "speed"))],
            int(options.get("iter_max", 50)),
            int(options.get("warm_start", 0)),
        )
        if not handle:
            raise MemoryError("the OCP-QP solver could not allocate its memory")
        self._handle: ctypes.c_void_p | None = ctypes.c_void_p(handle)
        self._step = lib.auvdock_ocp_step
        self._free = lib.auvdock_ocp_free
        self._w = np.zeros(self.nw)
        self._info = np.zeros(8)
        self._info_p = self._info.ctypes.data
        self._w_p = self._w.ctypes.data
        #: One step at a time: the step is shared by every controller of its problem in a process
        #: (:meth:`auvdock.vehicle.Vehicle.built`), and threads (a Dask worker's) may run two at once.
        self._lock = threading.Lock()

    def __del__(self) -> None:
        handle = getattr(self, "_handle", None)
        if handle is not None and handle.value:
            self._free(handle)
            self._handle = None

    def step(
        self, w_bar: np.ndarray, p: np.ndarray, lbx: np.ndarray, ubx: np.ndarray
    ) -> tuple[np.ndarray, bool, str, float, float]:
        """One QP step from ``w_bar`` (nw,) with parameters ``p`` and bounds ``lbx``, ``ubx`` (nw,):
        ``(w_new, success, return_status, model cost, step infinity norm)`` as
        :meth:`auvdock.controllers.rti.RealTimeIteration.step` returns them."""
        wb = np.ascontiguousarray(w_bar, dtype=float)
        pp = np.ascontiguousarray(p, dtype=float)
        lb = np.ascontiguousarray(lbx, dtype=float)
        ub = np.ascontiguousarray(ubx, dtype=float)
        with self._lock:  # one step at a time in the one workspace (ctypes lets go of the GIL in the call)
            status = self._step(
                self._handle,
                wb.ctypes.data,
                pp.ctypes.data,
                lb.ctypes.data,
                ub.ctypes.data,
                self._w_p,
                self._info_p,
            )
            info = self._info.copy()
            w_new = self._w.copy()
        timing.add("qp data", float(info[6]))
        timing.add("qp", float(info[7]))
        if status < 0:
            raise RuntimeError(f"the QP data function failed (flag {int(info[5])})")
        # the return status as the plugin gives it: HPIPM's code (0 solved, 1 the iteration limit, 2 the
        # smallest step, 3 NaN in the solution, 4 inconsistent equalities), as text
        return w_new, status == 0, str(status), float(info[2]), float(info[3])


def build_ocp_step(
    fn: ca.Function, dims: dict[str, Any], options: dict[str, Any], key_parts: list[bytes | str]
) -> tuple[OcpQpStep, str] | None:
    """The compiled step of the QP whose blocks ``fn`` gives (``(w, p) -> (blocks, f)`` in ``ocp_qp.c``'s
    order: :func:`stage_blocks` or :func:`auvdock.controllers.qp_stages.blocks_function`) and ``dims``
    lays out (``{"N", "nx", "nu", "ng"}``), or None when it cannot be had this time (no compiler,
    ``AUVDOCK_COMPILE=never``, compiling in the background, the build failed): the caller runs the
    plugin.  ``key_parts`` define the problem (the cache key)."""
    nx, nu = [int(v) for v in dims["nx"]], [int(v) for v in dims["nu"]]
    if any(int(v) != 0 for v in dims.get("ng", [])):
        raise ValueError("the OCP-QP step has no general constraints (ng must be 0)")
    cdir = _casadi_dir()
    flags = (
        f"-DAUVDOCK_QP_BLOCKS={fn.name()}",
        f"-I{cdir / 'include'}",
        f"-L{cdir}",
        f"-Wl,-rpath,{cdir}",
        "-lhpipm",
        "-lblasfeo",
    )

    def write_sources(stem: str) -> list[str]:
        cg = ca.CodeGenerator(f"{stem}_blocks.c")
        cg.add(fn)
        cg.generate()
        glue = f"{stem}_step.c"
        Path(glue).write_text(_SOURCE.read_text())
        return [f"{stem}_blocks.c", glue]

    def load(so: Path) -> OcpQpStep:
        return OcpQpStep(ctypes.CDLL(os.fspath(so)), nx, nu, options)

    options_key = repr(sorted(options.items()))
    return compiled_library(
        "rti_ocp_qp", [*key_parts, options_key, _SOURCE.read_bytes()], write_sources, load, flags
    )
