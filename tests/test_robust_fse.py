"""The robust default FSE-MPCs (controller.variant: robust) dock where the paper's do not.

Paper case 3 (``south``: Sequential held 0.23 m off with the paper's formulation) and case 4
(``east_strong``, 2 m/s: Optimized 0.24 m off), from the zero-flow prior, with the paper's
Assumption 1 sensing, counted over 10 seeds of its noise.  Offset-free tracking estimates what
the flow estimate leaves (a disturbance wrench and a velocity offset) and Sequential's MPC knows
its perception input.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers.plant import plant

from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation

ROOT = Path(__file__).resolve().parents[1]


#: Seeds of the sensing noise each claim is counted over, and how many of them must dock.
SEEDS = range(10)
AT_LEAST = 9


@pytest.mark.slow
@pytest.mark.parametrize(
    ("controller", "case"),
    [("sequential", "south"), ("optimized", "east_strong")],  # where the paper's variant times out
)
def test_robust_fse_docks_where_the_paper_variant_does_not(controller, case) -> None:
    """Over 10 seeds of the simulated sensing (Assumption 1's noise; the only random input of
    these runs), the robust variant docks in at least 9, within the tolerance, with no failed
    solve in the runs that dock."""
    from auvdock.loop.assemble import build_autopilot

    m = load_mission(ROOT / "missions" / f"{case}.yaml").with_updates(**{"controller.type": controller})
    assert m.controller.variant == "robust" and m.estimator.prior_flow_ned_m_s == [0.0, 0.0, 0.0]
    # one autopilot flies every seed (the seed is the plant's sensing noise; simulate resets the
    # autopilot at the start of each run): the same runs as building it anew each time, bit for
    # bit, without its construction (about 0.9 s) ten times
    ap = build_autopilot(m, m.build_vehicle(), m.build_dock())
    outcomes = [run_simulation(m.with_updates(seed=seed), autopilot=ap).outcome for seed in SEEDS]
    docked = [o for o in outcomes if o["docked"]]
    times = ", ".join(f"{o['time_to_dock_s']:.2f}" if o["docked"] else "timeout" for o in outcomes)
    print(f"{controller} {case}: docked {len(docked)}/{len(outcomes)} seeds ({times} s)")
    assert len(docked) >= AT_LEAST, times
    assert all(o["closest_approach_m"] <= 0.05 and o["solver_failures"] == 0 for o in docked)


@pytest.mark.parametrize("controller", ["sequential", "optimized"])
@pytest.mark.slow
def test_robust_fse_docks_with_plant_model_error(controller) -> None:
    """Still water (the tank trial), a plant whose thrusters push 88 % of the command, with
    1.9 N more buoyancy and 30 % more damping than the model: the robust flow filter gates the
    updates a model error would drive (the paper's filter reads such an error as a current: while
    the vehicle hardly turns, a 0.3 m/s^2 residual is metres per second of flow) and reads the
    pose's own motion too, so its estimate stays near the true still water and the controller
    docks.  (The paper variant is not flown here: nothing about it is asserted.)"""
    from auvdock.loop.assemble import build_autopilot

    m = load_mission(ROOT / "missions" / "tank_positioned.yaml")
    m = m.with_updates(**{"controller.type": controller})
    truth = plant(m, thruster_gain=0.88, buoyancy_N=1.0165, linear_damping=1.3, quadratic_damping=1.3)
    mv = m.with_updates(**{"controller.variant": "robust"})
    ap = build_autopilot(mv, mv.build_vehicle(), mv.build_dock())
    r = run_simulation(truth, autopilot=ap).outcome
    assert r["docked"], r
    assert r["flow_final_error_m_s"] < 0.02
