"""``auvdock compare`` / ``auvdock report`` on the campaign engine: small campaigns, 2 workers.

2 cases (still water, paper case 2) x 2 controllers (oracle, naive) with a 3 s timeout:
every run times out, which is fine here -- the campaign machinery is under test, the
controllers are tested in test_sim.py and test_fse.py.  Faults are injected by runners
from tests/helpers/campaign_faults.py (production code has no fault hook).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import h5py
import numpy as np
import pytest
from helpers.campaign_faults import inject
from typer.testing import CliRunner

from auvdock.campaign import (
    TABLE_COLUMNS,
    ResultsFileError,
    campaign_specs,
    execute_run,
    read_campaign,
    run_campaign,
    summary_rows,
)
from auvdock.cli import app
from auvdock.results.store import read_run

ROOT = Path(__file__).resolve().parents[1]
MISSIONS = [ROOT / "missions" / "still.yaml", ROOT / "missions" / "diagonal.yaml"]
FOUR = ["still", "diagonal", "south", "east_strong"]  # shipped names
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
        assert f.attrs["format"] == "auvdock-campaign" and f.attrs["kind"] == "compare"
        assert "compare" in f.attrs["command_line"]
        assert "cpu_count" in f.attrs["machine"]
        assert f.attrs["executor"] == "2 local worker processes"
        table = f["campaign_table"][()]
        assert list(table.dtype.names) == list(TABLE_COLUMNS)
        assert len(table) == 4
        for case in ("still", "diagonal"):
            for ctrl in CONTROLLERS:
                g = f[f"runs/{case}/{ctrl}"]
                assert g.attrs["format"] == "auvdock-run"
                assert bool(g.attrs["complete"])
        r = read_run(f, "/runs/diagonal/oracle")  # the same run layout as auvdock sim
    assert r.state.shape[1] == 12
    assert r.time_s[-1] == pytest.approx(3.0, abs=0.051)
    records, _ = read_campaign(path)
    ids = ["still/oracle", "still/naive", "diagonal/oracle", "diagonal/naive"]
    assert [x["run_id"] for x in records] == ids
    assert [(x["case"], x["controller"]) for x in records][2] == ("diagonal", "oracle")
    for x in records:
        assert x["status"] == "done" and not x["docked"] and x["attempts"] == 1 and x["error"] == ""
        assert x["wall_time_s"] > 0 and x["setup_time_s"] > 0  # closed loop and controller set-up apart
        assert x["worker"] and x["tolerance_m"] == 0.05
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
    assert "setup s" in md and "not included in wall s" in md
    csv_lines = (out / "summary.csv").read_text().splitlines()
    assert csv_lines[0] == ",".join(TABLE_COLUMNS)
    assert len(csv_lines) == 5
    assert "campaign wall time" in output and "controller set-up" in output
    # the throughput, and its arithmetic: runs / (wall s x cores)
    line = r"throughput: ([0-9.]+) runs per core-second \((\d+) runs in ([0-9.]+) s on (\d+) cores?\)"
    m = re.search(line, output)
    assert m is not None, output
    rate, runs, wall, cores = float(m[1]), int(m[2]), float(m[3]), int(m[4])
    assert runs == 4 and cores >= 1 and rate == pytest.approx(runs / (wall * cores), abs=6e-4, rel=0.05)


def test_compare_twice_into_one_folder_exits_2(campaign) -> None:
    out, _ = campaign
    res = _compare(out, "--no-plots")
    assert res.exit_code == 2
    assert res.stderr == (
        f"error: {out / 'campaign.h5'}: a campaign is already there; use --resume to continue it or "
        "--force to start again\n"
    )
    res = _compare(out, "--resume", "--force")
    assert res.exit_code == 2 and res.stderr == "error: --resume and --force: give one of them\n"


def test_resume_runs_nothing(campaign) -> None:
    out, _ = campaign
    path = out / "campaign.h5"
    with h5py.File(path, "r") as f:
        before = f["runs/still/oracle"].attrs["created_utc"]
        states = f["runs/still/oracle/state"][()]
        workers = list(f["campaign_table"]["worker"])
    res = _compare(out, "--resume", "--no-plots")
    assert res.exit_code == 0, res.output
    assert "resumed: 4 runs already complete, 0 run now" in res.output
    with h5py.File(path, "r") as f:
        assert f["runs/still/oracle"].attrs["created_utc"] == before
        assert np.array_equal(f["runs/still/oracle/state"][()], states)
        assert list(f["campaign_table"]["worker"]) == workers
        assert "compare" in f.attrs["resumed_with"]
        assert f.attrs["executor"] == "none (nothing to run)"


@pytest.mark.slow
def test_force_starts_again(campaign, tmp_path) -> None:
    out, _ = campaign
    shutil.copy(out / "campaign.h5", tmp_path / "campaign.h5")
    with h5py.File(tmp_path / "campaign.h5", "r+") as f:
        f.attrs["old"] = 1
    res = _compare(tmp_path, "--force", "--no-plots")
    assert res.exit_code == 0, res.output
    assert "resumed" not in res.output
    with h5py.File(tmp_path / "campaign.h5", "r") as f:
        assert "old" not in f.attrs and len(f["campaign_table"]) == 4
        assert "--force" in f.attrs["command_line"]


def test_report_regenerates_identical_tables(campaign, tmp_path) -> None:
    out, _ = campaign
    shutil.copy(out / "campaign.h5", tmp_path / "campaign.h5")
    res = runner.invoke(app, ["report", str(tmp_path / "campaign.h5")])
    assert res.exit_code == 0, res.output
    for name in ("summary.csv", "summary.md", "findings.md"):
        assert (tmp_path / name).read_bytes() == (out / name).read_bytes(), name
    for fig in FIGURES:
        assert (tmp_path / f"{fig}.png").is_file()


def test_a_file_that_is_not_ours_is_never_overwritten(tmp_path) -> None:
    (tmp_path / "campaign.h5").write_text("my notes")
    for flag in ("--force", "--resume"):
        res = _compare(tmp_path, flag)
        assert res.exit_code == 2
        head = f"error: {tmp_path / 'campaign.h5'}: exists and is not a readable HDF5 file"
        assert res.stderr.startswith(head)
    assert (tmp_path / "campaign.h5").read_text() == "my notes"


# ------------------------------------------------------------------------------ faults


def test_failure_in_one_run_does_not_stop_the_others(tmp_path) -> None:
    specs = campaign_specs(MISSIONS[:1], ["oracle", "naive"], timeout_s=2.0)
    res = run_campaign(
        specs, tmp_path / "campaign.h5", jobs=2, runner=functools.partial(inject, fail=["still/naive"])
    )
    by = {r["controller"]: r for r in res.records}
    assert by["naive"]["status"] == "failed"
    assert by["naive"]["error"] == "RuntimeError: injected failure"
    assert by["naive"]["attempts"] == 1  # a run that raises is not retried
    assert by["oracle"]["status"] == "done"
    assert res.errors == {"still/naive": "RuntimeError: injected failure"}
    with h5py.File(tmp_path / "campaign.h5", "r") as f:
        assert "runs/still/oracle" in f
        assert "runs/still/naive" not in f
        assert len(f["campaign_table"]) == 2
    row = [r for r in summary_rows(res.records) if r[1] == "naive"][0]
    assert row[2] == "failed"
    assert row[3] == "failed: RuntimeError: injected failure"


@pytest.mark.slow
def test_kill_9_of_a_worker_costs_only_its_run(tmp_path) -> None:
    """8 runs on 2 workers: the worker holding diagonal/naive is SIGKILLed once (the run is
    retried and completes), the one holding south/oracle every time (recorded as failed after
    its retry); the other runs are unaffected."""
    specs = campaign_specs(FOUR, CONTROLLERS, timeout_s=1.0)
    path = tmp_path / "campaign.h5"
    faults = functools.partial(
        inject, marker_dir=str(tmp_path), kill_once=["diagonal/naive"], kill_always=["south/oracle"]
    )
    res = run_campaign(specs, path, jobs=2, runner=faults)
    rows, _ = read_campaign(path)
    assert len(rows) == 8
    by = {r["run_id"]: r for r in rows}
    assert [r["run_id"] for r in rows if r["status"] == "failed"] == ["south/oracle"]
    assert by["south/oracle"]["attempts"] == 2
    assert re.fullmatch(
        r"its worker process \(pid \d+\) died: killed by SIGKILL; given up after 2 attempts",
        by["south/oracle"]["error"],
    )
    assert by["diagonal/naive"]["status"] == "done" and by["diagonal/naive"]["attempts"] == 2
    assert (tmp_path / "diagonal__naive.killed").exists()
    others = [r for k, r in by.items() if k not in ("south/oracle", "diagonal/naive")]
    assert len(others) == 6 and all(r["attempts"] == 1 and r["status"] == "done" for r in others)
    assert list(res.errors) == ["south/oracle"]


def test_ctrl_c_in_the_driver_keeps_finished_runs_and_resume_completes(tmp_path) -> None:
    specs = campaign_specs(MISSIONS[:1], ["oracle", "naive"], timeout_s=1.0)
    path = tmp_path / "campaign.h5"

    def stop(kind, spec, info):
        if kind == "done":
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_campaign(specs, path, jobs=1, on_event=stop)
    records, _ = read_campaign(path)  # readable, with the finished run
    assert [r["status"] for r in records] == ["done"]
    first = records[0]["run_id"]
    with pytest.raises(ResultsFileError):
        run_campaign(specs, path, jobs=1)  # neither resume nor force
    res = run_campaign(specs, path, jobs=1, resume=True)
    assert res.skipped == [first]
    assert len(res.ran) == 1 and res.ran[0] != first
    assert [r["status"] for r in res.records] == ["done", "done"]


def test_resume_with_other_settings_is_refused(tmp_path) -> None:
    path = tmp_path / "campaign.h5"
    run_campaign(campaign_specs(MISSIONS[:1], ["naive"], timeout_s=0.5), path, jobs=1)
    with pytest.raises(ResultsFileError, match="run still/naive there was made with other settings"):
        run_campaign(campaign_specs(MISSIONS[:1], ["naive"], timeout_s=0.6), path, jobs=1, resume=True)


def test_exception_in_run_is_recorded_not_raised() -> None:
    spec = campaign_specs(MISSIONS[:1], ["oracle"])[0]
    broken = dataclasses.replace(spec, overrides={"controller.horizon_steps": 0})
    out = execute_run(broken)
    assert out["row"]["status"] == "failed" and out["image"] is None
    assert out["row"]["error"].startswith("MissionError: still/oracle: controller.horizon_steps: ")


# ------------------------------------------------------------------------------ the command in a subprocess


def _driver(args: list[str], cwd: Path) -> subprocess.Popen:
    env = {**os.environ, "AUVDOCK_COMPILE": "never", "COLUMNS": "200"}
    return subprocess.Popen(
        [sys.executable, "-m", "auvdock", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for_finished_run(p: subprocess.Popen, lines: list[str]) -> None:
    """Read the driver's stdout until a run's outcome line (keeps reading in a thread)."""
    seen = threading.Event()

    def read() -> None:
        for line in p.stdout:
            lines.append(line)
            if re.search(r"(docked|timeout) [\d.]+ s\s+\(wall", line):
                seen.set()
        seen.set()

    threading.Thread(target=read, daemon=True).start()
    assert seen.wait(120), "".join(lines)


def _worker_pids(driver_pid: int) -> list[int]:
    import psutil

    return [
        c.pid
        for c in psutil.Process(driver_pid).children(recursive=True)
        if "spawn_main" in " ".join(c.cmdline())
    ]


def _alive(pid: int) -> bool:
    import psutil

    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


@pytest.mark.slow
def test_ctrl_c_subprocess_exits_130_and_resume_finishes(tmp_path) -> None:
    # 10 s runs (about 2 s each): when the first has finished, six are still to start, several
    # seconds of work for the two workers, so the SIGINT lands while the campaign runs (as the
    # kill -9 test below, with 4 s runs); no run docks by then, which this test does not need
    args = ["compare", *FOUR, "-c", "oracle,naive", "--timeout", "10", "--jobs", "2", "--out", str(tmp_path)]
    p = _driver([*args, "--no-plots"], tmp_path)
    lines: list[str] = []
    _wait_for_finished_run(p, lines)
    workers = _worker_pids(p.pid)
    p.send_signal(signal.SIGINT)  # the driver only, as a test; a terminal sends it to the group
    err = p.stderr.read()
    assert p.wait(60) == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == (
        f"interrupted: the finished runs are in {tmp_path / 'campaign.h5'}; continue with --resume"
    )
    records, _ = read_campaign(tmp_path / "campaign.h5")
    assert 1 <= len(records) < 8 and all(r["status"] == "done" for r in records)
    assert workers and not any(_alive(pid) for pid in workers)  # stopped with the driver
    res = runner.invoke(app, [*args, "--resume", "--no-plots"])
    assert res.exit_code == 0, res.output
    assert f"resumed: {len(records)} runs already complete, {8 - len(records)} run now" in res.output
    records, _ = read_campaign(tmp_path / "campaign.h5")
    assert len(records) == 8 and all(r["status"] == "done" for r in records)


@pytest.mark.slow
def test_kill_9_of_a_worker_from_outside(tmp_path) -> None:
    """A real worker of ``auvdock compare`` SIGKILLed from outside: 8 rows, at most one failed."""
    args = ["compare", *FOUR, "-c", "oracle,naive", "--timeout", "4", "--jobs", "2", "--out", str(tmp_path)]
    p = _driver([*args, "--no-plots"], tmp_path)
    lines: list[str] = []
    _wait_for_finished_run(p, lines)
    pids = _worker_pids(p.pid)
    assert len(pids) == 2, pids
    os.kill(pids[0], signal.SIGKILL)
    code = p.wait(180)
    out = "".join(lines)
    assert code in (0, 1), out + p.stderr.read()
    records, _ = read_campaign(tmp_path / "campaign.h5")
    assert len(records) == 8
    assert sum(r["status"] == "failed" for r in records) <= 1
    assert sum(r["status"] == "done" for r in records) >= 7


# ------------------------------------------------------------------------------ bad input


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
        "(known: naive, kinematic, oracle, sequential, optimized, ce)"
    )


def test_report_on_a_run_file_exits_2(tmp_path) -> None:
    p = tmp_path / "x.h5"
    with h5py.File(p, "w") as f:
        f.attrs["format"] = "auvdock-run"
    res = runner.invoke(app, ["report", str(p)])
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: {p}: not an auvdock campaign or sweep file (written by auvdock compare or auvdock sweep)"
    )


def test_report_on_an_old_campaign_file_exits_2(tmp_path) -> None:
    p = tmp_path / "campaign.h5"
    with h5py.File(p, "w") as f:
        f.attrs["format"] = "auvdock-campaign"
        f.attrs["format_version"] = 1
        f.create_dataset("campaign_table", data=np.zeros(1, dtype=[("case", "S8")]))
    res = runner.invoke(app, ["report", str(p)])
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: {p}: an auvdock results file of format version 1; this auvdock reads version 2 "
        "(run the campaign again)"
    )
