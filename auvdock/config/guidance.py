"""The mission's ``guidance`` section (the approach and the lost-target policy with a dock camera) and
the guidance's phases as recorded.  The guidance itself is :mod:`auvdock.loop.guidance`'s."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from auvdock.schema.strict import PosFloat, Strict

__all__ = ["GUIDANCE_PHASES", "GuidanceSettings"]

#: ``guidance_phase`` codes recorded per step (index into this tuple).
GUIDANCE_PHASES = ("approach", "transit", "search", "align", "coast", "back_off", "given_up", "hold")


class GuidanceSettings(Strict):
    """The mission's ``guidance`` section: the approach and the lost-target policy (with a dock camera)."""

    standoff_m: PosFloat = Field(
        default=1.5,
        description="the standoff point's distance in front of the docking point, on the dock's axis, m "
        "(at 1.5 m the default camera sees the whole marker panel, its 0.15 m marker 38 px wide)",
    )
    arrive_m: PosFloat = Field(
        default=0.3,
        description="within this distance of the standoff point (by the estimate) it is reached, and the "
        "final approach starts within this distance of the dock's axis, m",
    )
    coast_s: PosFloat = Field(
        default=1.0, description="no camera fix for this long: stop flying on the prediction and back off, s"
    )
    search_yaw_deg: Annotated[float, Field(gt=0, le=180)] = Field(
        default=45.0,
        description="the search's heading sweep about the bearing to the dock (about the dock's heading "
        "while it has never been seen), +- deg",
    )
    search_period_s: PosFloat = Field(default=20.0, description="period of one search sweep, s")
    search_max_m: PosFloat = Field(
        default=2.5,
        description="the search's largest excursion along and across the dock's axis, m: the search "
        "moves the standoff point over three standard deviations of the vehicle's position relative to the "
        "dock (the navigation filter's), towards the dock along its axis and back over one sweep period and "
        "across it over two, at most this far",
    )
    look_at_dock: bool = Field(
        default=True,
        description="once the dock has been seen, away from the entry tube (align, back off, search) the "
        "heading is the bearing to where the dock is believed to be, so that the camera keeps it in view; "
        "false: the dock's heading",
    )
    entry_gate: bool = Field(
        default=False,
        description="time the entry to the sea: in the entry tube, hold on the dock's axis gate_m "
        "in front of "
        "the docking point, moving with the dock, until the vehicle has sat within gate_offset_m "
        "of the axis, "
        "its cross-axis speed relative to the dock within gate_speed_m_s, for gate_hold_s; then go in, and "
        "abort back to the hold when the cross-axis offset predicted abort_lead_s ahead leaves the funnel's "
        "cone (the entry corridor's) before the nose reaches the cradle (false: go in as soon as the vehicle "
        "is in the entry tube).  Needs the dock's body (docking.criterion: capture)",
    )
    gate_m: PosFloat = Field(
        default=1.0,
        description="the hold point's distance in front of the docking point on the dock's axis, m (outside "
        "the shipped dock's funnel, whose mouth the body origin reaches 0.78 m out)",
    )
    gate_offset_m: PosFloat = Field(
        default=0.04,
        description="cross-axis offset from the dock's axis (by the estimate) allowed to go in, "
        "m: about half "
        "the cradle's clearance (0.086 m on the shipped dock's BlueROV2 cradle)",
    )
    gate_speed_m_s: PosFloat = Field(
        default=0.05, description="cross-axis speed relative to the dock allowed to go in, m/s"
    )
    gate_hold_s: PosFloat = Field(
        default=0.5,
        description="how long both must hold before going in, s (the window's start, not a guess)",
    )
    abort_lead_s: PosFloat = Field(default=0.5, description="how far ahead the abort test looks, s")
    give_up_s: PosFloat = Field(
        default=45.0,
        description="no camera fix for this long (or none this long after the start), and the search has "
        "covered its pattern once (two sweep periods): give up, zero thrust, the run ends (reason "
        "lost_target), s",
    )
