"""What the controllers steer to, and what they do when the camera loses the dock.

Between the estimation stage and the controller (:class:`auvdock.loop.autopilot.Autopilot`), the
guidance turns the estimate into the target every controller tracks: a
:class:`SteeringTarget`, the dock's motion as the mission charts it, moved to where the
navigation filter places the dock (its anchor, anchored by the camera's fixes) and, in some
phases, to a standoff point in front of the dock's entry or turned away from its heading.
The controllers track it as they track a dock (position, velocity and heading over the
horizon), so the same policy serves every controller, in ``sim``, ``fly`` and ``replay``.

With a dock camera (``sensors.dock_camera``, ``estimation: filter``) the guidance is a small
state machine on the age of the newest camera fix (:class:`Guidance`; the settings are the
mission's ``guidance`` section, :class:`GuidanceSettings`):

==========  ==========================================================================
phase       what the controllers steer to
==========  ==========================================================================
transit     the dock has never been seen: the standoff point ``standoff_m`` in front of
            the dock's entry, on its axis, by dead reckoning
search      at the standoff point (within ``arrive_m``, by the estimate) and nothing seen:
            the standoff point moved over the relative uncertainty (three standard deviations
            of the vehicle's position relative to the dock, at most ``search_max_m``): towards
            the dock along its axis and back over one sweep, across it over two, while the heading sweeps
            ``+- search_yaw_deg`` about the bearing to the dock (the dock's heading if never
            seen), period ``search_period_s``
align       seen, but not yet in the entry tube (in front of the entry, within ``arrive_m``
            of the dock's axis, no farther than the standoff point): the standoff point
hold        in the entry tube with ``entry_gate`` (and the dock's body): the hold point ``gate_m``
            in front of the docking point on its axis, moving with the dock, until the entry's
            window opens (:meth:`Guidance._window`: on the axis within ``gate_offset_m``, the
            estimate as sure, crossing it slower than ``gate_speed_m_s``, for ``gate_hold_s``)
approach    in the entry tube, a fix within :data:`FRESH_FIX_S` (and the window opened): the dock
            itself; back to ``hold`` (an abort, counted) when the cross-axis offset predicted
            ``abort_lead_s`` ahead leaves the funnel's cone before the nose reaches the cradle
coast       approaching, no fix for up to ``coast_s``: the dock, on the filter's prediction
back_off    no fix for longer: the standoff point (moving back widens what the camera
            covers), at the dock's heading; arrived there and still nothing: search
given_up    no fix for ``give_up_s`` (or never, ``give_up_s`` after the start), once the search
            has covered its pattern (two sweep periods; or could not start for that long): the
            controller step reports ``lost_target`` with zero thrust and the run ends
==========  ==========================================================================

Once the dock has been seen, away from the entry tube (align, back off, search) the heading held is
the bearing from the vehicle to where the dock is believed to be (``look_at_dock``), so that a
glimpse of the dock is not lost by turning away from it; on the dock's axis that bearing is the
dock's heading.  (In transit the heading is the dock's: turning towards a dock not yet seen, by dead
reckoning, in a current, cost more than it found -- measured on paper cases 2 and 3.)  A fix
returns to ``align`` or, in the entry tube, ``approach``.  Every loss (a fix older than ``coast_s``)
is a :class:`LostTrack` event with how it ended: re-acquired (in which phase, after how long) or
not at all (the run ended).  Without a dock camera the guidance steers to the dock all the
time (the paper's Assumption 2, or absolute positioning), except where the controller holds the
dock's entry corridor (``entry``; :mod:`auvdock.controllers.entry`): then, until the vehicle is in
the entry tube, it steers to the standoff point (``align``), and from there to the dock
(``approach``, kept once begun) -- the way round the dock that a corridor over a short horizon
cannot find from beside it.

Frames: NED positions (m), headings clockwise from north (rad), times on the mission clock (s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from auvdock.config.guidance import GUIDANCE_PHASES, GuidanceSettings
from auvdock.vehicle.geometry import rotation_zyx
from auvdock.world.dock import TranslatingDock

if TYPE_CHECKING:
    from auvdock.controllers.entry import EntryCorridor
    from auvdock.estimation.estimate import Estimate, HeaveError
    from auvdock.world.dock import DockMotion

__all__ = [
    "GUIDANCE_SERIES",
    "SteeringTarget",
    "LostTrack",
    "Guidance",
    "lost_track_summary",
]

#: A fix at most this old (s) is fresh: ``approach``; older, up to ``coast_s``: ``coast`` (four
#: frames of the 15 Hz camera missed).
FRESH_FIX_S = 0.25
#: Per-step series the guidance records (name -> per-row shape).
GUIDANCE_SERIES: dict[str, tuple[int, ...]] = {"guidance_phase": (), "dock_fix_age_s": ()}


class SteeringTarget(TranslatingDock):
    """The target the controllers track: a dock's motion, moved and turned by the guidance.

    ``position(t) = dock.position(t) + offset + e3 heave_error(t) + R_z(heading) (-standoff, 0, 0)``, its
    velocity the dock's plus the heave error's rate, its heading the dock's plus ``yaw_offset_rad``.
    ``offset`` (3,, NED m) is where the estimation stage places the dock relative to the mission's;
    ``heave_error`` (:class:`~auvdock.estimation.estimate.HeaveError`, or None) the docking point's heave
    beyond the dock's forecast motion, as the navigation filter estimates it and runs it forward;
    ``standoff_m`` (m) moves the target in front of the dock's entry along its axis.

    Parameters
    ----------
    dock : DockMotion
        The dock as the mission charts it (the paper's sinusoid, or a WEC buoy's heave).
    """

    def __init__(self, dock: DockMotion) -> None:
        self.dock = dock
        self.offset = np.zeros(3)
        self.standoff_m = 0.0
        self.yaw_offset_rad = 0.0
        self.heave_error: HeaveError | None = None
        #: The search's shift of the target (NED, m): a pattern over the relative uncertainty.
        self.search_shift = np.zeros(3)

    @property
    def heading_rad(self) -> float:  # type: ignore[override]
        """The heading to hold at the target, rad."""
        return float(self.dock.heading_rad) + self.yaw_offset_rad

    @property
    def entry_heading_rad(self) -> float:
        """The dock's heading (its entry's axis, without the guidance's yaw offset), rad."""
        return float(self.dock.heading_rad)

    @property
    def position_ned_m(self) -> tuple[float, float, float]:
        """The target's anchor: the dock's, moved as the target is (NED, m)."""
        n, e, d = np.asarray(self.dock.position_ned_m, dtype=float) + self._shift()
        return float(n), float(e), float(d)

    def _shift(self) -> np.ndarray:
        psi = float(self.dock.heading_rad)
        return (
            self.offset + self.search_shift - self.standoff_m * np.array([math.cos(psi), math.sin(psi), 0.0])
        )

    def position(self, t: float | np.ndarray) -> np.ndarray:
        """The target's position (NED, m) at time(s) ``t`` (s), shape (..., 3)."""
        p = np.asarray(self.dock.position(t), dtype=float) + self._shift()
        if self.heave_error is not None:
            p[..., 2] += self.heave_error.ahead(t)[0]
        return p

    def velocity(self, t: float | np.ndarray) -> np.ndarray:
        """The target's velocity (NED, m/s): the dock's, with the heave error's rate."""
        v = np.array(self.dock.velocity(t), dtype=float)
        if self.heave_error is not None:
            v[..., 2] += self.heave_error.ahead(t)[1]
        return v

    def dock_position(self, t: float) -> np.ndarray:
        """Where the estimation stage places the docking point at ``t`` (NED, m)."""
        p = np.asarray(self.dock.position(t), dtype=float) + self.offset
        if self.heave_error is not None:
            p = p.copy()
            p[2] += float(self.heave_error.ahead(t)[0])
        return p


@dataclass
class LostTrack:
    """One loss of the dock: the camera's last fix before it (s), when the loss began (s: the
    fix became older than ``coast_s``), when it ended (s; None while it lasts), and how
    (``reacquired in PHASE``, or what ended the run)."""

    last_fix_t: float
    t_lost: float
    t_end: float | None = None
    ended: str = ""

    @property
    def duration_s(self) -> float:
        """Seconds without a fix, from the last fix to the end of the loss (NaN while it lasts)."""
        return math.nan if self.t_end is None else self.t_end - self.last_fix_t


class Guidance:
    """The guidance of one run (see the module docstring).

    Parameters
    ----------
    settings : GuidanceSettings
        The mission's ``guidance``.
    dock : DockMotion
        The dock as the mission charts it.
    camera : bool
        The vehicle finds the dock with its camera (``sensors.dock_camera`` with ``estimation:
        filter``); False: steer to the dock all the time (but see ``entry``).
    entry : bool
        Without a camera: approach through the standoff point on the dock's axis (the controller
        holds the dock's entry corridor).
    corridor : EntryCorridor, optional
        The dock's entry corridor (its funnel's cone): with ``entry_gate``, the entry is timed on it
        (:meth:`_window`, :meth:`_abort`).  None: no gate.
    """

    def __init__(
        self,
        settings: GuidanceSettings,
        dock: DockMotion,
        camera: bool,
        entry: bool = False,
        corridor: EntryCorridor | None = None,
    ) -> None:
        self.settings = settings
        self.camera = bool(camera)
        self.entry = bool(entry) and not self.camera
        self.corridor = corridor if settings.entry_gate else None
        self.target = SteeringTarget(dock)
        self.reset()

    @property
    def records(self) -> bool:
        """Whether the guidance's phases are worth recording (a camera, or the way through the entry)."""
        return self.camera or self.entry

    def reset(self) -> None:
        """Start a new run: nothing seen yet."""
        self.phase = "transit" if self.camera else "align" if self.entry else "approach"
        self.target.offset = np.zeros(3)
        self.target.heave_error = None
        self.target.search_shift = np.zeros(3)
        self._search_extent = np.zeros(2)
        self.target.standoff_m = self.settings.standoff_m if self.camera or self.entry else 0.0
        self.target.yaw_offset_rad = 0.0
        self.events: list[LostTrack] = []
        #: Entries aborted back to the hold point (``entry_gate``).
        self.aborts = 0
        self._window_since: float | None = None
        self._search_t0: float | None = None
        self._last_fix: float | None = None
        #: The instant of the camera's first fix of the dock, s (None: not seen yet).
        self.first_fix_t: float | None = None

    def _set(self, phase: str, t: float, est: Estimate) -> None:
        s = self.settings
        if phase == "search" and self.phase != "search":
            self._search_t0 = t
            self._search_extent = self._search_span(est)
        self.phase = phase
        standoff = {
            "transit": s.standoff_m,
            "search": s.standoff_m,
            "align": s.standoff_m,
            "back_off": s.standoff_m,
        }
        standoff["hold"] = s.gate_m
        self.target.standoff_m = standoff.get(phase, 0.0)
        # once the dock has been seen, away from the entry tube the camera looks where the dock is
        # believed to be: the heading is the bearing to it (the dock's heading once on its axis), and
        # the search sweeps about that bearing
        looking = phase in ("align", "back_off", "search", "hold") and self._last_fix is not None
        look = self._bearing_offset(est) if looking and s.look_at_dock else 0.0
        self.target.search_shift = np.zeros(3)
        if phase == "search":
            assert self._search_t0 is not None
            w = 2.0 * math.pi / s.search_period_s
            tau = t - self._search_t0
            look += math.radians(s.search_yaw_deg) * math.sin(w * tau)
            # along the dock's axis over one sweep period, across it over two: the relative uncertainty's
            # 3-sigma extent in both, while the heading sweeps;
            psi = float(self.target.dock.heading_rad)
            # forward only (a dock nearer than believed is in view; one farther is not), and back, at
            # most search_max_m * w / 2 fast (0.39 m/s for 2.5 m in 20 s)
            along, across = self._search_extent * np.array(
                [0.5 * (1.0 - math.cos(w * tau)), math.sin(0.5 * w * tau)]
            )
            self.target.search_shift = along * np.array(
                [math.cos(psi), math.sin(psi), 0.0]
            ) + across * np.array([-math.sin(psi), math.cos(psi), 0.0])
        self.target.yaw_offset_rad = look

    def _search_span(self, est: Estimate) -> np.ndarray:
        """The search's extent along and across the dock's axis (2,, m): three standard deviations of the
        vehicle's position relative to the dock (the estimate's), at most ``search_max_m``."""
        s = self.settings
        if est.relative_cov is None:
            return np.full(2, s.search_max_m)
        psi = float(self.target.dock.heading_rad)
        C = np.asarray(est.relative_cov, dtype=float)
        axes = np.array([[math.cos(psi), math.sin(psi), 0.0], [-math.sin(psi), math.cos(psi), 0.0]])
        sig = np.sqrt(np.clip(np.einsum("ij,jk,ik->i", axes, C, axes), 0.0, None))
        return np.minimum(3.0 * sig, s.search_max_m)

    def _searched(self, t: float) -> bool:
        """Whether the search has covered its pattern once (two sweep periods) by ``t``."""
        return self._search_t0 is not None and t - self._search_t0 >= 2.0 * self.settings.search_period_s

    def _bearing_offset(self, est: Estimate) -> float:
        """The bearing from the vehicle (by the estimate) to the docking point, relative to the dock's
        heading, rad, wrapped to [-pi, pi); 0 within ``arrive_m`` of the dock (no bearing to speak of)."""
        rel = self.target.dock_position(float(est.t)) - np.asarray(est.state[0:3], dtype=float)
        if math.hypot(rel[0], rel[1]) < self.settings.arrive_m:
            return 0.0
        off = math.atan2(rel[1], rel[0]) - float(self.target.dock.heading_rad)
        return (off + math.pi) % (2.0 * math.pi) - math.pi

    def update(self, est: Estimate) -> dict[str, np.ndarray]:
        """Move the target for the estimate ``est`` of one instant; the series to record."""
        t = float(est.t)
        if est.dock_offset_ned is not None:
            self.target.offset = np.asarray(est.dock_offset_ned, dtype=float).copy()
        self.target.heave_error = est.dock_heave_error
        if not self.camera:
            if self.entry:  # through the standoff point into the entry tube, then the dock
                if self.phase == "approach":
                    phase = self._entering(est, t)
                elif self.phase == "hold" or self._in_entry(est):
                    phase = self._gate(est, t, fresh=True)
                else:
                    phase = "align"
                self._set(phase, t, est)
            code = float(GUIDANCE_PHASES.index(self.phase))
            return {"guidance_phase": np.asarray(code), "dock_fix_age_s": np.asarray(math.nan)}
        s = self.settings
        fix = est.dock_fix_t
        age = math.inf if fix is None else t - fix
        if fix is not None and (self._last_fix is None or fix > self._last_fix):
            if self.events and self.events[-1].t_end is None:  # a loss ends: re-acquired
                ev = self.events[-1]
                ev.t_end, ev.ended = fix, f"reacquired in {self.phase}"
            self._last_fix = fix
            if self.first_fix_t is None:
                self.first_fix_t = float(fix)
        if self.phase == "given_up":
            phase = "given_up"
        elif fix is None:  # never seen
            # give up only once the search has covered the relative uncertainty (or could not start)
            if t > s.give_up_s and (self._searched(t) or t > s.give_up_s + 2.0 * s.search_period_s):
                phase = "given_up"
            elif self.phase == "transit" and self._at_standoff(est):
                phase = "search"
            else:
                phase = self.phase
        elif age <= s.coast_s:
            if self.phase in ("approach", "coast"):
                phase = "approach" if age <= FRESH_FIX_S else "coast"
                if phase == "approach":
                    phase = self._entering(est, t)
            elif self.phase == "hold" or self._in_entry(est):
                phase = self._gate(est, t, fresh=age <= FRESH_FIX_S)
            else:
                phase = "align"
        else:  # seen before, lost now
            phase = self.phase
            if self.phase in ("approach", "coast", "align", "transit", "hold"):
                self.events.append(LostTrack(fix, fix + s.coast_s))
                phase = "back_off"
            if age > s.give_up_s and (self._searched(t) or age > s.give_up_s + 2.0 * s.search_period_s):
                self._close_loss(t, "given up")
                phase = "given_up"
            elif phase == "back_off" and self._at_standoff(est):
                phase = "search"
        self._set(phase, t, est)
        return {
            "guidance_phase": np.asarray(float(GUIDANCE_PHASES.index(self.phase))),
            "dock_fix_age_s": np.asarray(age if math.isfinite(age) else math.nan),
        }

    def _at_standoff(self, est: Estimate) -> bool:
        p = np.asarray(est.state[0:3], dtype=float)
        return float(np.linalg.norm(p - self.target.position(float(est.t)))) <= self.settings.arrive_m

    def _in_entry(self, est: Estimate) -> bool:
        """The vehicle (by the estimate) is in the entry tube: in front of the dock's entry, no
        farther than the standoff point (plus ``arrive_m``), within ``arrive_m`` of the axis."""
        t = float(est.t)
        psi = float(self.target.dock.heading_rad)
        rel = np.asarray(est.state[0:3], dtype=float) - self.target.dock_position(t)
        along = rel[0] * math.cos(psi) + rel[1] * math.sin(psi)  # dock x: ahead of the entry < 0
        across = math.hypot(-rel[0] * math.sin(psi) + rel[1] * math.cos(psi), rel[2])
        s = self.settings
        return -(s.standoff_m + s.arrive_m) <= along < 0.0 and across <= s.arrive_m

    # --- the entry timed to the sea ---------------------------------------------------------------
    def _cross_axis(self, est: Estimate) -> tuple[float, np.ndarray, np.ndarray]:
        """The vehicle's position along the dock's axis relative to the docking point (m; ahead of the entry
        < 0), its offset from the axis (3,, NED m) and its velocity across the axis relative to the dock's
        (3,, m/s), by the estimate."""
        t = float(est.t)
        psi = float(self.target.dock.heading_rad)
        axis = np.array([math.cos(psi), math.sin(psi), 0.0])
        x = np.asarray(est.state, dtype=float)
        rel = x[0:3] - self.target.dock_position(t)
        along = float(axis @ rel)
        v = rotation_zyx(float(x[3]), float(x[4]), float(x[5])) @ x[6:9] - np.asarray(
            self.target.velocity(t), dtype=float
        )
        return along, rel - along * axis, v - float(axis @ v) * axis

    def _window(self, est: Estimate) -> bool:
        """Whether the entry's window is open now: on the axis within ``gate_offset_m`` (and the estimate as
        sure of it), moving across it relative to the dock slower than ``gate_speed_m_s``."""
        s = self.settings
        _, off, v = self._cross_axis(est)
        sure = True
        if est.relative_cov is not None:
            sure = (
                math.sqrt(max(float(np.max(np.linalg.eigvalsh(np.asarray(est.relative_cov)))), 0.0))
                <= s.gate_offset_m
            )
        return (
            float(np.linalg.norm(off)) <= s.gate_offset_m
            and float(np.linalg.norm(v)) <= s.gate_speed_m_s
            and sure
        )

    def _gate(self, est: Estimate, t: float, fresh: bool) -> str:
        """In the entry tube: hold, or go in once the window has stayed open ``gate_hold_s`` (with
        a fresh fix);
        without a gate, go in at once (``coast`` on a stale fix, as before)."""
        if self.corridor is None:
            return "approach" if fresh else "coast"
        if not self._window(est):
            self._window_since = None
            return "hold"
        if self._window_since is None:
            self._window_since = t
        if fresh and t - self._window_since >= self.settings.gate_hold_s - 1e-9:
            self._window_since = None
            return "approach"
        return "hold"

    def _entering(self, est: Estimate, t: float) -> str:
        """Going in: abort to the hold point (``hold``) when the cross-axis offset predicted ``abort_lead_s``
        ahead leaves the funnel's cone where the vehicle will then be, before the nose reaches the cradle."""
        c = self.corridor
        if c is None:
            return "approach"
        along, off, v = self._cross_axis(est)
        if along >= c.cradle_x_m:  # the nose is in the cradle: committed
            return "approach"
        lead = self.settings.abort_lead_s
        ahead = float(np.linalg.norm(off + lead * v))
        allowed = c.cradle_radius_m + c.taper * max(0.0, c.cradle_x_m - along)
        if ahead > allowed:
            self.aborts += 1
            self._window_since = None
            return "hold"
        return "approach"

    def _close_loss(self, t: float, how: str) -> None:
        if self.events and self.events[-1].t_end is None:
            self.events[-1].t_end, self.events[-1].ended = t, how

    def finish(self, t: float, how: str) -> None:
        """The run ended at ``t`` (s) by ``how`` (captured, collided, timeout, ...): a loss still
        open ends with it."""
        self._close_loss(t, f"not reacquired ({how})")


def lost_track_summary(events: list[LostTrack], first_fix_t: float | None = None) -> dict[str, object]:
    """Outcome figures of a run's losses: their number, how many were re-acquired, the longest
    gap (s), and how each ended (``"3.20-4.85 s: reacquired in back_off; ..."``); and the instant
    the camera first saw the dock (``dock_first_seen_s``, s; NaN: never seen, so no loss either)."""
    back = [e for e in events if e.ended.startswith("reacquired")]
    longest = max((e.duration_s for e in events if e.t_end is not None), default=math.nan)
    return {
        "dock_first_seen_s": math.nan if first_fix_t is None else float(first_fix_t),
        "lost_track_events": len(events),
        "lost_track_reacquired": len(back),
        "lost_track_longest_s": float(longest),
        "lost_track_log": "; ".join(
            f"{e.last_fix_t:.2f}-{'' if e.t_end is None else f'{e.t_end:.2f}'} s: {e.ended or 'open'}"
            for e in events
        ),
    }
