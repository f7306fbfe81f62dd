"""The sweep's comparison of the explorers with certainty equivalence (auvdock.sweep.exploration), on
tables whose answers are known."""

from __future__ import annotations

import math

from auvdock.sweep.exploration import compare_regimes, exploration_report


def _rows(
    controller: str, speed: float, docked: int, n: int, t: float = 20.0, rel: float = 0.1
) -> list[dict]:
    return [
        {
            "controller": controller,
            "flow.speed_m_s": speed,
            "docked": i < docked,
            "time_to_dock_s": t if i < docked else math.nan,
            "relative_position_rmse_m": rel,
            "navigation_current_rmse_m_s": 0.05,
            "status": "done",
            "error": "",
        }
        for i in range(n)
    ]


def test_verdicts_follow_the_wilson_intervals():
    rows = (
        _rows("ce", 0.0, 20, 20) + _rows("sequential", 0.0, 19, 20)  # 95 % [75, 99] against [84, 100]
        + _rows("ce", 1.0, 6, 20) + _rows("sequential", 1.0, 18, 20, t=25.0, rel=0.05)  # [70, 97] > [15, 52]
        + _rows("ce", 2.0, 20, 20) + _rows("optimized", 2.0, 5, 20)  # [11, 47] < [84, 100]
    )  # fmt: skip
    comps = {(c.regime["flow.speed_m_s"], c.controller): c for c in compare_regimes(rows, ["flow.speed_m_s"])}
    assert comps[(0.0, "sequential")].verdict == "same"
    assert comps[(1.0, "sequential")].verdict == "beats"
    assert comps[(2.0, "optimized")].verdict == "loses"
    header, table, findings = exploration_report(rows, ["flow.speed_m_s"])
    assert len(table) == 3 and header[1] == "controller"
    seq = next(f for f in findings if f.startswith("sequential:"))
    assert seq.startswith("sequential: beats ce beyond the Wilson intervals in 1 of 2 regimes, loses in 0")
    assert "flow.speed_m_s = 1.0: 18/20 above 6/20." in seq
    assert "its median time is +2.5 s from ce's" in seq  # (25 - 20 and 20 - 20: median 2.5)
    assert "relative-position error: -0.025 m" in seq  # (0.05 - 0.1 and 0.1 - 0.1)
    opt = next(f for f in findings if f.startswith("optimized:"))
    assert "loses in 1" in opt and "flow.speed_m_s = 2.0: 5/20 below 20/20." in opt
    assert not any(f.startswith("No explorer") for f in findings)


def test_without_ce_there_is_nothing_to_compare_and_no_difference_is_said_so():
    assert exploration_report(_rows("sequential", 0.0, 5, 5), ["flow.speed_m_s"]) == (
        exploration_report([], ["flow.speed_m_s"])[0],
        [],
        [],
    )
    rows = _rows("ce", 0.5, 5, 5) + _rows("optimized", 0.5, 5, 5)
    _, _, findings = exploration_report(rows, ["flow.speed_m_s"])
    assert findings[-1].startswith("No explorer's success differs from ce's beyond the Wilson intervals")
