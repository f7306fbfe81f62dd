"""BufferedFunction: a CasADi Function called on bound arrays gives the plain call's values."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from auvdock.runtime.fastcall import BufferedFunction


def _fn() -> ca.Function:
    x = ca.SX.sym("x", 3)
    y = ca.SX.sym("y", 2)
    M = ca.vertcat(ca.horzcat(x[0], y[0]), ca.horzcat(x[1] * y[1], x[2]))
    return ca.Function("f", [x, y], [ca.sin(x) * y[0], M], ["x", "y"], ["s", "M"])


def test_same_values_as_a_plain_call_and_outputs_are_reused() -> None:
    f = _fn()
    bf = BufferedFunction(f)
    rng = np.random.default_rng(1)
    first = None
    for _ in range(5):
        x, y = rng.normal(size=3), rng.normal(size=2)
        s, M = bf(x, y)
        first = s if first is None else first
        s_ref, M_ref = f(x, y)
        assert np.array_equal(s, np.asarray(s_ref).ravel())
        # a matrix output is its nonzeros, column-major
        assert np.array_equal(M.reshape(2, 2, order="F"), np.asarray(M_ref))
    assert first is bf.outputs[0]  # the same array, overwritten by every call


def test_bound_arrays_and_none_keeps_an_input() -> None:
    f = _fn()
    bf = BufferedFunction(f)
    x = np.array([0.1, 0.2, 0.3])
    bf.bind_input("x", x)
    out = np.zeros(3)
    bf.bind_output("s", out)
    bf(None, [2.0, 1.0])
    assert np.allclose(out, 2.0 * np.sin(x))
    x[:] = [1.0, 2.0, 3.0]  # written in place: read at the next evaluation
    bf.evaluate()
    assert np.allclose(out, 2.0 * np.sin(x))


def test_wrong_array_is_refused_with_its_size() -> None:
    bf = BufferedFunction(_fn())
    with pytest.raises(ValueError, match=r"^input 1 of f needs 2 contiguous float64 values$"):
        bf.bind_input("y", np.zeros(3))
    with pytest.raises(ValueError, match=r"^output 1 of f needs 4 contiguous float64 values$"):
        bf.bind_output(1, np.zeros(4, dtype=np.float32))
