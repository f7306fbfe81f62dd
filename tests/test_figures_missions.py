"""Figure content on short simulated runs of the shipped missions (issue 19): the tank missions'
2-D path, a paper case with a strong current, and the PNG files each kind of run writes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.quiver import Quiver, QuiverKey

from auvdock.config.mission import load_mission
from auvdock.loop.simulation import run_simulation
from auvdock.results.plots import plot_run, run_figures
from auvdock.results.store import RunResults, read_run

ROOT = Path(__file__).resolve().parents[1]
BASE = ["trajectory_3d", "top_view", "distance", "thrust"]
FSE_EXTRA = ["flow_estimate", "information"]


def short_run(tmp_path: Path, mission: str, timeout_s: float, **updates: object) -> RunResults:
    m = load_mission(ROOT / "missions" / f"{mission}.yaml")
    if updates:
        m = m.with_updates(**updates)
    h5 = tmp_path / f"{mission}.h5"
    run_simulation(m, out=h5, timeout_s=timeout_s)
    return read_run(h5)


def spans_3d(ax) -> np.ndarray:
    return np.array([abs(np.diff(lim)[0]) for lim in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim())])


@pytest.fixture(scope="module")
def tank_run(tmp_path_factory: pytest.TempPathFactory) -> RunResults:
    return short_run(tmp_path_factory.mktemp("tank"), "tank_positioned", 3.0)


def test_tank_3d_view_equal_scale_and_no_noise_axis(tank_run: RunResults) -> None:
    east = tank_run.state[:, 1]
    assert np.ptp(east) < 1e-9  # the tank path is 2-D: east is rounding noise (or exactly 0)
    figures = dict(run_figures(tank_run))
    (ax,) = figures["trajectory_3d"].axes
    spans = spans_3d(ax)
    box = np.asarray(ax.get_box_aspect(), dtype=float)
    np.testing.assert_allclose(box / box[0], spans / spans[0], rtol=1e-9)  # one scale on all axes
    assert spans[0] >= 0.2  # not +-1e-16 m
    assert spans[0] >= 0.25 * spans.max() - 1e-12
    assert ax.get_zlim()[0] > ax.get_zlim()[1]  # down drawn downwards
    # the dock (2 m north) and the start are inside the limits
    lo_n, hi_n = sorted(ax.get_ylim())
    assert lo_n <= 0.0 and hi_n >= 2.0


def test_tank_thrust_groups_and_vehicle_limits(tank_run: RunResults) -> None:
    (ax,) = dict(run_figures(tank_run))["thrust"].axes
    series = {ln.get_label(): ln for ln in ax.get_lines() if str(ln.get_gid()).startswith("thrust ")}
    # the Heavy's thrusters work in identical pairs here; every thruster is named exactly once
    named = [t for label in series for t in label.split(" = ")]
    assert sorted(named, key=lambda t: int(t[1:])) == [f"T{i}" for i in range(1, 9)]
    assert len(series) < 8
    for label, line in series.items():
        for t in label.split(" = "):
            np.testing.assert_allclose(tank_run.thrust_N[:, int(t[1:]) - 1], line.get_ydata(), atol=1e-6)
    limits = {ln.get_gid(): float(ln.get_ydata()[0]) for ln in ax.get_lines() if "limit" in str(ln.get_gid())}
    assert limits == {"thrust_limit_max": 51.4, "thrust_limit_min": -39.9}  # BlueROV2 Heavy, 16 V


def test_case_mission_top_view_arrows_and_key(tmp_path: Path) -> None:
    run = short_run(tmp_path, "east_strong", 2.0)  # case 4: 2 m/s east
    m = load_mission(ROOT / "missions" / "east_strong.yaml")
    figures = dict(run_figures(run, flow_field=m.build_flow()))
    (ax,) = figures["top_view"].axes
    (q,) = [c for c in ax.collections if isinstance(c, Quiver)]
    speed = np.hypot(q.U, q.V)
    np.testing.assert_allclose(speed, 2.0)
    (key,) = [a for a in ax.artists if isinstance(a, QuiverKey)]
    assert key.U == 2.0 and key.Q is q
    assert "2 m/s" in key.text.get_text()
    # 3-D view of a 3-D path: one scale too
    (ax3,) = figures["trajectory_3d"].axes
    spans = spans_3d(ax3)
    box = np.asarray(ax3.get_box_aspect(), dtype=float)
    np.testing.assert_allclose(box / box[0], spans / spans[0], rtol=1e-9)


def test_png_files_per_kind_of_run(tmp_path: Path, tank_run: RunResults) -> None:
    """Baseline controllers (naive, kinematic, oracle): four PNGs; FSE-MPC runs: six."""
    paths = plot_run(tank_run, tmp_path / "oracle", prefix="tank_positioned_oracle_", dpi=30)
    assert [p.name for p in paths] == [f"tank_positioned_oracle_{n}.png" for n in BASE]
    fse = short_run(tmp_path, "gyre", 1.0, **{"controller.type": "sequential"})
    paths = plot_run(fse, tmp_path / "sequential", prefix="gyre_sequential_", dpi=30)
    assert [p.name for p in paths] == [f"gyre_sequential_{n}.png" for n in BASE + FSE_EXTRA]
