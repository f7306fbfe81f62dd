"""The dock's entry corridor in the MPC's cost (:mod:`auvdock.controllers.entry`): its geometry from the
dock's body, its violations at points worked out by hand, and a start beside the dock that, without the
corridor and the way in through the standoff point, ends in the dock's frame."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from auvdock.controllers.entry import EntryCorridor, entry_residuals
from auvdock.controllers.settings import EntrySpec
from auvdock.world.dock_body import DockBody, HullBox

HULL = HullBox()
BODY = DockBody.for_hull(HULL)  # back plate 0.05 m ahead of the docked nose
C = EntryCorridor.for_dock(EntrySpec(), BODY, HULL)


def _g(p, v=(0.0, 0.0, 0.0), yaw=0.0, heading=0.0):
    """The three violations for the dock at the origin facing ``heading``, not moving."""
    return np.asarray(
        ca.DM(
            entry_residuals(
                C, ca.DM(p), ca.DM(v), ca.DM(yaw), ca.DM.zeros(3), ca.DM.zeros(3), ca.DM(heading), ca.DM(1.0)
            )
        )
    ).ravel()


def test_the_corridor_is_the_funnels_cone_less_the_hull():
    nose = 0.2285
    assert C.cradle_radius_m == pytest.approx(0.40 - math.hypot(0.575, 0.254) / 2)  # 0.086 m
    assert C.taper == pytest.approx(0.5 / 0.6)  # mouth 0.9 m, cradle 0.4 m, funnel 0.6 m
    assert C.cradle_x_m == pytest.approx(BODY.back_x_m - 0.30 - nose)
    assert C.face_x_m == pytest.approx(BODY.back_x_m - 0.90 - nose)
    assert C.side_radius_m == pytest.approx(1.2 + math.hypot(0.575, 0.254) / 2)
    # at the mouth the cone is the mouth less the hull's half-diagonal
    assert C.cradle_radius_m + C.taper * (C.cradle_x_m - C.face_x_m) == pytest.approx(0.9 - 0.3142, abs=1e-3)


def test_on_the_axis_in_front_and_beside_the_frame_nothing_is_violated():
    assert np.allclose(_g([-3.0, 0.0, 0.0]), 0.0)  # on the axis, ahead
    assert np.allclose(_g([-3.0, 2.5, 0.4]), 0.0)  # ahead of the face, off the axis
    assert _g([0.0, 2.0, 0.0])[0] == 0.0  # beside the frame, clear of it


def test_inside_the_frame_the_violation_is_the_shortest_way_out():
    # beside the funnel, level with the cradle's entrance: out sideways (r_s - r), forwards
    # (x - x_f) or into the cone (r - r_c): the least of the three
    x, r = C.cradle_x_m, 0.8
    expected = min(C.side_radius_m - r, x - C.face_x_m, r - C.cradle_radius_m)
    assert _g([x, 0.0, r])[0] == pytest.approx(expected, abs=1e-6)
    # the same point for a dock facing east: x_d is east, the offset r to the north
    assert _g([r, x, 0.0], heading=math.pi / 2)[0] == pytest.approx(expected, abs=1e-6)


def test_closing_fast_and_turned_away_near_the_cradle_are_violations():
    x = C.cradle_x_m - 0.2  # 0.2 m ahead of the cradle's entrance, on the axis
    speed = _g([x, 0, 0], v=(0.5, 0, 0))[1]
    assert speed == pytest.approx(0.5 - (C.contact_speed_m_s + C.deceleration_1_s * 0.2))
    assert _g([x, 0, 0], v=(-0.5, 0, 0))[1] == 0.0  # backing off
    yaw = _g([x, 0, 0], yaw=0.5)[2]
    assert yaw == pytest.approx(0.5 - (C.heading_margin_rad + C.heading_slope_rad_m * 0.2))


BESIDE = [[2.0, 2.2, 1.0, 0, 0, 0, 0, 0, 0, 0, 0, 0], [2.0, -2.2, 1.0, 0, 0, math.pi / 2, 0, 0, 0, 0, 0, 0]]


@pytest.mark.parametrize("start", BESIDE, ids=["east", "west-facing-east"])
def test_a_start_beside_the_dock_is_brought_round_to_its_entry(start):
    """basin_regular with motion capture, the vehicle started level with the dock 2.2 m to one side
    (the straight line to the docking point crosses the dock's frame): with the entry corridor and the
    way in through the standoff point, Certainty-equivalent MPC captures without collision; with them
    switched off it strikes the frame."""
    import auvdock
    from auvdock.sensing.suites import suite_updates

    fields = {**suite_updates("motion_capture"), "start.state": start, "seed": 0}
    on = auvdock.simulate("basin_regular", controller="ce", **fields)
    assert on.outcome["reason"] == "captured" and not on.outcome["collided"], on.outcome
    recorded = np.asarray(on.series["guidance_phase"])
    phases = set(recorded[np.isfinite(recorded)].astype(int).tolist())
    assert phases == {0, 3}  # align (to the standoff point), then approach
    off = auvdock.simulate("basin_regular", controller="ce", **fields, **{"controller.entry.enabled": False})
    assert off.outcome["reason"] == "collided", off.outcome
    assert off.outcome["contact_what"] == "structure face"
