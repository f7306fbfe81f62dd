"""Tests of auvdock.campaign.plots: the summary figures of a docking campaign."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from auvdock.campaign.plots import (
    CONTROLLER_COLORS,
    CONTROLLER_LABELS,
    CONTROLLER_ORDER,
    campaign_figures,
    controller_color,
    controller_label,
    plot_campaign,
)
from auvdock.results.store import RunResults

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
FIGURES = ("fig2_trajectories", "fig3_travel_time", "fig4_path_length", "fig5_flow_rmse")
DOCK_NED = np.array([2.0, 3.0, 5.0])
TIMEOUT_S = 75.0


def synthetic_run(*, docked: bool, bend: float, n: int = 30, tolerance_m: float | None = 0.05) -> RunResults:
    """A path from (0, 0, 5) m NED towards a dock at (2, 3, 5) m heaving 0.5 m; ends short if not docked."""
    t = np.linspace(0.0, 30.0, n)
    s = np.linspace(0.0, 1.0 if docked else 0.6, n)
    state = np.zeros((n, 12))
    state[:, :3] = s[:, None] * DOCK_NED + np.array([0.0, 0.0, 5.0]) * (1 - s[:, None])
    state[:, 1] += bend * np.sin(np.pi * s)
    dock = np.tile(DOCK_NED, (n, 1))
    dock[:, 2] += 0.5 * np.sin(0.1 * t)
    attrs: dict[str, Any] = {"complete": True, "docked": docked}
    if tolerance_m is not None:
        attrs["tolerance_m"] = tolerance_m
    return RunResults(
        time_s=t,
        state=state,
        thrust_N=np.zeros((n, 8)),
        wrench=np.zeros((n, 6)),
        flow_ned_m_s=np.zeros((n, 3)),
        dock_position_m=dock,
        dock_velocity_m_s=np.zeros((n, 3)),
        distance_m=np.linalg.norm(state[:, :3] - dock, axis=1),
        solve_time_s=np.full(n, 0.01),
        solver_status=np.zeros(n, dtype=np.int8),
        attrs=attrs,
    )


def record(
    case: str, controller: str, *, status: str = "done", docked: bool = True, flow_rmse: float = math.nan
) -> dict[str, Any]:
    """One row of the campaign table, with every key ``auvdock compare`` writes."""
    failed = status != "done"
    return {
        "case": case,
        "case_label": f"{case}: synthetic current case with a long label",
        "controller": controller,
        "status": status,
        "error": "RuntimeError: solver blew up" if failed else "",
        "docked": docked and not failed,
        "time_to_dock_s": 30.0 if docked and not failed else math.nan,
        "end_time_s": 30.0 if docked else TIMEOUT_S,
        "timeout_s": TIMEOUT_S,
        "path_length_m": math.nan if failed else 3.6 + len(controller) / 10,
        "closest_approach_m": 0.01,
        "contact_speed_m_s": 0.1,
        "flow_rmse_m_s": flow_rmse,
        "flow_final_error_m_s": flow_rmse,
        "solve_time_median_s": 0.01,
        "solve_time_p95_s": 0.02,
        "solve_time_p99_s": 0.03,
        "solver_failures": 0,
        "wall_time_s": 1.0,
    }


def campaign() -> tuple[list[dict[str, Any]], dict[tuple[str, str], RunResults]]:
    """2 cases x 3 controllers: case_b/naive failed (no run), case_b/kinematic not docked, FSE flow values."""
    records = [
        record("case_a", "sequential", flow_rmse=0.12),
        record("case_a", "naive"),
        record("case_a", "kinematic"),
        record("case_b", "naive", status="failed"),
        record("case_b", "kinematic", docked=False),
        record("case_b", "sequential", flow_rmse=0.05),
    ]
    runs = {
        ("case_a", "naive"): synthetic_run(docked=True, bend=0.5),
        ("case_a", "kinematic"): synthetic_run(docked=True, bend=-0.3),
        ("case_a", "sequential"): synthetic_run(docked=True, bend=0.1),
        ("case_b", "kinematic"): synthetic_run(docked=False, bend=0.8, tolerance_m=None),
        ("case_b", "sequential"): synthetic_run(docked=True, bend=0.2),
    }
    return records, runs


def assert_nonempty(path: Path) -> None:
    assert path.is_file(), path
    assert path.stat().st_size > 1000, path
    if path.suffix == ".png":
        assert path.read_bytes()[:8] == PNG_SIGNATURE, path
    elif path.suffix == ".pdf":
        assert path.read_bytes()[:5] == b"%PDF-", path


def test_plot_campaign_writes_png_and_pdf(tmp_path: Path) -> None:
    records, runs = campaign()
    out = tmp_path / "figs"
    paths = plot_campaign(records, runs, out, formats=("png", "pdf"), dpi=40)
    expected = [out / f"{name}.{ext}" for name in FIGURES for ext in ("png", "pdf")]
    assert paths == expected
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in expected)
    for p in paths:
        assert_nonempty(p)

    # a rerun gives byte-identical files (no time stamps)
    again = plot_campaign(records, runs, tmp_path / "again", formats=("png", "pdf"), dpi=40)
    for p, q in zip(paths, again, strict=True):
        assert p.read_bytes() == q.read_bytes(), p.name


def test_no_flow_estimator_still_writes_fig5(tmp_path: Path) -> None:
    records, runs = campaign()
    records = [r for r in records if r["controller"] != "sequential"]
    runs = {k: v for k, v in runs.items() if k[1] != "sequential"}
    paths = plot_campaign(records, runs, tmp_path, dpi=30)
    assert [p.name for p in paths] == [f"{name}.png" for name in FIGURES]
    for p in paths:
        assert_nonempty(p)


def test_unusual_campaigns(tmp_path: Path) -> None:
    """One case, no trajectories at all, an unknown controller, flow RMSEs 500x apart, a NaN value."""
    records = [
        record("solo", "custom", flow_rmse=0.001),
        record("solo", "optimized", flow_rmse=0.5),
        record("solo", "oracle", docked=False),
        {**record("solo", "naive"), "path_length_m": math.nan},
    ]
    paths = plot_campaign(records, {}, tmp_path, formats=(".PNG",), dpi=30)
    assert [p.name for p in paths] == [f"{name}.png" for name in FIGURES]
    for p in paths:
        assert_nonempty(p)


def test_bad_arguments(tmp_path: Path) -> None:
    records, runs = campaign()
    with pytest.raises(ValueError, match="formats"):
        plot_campaign(records, runs, tmp_path, formats=())
    with pytest.raises(ValueError, match="unsupported"):
        plot_campaign(records, runs, tmp_path, formats=("png", "nope"))
    with pytest.raises(ValueError, match="records"):
        plot_campaign([], runs, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_controller_colors_and_labels() -> None:
    assert tuple(CONTROLLER_COLORS) == CONTROLLER_ORDER
    assert tuple(CONTROLLER_LABELS) == CONTROLLER_ORDER
    colors = [controller_color(c) for c in CONTROLLER_ORDER]
    assert len(set(colors)) == len(CONTROLLER_ORDER)
    assert colors == [controller_color(c) for c in CONTROLLER_ORDER]  # stable
    fallback = controller_color("my_new_controller")
    assert fallback == controller_color("my_new_controller")
    assert fallback not in colors
    assert controller_label("optimized") == "Optimized FSE-MPC"
    assert controller_label("my_new_controller") == "my_new_controller"


# ----------------------------------------------------------------------------- figure content


def figures(records, runs) -> dict[str, Figure]:
    built = campaign_figures(records, runs)
    assert [name for name, _ in built] == list(FIGURES)
    return dict(built)


def paths_of(ax: Axes) -> dict[str, Line2D]:
    return {str(ln.get_gid())[5:]: ln for ln in ax.get_lines() if str(ln.get_gid()).startswith("path ")}


def assert_legend_inside(fig: Figure, name: str) -> None:
    fig.canvas.draw()
    (legend,) = fig.legends
    box, page = legend.get_window_extent(), fig.bbox
    assert box.x0 >= page.x0 - 0.5 and box.x1 <= page.x1 + 0.5, (name, box, page)
    assert box.y0 >= page.y0 - 0.5 and box.y1 <= page.y1 + 0.5, (name, box, page)


def test_fig2_coinciding_paths_stay_visible_and_are_named() -> None:
    records = [record("case_a", c) for c in ("naive", "kinematic", "oracle")]
    runs = {
        ("case_a", "naive"): synthetic_run(docked=True, bend=0.5),
        ("case_a", "kinematic"): synthetic_run(docked=True, bend=0.1),
        ("case_a", "oracle"): synthetic_run(docked=True, bend=0.1),  # the same path as kinematic
    }
    fig = figures(records, runs)["fig2_trajectories"]
    ax = fig.axes[0]
    lines = paths_of(ax)
    assert set(lines) == {"naive", "kinematic", "oracle"}
    kin, ora = lines["kinematic"], lines["oracle"]
    np.testing.assert_array_equal(kin.get_xydata(), ora.get_xydata())
    # oracle on top, thinner and dashed: kinematic shows at its sides and through its gaps
    assert ora.get_zorder() > kin.get_zorder()
    assert ora.get_linewidth() < kin.get_linewidth()
    assert kin.get_linestyle() == "-" and ora.get_linestyle() != "-"
    assert "same path" in ax.get_xlabel()
    assert "Kinematic MPC = Oracle MPC" in ax.get_xlabel().replace("\n", " ")
    assert "Naive MPC" not in ax.get_xlabel()
    # the legend shows each controller's line style
    handles = {h.get_label(): h for h in fig.legends[0].legend_handles}
    assert handles["Oracle MPC"].get_linestyle() == ora.get_linestyle()


def test_fig2_dock_inset_shows_the_tolerance_circle() -> None:
    records, runs = campaign()
    fig = figures(records, runs)["fig2_trajectories"]
    panel_a, panel_b = fig.axes[:2]
    (inset,) = [a for a in panel_a.child_axes if a.get_gid() == "dock inset"]
    circles = [p for p in inset.patches if isinstance(p, Circle) and p.get_gid() == "docking tolerance"]
    (circle,) = circles
    assert circle.get_radius() == pytest.approx(0.05)
    np.testing.assert_allclose(circle.get_center(), (DOCK_NED[1], DOCK_NED[0]))
    # zoomed to 3 tolerance radii: the 5 cm circle spans a third of the inset (not hidden by the star)
    assert np.diff(inset.get_xlim())[0] == pytest.approx(6 * 0.05)
    assert np.diff(inset.get_ylim())[0] == pytest.approx(6 * 0.05)
    # case_b: the tolerance comes from the run that recorded one
    assert [a for a in panel_b.child_axes if a.get_gid() == "dock inset"]


def test_fig2_no_inset_without_a_tolerance() -> None:
    records = [record("solo", "oracle")]
    runs = {("solo", "oracle"): synthetic_run(docked=True, bend=0.2, tolerance_m=None)}
    ax = figures(records, runs)["fig2_trajectories"].axes[0]
    assert not ax.child_axes
    assert not [p for p in ax.patches if isinstance(p, Circle)]


def test_fig2_inset_in_an_empty_corner() -> None:
    records, runs = campaign()
    fig = figures(records, runs)["fig2_trajectories"]
    fig.canvas.draw()
    ax = fig.axes[0]
    (inset,) = ax.child_axes
    box = inset.get_window_extent()
    to_pixels = ax.transData
    for line in paths_of(ax).values():
        xy = to_pixels.transform(line.get_xydata())
        inside = (xy[:, 0] > box.x0) & (xy[:, 0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)
        assert not inside.any(), line.get_gid()


@pytest.mark.parametrize("n_cases", [1, 2, 4])
def test_legends_fit_the_figure(n_cases: int) -> None:
    controllers = ("naive", "kinematic", "oracle", "sequential", "optimized")
    records, runs = [], {}
    for i in range(n_cases):
        for c in controllers:
            docked = c != "oracle"
            records.append(record(f"case_{i}", c, docked=docked, flow_rmse=0.1 if "q" in c else math.nan))
            runs[(f"case_{i}", c)] = synthetic_run(docked=docked, bend=0.1 * len(c))
    for name, fig in figures(records, runs).items():
        assert_legend_inside(fig, name)


def bar_notes(ax: Axes) -> list[str]:
    return [t.get_text() for t in ax.texts if t.get_gid() == "bar note"]


def bars(ax: Axes) -> dict[str, Any]:
    return {str(p.get_gid()): p for p in ax.patches if str(p.get_gid()).startswith("bar ")}


def test_fig5_linear_axis_values_and_timed_out_runs_apart() -> None:
    records = [
        record("case_a", "sequential", flow_rmse=0.001),
        record("case_a", "optimized", flow_rmse=0.5),
        record("case_b", "sequential", docked=False, flow_rmse=0.2),  # timed out at 75 s
        record("case_b", "optimized", flow_rmse=0.03),
    ]
    ax = figures(records, {})["fig5_flow_rmse"].axes[0]
    assert ax.get_yscale() == "linear"  # bar heights show the ratios
    b = bars(ax)
    assert set(b) == {
        "bar case_a sequential",
        "bar case_a optimized",
        "bar case_b sequential not docked",
        "bar case_b optimized",
    }
    assert b["bar case_a optimized"].get_height() == pytest.approx(0.5)
    assert b["bar case_a optimized"].get_height() / b["bar case_b optimized"].get_height() == pytest.approx(
        0.5 / 0.03
    )
    timed_out = b["bar case_b sequential not docked"]
    assert timed_out.get_hatch() and not b["bar case_b optimized"].get_hatch()
    notes = bar_notes(ax)
    assert "0.001" in notes and "0.5" in notes and "0.03" in notes  # every bar labelled with its value
    assert any("0.2" in n and "timed out 75 s" in n for n in notes)
    legend_text = " ".join(t.get_text() for t in ax.get_figure().legends[0].get_texts())
    assert "not comparable" in legend_text


def test_fig3_fig4_mark_runs_that_did_not_dock() -> None:
    records, runs = campaign()
    records.append({**record("case_b", "oracle", docked=False), "reason": "diverged", "end_time_s": 12.5})
    built = figures(records, runs)
    for name in ("fig3_travel_time", "fig4_path_length"):
        ax = built[name].axes[0]
        b = bars(ax)
        assert b["bar case_b kinematic not docked"].get_hatch()
        assert b["bar case_b oracle not docked"].get_hatch()
        assert not b["bar case_a kinematic"].get_hatch()
        notes = bar_notes(ax)
        assert "timed out 75 s" in notes and "diverged 12.5 s" in notes, name
        assert any(t.get_text() == "failed" for t in ax.texts)  # case_b naive: no bar
        assert "bar case_b naive" not in " ".join(b)
