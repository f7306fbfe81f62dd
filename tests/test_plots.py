"""Tests of auvdock.plots: PNG figures of one run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from auvdock.flow import ConstantCurrent, flow_case
from auvdock.plots import plot_run
from auvdock.results import RunResults, RunWriter, read_run

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
BASE_FILES = ["trajectory_3d.png", "top_view.png", "distance.png", "thrust.png"]
FLOW_EXTRAS = {
    "flow_estimate_m_s": (3,),
    "flow_body_true_m_s": (3,),
    "flow_covariance": (3, 3),
    "information": (),
}


def synthetic_run(path: Path, n: int = 40, *, extras: bool = False, flow: float = 0.3) -> RunResults:
    """A short approach from the origin to a heaving dock at (10, 5, ~3) m NED."""
    dt = 0.1
    dock0 = np.array([10.0, 5.0, 3.0])
    with RunWriter(
        path,
        mission_name="unit_mission",
        mission_yaml="name: unit_mission\n",
        controller="flow_mpc",
        extra_series=FLOW_EXTRAS if extras else None,
        attrs={"tolerance_m": 0.2},
    ) as w:
        for k in range(n):
            t = k * dt
            s = k / max(n - 1, 1)
            x = np.zeros(12)
            x[:3] = s * dock0 + np.array([0.0, np.sin(np.pi * s), 0.0])
            dock = dock0 + np.array([0.0, 0.0, 0.3 * np.sin(t)])
            row = {
                "time_s": t,
                "state": x,
                "thrust_N": 5.0 * np.sin(t + np.arange(8)),
                "wrench": np.zeros(6),
                "flow_ned_m_s": np.array([flow, -flow, 0.0]),
                "dock_position_m": dock,
                "dock_velocity_m_s": np.array([0.0, 0.0, 0.3 * np.cos(t)]),
                "distance_m": float(np.linalg.norm(x[:3] - dock)),
                "solve_time_s": 0.01,
                "solver_status": 0,
            }
            if extras:
                row["flow_estimate_m_s"] = np.array([flow, -flow, 0.0]) * (1 - np.exp(-t))
                row["flow_body_true_m_s"] = np.array([flow, -flow, 0.0])
                row["flow_covariance"] = np.eye(3) * 0.01 * np.exp(-t)
                row["information"] = np.exp(t)
            w.append(**row)
        if n:
            w.finish({"docked": True, "time_to_dock_s": (n - 1) * dt, "reason": "docked"})
    return read_run(path)


def assert_png(path: Path) -> None:
    assert path.is_file(), path
    data = path.read_bytes()
    assert len(data) > 1000, path
    assert data[:8] == PNG_SIGNATURE, path


def test_plot_run_makes_four_pngs(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5")
    paths = plot_run(results, tmp_path / "figs", dpi=50)
    assert [p.name for p in paths] == BASE_FILES
    for p in paths:
        assert p.parent == tmp_path / "figs"
        assert_png(p)
    assert sorted(p.name for p in (tmp_path / "figs").iterdir()) == sorted(BASE_FILES)


def test_plot_run_with_flow_extras_and_field(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5", extras=True)
    paths = plot_run(
        results, tmp_path, prefix="case2_flow_mpc_", flow_field=ConstantCurrent(0.5, 0.5), dpi=50
    )
    names = [p.name for p in paths]
    assert names == [f"case2_flow_mpc_{n}" for n in [*BASE_FILES, "flow_estimate.png", "information.png"]]
    for p in paths:
        assert_png(p)


def test_plot_run_without_covariance_or_information(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5", extras=True)
    del results.extras["flow_covariance"]
    del results.extras["information"]
    paths = plot_run(results, tmp_path, flow_field=flow_case("case5"), dpi=50)
    assert [p.name for p in paths] == [*BASE_FILES, "flow_estimate.png"]


def test_plot_run_still_water_single_step(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5", n=1, flow=0.0)
    paths = plot_run(results, tmp_path, dpi=50)
    assert len(paths) == 4
    for p in paths:
        assert_png(p)


def test_plot_run_empty_run_raises(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5", n=0)
    assert results.n_steps == 0
    with pytest.raises(ValueError, match="no recorded steps"):
        plot_run(results, tmp_path / "figs")
    assert not (tmp_path / "figs").exists()


def test_plot_run_rejects_misshaped_extra(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5", extras=True)
    results.extras["flow_estimate_m_s"] = results.extras["flow_estimate_m_s"][:, :2]
    with pytest.raises(ValueError, match="flow_estimate_m_s"):
        plot_run(results, tmp_path)
