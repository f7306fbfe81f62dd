"""A non-uniform time grid for the MPC's prediction (``controller.coarse``; issue 39): fine steps first,
coarse later, so that the horizon sees seconds ahead."""

from __future__ import annotations

import numpy as np
import pytest

from auvdock.config.mission import MissionError, load_mission
from auvdock.controllers.mpc import shift_on_grid, shift_solution
from auvdock.loop.assemble import build_autopilot
from auvdock.loop.simulation import run_simulation
from auvdock.vehicle.model import rk4


def test_the_grid_is_fine_steps_then_coarse_ones_each_a_whole_number_of_periods() -> None:
    m = load_mission("diagonal").with_updates(**{"controller.coarse.steps": 3, "controller.coarse.dt_s": 0.2})
    assert m.controller.stage_lengths_s() == [0.05] * 10 + [0.2] * 3
    assert m.controller.horizon_text() == "N = 10 x 0.05 s + 3 x 0.2 s (1.1 s)"
    assert load_mission("diagonal").controller.horizon_text() == "N = 10, dt = 0.05 s"
    with pytest.raises(MissionError) as e:
        load_mission("diagonal").with_updates(
            **{"controller.coarse.steps": 3, "controller.coarse.dt_s": 0.12}
        )
    assert str(e.value).endswith("controller: coarse.dt_s: 0.12 s is not a whole multiple of dt_s (0.05 s)")


def test_a_shift_on_a_uniform_grid_is_the_plain_shift_and_on_a_coarse_one_follows_the_plan() -> None:
    """Moving a plan one control period later: on a uniform grid exactly the shift by one node; on a
    coarse grid a plan linear in time lands on the same line (inside coarse steps too) and each stage's
    input is the one the old plan held at its new start."""
    nx, nu, n = 2, 1, 6
    stage = nx + 2 * nu
    starts = stage * np.arange(n + 1)[:, None]
    ix, iv, iu = starts + np.arange(nx), starts + nx + np.arange(nu), starts[:n] + nx + nu + np.arange(nu)
    dt = 0.05
    rng = np.random.default_rng(0)
    w = rng.normal(size=stage * n + nx + nu)
    w[iv[1:]] = w[iu]  # a plan: each stage's previous input is the input before it
    uniform = shift_on_grid(w, ix, iv, iu, dt * np.arange(n), np.full(n, dt), dt)
    plain = shift_solution(w, ix, iv, iu)
    np.testing.assert_allclose(uniform[ix], plain[ix], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(uniform[iu], plain[iu])
    np.testing.assert_array_equal(uniform[iv[1:]], plain[iv[1:]])
    # fine, fine, then coarse steps of 0.2 s
    lengths = np.array([dt, dt, 0.2, 0.2, 0.2, 0.2])
    offsets = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    nodes = np.append(offsets, offsets[-1] + lengths[-1])
    w = np.zeros_like(w)
    w[ix[:, 0]] = 1.0 + 2.0 * nodes  # a state linear in time
    w[ix[:, 1]] = -nodes
    w[iu[:, 0]] = 10.0 * np.arange(n)  # input k over stage k
    out = shift_on_grid(w, ix, iv, iu, offsets, lengths, dt)
    later = np.minimum(nodes + dt, nodes[-1])  # (held past the plan's end)
    np.testing.assert_allclose(out[ix[:, 0]], 1.0 + 2.0 * later, atol=1e-12)
    np.testing.assert_allclose(out[ix[:, 1]], -later, atol=1e-12)
    # stage starts 0.05, 0.1, 0.35, 0.55, 0.75, 0.95 s fall in stages 1, 2, 2, 3, 4, 5
    np.testing.assert_array_equal(out[iu[:, 0]], [10.0, 20.0, 20.0, 30.0, 40.0, 50.0])
    np.testing.assert_array_equal(out[iv[1:, 0]], out[iu[:, 0]])


def test_a_coarse_stage_predicts_what_fine_steps_of_the_same_model_predict() -> None:
    """The plan's coarse nodes are where RK4 steps of the control period with the stage's thrust held
    take the one model (the prediction is as accurate as the fine part's)."""
    m = load_mission("diagonal").with_updates(
        **{
            "controller.coarse.steps": 4,
            "controller.coarse.dt_s": 0.25,
            "controller.variant": "paper",
            "controller.solver.name": "sqp",  # iterated until the stages join up
        }
    )
    vehicle, dock = m.build_vehicle(), m.build_dock()
    ap = build_autopilot(m, vehicle, dock, "oracle")
    mpc = ap.controller.mpc  # type: ignore[attr-defined]
    flow = m.build_flow().velocity(m.start_state()[0:3], 0.0)
    r = mpc.solve(0.0, m.start_state(), np.zeros(8), flow)
    assert r.status == 0 and r.plan_state.shape == (15, 12) and r.plan_thrust.shape == (14, 8)
    model = vehicle.model
    zero = np.zeros(3)

    def f(x, u):
        return np.asarray(model.dynamics(x, u, flow, zero)).ravel()

    x = r.plan_state[10]
    for k in range(10, 14):  # the coarse stages: 5 steps of 0.05 s each
        x = np.asarray(rk4(f, x, 0.25, 5, r.plan_thrust[k])).ravel()
        np.testing.assert_allclose(x, r.plan_state[k + 1], rtol=0, atol=1e-6)


@pytest.mark.parametrize("controller", ["oracle", "optimized"])
def test_a_horizon_of_seconds_docks_where_half_a_second_does(controller: str) -> None:
    """The paper's case 2: with 10 fine steps and 12 coarse ones of 0.25 s (3.5 s ahead) the vehicle
    docks, and sooner than on the paper's 0.5 s (19.85-19.90 s): it sees the dock's heave coming."""
    m = load_mission("diagonal").with_updates(**{"controller.coarse.steps": 12})
    s = run_simulation(m, controller=controller, timeout_s=12.0)
    assert s.outcome["reason"] == "docked" and s.outcome["time_to_dock_s"] < 10.0


@pytest.mark.parametrize("coarse", [0, 4])
def test_the_warm_start_begins_at_the_state_and_the_thrust_really_applied(coarse: int) -> None:
    """The shifted plan's first node is the measured state and its previous input the thrust applied
    (which may differ from the plan's first input: Sequential adds its perception input after the
    solve), on a uniform grid and on a coarse one."""
    m = load_mission("diagonal").with_updates(**{"controller.coarse.steps": coarse})
    ap = build_autopilot(m, m.build_vehicle(), m.build_dock(), "oracle")
    mpc = ap.controller.mpc  # type: ignore[attr-defined]
    flow = np.array([0.5, 0.5, 0.0])
    x = m.start_state()
    mpc.solve(0.0, x, np.zeros(8), flow)
    seen = {}
    solve = mpc._solver.solve

    def spy(w0, *args, **kw):
        seen["w0"] = w0.copy()
        return solve(w0, *args, **kw)

    mpc._solver.solve = spy
    applied = np.linspace(-3.0, 3.0, 8)
    x2 = x.copy()
    x2[0] += 0.01
    mpc.solve(0.05, x2, applied, flow)
    w0 = seen["w0"]
    np.testing.assert_array_equal(w0[mpc._iv[0]], applied)
    np.testing.assert_allclose(w0[mpc._ix[0]][0:3], x2[0:3], atol=1e-12)
