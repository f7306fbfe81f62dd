"""The real-time iteration's step compiled whole (:mod:`auvdock.controllers.ocp_qp`) against its reference,
HPIPM through CasADi's conic plugin: the same bits on random states and along closed-loop runs."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from auvdock.controllers.ocp_qp import stage_blocks
from auvdock.controllers.rti import RealTimeIteration

N, NX, NU = 8, 3, 2


def _pendulum_problem(couple: bool = False):
    """A damped pendulum on a cart, RK4 over 0.1 s, in the MPC's stage order: w = [x_0, u_0, ..., x_N],
    the gaps F(x_k, u_k) - x_(k+1); a quadratic cost with an input-rate term in the state (as the MPC's
    previous-input state); p = [x_0 (3), reference angle]."""
    x = ca.SX.sym("x", NX)  # angle, rate, previous input
    u = ca.SX.sym("u", NU)
    ode = ca.vertcat(x[1], -9.81 * ca.sin(x[0]) - 0.3 * x[1] + u[0] + 0.2 * u[1] * ca.cos(x[0]), 0)
    f_ode = ca.Function("f", [x, u], [ode])
    h = 0.1
    k1 = f_ode(x, u)
    k2 = f_ode(x + h / 2 * k1, u)
    k3 = f_ode(x + h / 2 * k2, u)
    k4 = f_ode(x + h * k3, u)
    nxt = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    F = ca.Function("F", [x, u], [ca.vertcat(nxt[0:2], u[0])])
    X = ca.SX.sym("X", NX, N + 1)
    U = ca.SX.sym("U", NU, N)
    p = ca.SX.sym("p", NX + 1)
    blocks, res, g = [], [], []
    for k in range(N + 1):
        blocks += [X[:, k]] + ([U[:, k]] if k < N else [])
        res += [X[0, k] - p[NX], 0.3 * X[1, k], 0.1 * X[2, k]]
        if k < N:
            res += [U[:, k] * 0.3, 0.5 * (U[0, k] - X[2, k])]
            g.append(F(X[:, k], U[:, k]) - X[:, k + 1])
    if couple:
        res.append(X[0, 1] - X[0, 3])  # a residual of two stages: not stage-wise
    w = ca.vertcat(*blocks)
    r = ca.vertcat(*res)
    f = ca.dot(r, r)
    Jr = ca.jacobian(r, w)
    H = 2 * ca.mtimes(Jr.T, Jr)
    dims = {"N": N, "nx": [NX] * (N + 1), "nu": [NU] * N + [0], "ng": [0] * (N + 1)}
    return w, p, f, ca.vertcat(*g), H, dims


def _bounds(x0: np.ndarray, nw: int) -> tuple[np.ndarray, np.ndarray]:
    lbx, ubx = np.full(nw, -np.inf), np.full(nw, np.inf)
    stage = NX + NU
    lbx[0:NX] = ubx[0:NX] = x0
    for k in range(N):
        iu = k * stage + NX + np.arange(NU)
        lbx[iu], ubx[iu] = -2.0, 2.0  # active for the larger swings
        ix = (k + 1) * stage + 1
        lbx[ix], ubx[ix] = -6.0, 6.0  # the rate
    return lbx, ubx


@pytest.fixture(scope="module")
def compiled(tmp_path_factory):
    """The pendulum's RTI, compiled whole and as the reference (a cache of its own)."""
    mp = pytest.MonkeyPatch()
    mp.setenv("AUVDOCK_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
    mp.setenv("AUVDOCK_COMPILE", "wait")
    try:
        w, p, f, g, H, dims = _pendulum_problem()
        fast = RealTimeIteration(w, p, f, g, H, qp="hpipm", dims=dims)
        ref = RealTimeIteration(w, p, f, g, H, qp="hpipm_casadi", dims=dims)
    finally:
        mp.undo()
    assert fast.ocp is not None and fast.build == "compiled"
    assert ref.ocp is None
    return fast, ref, w.shape[0]


def test_the_compiled_step_gives_the_plugins_bits_on_random_states(compiled) -> None:
    fast, ref, nw = compiled
    rng = np.random.default_rng(7)
    active = solved = 0
    for _ in range(30):
        x0 = np.array([rng.uniform(-2.5, 2.5), rng.uniform(-2, 2), rng.uniform(-1, 1)])
        p = np.append(x0, rng.uniform(-0.5, 0.5))
        w_bar = rng.normal(size=nw) * 0.05
        lbx, ubx = _bounds(x0, nw)
        a = fast.step(w_bar, p, lbx, ubx, 0.0, 0.0)
        b = ref.step(w_bar, p, lbx, ubx, 0.0, 0.0)
        np.testing.assert_array_equal(a[0], b[0])  # the iterate, bit for bit
        assert a[1:3] == b[1:3]
        solved += int(a[1])
        assert a[3] == pytest.approx(b[3], rel=1e-12, abs=1e-12) and a[4] == b[4]
        inputs = a[0][: N * (NX + NU)].reshape(N, NX + NU)[:, NX:]
        active += int(np.any(np.isclose(np.abs(inputs), 2.0)))
    assert active >= 3  # the input bounds were active in some
    # random linearisations far from a plan: HPIPM stops at its iteration limit in some, both alike
    assert solved >= 10


def test_the_compiled_step_gives_the_plugins_bits_along_a_closed_loop(compiled) -> None:
    """Receding horizon from a large swing: each step shifts the iterate and steps once (RTI); the plant is
    the model itself.  The inputs applied are the same bits over 60 steps."""
    fast, ref, nw = compiled
    w, p_sym, f, g, H, _ = _pendulum_problem()
    F = ca.Function("gaps", [w, p_sym], [g])
    stage = NX + NU
    out = []
    for rti in (fast, ref):
        x = np.array([2.4, 0.0, 0.0])
        wk = np.zeros(nw)
        applied = []
        solved = 0
        for _ in range(60):
            lbx, ubx = _bounds(x, nw)
            wk[0:NX] = x
            wk, ok, *_ = rti.step(wk, np.append(x, 0.0), lbx, ubx, 0.0, 0.0)
            solved += int(ok)
            u = wk[NX : NX + NU].copy()
            applied.append(u)
            # the plant: the first gap closed (x_1 = F(x_0, u_0)), read back through the gap function
            w1 = wk.copy()
            w1[stage : stage + NX] = 0.0
            x = np.asarray(F(w1, np.append(x, 0.0))).ravel()[0:NX]
            wk = np.concatenate([wk[stage:], wk[-stage:]])  # shifted warm start
        out.append(np.array(applied))
        assert solved >= 50
    np.testing.assert_array_equal(out[0], out[1])
    assert abs(out[0][-1][0]) < 0.5  # it did swing the pendulum down and settle


def test_threads_stepping_one_compiled_step_get_their_own_answers(compiled) -> None:
    """The step is shared by the controllers of one problem in a process, and the call lets go of the
    GIL: four threads stepping it at once get the answers one thread gets."""
    from concurrent.futures import ThreadPoolExecutor

    fast, _, nw = compiled
    rng = np.random.default_rng(3)
    cases = []
    for _ in range(40):
        x0 = np.array([rng.uniform(-2.5, 2.5), rng.uniform(-2, 2), rng.uniform(-1, 1)])
        cases.append((rng.normal(size=nw) * 0.05, np.append(x0, 0.2), *_bounds(x0, nw)))
    alone = [fast.step(w, p, lb, ub, 0.0, 0.0)[0] for w, p, lb, ub in cases]
    with ThreadPoolExecutor(4) as pool:
        together = list(pool.map(lambda c: fast.step(c[0], c[1], c[2], c[3], 0.0, 0.0)[0], cases * 5))
    for k, w in enumerate(together):
        np.testing.assert_array_equal(w, alone[k % len(cases)])


def test_a_problem_that_is_not_stage_wise_is_refused_with_its_reason() -> None:
    w, p, f, g, H, dims = _pendulum_problem(couple=True)
    grad, Jg = ca.gradient(f, w), ca.jacobian(g, w)
    with pytest.raises(ValueError) as e:
        stage_blocks(w, p, f, g, H, grad, Jg, dims["nx"], dims["nu"])
    assert str(e.value) == "stage_blocks: the Hessian has entries outside the stage blocks"


@pytest.mark.slow
def test_the_docking_mpc_flies_the_same_bits_compiled_whole(tmp_path, monkeypatch) -> None:
    """Oracle on the paper's gyre (a 3-step horizon): the whole step compiled (its data stage by stage,
    :mod:`auvdock.controllers.qp_stages`) and the plugin on the same data uncompiled (what runs until the
    library is built) give the same thrust, bit for bit, for 8 s of flight; the whole problem's derivatives
    through the plugin (the reference, ``hpipm_casadi``) within rounding."""
    from auvdock.config.mission import load_mission
    from auvdock.loop.simulation import run_simulation

    monkeypatch.setenv("AUVDOCK_CACHE_DIR", str(tmp_path))
    thrust = {}
    for qp, mode in (("hpipm", "wait"), ("hpipm", "never"), ("hpipm_casadi", "never")):
        monkeypatch.setenv("AUVDOCK_COMPILE", mode)
        m = load_mission("gyre").with_updates(
            **{"controller.type": "oracle", "controller.solver.qp": qp, "controller.horizon_steps": 3}
        )
        s = run_simulation(m, keep=True, timeout_s=8.0)
        assert s.run is not None
        thrust[qp, mode] = np.asarray(s.run.thrust_N)
        assert np.all(np.asarray(s.run.solver_status)[:-1] == 0)
    assert len(list(tmp_path.rglob("rti_ocp_qp-*.so"))) == 1  # the whole step was compiled (and flew)
    assert thrust["hpipm", "wait"].shape == (161, 8)
    np.testing.assert_array_equal(thrust["hpipm", "wait"], thrust["hpipm", "never"])
    np.testing.assert_allclose(thrust["hpipm", "wait"], thrust["hpipm_casadi", "never"], rtol=0, atol=1e-9)
