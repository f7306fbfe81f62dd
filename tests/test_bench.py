"""``auvdock bench``: the table and JSON output on a short run; bad input exits 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from auvdock.cli import app

runner = CliRunner()


def test_bench_json_rows() -> None:
    res = runner.invoke(app, ["bench", "--case", "2", "-c", "oracle,naive", "--timeout", "1", "--json"])
    assert res.exit_code == 0, res.output
    rows = [json.loads(line) for line in res.stdout.strip().splitlines()]
    assert [(r["case"], r["controller"], r["solver"]) for r in rows] == [
        (2, "oracle", "rti"),
        (2, "naive", "rti"),
    ]
    for r in rows:
        assert r["docked"] is False and r["time_to_dock_s"] is None  # 1 s is too short
        assert r["steps"] == 20
        assert 0 < r["median_ms"] <= r["p95_ms"] <= r["p99_ms"] <= r["max_ms"]
        # where the time goes (rti: its QP data and its QP; the rest Python), each part at most
        # the step, the medians of the parts and of the rest within the step's median
        parts = r["parts_median_ms"]
        assert list(parts) == ["qp data", "qp", "python"]
        assert all(0 < v <= r["max_ms"] for v in parts.values())
        assert sum(parts.values()) <= 1.5 * r["median_ms"]


def test_bench_table() -> None:
    res = runner.invoke(
        app, ["bench", "--case", "1", "-c", "oracle", "--solvers", "ipopt", "--timeout", "0.5"]
    )
    assert res.exit_code == 0, res.output
    assert "bench on " in res.output and "CasADi" in res.output
    assert "median" in res.output
    assert "where a step's time goes" in res.output


def test_bench_parts_of_an_fse_step() -> None:
    """Sequential FSE-MPC on sqp: the flow filter, the perception law, the NLP's function
    evaluations and its solver, and Python."""
    from auvdock.campaign.bench import bench_rows

    (row,) = bench_rows([2], ["sequential"], ["sqp"], timeout_s=0.5)
    want = ["flow filter", "perception", "nlp functions", "nlp solver", "python"]
    assert list(row["parts_median_ms"]) == want
    assert row["parts_median_ms"]["nlp solver"] > 0


def test_bench_bad_input() -> None:
    res = runner.invoke(app, ["bench", "--case", "7"])
    assert res.exit_code == 2
    assert res.stderr.strip() == "error: --case: 7 is not one of the paper's cases 1..6"
    res = runner.invoke(app, ["bench", "--solvers", "fast"])
    assert res.exit_code == 2
    assert res.stderr.strip() == "error: --solvers: unknown solver 'fast' (known: auto, ipopt, sqp, rti)"


def test_step_figures_leave_out_the_cold_start_and_rounds_take_medians() -> None:
    from auvdock.campaign.bench import rounds_median, step_figures

    times = np.array([0.5, 0.001, 0.002, 0.003, 0.004])  # s; the first a cold start
    parts = {"qp": np.array([0.4, 0.0005, 0.001, 0.0015, 0.002])}
    pct, mx, where = step_figures(times, parts)
    assert pct[0] == pytest.approx(2.5) and mx == pytest.approx(4.0)
    assert where == pytest.approx({"qp": 1.25, "python": 1.25})
    other = (pct + 2.0, mx + 2.0, {"qp": 3.25, "python": 1.25})
    third = (pct + 4.0, mx + 4.0, {"qp": 5.25})
    pct3, mx3, where3 = rounds_median([(pct, mx, where), other, third])
    assert pct3 == pytest.approx(pct + 2.0) and mx3 == pytest.approx(6.0)
    assert where3["qp"] == pytest.approx(3.25) and "python" not in where3  # the last round's parts


def test_busy_loops_run_beside_the_block_and_stop_with_it() -> None:
    import multiprocessing as mp

    from auvdock.campaign.bench import busy_loops

    before = len(mp.active_children())
    with busy_loops(2):
        assert len(mp.active_children()) == before + 2
    assert len(mp.active_children()) == before
