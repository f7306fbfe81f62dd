"""``auvdock compare`` / ``auvdock report``: a small campaign in two worker processes.

2 cases (still water, paper case 2) x 2 controllers (oracle, naive) with a 3 s timeout:
every run times out, which is fine here -- the campaign machinery is under test, the
controllers are tested in test_sim.py and test_fse.py.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from auvdock.campaign import (
    TABLE_COLUMNS,
    campaign_specs,
    check_findings,
    execute_run,
    read_campaign,
    run_campaign,
)
from auvdock.cli import app
from auvdock.results import read_run

ROOT = Path(__file__).resolve().parents[1]
MISSIONS = [ROOT / "missions" / "still.yaml", ROOT / "missions" / "diagonal.yaml"]
CONTROLLERS = ["oracle", "naive"]
FIGURES = ["fig2_trajectories", "fig3_travel_time", "fig4_path_length", "fig5_flow_rmse"]
runner = CliRunner()


def _compare(out: Path, *extra: str):
    args = ["compare", *map(str, MISSIONS), "-c", ",".join(CONTROLLERS), "--timeout", "3"]
    return runner.invoke(app, [*args, "--jobs", "2", "--out", str(out), *extra])


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("compare")
    res = _compare(out)
    assert res.exit_code == 0, res.output
    return out, res.output


def test_campaign_file_layout(campaign) -> None:
    out, _ = campaign
    path = out / "campaign.h5"
    with h5py.File(path, "r") as f:
        assert f.attrs["format"] == "auvdock-campaign"
        assert "compare" in f.attrs["command_line"]
        assert "cpu_count" in f.attrs["machine"]
        table = f["campaign_table"][()]
        assert list(table.dtype.names) == list(TABLE_COLUMNS)
        assert len(table) == 4
        for case in ("still", "diagonal"):
            for ctrl in CONTROLLERS:
                g = f[f"runs/{case}/{ctrl}"]
                assert g.attrs["format"] == "auvdock-run"
                assert bool(g.attrs["complete"])
        # the same run layout as auvdock sim
        r = read_run(f, "/runs/diagonal/oracle")
    assert r.state.shape[1] == 12
    assert r.time_s[-1] == pytest.approx(3.0, abs=0.051)
    records, _ = read_campaign(path)
    assert [(x["case"], x["controller"]) for x in records] == [
        ("still", "oracle"),
        ("still", "naive"),
        ("diagonal", "oracle"),
        ("diagonal", "naive"),
    ]
    assert all(x["status"] == "done" and not x["docked"] for x in records)
    assert records[2]["paper_case"] == 2
    assert records[2]["timeout_s"] == 3.0


def test_tables_and_figures_written(campaign) -> None:
    out, output = campaign
    for name in ("summary.csv", "summary.md", "findings.md"):
        assert (out / name).is_file(), name
    for fig in FIGURES:
        assert (out / f"{fig}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (out / "summary.md").read_text()
    assert "| diagonal | naive | no | timeout 3 s |" in md
    csv_lines = (out / "summary.csv").read_text().splitlines()
    assert csv_lines[0] == ",".join(TABLE_COLUMNS)
    assert len(csv_lines) == 5
    assert "campaign wall time" in output


def test_resume_runs_nothing(campaign) -> None:
    out, _ = campaign
    path = out / "campaign.h5"
    with h5py.File(path, "r") as f:
        before = f["runs/still/oracle"].attrs["created_utc"]
        states = f["runs/still/oracle/state"][()]
    res = _compare(out, "--resume", "--no-plots")
    assert res.exit_code == 0, res.output
    assert "resumed: 4 runs already complete, 0 run now" in res.output
    with h5py.File(path, "r") as f:
        assert f["runs/still/oracle"].attrs["created_utc"] == before
        assert np.array_equal(f["runs/still/oracle/state"][()], states)
        assert "compare" in f.attrs["resumed_with"]


def test_report_regenerates_identical_tables(campaign, tmp_path) -> None:
    out, _ = campaign
    shutil.copy(out / "campaign.h5", tmp_path / "campaign.h5")
    res = runner.invoke(app, ["report", str(tmp_path / "campaign.h5")])
    assert res.exit_code == 0, res.output
    for name in ("summary.csv", "summary.md", "findings.md"):
        assert (tmp_path / name).read_bytes() == (out / name).read_bytes(), name
    for fig in FIGURES:
        assert (tmp_path / f"{fig}.png").is_file()


def _failing_runner(spec, progress_queue=None):
    """An injected failure: the naive run raises inside the worker, the others run normally."""
    if spec.controller == "naive":
        raise RuntimeError("injected failure")
    return execute_run(spec, progress_queue)


def test_failure_in_one_run_does_not_stop_the_others(tmp_path) -> None:
    specs = campaign_specs(MISSIONS[:1], ["oracle", "naive"], tmp_path, timeout_s=2.0)
    res = run_campaign(specs, tmp_path / "campaign.h5", jobs=2, runner=_failing_runner)
    by = {r["controller"]: r for r in res.records}
    assert by["naive"]["status"] == "failed"
    assert by["naive"]["error"] == "RuntimeError: injected failure"
    assert by["oracle"]["status"] == "done"
    with h5py.File(tmp_path / "campaign.h5", "r") as f:
        assert "runs/still/oracle" in f
        assert "runs/still/naive" not in f
        assert len(f["campaign_table"]) == 2
    # and the table shows it
    from auvdock.campaign import summary_rows

    row = [r for r in summary_rows(res.records) if r[1] == "naive"][0]
    assert row[2] == "failed"
    assert row[3] == "failed: RuntimeError: injected failure"


def _interrupting_runner(spec, progress_queue=None):
    if spec.controller == "naive":
        raise KeyboardInterrupt
    return execute_run(spec, progress_queue)


def test_ctrl_c_keeps_finished_runs_and_resume_completes(tmp_path) -> None:
    specs = campaign_specs(MISSIONS[:1], ["oracle", "naive"], tmp_path, timeout_s=1.0)
    path = tmp_path / "campaign.h5"
    with pytest.raises(KeyboardInterrupt):
        run_campaign(specs, path, jobs=1, runner=_interrupting_runner)
    records, _ = read_campaign(path)  # readable, with the finished run
    assert [(r["controller"], r["status"]) for r in records] == [("oracle", "done")]
    res = run_campaign(specs, path, jobs=1, resume=True)
    assert res.skipped == [("still", "oracle")]
    assert res.ran == [("still", "naive")]
    assert [r["status"] for r in res.records] == ["done", "done"]


def test_exception_in_run_is_recorded_not_raised(tmp_path) -> None:
    bad = tmp_path / "still.yaml"
    bad.write_text((ROOT / "missions" / "still.yaml").read_text())
    specs = campaign_specs([bad], ["oracle"], tmp_path)
    bad.write_text("name: [unterminated")  # broken after validation, before the run
    rec = execute_run(specs[0])
    assert rec["status"] == "failed"
    assert rec["error"].startswith("MissionError: ")


def test_bad_mission_exits_2(tmp_path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\ncontroller:\n  horizon_steps: 0\n")
    res = runner.invoke(app, ["compare", str(bad), "--out", str(tmp_path)])
    assert res.exit_code == 2
    assert res.stderr.strip().startswith(f"error: {bad}: controller.horizon_steps: ")
    assert len(res.stderr.strip().splitlines()) == 1


def test_unknown_controller_exits_2(tmp_path) -> None:
    res = runner.invoke(app, ["compare", "-c", "oracle,magic", "--out", str(tmp_path)])
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        "error: --controllers: unknown controller 'magic' "
        "(known: naive, kinematic, oracle, sequential, optimized)"
    )


def test_report_on_a_run_file_exits_2(tmp_path) -> None:
    p = tmp_path / "x.h5"
    with h5py.File(p, "w") as f:
        f.attrs["format"] = "auvdock-run"
    res = runner.invoke(app, ["report", str(p)])
    assert res.exit_code == 2
    assert res.stderr.strip() == f"error: {p}: not an auvdock campaign file (written by auvdock compare)"


def test_findings_on_the_papers_table() -> None:
    """The findings checker on a hand-made six-case table (the shape of our measured results)."""
    rows = []
    docks = {
        "oracle": {1, 2, 3, 4, 5, 6},
        "naive": {1, 5},
        "kinematic": {1, 2, 3, 4, 5, 6},
        "sequential": {1, 2, 5},
        "optimized": {1, 2, 3, 5, 6},
    }
    for c in range(1, 7):
        for ctrl, ok in docks.items():
            rows.append(
                {
                    "case": f"c{c}",
                    "paper_case": c,
                    "controller": ctrl,
                    "status": "done",
                    "docked": c in ok,
                    "time_to_dock_s": {"oracle": 20.0, "sequential": 30.0, "optimized": 25.0}.get(ctrl, 20.0),
                    "flow_rmse_m_s": {"sequential": 0.04, "optimized": 0.03}.get(ctrl, np.nan),
                    "wall_time_s": 10.0,
                }
            )
    f = {x.finding.split(" docks")[0]: x for x in check_findings(rows)}
    assert f["Oracle MPC"].verdict == "holds"
    assert f["Naive MPC"].verdict == "holds"
    assert f["Kinematic MPC"].verdict == "differs"
    assert "Property 8.1" in f["Kinematic MPC"].explanation
    assert f["Sequential FSE-MPC"].verdict == "differs"
    assert f["Sequential FSE-MPC"].measured == "docks in 1, 2, 5; times out in 3, 4, 6"
    travel = [x for x in check_findings(rows) if x.finding.startswith("Travel")][0]
    assert travel.verdict == "differs"  # optimized (25 s) docks before sequential (30 s)
    rmse = [x for x in check_findings(rows) if x.finding.startswith("Flow RMSE")][0]
    assert rmse.verdict == "holds"
