"""The bounded fallback when solves fail (mpc.FALLBACK_RULE): never an old input repeated."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from auvdock.config.mission import load_mission
from auvdock.controllers import build_controller
from auvdock.controllers.status import STATUS_FAILED, STATUS_FALLBACK_ZERO, STATUS_OK

ROOT = Path(__file__).resolve().parents[1]
FLOW = np.array([0.5, 0.5, 0.0])  # case 2's current
NAN_FLOW = np.full(3, np.nan)  # a diverged estimate: the solve is not attempted (status failed)


@pytest.mark.parametrize("solver", ["rti", "sqp"])
@pytest.mark.parametrize("fallback_steps", [0, 2])
def test_every_solve_failing_gives_the_plan_then_neutral(solver, fallback_steps) -> None:
    m = load_mission(ROOT / "missions" / "diagonal.yaml").with_updates(
        **{
            "controller.type": "oracle",
            "controller.solver.name": solver,
            "controller.solver.fallback_steps": fallback_steps,
        }
    )
    mpc = build_controller(m.controller, m.build_vehicle(), m.build_dock()).mpc
    x = m.start_state()
    good = mpc.solve(0.0, x, np.zeros(8), FLOW)
    assert good.status == STATUS_OK and np.any(good.thrust != 0)
    plan = good.plan_thrust.copy()
    thrusts = []
    for k in range(1, 8):  # every later solve fails
        r = mpc.solve(0.05 * k, x, good.thrust, NAN_FLOW)
        thrusts.append(r.thrust)
        if k <= fallback_steps:  # the plan's input for this instant
            assert r.status == STATUS_FAILED
            np.testing.assert_allclose(r.thrust, np.clip(plan[k], mpc.u_min, mpc.u_max))
        else:  # then neutral, at once and for as long as the failures last
            assert r.status == STATUS_FALLBACK_ZERO
            np.testing.assert_array_equal(r.thrust, np.zeros(8))
    # no input is ever repeated from an older step (the old rule held plan[N - 1] for ever)
    for a, b in zip(thrusts, thrusts[1:], strict=False):
        assert np.all(a == 0) or not np.allclose(a, b)
    # a later good solve takes over again
    again = mpc.solve(0.4, x, np.zeros(8), FLOW)
    assert again.status == STATUS_OK and np.any(again.thrust != 0)
