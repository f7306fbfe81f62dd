"""Tests of auvdock.campaign_plots: the summary figures of a docking campaign."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from auvdock.campaign_plots import (
    CONTROLLER_COLORS,
    CONTROLLER_LABELS,
    CONTROLLER_ORDER,
    controller_color,
    controller_label,
    plot_campaign,
)
from auvdock.results import RunResults

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
    """One case, no trajectories at all, an unknown controller, a log-scale flow RMSE, a NaN value."""
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
