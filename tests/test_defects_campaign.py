"""Campaign defects: findings of a campaign of some cases, ``--resume`` with other missions or
controllers, controller identity from the registry only.

The committed campaign (docs/compare) is the reference: its findings and summary tables are
rebuilt from its summary.csv and must come out as committed.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import re
from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from auvdock.campaign import check_findings, read_campaign, write_tables
from auvdock.campaign.compare import TABLE_COLUMNS
from auvdock.cli import app
from auvdock.controllers import registry

ROOT = Path(__file__).resolve().parents[1]
COMMITTED = ROOT / "docs" / "compare"
runner = CliRunner()


def _row(case: int, controller: str, docked: bool, t: float = 20.0) -> dict:
    return {
        "run_id": f"c{case}/{controller}", "case": f"c{case}", "case_label": f"case {case}",
        "paper_case": case, "controller": controller, "seed": 0, "status": "done", "error": "",
        "attempts": 1, "docked": docked,
        "reason": "docked" if docked else "timeout", "time_to_dock_s": t if docked else math.nan,
        "end_time_s": t if docked else 75.0, "timeout_s": 75.0, "tolerance_m": 0.05, "path_length_m": 3.6,
        "closest_approach_m": 0.049 if docked else 0.3, "contact_speed_m_s": 0.01, "flow_rmse_m_s": math.nan,
        "flow_final_error_m_s": math.nan, "solve_time_median_s": 0.002, "solve_time_p95_s": 0.003,
        "wall_time_s": 4.0, "setup_time_s": 0.5,
    }  # fmt: skip


def _by_finding(rows) -> dict:
    return {f.finding: f for f in check_findings(rows)}


# ------------------------------------------------------------------------- 1: findings over the cases run


def test_findings_of_a_campaign_of_two_cases_are_checked_on_those_cases(tmp_path) -> None:
    """Oracle ran and docked in the two cases given: "Oracle docks in all six cases" holds over
    cases 1 and 2, and says it covers those only (it said "not run")."""
    rows = [_row(1, "oracle", True), _row(2, "oracle", True)]
    f = _by_finding(rows)["Oracle MPC docks in all six cases"]
    assert f.verdict == "holds"
    assert (
        f.measured == "over cases 1, 2 only (no finished run in 3, 4, 5, 6): docks in 1, 2; times out in none"
    )
    write_tables(rows, tmp_path, {"command_line": "auvdock compare still diagonal -c oracle"})
    md = (tmp_path / "findings.md").read_text()
    assert (
        "This campaign ran paper cases 1, 2 only (no finished run in 3, 4, 5, 6): each finding is checked on "
        "the cases it ran, and says so." in md
    )
    assert (
        "| Oracle MPC docks in all six cases | over cases 1, 2 only (no finished run in 3, 4, 5, 6): " in md
    )
    assert "| Naive MPC docks in cases 1 and 5 only | cases run: none | not run |  |" in md


def test_a_subset_finding_that_differs_explains_from_the_cases_run() -> None:
    """Naive MPC should dock in case 1 only of {1, 2}; docking in case 2 as well differs, and the
    explanation names case 2, and nothing about the cases not run."""
    rows = [
        _row(1, "naive", True),
        _row(2, "naive", True, 19.5),
        _row(1, "oracle", True),
        _row(2, "oracle", True),
    ]
    f = _by_finding(rows)["Naive MPC docks in cases 1 and 5 only"]
    assert f.verdict == "differs"
    assert f.measured.startswith("over cases 1, 2 only (no finished run in 3, 4, 5, 6): docks in 1, 2")
    assert f.explanation.startswith("Docks where the paper's times out: case 2 at 19.50 s.")
    assert "case 5" not in f.explanation.lower()


def test_flow_rmse_clearly_is_not_held_against_cases_not_run() -> None:
    rows = []
    for c in (1, 2):
        for ctrl, rmse in (("sequential", 0.06), ("optimized", 0.03)):
            r = _row(c, ctrl, True)
            r["flow_rmse_m_s"] = rmse
            rows.append(r)
    f = _by_finding(rows)["Flow RMSE: Optimized < Sequential, clearly so in cases 2 and 4"]
    assert f.verdict == "holds"
    assert f.measured.endswith("; 'clearly' not checked in case 4 (not run)")


def _committed_rows() -> list[dict]:
    kinds = {"str": str, "int": int, "float": float, "bool": lambda v: v == "True"}
    with (COMMITTED / "summary.csv").open() as fh:
        return [{k: kinds[TABLE_COLUMNS[k]](v) for k, v in r.items()} for r in csv.DictReader(fh)]


def _table_lines(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith("|")]


def test_the_committed_campaign_tables_are_unchanged(tmp_path) -> None:
    """All six cases: findings.md's and summary.md's tables come out exactly as committed (and
    findings.md gets no coverage sentence)."""
    rows = _committed_rows()
    assert len(rows) == 60
    cmd = re.search(r"Made with `(.*)` \(auvdock ([^)]*)\)", (COMMITTED / "summary.md").read_text())
    write_tables(rows, tmp_path, {"command_line": cmd.group(1), "auvdock_version": cmd.group(2)})
    assert (tmp_path / "summary.md").read_text() == (COMMITTED / "summary.md").read_text()
    new, old = (tmp_path / "findings.md").read_text(), (COMMITTED / "findings.md").read_text()
    assert _table_lines(new) == _table_lines(old)
    assert "This campaign ran" not in new


# ------------------------------------------------------------------------------ 2: --resume with another set


def _compare(out: Path, *args: str):
    return runner.invoke(
        app, ["compare", *args, "--timeout", "0.3", "--jobs", "1", "--out", str(out), "--no-plots"]
    )


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("resume")
    res = _compare(out, "still", "-c", "oracle,naive")
    assert res.exit_code == 0, res.output + res.stderr
    return out


def _state(out: Path) -> tuple:
    with h5py.File(out / "campaign.h5", "r") as f:
        return len(f["campaign_table"]), str(f.attrs["command_line"]), "resumed_with" in f.attrs


@pytest.mark.parametrize(
    ("args", "made_with", "asks_for"),
    [
        (["still", "-c", "oracle"], "controllers oracle,naive", "oracle"),
        (["still", "-c", "oracle,naive,sequential"], "controllers oracle,naive", "oracle,naive,sequential"),
        (["still", "diagonal", "-c", "oracle,naive"], "missions still", "still,diagonal"),
        (["diagonal", "-c", "oracle"], "missions still and controllers oracle,naive",
         "missions diagonal and controllers oracle"),
    ],
)  # fmt: skip
def test_resume_with_other_missions_or_controllers_is_refused(
    small_campaign, args, made_with, asks_for
) -> None:
    before = _state(small_campaign)
    res = _compare(small_campaign, *args, "--resume")
    assert res.exit_code == 2, res.output
    assert (
        res.stderr
        == f"error: --resume: {small_campaign}/ was made with {made_with}; this run asks for {asks_for}\n"
    )
    assert _state(small_campaign) == before  # nothing ran, nothing recorded


def test_resume_with_the_same_set_in_another_order_goes_on(small_campaign) -> None:
    res = _compare(small_campaign, "still", "-c", "naive,oracle", "--resume")
    assert res.exit_code == 0, res.output + res.stderr
    assert "resumed: 2 runs already complete, 0 run now" in res.output


def test_resume_of_a_file_written_before_the_sets_were_recorded(small_campaign, tmp_path) -> None:
    """A campaign file without the missions/controllers attributes: its table says what it holds."""
    (tmp_path / "campaign.h5").write_bytes((small_campaign / "campaign.h5").read_bytes())
    with h5py.File(tmp_path / "campaign.h5", "r+") as f:
        del f.attrs["missions"], f.attrs["controllers"]
    res = _compare(tmp_path, "still", "-c", "oracle", "--resume")
    assert res.exit_code == 2
    assert (
        res.stderr
        == f"error: --resume: {tmp_path}/ was made with controllers oracle,naive; this run asks for oracle\n"
    )


def test_the_small_campaign_findings_say_what_they_cover(small_campaign) -> None:
    """compare on one case: the findings are checked on case 1 and say so (Oracle "differs" over
    case 1 here -- a 0.3 s timeout -- instead of "not run")."""
    md = (small_campaign / "findings.md").read_text()
    assert "This campaign ran paper case 1 only (no finished run in 2, 3, 4, 5, 6)" in md
    assert (
        "| Oracle MPC docks in all six cases | over case 1 only (no finished run in 2, 3, 4, 5, 6): "
        "docks in none; times out in 1 | differs | Case 1: timeout at 0.3 s" in md
    )
    records, attrs = read_campaign(small_campaign / "campaign.h5")
    assert attrs["missions"] == ["still"] and sorted(attrs["controllers"]) == ["naive", "oracle"]


# ------------------------------------------------------------------------------ 8: controller identity


def test_figures_take_names_order_and_colours_from_the_registry() -> None:
    from auvdock.campaign import plots

    assert plots.CONTROLLER_ORDER == tuple(registry.CONTROLLERS) == registry.controller_names()
    assert plots.CONTROLLER_LABELS == {n: e.label for n, e in registry.CONTROLLERS.items()}
    assert plots.CONTROLLER_COLORS == {n: e.colour for n, e in registry.CONTROLLERS.items()}
    # the committed figures' identity, unchanged
    assert plots.CONTROLLER_COLORS == {
        "naive": "#D55E00", "kinematic": "#E69F00", "oracle": "#009E73", "sequential": "#0072B2",
        "optimized": "#CC79A7", "ce": "#000000",
    }  # fmt: skip
    assert plots.controller_label("oracle@paper") == "oracle@paper"  # variants: shown by their spec
    assert plots._controller_linestyle("oracle", 7) == (0, (5, 2))


def test_findings_take_display_names_from_the_registry(monkeypatch) -> None:
    entries = dict(registry.CONTROLLERS)
    entries["oracle"] = dataclasses.replace(entries["oracle"], label="Oracle-X MPC", short_label="OracleX")
    monkeypatch.setattr(registry, "CONTROLLERS", entries)
    findings = [f.finding for f in check_findings([_row(1, "oracle", True)])]
    assert "Oracle-X MPC docks in all six cases" in findings
    assert "Travel time: Optimized > Sequential > OracleX" in findings


def test_bench_defaults_to_the_registry(monkeypatch) -> None:
    import inspect

    from auvdock.campaign import bench

    assert inspect.signature(bench.bench_rows).parameters["controllers"].default is None


def test_no_module_retypes_controller_identity_or_estimation_modes() -> None:
    """Display names and the controller list live in the registry; ("truth", "filter") in
    auvdock.estimation.stage.ESTIMATION_MODES."""
    names = [e.label for e in registry.CONTROLLERS.values()]
    order = ", ".join(f'"{n}"' for n in registry.CONTROLLERS)
    for path in sorted((ROOT / "auvdock" / "campaign").glob("*.py")):
        text = path.read_text()
        for label in names:
            assert f'"{label}"' not in text, (path.name, label)
        assert f"({order})" not in text, path.name
    for path in sorted((ROOT / "auvdock" / "cli").glob("*.py")):
        text = path.read_text()
        assert '("truth", "filter")' not in text, path.name
        assert "naive | kinematic" not in text, path.name


def test_estimation_choices_come_from_the_estimation_stage(monkeypatch) -> None:
    from auvdock.estimation import stage

    monkeypatch.setattr(stage, "ESTIMATION_MODES", ("truth", "filter", "magic"))
    for command in (["sim", "still"], ["compare", "still"], ["fly", "tank_positioned"]):
        res = runner.invoke(app, [*command, "--estimation", "nope"])
        assert res.exit_code == 2, res.output
        assert res.stderr == "error: --estimation: must be truth, filter or magic (got 'nope')\n"
