"""The dock's entry as the docking MPC sees it: a corridor of soft constraints (:class:`EntryCorridor`).

Docking means entering the dock's funnel and cradle without touching them
(:mod:`auvdock.world.dock_body`).  The MPC tracks the docking point; with an entry corridor its
cost also keeps every predicted state (k = 1..N) out of the dock's structure except through the
funnel, at a closing speed that falls to a contact speed at the cradle, with the heading turned
to the dock's as the vehicle closes in.  In the dock frame {d} (x_d along the dock's heading,
origin at the docking point), for the vehicle's body origin at ``x_d = s`` with ``r`` its
distance from the axis, ``d = max(0, x_c - s)`` its distance ahead of the point ``x_c`` where the
nose reaches the cradle's entrance and ``D = d + max(0, r - r_c)`` its distance from the cradle's
mouth::

    max(x_f - s, r - r_s, r_c + tan(half-angle) d - r) >= 0   (out of the structure, or in the cone)
    v_close       <= v_contact + a_close D                    (closing speed on the axis, m/s)
    |psi - psi_d| <= psi_0 + k_psi D                          (heading, rad)

The first is "in front of the structure's face (the nose short of the mouth, ``x_f``), or clear
of its sides (``r_s`` = the frame's half-width plus the hull's half cross-section diagonal), or
inside the funnel's cone".  ``r_c`` = cradle radius minus the hull's half-diagonal (an aligned hull
then fits the cradle), and the cone's taper is the funnel's, so that at the funnel's mouth the
cone is the mouth minus the hull's half-diagonal.  The frame's square sides are taken as the
circle through their midpoints.  The corridor is local, as every MPC constraint over a short
horizon is: it stops a plan that would cut through the frame or strike the funnel, but it does not
find the way round the dock from beside it; the guidance does (:mod:`auvdock.loop.guidance`: the
standoff point on the axis first, then the approach).  A vehicle behind the back plate is not
planned around it.

Each bound is a soft constraint with a quadratic penalty on its violation, ``w max(0, g)^2``
(a residual of the Gauss-Newton cost, so the QP keeps its stage structure; Kerrigan and
Maciejowski 2000 on soft constraints), weighted by :class:`EntrySpec`'s weights.  Where the
estimate places the dock (the steering target's position plus its standoff), the corridor
moves with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca

if TYPE_CHECKING:
    from auvdock.controllers.settings import EntrySpec
    from auvdock.world.dock_body import DockBody, HullBox

__all__ = ["EntryCorridor", "entry_residuals"]


@dataclass(frozen=True)
class EntryCorridor:
    """The corridor's geometry and weights (see the module docstring).

    Attributes
    ----------
    cradle_x_m : float
        ``x_c``: x_d of the body origin when the nose is at the cradle's entrance, m.
    face_x_m : float
        ``x_f``: x_d of the body origin when the nose is at the structure's face (the mouth), m.
    side_radius_m : float
        ``r_s``: the frame's half-width plus the hull's half cross-section diagonal, m.
    cradle_radius_m : float
        ``r_c``: the corridor's radius there (cradle radius minus the hull's half cross-section
        diagonal), m.
    taper : float
        ``tan(half-angle)`` of the funnel's cone.
    contact_speed_m_s, deceleration_1_s : float
        ``v_contact`` (m/s) and ``a_close`` (1/s).
    heading_margin_rad, heading_slope_rad_m : float
        ``psi_0`` (rad) and ``k_psi`` (rad/m).
    weights : tuple of 3 floats
        Penalties on the cone (1/m^2), the closing speed (s^2/m^2) and the heading (1/rad^2).
    """

    cradle_x_m: float
    face_x_m: float
    side_radius_m: float
    cradle_radius_m: float
    taper: float
    contact_speed_m_s: float
    deceleration_1_s: float
    heading_margin_rad: float
    heading_slope_rad_m: float
    weights: tuple[float, float, float]

    @classmethod
    def for_dock(cls, spec: EntrySpec, body: DockBody, hull: HullBox) -> EntryCorridor:
        """The corridor of ``body`` for a vehicle of hull ``hull``, with ``spec``'s speeds and weights."""
        return cls(
            cradle_x_m=float(body.cradle_entrance_x_m - hull.nose_b_m[0]),
            face_x_m=float(body.mouth_x_m - hull.nose_b_m[0]),
            side_radius_m=float(body.structure_half_width_m + hull.half_cross_diagonal_m),
            cradle_radius_m=max(0.0, body.cradle_radius_m - hull.half_cross_diagonal_m),
            taper=math.tan(body.half_angle_rad),
            contact_speed_m_s=float(spec.contact_speed_m_s),
            deceleration_1_s=float(spec.deceleration_1_s),
            heading_margin_rad=math.radians(spec.heading_margin_deg),
            heading_slope_rad_m=math.radians(spec.heading_slope_deg_m),
            weights=(float(spec.lateral_weight), float(spec.speed_weight), float(spec.heading_weight)),
        )


def entry_residuals(
    corridor: EntryCorridor,
    position_ned: ca.SX,
    velocity_ned: ca.SX,
    yaw: ca.SX,
    dock_point_ned: ca.SX,
    dock_velocity_ned: ca.SX,
    dock_heading: ca.SX,
    active: ca.SX,
) -> ca.SX:
    """The three violations (3,) of one predicted state: ``active max(0, g_i)`` for the structure, the
    closing speed and the heading (module docstring), each to be weighted by ``corridor.weights``.

    ``position_ned``, ``velocity_ned`` (3, m, m/s over ground) and ``yaw`` (rad) of the vehicle;
    ``dock_point_ned``, ``dock_velocity_ned`` (3) of the docking point; ``dock_heading`` (rad, within
    pi of ``yaw``); ``active`` 1 or 0.
    """
    axis = ca.vertcat(ca.cos(dock_heading), ca.sin(dock_heading), 0)
    rel = position_ned - dock_point_ned
    along = ca.dot(axis, rel)
    off = rel - along * axis
    r = ca.sqrt(ca.dot(off, off) + 1e-8)
    d = ca.fmax(0, corridor.cradle_x_m - along)
    D = d + ca.fmax(0, r - corridor.cradle_radius_m)
    closing = ca.dot(axis, velocity_ned - dock_velocity_ned)
    clear = ca.fmax(
        ca.fmax(corridor.face_x_m - along, r - corridor.side_radius_m),
        corridor.cradle_radius_m + corridor.taper * d - r,
    )
    g_speed = closing - (corridor.contact_speed_m_s + corridor.deceleration_1_s * D)
    g_yaw = ca.fabs(yaw - dock_heading) - (corridor.heading_margin_rad + corridor.heading_slope_rad_m * D)
    return active * ca.vertcat(ca.fmax(0, -clear), ca.fmax(0, g_speed), ca.fmax(0, g_yaw))
