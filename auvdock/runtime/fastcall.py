"""Calling a CasADi Function every control step without converting its arguments each time.

A plain call ``fn(x, u, ...)`` converts every NumPy argument to a CasADi ``DM`` and every
result back: 10-25 us per argument, more than the compiled function itself takes (the MPC's
one-step model: 45 us per call, 0.35 us of it evaluation).  :class:`BufferedFunction` binds
preallocated NumPy arrays to the function's inputs and outputs once (CasADi's
``Function.buffer``) and then only copies into them and evaluates.  Inputs and outputs are
the NONZEROS of each argument (column-major), so a sparse output of one function can be
bound directly as the sparse input of another with the same sparsity (the RTI's QP data into
the QP solver) and nothing is copied between them.
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np

__all__ = ["BufferedFunction"]


class BufferedFunction:
    """``fn`` evaluated on preallocated arrays (nonzeros of each input and output).

    Parameters
    ----------
    fn : casadi.Function
        Any function (SX, external, conic, nlpsol); :meth:`stats` gives its statistics of the
        last call (the buffer has its own memory, so ``fn.stats()`` does not see it).

    Attributes
    ----------
    inputs, outputs : list of ndarray
        One float array per argument, of the argument's number of nonzeros.  A call returns
        ``outputs`` themselves: the next call overwrites them (copy what must be kept).
    """

    def __init__(self, fn: ca.Function) -> None:
        self.fn = fn
        self._buf, self._eval = fn.buffer()
        self.inputs: list[np.ndarray] = []
        self.outputs: list[np.ndarray] = []
        for i in range(fn.n_in()):
            self.bind_input(i, np.zeros(fn.nnz_in(i)))
        self.outputs = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
        for i, a in enumerate(self.outputs):
            # casadi's stub lists a byte size its wrapper takes from the buffer (.data: the memoryview)
            self._buf.set_res(i, a.data)  # type: ignore[call-arg]

    def bind_input(self, i: int | str, array: np.ndarray) -> None:
        """Use ``array`` (float64, contiguous, nnz of input ``i`` long) as input ``i`` from now on
        (a C-ordered 2-D array is read column-major: as its transpose)."""
        k = self.fn.index_in(i) if isinstance(i, str) else int(i)
        if array.dtype != np.float64 or not array.flags.c_contiguous or array.size != self.fn.nnz_in(k):
            raise ValueError(
                f"input {k} of {self.fn.name()} needs {self.fn.nnz_in(k)} contiguous float64 values"
            )
        # casadi's stub lists a byte size its wrapper takes from the buffer (.data: the memoryview)
        self._buf.set_arg(k, array.data)  # type: ignore[call-arg]
        if k < len(self.inputs):
            self.inputs[k] = array
        else:
            self.inputs.append(array)

    def bind_output(self, i: int | str, array: np.ndarray) -> None:
        """Have output ``i`` written into ``array`` (float64, contiguous, nnz long) from now on.

        A dense matrix output bound to a C-ordered 2-D array reads as its transpose there
        (CasADi writes column-major)."""
        k = self.fn.index_out(i) if isinstance(i, str) else int(i)
        if array.dtype != np.float64 or not array.flags.c_contiguous or array.size != self.fn.nnz_out(k):
            raise ValueError(
                f"output {k} of {self.fn.name()} needs {self.fn.nnz_out(k)} contiguous float64 values"
            )
        # casadi's stub lists a byte size its wrapper takes from the buffer (.data: the memoryview)
        self._buf.set_res(k, array.data)  # type: ignore[call-arg]
        self.outputs[k] = array

    def evaluate(self) -> None:
        """Evaluate on what the input arrays hold now."""
        self._eval()

    def __call__(self, *args: np.ndarray | Sequence[float] | float | None) -> list[np.ndarray]:
        """Copy the given arguments (None: keep what the input array holds) and evaluate."""
        for a, dst in zip(args, self.inputs, strict=False):
            if a is not None:
                dst[:] = np.ravel(a, order="F")
        self._eval()
        return self.outputs

    def stats(self) -> dict:
        """The solver statistics of the last call (of this buffer's own memory)."""
        return self._buf.stats()
