"""Closed-loop simulation with the baseline MPCs: outcomes, limits, the results file, failures."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from auvdock.cli import app
from auvdock.config.mission import load_mission
from auvdock.controllers.status import STATUS_NO_STEP, STATUS_OK
from auvdock.loop.simulation import run_simulation
from auvdock.results.store import read_run

ROOT = Path(__file__).resolve().parents[1]
runner = CliRunner()


def mission(name: str, **updates):
    m = load_mission(ROOT / "missions" / f"{name}.yaml")
    return m.with_updates(**updates) if updates else m


@pytest.fixture(scope="module")
def oracle_case2(tmp_path_factory):
    out = tmp_path_factory.mktemp("sim") / "case2_oracle.h5"
    s = run_simulation(mission("diagonal", **{"controller.type": "oracle"}), out=out, timeout_s=40.0)
    return s, out


def test_oracle_docks_in_still_water() -> None:
    s = run_simulation(mission("still", **{"controller.type": "oracle"}), timeout_s=40.0)
    assert s.docked
    assert s.outcome["closest_approach_m"] <= 0.05
    assert s.outcome["solver_failures"] == 0


def test_oracle_docks_in_case2(oracle_case2) -> None:
    s, _ = oracle_case2
    assert s.docked
    assert s.outcome["time_to_dock_s"] < 40.0
    # contact is gentle: the vehicle tracks the dock's velocity
    assert s.outcome["contact_speed_m_s"] < 0.2
    assert abs(s.outcome["heading_error_rad"]) < np.radians(5)


@pytest.mark.slow
def test_naive_fails_in_case2() -> None:
    """The paper's finding: a controller blind to a 0.7 m/s current cannot close the last centimetres."""
    s = run_simulation(
        mission("diagonal", **{"controller.type": "naive", "controller.variant": "paper"}), timeout_s=40.0
    )
    assert not s.docked
    assert s.outcome["reason"] == "timeout"
    assert s.outcome["closest_approach_m"] > 0.05


def test_offset_free_naive_docks_in_case2() -> None:
    """The robust default estimates the current's steady drag as a disturbance: offset-free, the
    same blind model docks."""
    s = run_simulation(mission("diagonal", **{"controller.type": "naive"}), timeout_s=40.0)
    assert s.docked, s.outcome


def test_thrust_limits_never_exceeded(oracle_case2) -> None:
    _, out = oracle_case2
    r = read_run(out)
    m = mission("diagonal").build_vehicle()
    assert np.all(r.thrust_N >= m.thrust_min - 1e-9)
    assert np.all(r.thrust_N <= m.thrust_max + 1e-9)
    assert np.abs(r.thrust_N).max() > 1.0  # the controller did push


def test_results_file_layout(oracle_case2) -> None:
    s, out = oracle_case2
    r = read_run(out)
    # one row per control step, then the final (docked) state with status no_step
    T = s.outcome["n_steps"] + 1
    assert T > 10 and r.n_steps == T
    shapes = {
        "time_s": (T,),
        "state": (T, 12),
        "thrust_N": (T, 8),
        "wrench": (T, 6),
        "flow_ned_m_s": (T, 3),
        "dock_position_m": (T, 3),
        "dock_velocity_m_s": (T, 3),
        "distance_m": (T,),
        "solve_time_s": (T,),
        "solver_status": (T,),
    }
    for name, shape in shapes.items():
        assert getattr(r, name).shape == shape, name
    assert r.complete
    assert r.controller == "oracle"
    assert "case2" in r.mission_yaml
    assert r.outcome()["docked"] is True
    np.testing.assert_allclose(r.time_s[1] - r.time_s[0], 0.05)
    np.testing.assert_allclose(r.flow_ned_m_s[0], [0.5, 0.5, 0.0])
    B = mission("diagonal").build_vehicle().allocation
    np.testing.assert_allclose(r.wrench, r.thrust_N @ B.T, atol=1e-9)
    assert np.all(r.solver_status[:-1] == STATUS_OK) and r.solver_status[-1] == STATUS_NO_STEP
    assert np.count_nonzero(r.control_rows()) == T - 1
    # the state in which docking is declared is in the file, within the tolerance
    assert r.distance_m[-1] == r.distance_m.min() <= r.attrs["tolerance_m"]
    np.testing.assert_allclose(np.linalg.norm(r.state[-1, 0:3] - r.dock_position_m[-1]), r.distance_m[-1])


def test_interrupted_run_keeps_finished_steps(tmp_path: Path) -> None:
    out = tmp_path / "interrupted.h5"
    k_stop = 7

    def interrupt(p) -> None:
        if p.step + 1 == k_stop:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_simulation(mission("still"), out=out, progress=interrupt)
    r = read_run(out)
    assert r.n_steps == k_stop
    assert r.complete is False
    assert r.state.shape == (k_stop, 12)


def test_solver_failure_does_not_stop_the_run(tmp_path: Path) -> None:
    # SQP stopped after one iteration: every solve that needs more is a failure
    m = mission("still", **{"controller.solver.name": "sqp", "controller.solver.max_iter": 1})
    out = tmp_path / "fail.h5"
    s = run_simulation(m, out=out, timeout_s=2.0)
    r = read_run(out)
    assert r.complete
    assert r.n_steps == 41  # every step of the 2 s ran, then the final state
    assert s.outcome["solver_failures"] > 0
    steps = r.solver_status[r.control_rows()]
    assert np.count_nonzero(steps != STATUS_OK) == s.outcome["solver_failures"]
    assert np.all(np.isfinite(r.thrust_N))


@pytest.mark.slow
def test_cli_sim_and_plot(tmp_path: Path) -> None:
    res = runner.invoke(
        app, ["sim", str(ROOT / "missions" / "still.yaml"), "--out", str(tmp_path), "--timeout", "40"]
    )
    assert res.exit_code == 0, res.output
    h5 = tmp_path / "still_oracle.h5"
    assert h5.is_file()
    assert (tmp_path / "still_oracle_top_view.png").is_file()
    assert "docked" in res.output
    for p in tmp_path.glob("*.png"):
        p.unlink()
    res = runner.invoke(app, ["plot", str(h5)])
    assert res.exit_code == 0, res.output
    pngs = sorted(p.name for p in tmp_path.glob("*.png"))
    assert pngs == sorted(
        f"still_oracle_{n}.png" for n in ("trajectory_3d", "top_view", "distance", "thrust")
    )


def test_cli_sim_timeout_exits_1(tmp_path: Path) -> None:
    res = runner.invoke(
        app,
        [
            "sim",
            str(ROOT / "missions" / "still.yaml"),
            "--out",
            str(tmp_path),
            "--timeout",
            "1",
            "--no-plots",
        ],
    )
    assert res.exit_code == 1
    assert not list(tmp_path.glob("*.png"))


def test_cli_sim_bad_controller_exit_2(tmp_path: Path) -> None:
    res = runner.invoke(app, ["sim", str(ROOT / "missions" / "still.yaml"), "--controller", "magic"])
    assert res.exit_code == 2
    assert (
        res.stderr.strip() == "error: --controller: unknown controller 'magic' "
        "(known: naive, kinematic, oracle, sequential, optimized, ce)"
    )


def test_cli_plot_not_a_results_file(tmp_path: Path) -> None:
    p = tmp_path / "x.h5"
    p.write_bytes(b"not hdf5")
    res = runner.invoke(app, ["plot", str(p)])
    assert res.exit_code == 2
    assert str(p) in res.stderr


def test_ctrl_c_during_a_solve_is_an_interrupt_not_solver_trouble() -> None:
    """CasADi turns Ctrl-C inside a solve into a failed solve; the MPC must raise it instead."""
    import signal

    from auvdock.controllers import build_controller

    m = mission("diagonal", **{"controller.solver.name": "ipopt"})
    c = build_controller(m.with_controller("oracle").controller, m.build_vehicle(), m.build_dock())
    x = m.start_state()
    old = signal.signal(signal.SIGALRM, lambda *a: signal.raise_signal(signal.SIGINT))
    statuses = []
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.3)
        with pytest.raises(KeyboardInterrupt):
            for _ in range(2000):
                statuses.append(c.mpc.solve(0.0, x, np.zeros(8), np.array([0.5, 0.5, 0.0])).status)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    assert statuses and all(s == STATUS_OK for s in statuses)


def test_six_thruster_bluerov2_docks_in_the_tank() -> None:
    """Dimensions come from the vehicle file: the standard 6-thruster frame flies the same loop."""
    m = load_mission(ROOT / "missions" / "tank_bluerov2.yaml")
    v = m.build_vehicle()
    assert v.n_thrusters == 6 and v.allocation.shape == (6, 6)
    s = run_simulation(m)
    assert s.docked, s.outcome
    assert s.outcome["solver_failures"] == 0
    assert s.outcome["time_to_dock_s"] < 40.0
