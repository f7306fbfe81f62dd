"""The sweep summary's "Oracle against the best deployable controller" (auvdock.sweep.oracle_gap) on a
hand-made run table: groups, the best deployable, the gaps and the findings, from the rows alone."""

from __future__ import annotations

import math

from auvdock.sweep.oracle_gap import oracle_gap_report


def _runs(hs: float, controller: str, captured: list[float | None]) -> list[dict]:
    return [
        {
            "sea.waves.hs_m": hs,
            "sensors.suite": "acoustic+camera",
            "controller": controller,
            "docked": t is not None,
            "time_to_dock_s": math.nan if t is None else t,
        }
        for t in captured
    ]


def test_the_gap_is_oracle_against_the_deployable_controller_that_captured_most():
    rows = (
        _runs(1.0, "oracle", [20.0, 22.0, 24.0, 26.0])
        + _runs(1.0, "ce", [30.0, None, None, None])
        + _runs(1.0, "sequential", [28.0, 32.0, None, None])
        + _runs(2.75, "oracle", [40.0, None, None, None])
        + _runs(2.75, "ce", [35.0, None, None, None])
        + _runs(2.75, "sequential", [45.0, None, None, None])
    )
    header, body, findings = oracle_gap_report(rows, ["sea.waves.hs_m", "sensors.suite", "seed"])
    assert header[:2] == ["sea.waves.hs_m", "sensors.suite"]
    first, second = body
    assert first[2:5] == ["4/4 [51-100 %]", "23.0 s", "sequential"]
    assert first[5:] == ["2/4 [15-85 %]", "30.0 s", "+50 pp", "7.0 s"]
    # a tie in captures goes to the sooner median time
    assert second[4:6] == ["ce", "1/4 [5-70 %]"] and second[7:] == ["+0 pp", "-5.0 s"]
    assert findings == [
        "Oracle captures more than the best deployable controller in 1 of 2 sea states (x suites); its 95 % "
        "interval lies wholly above the best deployable's in 0."
    ]


def test_no_table_without_oracle_or_without_a_sea_field():
    rows = _runs(1.0, "ce", [30.0]) + _runs(1.0, "sequential", [31.0])
    assert oracle_gap_report(rows, ["sea.waves.hs_m"]) == ([], [], [])
    assert oracle_gap_report(_runs(1.0, "oracle", [1.0]) + rows, ["seed"]) == ([], [], [])
