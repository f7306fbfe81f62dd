"""The guidance (auvdock.loop.guidance): the approach through a standoff point and the lost-target
policy, as a state machine on the estimates it is handed, and in the closed loop on the camera."""

from __future__ import annotations

import math

import numpy as np
import pytest

from auvdock.config.guidance import GUIDANCE_PHASES, GuidanceSettings
from auvdock.estimation.estimate import Estimate
from auvdock.loop.guidance import Guidance, lost_track_summary
from auvdock.world.dock import HeaveDock

DOCK = HeaveDock(position_ned_m=(2.0, 0.0, 1.0), heading_rad=0.0)  # entry from the south, at rest


def _est(t: float, p: tuple[float, float, float], fix: float | None, offset=(0.0, 0.0, 0.0)) -> Estimate:
    x = np.zeros(12)
    x[0:3] = p
    return Estimate(t, x, dock_offset_ned=np.array(offset, dtype=float), dock_fix_t=fix)


def test_without_a_camera_the_target_is_the_dock_where_the_estimate_places_it():
    g = Guidance(GuidanceSettings(), DOCK, camera=False)
    series = g.update(_est(0.0, (0.0, 0.0, 1.0), None, offset=(0.1, -0.2, 0.0)))
    assert g.phase == "approach" and g.target.standoff_m == 0.0 and g.target.yaw_offset_rad == 0.0
    np.testing.assert_allclose(g.target.position(0.0), [2.1, -0.2, 1.0])
    assert math.isnan(float(series["dock_fix_age_s"]))


def test_transit_to_the_standoff_point_then_search_when_nothing_is_seen():
    s = GuidanceSettings()
    g = Guidance(s, DOCK, camera=True)
    g.update(_est(0.0, (0.0, 0.0, 1.0), None))
    assert g.phase == "transit"
    np.testing.assert_allclose(g.target.position(0.0), [2.0 - s.standoff_m, 0.0, 1.0])  # on the axis
    assert g.target.heading_rad == 0.0
    g.update(_est(5.0, (0.5, 0.1, 1.0), None))  # 0.1 m from the standoff point: arrived
    assert g.phase == "search"
    g.update(_est(5.0 + s.search_period_s / 4, (0.5, 0.1, 1.0), None))  # a quarter sweep later
    assert g.target.yaw_offset_rad == pytest.approx(math.radians(s.search_yaw_deg), rel=1e-6)
    g.update(_est(s.give_up_s + 0.1, (0.5, 0.1, 1.0), None))
    assert g.phase == "given_up"


def test_seen_off_the_axis_align_facing_the_dock_then_approach_in_the_entry_tube():
    g = Guidance(GuidanceSettings(), DOCK, camera=True)
    g.update(_est(1.0, (0.0, 1.0, 1.0), fix=0.9))  # seen from the south-east of the entry
    assert g.phase == "align" and g.target.standoff_m == 1.5
    # it faces the dock: the bearing from (0, 1) to (2, 0)
    assert g.target.yaw_offset_rad == pytest.approx(math.atan2(-1.0, 2.0), rel=1e-9)
    g.update(_est(3.0, (0.6, 0.1, 1.0), fix=2.95))  # on the axis, 1.4 m in front: the entry tube
    assert g.phase == "approach" and g.target.standoff_m == 0.0 and g.target.yaw_offset_rad == 0.0
    np.testing.assert_allclose(g.target.position(3.0), [2.0, 0.0, 1.0])


def test_a_loss_coasts_backs_off_searches_and_ends_reacquired():
    s = GuidanceSettings()
    g = Guidance(s, DOCK, camera=True)
    g.update(_est(1.0, (1.0, 0.0, 1.0), fix=0.95))
    assert g.phase == "approach"
    g.update(_est(1.5, (1.1, 0.0, 1.0), fix=0.95))  # 0.55 s without a fix
    assert g.phase == "coast" and g.target.standoff_m == 0.0
    g.update(_est(2.0, (1.1, 0.0, 1.0), fix=0.95))  # 1.05 s: lost
    assert g.phase == "back_off" and g.target.standoff_m == s.standoff_m
    assert len(g.events) == 1 and g.events[0].t_end is None
    g.update(_est(4.0, (0.5, 0.0, 1.0), fix=0.95))  # back at the standoff point, still nothing
    assert g.phase == "search"
    series = g.update(_est(6.0, (0.5, 0.0, 1.0), fix=5.9))
    assert g.phase == "approach"
    assert GUIDANCE_PHASES[int(series["guidance_phase"])] == "approach"
    ev = g.events[0]
    assert (ev.last_fix_t, ev.t_end, ev.ended) == (0.95, 5.9, "reacquired in search")
    assert ev.duration_s == pytest.approx(4.95)
    summary = lost_track_summary(g.events)
    assert summary["lost_track_events"] == 1 and summary["lost_track_reacquired"] == 1
    assert summary["lost_track_log"] == "0.95-5.90 s: reacquired in search"


def test_a_loss_still_open_ends_with_the_run():
    g = Guidance(GuidanceSettings(), DOCK, camera=True)
    g.update(_est(1.0, (1.0, 0.0, 1.0), fix=0.95))
    g.update(_est(3.0, (1.0, 0.0, 1.0), fix=0.95))
    g.finish(3.0, "timeout")
    assert lost_track_summary(g.events)["lost_track_log"] == "0.95-3.00 s: not reacquired (timeout)"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_tank_trial_captures_on_the_camera_alone(seed):
    """tank_0p6hz as shipped: no position source, the dock found by its markers through the camera,
    the start and the dock drawn per seed; Certainty-equivalent MPC captures in the dock's body
    without collision, and the filter's relative-position error at the end is centimetres."""
    import auvdock

    run = auvdock.simulate("tank_0p6hz", controller="ce", seed=seed)
    o = run.outcome
    assert o["reason"] == "captured", o
    assert not o["collided"] and o["relative_position_final_error_m"] < 0.03
    phases = {GUIDANCE_PHASES[int(p)] for p in run.series["guidance_phase"] if np.isfinite(p)}
    assert "approach" in phases
