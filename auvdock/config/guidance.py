"""The mission's ``guidance`` section (the approach and the lost-target policy with a dock camera) and
the guidance's phases as recorded.  The guidance itself is :mod:`auvdock.loop.guidance`'s."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from auvdock.schema.strict import PosFloat, Strict

__all__ = ["GUIDANCE_PHASES", "GuidanceSettings"]

#: ``guidance_phase`` codes recorded per step (index into this tuple).
GUIDANCE_PHASES = ("approach", "transit", "search", "align", "coast", "back_off", "given_up")


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
    look_at_dock: bool = Field(
        default=True,
        description="once the dock has been seen, away from the entry tube (align, back off, search) the "
        "heading is the bearing to where the dock is believed to be, so that the camera keeps it in view; "
        "false: the dock's heading",
    )
    give_up_s: PosFloat = Field(
        default=45.0,
        description="no camera fix for this long (or none this long after the start): give up, zero "
        "thrust, the run ends (reason lost_target), s",
    )
