"""``compare --sea``: the basin and PacWave cases beside the paper's six, never counted as paper cases, and
what findings.md says of them computed from their rows."""

from __future__ import annotations

import math

from auvdock.campaign.compare import campaign_specs, compare_plan
from auvdock.campaign.sea_findings import sea_findings
from auvdock.config.catalog import SEA_MISSIONS, resolve


def test_the_sea_cases_are_not_paper_cases_whatever_their_current():
    specs = campaign_specs([resolve("gyre"), *(resolve(m) for m in SEA_MISSIONS)], ["oracle"])
    labels = {s.labels["case"]: s.labels for s in compare_plan(specs).specs}
    assert labels["gyre"]["paper_case"] == 5
    # both sea missions name the paper's still water (case 1) as their current
    assert labels["basin_regular"]["paper_case"] == 0
    assert labels["pacwave_common_10m"]["paper_case"] == 0
    assert "regular waves H 0.127 m, T 1.67 s" in labels["basin_regular"]["case_label"]
    assert "JONSWAP Hs 1.75 m, Tp 9.44 s" in labels["pacwave_common_10m"]["case_label"]


def _row(case: str, controller: str, reason: str, t: float = math.nan, **more) -> dict:
    return {
        "case": case,
        "paper_case": 0,
        "controller": controller,
        "status": "done",
        "docked": reason == "captured",
        "reason": reason,
        "time_to_dock_s": t,
        **more,
    }


def test_findings_at_sea_say_how_each_run_ended_and_the_gap_to_oracle():
    rows = [
        _row("basin", "oracle", "captured", 17.5),
        _row("basin", "ce", "captured", 18.25),
        _row("basin", "sequential", "collided", contact_what="funnel wall", impact_speed_m_s=0.12),
        _row("sea", "oracle", "captured", 30.0),
        _row("sea", "ce", "lost_target"),
        {**_row("paper", "oracle", "captured", 20.0), "paper_case": 2},
    ]
    text = sea_findings(rows)
    assert "### basin" in text and "### sea" in text and "### paper" not in text
    assert "- sequential: collided (funnel wall, 0.12 m/s)" in text
    assert "the soonest, ce, in 18.2 s, +0.8 s against oracle (told the truth)" in text
    assert "Deployable controllers that docked: 1 of 2" in text
    assert "- No deployable controller docked (1 ran); oracle (told the truth) did." in text
    assert sea_findings([rows[-1]]) == ""
