"""Tests of auvdock.results.plots: PNG figures of one run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.quiver import Quiver, QuiverKey

from auvdock.results.plots import plot_run, run_figures, thrust_limits_of
from auvdock.results.store import RunResults, RunWriter, read_run
from auvdock.world.flow import ConstantCurrent, flow_case

ROOT = Path(__file__).resolve().parents[1]

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


# ----------------------------------------------------------------------------- figure content


def figure(results: RunResults, name: str, **kwargs) -> Figure:
    figures = dict(run_figures(results, **kwargs))
    return figures[name]


def tank_like_run(path: Path, *, east_noise: float = 1e-17) -> RunResults:
    """A 2-D path like the tank missions': 2 m north, east only rounding noise, a 6 cm heave."""
    n = 60
    with RunWriter(
        path, mission_name="tank_like", mission_yaml="", controller="oracle", attrs={"tolerance_m": 0.05}
    ) as w:
        for k in range(n):
            t = 0.1 * k
            s = k / (n - 1)
            x = np.zeros(12)
            x[:3] = [1.95 * s, east_noise * np.sin(7.0 * k), 1.0 + 0.06 * np.sin(3.8 * t)]
            dock = np.array([2.0, 0.0, 1.0 + 0.0635 * np.sin(3.8 * t)])
            w.append(
                time_s=t, state=x, thrust_N=np.zeros(8), wrench=np.zeros(6), flow_ned_m_s=np.zeros(3),
                dock_position_m=dock, dock_velocity_m_s=np.zeros(3),
                distance_m=float(np.linalg.norm(x[:3] - dock)), solve_time_s=0.01, solver_status=0,
            )  # fmt: skip
        w.finish({"docked": True, "time_to_dock_s": (n - 1) * 0.1, "reason": "docked"})
    return read_run(path)


def axis_spans(ax) -> np.ndarray:
    return np.array([abs(np.diff(lim)[0]) for lim in (ax.get_xlim(), ax.get_ylim(), ax.get_zlim())])


def assert_equal_3d_scale(ax) -> None:
    """Box aspect proportional to the axis spans: one metre is as long on every axis."""
    spans = axis_spans(ax)
    box = np.asarray(ax.get_box_aspect(), dtype=float)
    np.testing.assert_allclose(box / box[0], spans / spans[0], rtol=1e-9)


def test_trajectory_3d_degenerate_axis_is_not_blown_up(tmp_path: Path) -> None:
    results = tank_like_run(tmp_path / "run.h5")
    fig = figure(results, "trajectory_3d")
    (ax,) = fig.axes
    assert ax.name == "3d"
    assert_equal_3d_scale(ax)
    spans = axis_spans(ax)  # east, north, down
    north_data = 2.0  # the dock at 2 m north, the start at 0
    # north covers its data; east (1e-17 m of noise) is at least 0.2 m and a quarter of north
    assert north_data <= spans[1] <= 1.3 * north_data
    assert spans[0] >= max(0.2, 0.25 * spans[1]) - 1e-12
    assert spans[0] < spans[1]  # widened, but not to the north's span
    assert abs(np.mean(ax.get_xlim())) < 1e-9  # centred on the (zero) east data
    z0, z1 = ax.get_zlim()
    assert z0 > z1  # down drawn downwards
    assert z1 <= 1.0 - 0.0635 and z0 >= 1.0 + 0.0635  # the heave fits
    # the legend is outside the axes
    assert ax.get_legend() is None and len(fig.legends) == 1


def test_trajectory_3d_equal_scale_on_a_3d_path(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5")  # 10 m north, 5 (+1) m east, 3 m down
    (ax,) = figure(results, "trajectory_3d").axes
    assert_equal_3d_scale(ax)
    spans = axis_spans(ax)
    assert spans[1] == pytest.approx(10.0 * 1.1, rel=0.02)  # north: data + 5 % margins
    assert spans[0] == pytest.approx(5.0 + 1.0, rel=0.02)  # east: data (0..5 m) + the same margins (m)
    assert spans[2] == pytest.approx(3.3 + 1.0, rel=0.02)  # down: 0..3.3 m + margins


class ShearFlow:
    """A current along east whose speed grows with east: 0.07 m/s at east -1 m to 2 m/s far east."""

    def velocity(self, p_ned: np.ndarray, t: float) -> np.ndarray:
        p = np.asarray(p_ned, dtype=float)
        v = np.zeros_like(p)
        v[..., 1] = np.clip(0.07 + 0.35 * (p[..., 1] + 1.0), 0.07, 2.0)
        return v


def quiver_of(ax) -> Quiver:
    (q,) = [c for c in ax.collections if isinstance(c, Quiver)]
    return q


def test_top_view_arrows_proportional_to_speed_with_key(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5")
    fig = figure(results, "top_view", flow_field=ShearFlow())
    (ax,) = fig.axes
    q = quiver_of(ax)
    assert q.scale_units == "xy" and q.angles == "xy"
    speed = np.hypot(q.U, q.V)
    assert speed.min() == pytest.approx(0.07) and speed.max() == pytest.approx(2.0)  # both in one map
    length = speed / q.scale  # arrow lengths in metres of the map
    np.testing.assert_allclose(length / speed, length[0] / speed[0])  # proportional
    assert length.max() / length.min() == pytest.approx(speed.max() / speed.min())
    # the quiver key: a nice reference speed at or above the fastest, drawn with the same scale
    (key,) = [a for a in ax.artists if isinstance(a, QuiverKey)]
    assert key.Q is q
    assert key.U == 2.0
    assert "2 m/s" in key.text.get_text()
    # legend outside the map: it covers no arrow
    assert ax.get_legend() is None and len(fig.legends) == 1
    fig.canvas.draw()
    legend_box = fig.legends[0].get_window_extent()
    assert not legend_box.overlaps(ax.get_window_extent())


def test_top_view_recorded_current_and_key(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5", flow=0.3)  # recorded (0.3, -0.3, 0) m/s along the path
    (ax,) = figure(results, "top_view").axes
    q = quiver_of(ax)
    speed = np.hypot(q.U, q.V)
    np.testing.assert_allclose(speed, 0.3 * np.sqrt(2))
    (key,) = [a for a in ax.artists if isinstance(a, QuiverKey)]
    assert key.U == 0.5  # the nice speed above 0.42 m/s
    # the key arrow and the current's arrows share one scale: 0.42 / 0.5 of the key's length
    np.testing.assert_allclose((speed / q.scale) / (key.U / q.scale), speed / 0.5)


def test_top_view_still_water_has_no_arrows(tmp_path: Path) -> None:
    results = tank_like_run(tmp_path / "run.h5")
    (ax,) = figure(results, "top_view", flow_field=ConstantCurrent(0.0, 0.0)).axes
    assert not [c for c in ax.collections if isinstance(c, Quiver)]
    assert any(t.get_text() == "no current" for t in ax.texts)


def thrust_lines(ax) -> dict[str, Line2D]:
    return {ln.get_label(): ln for ln in ax.get_lines() if str(ln.get_gid()).startswith("thrust ")}


def test_thrust_identical_thrusters_share_a_line_and_limits_are_drawn(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5")
    t = results.time_s
    thrust = np.stack(
        [np.sin(t), np.sin(t), -np.sin(t), -np.sin(t), np.cos(t), np.cos(t) + 0.5, t, t], axis=1
    )
    results.thrust_N[:] = thrust
    limits = (np.full(8, -39.9), np.full(8, 51.4))
    (ax,) = figure(results, "thrust", thrust_limits=limits).axes
    lines = thrust_lines(ax)
    assert list(lines) == ["T1 = T2", "T3 = T4", "T5", "T6", "T7 = T8"]
    np.testing.assert_array_equal(lines["T3 = T4"].get_ydata(), thrust[:, 2])
    styles = {(ln.get_color(), str(ln.get_linestyle())) for ln in lines.values()}
    assert len(styles) == len(lines)  # every line looks different
    tops = [ln for ln in ax.get_lines() if ln.get_gid() == "thrust_limit_max"]
    bottoms = [ln for ln in ax.get_lines() if ln.get_gid() == "thrust_limit_min"]
    assert len(tops) == 1 and len(bottoms) == 1
    np.testing.assert_allclose(tops[0].get_ydata(), 51.4)
    np.testing.assert_allclose(bottoms[0].get_ydata(), -39.9)
    lo, hi = ax.get_ylim()
    assert lo < -39.9 and hi > 51.4  # the limits are in view
    labels = [h.get_label() for h in fig_legend_handles(ax)]
    assert "thrust limit max 51.4 N" in labels and "thrust limit min -39.9 N" in labels


def fig_legend_handles(ax) -> list:
    (legend,) = ax.get_figure().legends
    return list(legend.legend_handles)


def test_thrust_limits_per_thruster(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5")
    lo = np.full(8, -40.0)
    hi = np.array([50.0] * 4 + [30.0] * 4)
    (ax,) = figure(results, "thrust", thrust_limits=(lo, hi)).axes
    tops = sorted(float(ln.get_ydata()[0]) for ln in ax.get_lines() if ln.get_gid() == "thrust_limit_max")
    assert tops == [30.0, 50.0]
    labels = [h.get_label() for h in fig_legend_handles(ax)]
    assert "thrust limit max 30 N (T5, T6, T7, T8)" in labels


def test_thrust_limits_from_the_stored_mission(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5")
    results.attrs["mission_yaml"] = (ROOT / "missions" / "tank_positioned.yaml").read_text()
    limits = thrust_limits_of(results)
    assert limits is not None
    np.testing.assert_allclose(limits[0], -39.9)  # BlueROV2 Heavy, T200 at 16 V
    np.testing.assert_allclose(limits[1], 51.4)
    results.attrs["thrust_min_N"], results.attrs["thrust_max_N"] = -10.0, 12.0  # recorded limits win
    lo, hi = thrust_limits_of(results)
    np.testing.assert_allclose(lo, -10.0)
    np.testing.assert_allclose(hi, 12.0)


def test_thrust_limits_unknown(tmp_path: Path) -> None:
    results = synthetic_run(tmp_path / "run.h5")
    results.attrs["mission_yaml"] = "not: [a mission"
    assert thrust_limits_of(results) is None
    (ax,) = figure(results, "thrust").axes
    assert not [ln for ln in ax.get_lines() if str(ln.get_gid()).startswith("thrust_limit")]
    assert any("thrust limits unknown" in t.get_text() for t in ax.texts)
