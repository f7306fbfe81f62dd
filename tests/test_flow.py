"""Tests of the flow fields (auvdock.world.flow) against hand computations from
docs/parameter-sources.md section 2.

Double gyre (Shadden et al. 2005) on [0, 2] x [0, 1], eps = 0.3::

    f = a x^2 + b x,  a = eps sin(w t),  b = 1 - 2 eps sin(w t),  w = 2 pi / T
    u_g = -pi A sin(pi f) cos(pi y),  v_g = pi A (2 a x + b) cos(pi f) sin(pi y)
    x_g = (East + 7500) / 10000,  y_g = (North + 7500) / 10000,  flow NED = (v_g, u_g, 0)
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from auvdock.world.flow import (
    FLOW_CASES,
    ConstantCurrent,
    DoubleGyre,
    FlowField,
    StillWater,
    flow_case,
    flow_case_names,
)

PI = math.pi
A5, T5 = 0.1 / PI, 12 * 3600.0
A6, T6 = 0.5, 6 * 3600.0


def symbolic_function(field: FlowField) -> ca.Function:
    p = ca.SX.sym("p", 3)
    t = ca.SX.sym("t")
    return ca.Function("v", [p, t], [field.symbolic(p, t)])


# --- hand-computed double-gyre values -------------------------------------------------------


def test_gyre_origin_t0_case5():
    # NED (0, 0), t = 0: x_g = y_g = 0.75, a = 0, b = 1, f = 0.75
    # u_g = -pi A sin(0.75 pi) cos(0.75 pi) = pi A / 2;  v_g = pi A cos(0.75 pi) sin(0.75 pi) = -pi A / 2
    v = flow_case("case5").velocity(np.array([0.0, 0.0, 5.0]), 0.0)
    np.testing.assert_allclose(v, [-PI * A5 / 2, PI * A5 / 2, 0.0], atol=1e-15)
    np.testing.assert_allclose(v, [-0.05, 0.05, 0.0], atol=1e-15)


def test_gyre_origin_quarter_period_case5():
    # t = T/4: sin(w t) = 1, a = 0.3, b = 0.4; at x_g = y_g = 0.75:
    # f = 0.3 * 0.5625 + 0.4 * 0.75 = 0.46875;  2 a x + b = 0.45 + 0.4 = 0.85
    f = 0.46875
    u_g = -PI * A5 * math.sin(PI * f) * math.cos(PI * 0.75)
    v_g = PI * A5 * 0.85 * math.cos(PI * f) * math.sin(PI * 0.75)
    v = flow_case("case5").velocity(np.array([0.0, 0.0, 0.0]), T5 / 4)
    np.testing.assert_allclose(v, [v_g, u_g, 0.0], atol=1e-14)
    # sign check of the hand numbers: u_g > 0 because cos(0.75 pi) < 0; v_g > 0 because f < 0.5
    assert u_g > 0 and v_g > 0


def test_gyre_centre_line_case6():
    # NED North = -2500, East = 2500: x_g = 1, y_g = 0.5 (the separatrix between the gyres)
    p = np.array([-2500.0, 2500.0, 3.0])
    # t = 0: f = 1: u_g = -pi A sin(pi) cos(pi/2) = 0, v_g = pi A cos(pi) sin(pi/2) = -pi A
    np.testing.assert_allclose(flow_case("case6").velocity(p, 0.0), [-PI * A6, 0.0, 0.0], atol=1e-14)
    # t = T/4: a = 0.3, b = 0.4: f = 0.7, 2 a x + b = 1.0, u_g = 0 (cos(pi/2)), v_g = pi A cos(0.7 pi)
    np.testing.assert_allclose(
        flow_case("case6").velocity(p, T6 / 4), [PI * A6 * math.cos(0.7 * PI), 0.0, 0.0], atol=1e-14
    )
    # t = 3T/4: sin(w t) = -1, a = -0.3, b = 1.6: f = 1.3, 2 a x + b = 1.0
    np.testing.assert_allclose(
        flow_case("case6").velocity(p, 3 * T6 / 4), [PI * A6 * math.cos(1.3 * PI), 0.0, 0.0], atol=1e-14
    )


def test_gyre_explicit_parameters():
    g = flow_case("case5")
    assert isinstance(g, DoubleGyre)
    assert (g.amplitude, g.period_s, g.epsilon) == (A5, T5, 0.3)
    assert (g.east_offset_m, g.north_offset_m, g.scale_m) == (7500.0, 7500.0, 10000.0)
    g6 = flow_case("case6")
    assert (g6.amplitude, g6.period_s, g6.epsilon) == (A6, T6, 0.3)


@pytest.mark.parametrize("name", ["case5", "case6"])
def test_gyre_no_flow_through_domain_boundary(name):
    """u_g = 0 on x_g = 0 and x_g = 2 (f = 0 and f = 2 at all t); v_g = 0 on y_g = 0 and y_g = 1."""
    g = flow_case(name)
    rng = np.random.default_rng(3)
    t = rng.uniform(0, 2 * g.period_s, 50)
    north = rng.uniform(-7500, 2500, 50)
    east = rng.uniform(-7500, 12500, 50)
    for e in (-7500.0, 12500.0):
        v = g.velocity(np.stack([north, np.full(50, e), np.zeros(50)], axis=-1), t)
        np.testing.assert_allclose(v[:, 1], 0.0, atol=1e-12)
    for n in (-7500.0, 2500.0):
        v = g.velocity(np.stack([np.full(50, n), east, np.zeros(50)], axis=-1), t)
        np.testing.assert_allclose(v[:, 0], 0.0, atol=1e-12)


@pytest.mark.parametrize("name", ["case5", "case6"])
def test_gyre_divergence_free_and_periodic(name):
    """A stream-function flow: d v_N / d North + d v_E / d East = 0; period T in time."""
    g = flow_case(name)
    p = ca.SX.sym("p", 3)
    t = ca.SX.sym("t")
    v = g.symbolic(p, t)
    jac = ca.Function("dv_dp", [p, t], [ca.jacobian(v, p)])
    rng = np.random.default_rng(4)
    for _ in range(20):
        pt = np.array([rng.uniform(-7500, 2500), rng.uniform(-7500, 12500), rng.uniform(0, 10)])
        tt = rng.uniform(0, 2 * g.period_s)
        J = np.asarray(jac(pt, tt))
        scale = np.abs(J).max()
        assert scale > 0
        assert abs(J[0, 0] + J[1, 1]) <= 1e-12 * max(scale, 1e-6)
        np.testing.assert_allclose(J[:, 2], 0.0, atol=0)  # no depth dependence
        np.testing.assert_allclose(J[2, :], 0.0, atol=0)  # no vertical flow
        np.testing.assert_allclose(g.velocity(pt, tt + g.period_s), g.velocity(pt, tt), atol=1e-12)


# --- symbolic and numpy agree ----------------------------------------------------------------


@pytest.mark.parametrize("name", list(FLOW_CASES))
def test_symbolic_matches_numpy(name):
    field = flow_case(name)
    fn = symbolic_function(field)
    rng = np.random.default_rng(5)
    pts = np.column_stack(
        [rng.uniform(-7500, 2500, 40), rng.uniform(-7500, 12500, 40), rng.uniform(0, 20, 40)]
    )
    pts[:10] = rng.uniform(-20, 20, (10, 3))  # near the docking area
    times = rng.uniform(0, 2 * 12 * 3600.0, 40)
    numeric = field.velocity(pts, times)
    assert numeric.shape == (40, 3)
    for k in range(40):
        sym = np.asarray(fn(pts[k], times[k])).ravel()
        np.testing.assert_allclose(sym, numeric[k], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(sym, field.velocity(pts[k], times[k]), rtol=1e-12, atol=1e-15)


def test_symbolic_shape():
    for field in FLOW_CASES.values():
        out = field.symbolic(ca.SX.sym("p", 3), ca.SX.sym("t"))
        assert out.shape == (3, 1)
        mx = field.symbolic(ca.MX.sym("p", 3), 0.0)
        assert mx.shape == (3, 1)


# --- names -----------------------------------------------------------------------------------


def test_case_names_and_aliases():
    assert list(FLOW_CASES) == [f"case{i}" for i in range(1, 7)]
    assert flow_case("case5") is FLOW_CASES["case5"]
    assert flow_case("gyre") is flow_case("case5")
    assert flow_case("double_gyre") is flow_case("case5")
    assert flow_case("gyre_fast") is flow_case("case6")
    assert flow_case("still") is flow_case("case1")
    names = flow_case_names()
    assert names[:6] == list(FLOW_CASES)
    for n in names:
        assert isinstance(flow_case(n), FlowField)
    with pytest.raises(KeyError):
        flow_case("case7")
    with pytest.raises(KeyError):
        flow_case("Gyre")


# --- constant fields -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "expected"),
    [("case1", (0.0, 0.0)), ("case2", (0.5, 0.5)), ("case3", (-1.0, 0.0)), ("case4", (0.0, 2.0))],
)
def test_constant_cases_are_uniform(name, expected):
    field = flow_case(name)
    rng = np.random.default_rng(6)
    pts = rng.uniform(-1000, 1000, (7, 5, 3))
    v = field.velocity(pts, rng.uniform(0, 1e5, (7, 5)))
    assert v.shape == (7, 5, 3)
    np.testing.assert_array_equal(v[..., 0], expected[0])
    np.testing.assert_array_equal(v[..., 1], expected[1])
    np.testing.assert_array_equal(v[..., 2], 0.0)


def test_still_water_and_constant_current():
    still = StillWater()
    assert isinstance(flow_case("case1"), StillWater)
    np.testing.assert_array_equal(still.velocity(np.array([1.0, 2.0, 3.0]), 7.0), [0.0, 0.0, 0.0])
    c = ConstantCurrent(0.5, -0.3)
    np.testing.assert_array_equal(c.velocity(np.zeros(3)), [0.5, -0.3, 0.0])
    sym = np.asarray(symbolic_function(c)([9.0, -4.0, 1.0], 3.0)).ravel()
    np.testing.assert_allclose(sym, [0.5, -0.3, 0.0], atol=0)


# --- vectorised shape contract -----------------------------------------------------------------


@pytest.mark.parametrize("name", ["case2", "case5"])
def test_velocity_shape_contract(name):
    field = flow_case(name)
    rng = np.random.default_rng(7)
    assert field.velocity(np.zeros(3)).shape == (3,)
    assert field.velocity(np.zeros((1, 3))).shape == (1, 3)
    pts = rng.uniform(-100, 100, (4, 6, 3))
    out = field.velocity(pts, 1000.0)
    assert out.shape == (4, 6, 3)
    # element-wise: the batch equals point-by-point evaluation, also with per-point times
    times = rng.uniform(0, 1e5, (4, 6))
    batch = field.velocity(pts, times)
    for i in range(4):
        for j in range(6):
            np.testing.assert_allclose(batch[i, j], field.velocity(pts[i, j], times[i, j]), atol=1e-15)
    np.testing.assert_array_equal(batch[..., 2], 0.0)
    with pytest.raises(ValueError):
        field.velocity(np.zeros((4, 2)))
