"""The dock's body and the capture criterion of a mission (``dock.body``, ``docking.capture``).

With ``docking.criterion: capture`` a simulated run ends *captured* (the vehicle's nose inside
the cradle, aligned and slow enough), *collided* (a hull point inside the dock's structure or
the WEC buoy, with the impact speed) or *timed out*; the geometry is
:mod:`auvdock.world.dock_body`'s.  ``criterion: point`` (default, the paper's) keeps the 5 cm
rule on the docking point.  Every default below is an assumption for a BlueROV2 docking cradle
(the paper gives no dimensions), stated in the field's description.
"""

from __future__ import annotations

from pydantic import Field

from auvdock.schema.strict import NonNegFloat, PosFloat, Strict
from auvdock.world.dock_body import CaptureLimits, DockBody, HullBox, WecBuoy

__all__ = ["DockBodySpec", "CaptureSpec"]


class DockBodySpec(Strict):
    """dock.body: the docking station as geometry in the dock frame (x along the docked heading)."""

    cradle_radius_m: PosFloat = Field(
        default=0.40,
        description="radius of the cradle the nose enters, m (the hull's half cross-diagonal: 0.317 m)",
    )
    cradle_depth_m: PosFloat = Field(default=0.30, description="length of the cradle, m")
    funnel_length_m: PosFloat = Field(default=0.60, description="length of the entry funnel, m")
    mouth_radius_m: PosFloat = Field(default=0.90, description="radius of the funnel's mouth, m")
    structure_half_width_m: PosFloat = Field(
        default=1.20, description="half-width of the frame around funnel and cradle (y and z), m"
    )
    back_plate_thickness_m: PosFloat = Field(default=0.05, description="thickness of the back plate, m")
    clearance_m: NonNegFloat | None = Field(
        default=None,
        description="gap from the docked vehicle's nose to the back plate, m (default: the back plate "
        "is the dock's marker panel, the plane of dock.markers)",
    )

    def build(
        self, hull: HullBox, buoy: WecBuoy | None = None, marker_plane_x_m: float | None = None
    ) -> DockBody:
        """The dock body for a vehicle of hull ``hull`` (its docked body origin at the docking point).

        ``marker_plane_x_m``: x_d of the dock's marker panel; without ``clearance_m`` the back
        plate's face is there (0.35 m for the default marker layout: 0.1215 m ahead of the docked
        Heavy's nose), else 0.05 m ahead of the nose."""
        if self.clearance_m is not None:
            clearance = float(self.clearance_m)
        elif marker_plane_x_m is not None:
            clearance = float(marker_plane_x_m) - float(hull.nose_b_m[0])
        else:
            clearance = 0.05
        return DockBody.for_hull(
            hull,
            clearance_m=clearance,
            cradle_radius_m=self.cradle_radius_m,
            cradle_depth_m=self.cradle_depth_m,
            funnel_length_m=self.funnel_length_m,
            mouth_radius_m=self.mouth_radius_m,
            structure_half_width_m=self.structure_half_width_m,
            back_plate_thickness_m=self.back_plate_thickness_m,
            buoy=buoy,
        )


class CaptureSpec(Strict):
    """docking.capture: when a vehicle in the cradle counts as captured."""

    max_heading_error_deg: PosFloat = Field(
        default=15.0, description="heading relative to the dock's, degrees"
    )
    max_pitch_roll_error_deg: PosFloat = Field(
        default=15.0, description="pitch and roll relative to the dock's, deg"
    )
    max_relative_speed_m_s: PosFloat = Field(
        default=0.3, description="speed relative to the dock at capture, m/s (an assumption: a latch's limit)"
    )
    nose_inside_depth_m: PosFloat = Field(
        default=0.10, description="how far past the cradle's entrance the nose is, m"
    )

    def build(self) -> CaptureLimits:
        """The capture limits."""
        return CaptureLimits(
            max_heading_error_deg=self.max_heading_error_deg,
            max_pitch_roll_error_deg=self.max_pitch_roll_error_deg,
            max_relative_speed_m_s=self.max_relative_speed_m_s,
            nose_inside_depth_m=self.nose_inside_depth_m,
        )
