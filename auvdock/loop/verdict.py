"""The docking verdict of a flown vehicle: "docked" only when what it knows allows it.

In simulation the simulator is the judge: the closed loop compares the true state with the dock
(``sim``, ``compare``, ``sweep``).  A vehicle has no truth, and one noisy reading is not enough: a
position fix 1 cm noisy per axis is 3 cm off one time in twenty, so "the reading came within 5 cm"
is often wrong (a loopback rehearsal declared docked on a reading 0.042 m from the dock while the
vehicle was 0.082 m away).  :class:`MarginVerdict` (``fly`` and ``replay``) judges on the estimate the
controller flies on (the estimation stage's, at its own instant ``t``): its relative position to the
dock ``r`` and that position's covariance ``P``:

* ``estimation: filter``: the navigation filter's relative position and relative covariance once its
  dock states have taken a camera fix of the dock (a direct relative measurement); before one (or
  without a dock camera) the dock is where the mission charts it (Assumption 2) and the covariance is
  the filter's position covariance.  The dock is the one the estimate is relative to, where the stage
  placed it (:attr:`~auvdock.estimation.estimate.Estimate.dock_position_ned`): with the dock's telemetry
  its motion is the forecast from that telemetry, not the chart's (judged on the chart's motion, a basin
  rehearsal placed the nose 3-7 mm deeper than the filter's estimate did and declared two captures the
  truth had not yet made);
* ``estimation: truth``: the autopilot's position telemetry, the mean of its last five distinct
  readings (each carried to the newest along the relative velocity it was read with), with the
  position source's stated noise over five (isotropic; independent readings) and its slowly varying
  error whole (``sensors.position.bias_std_m``: the mean does not average it), plus the dock's own
  covariance where the dock is tracked by the camera (``dock.source: camera``: the fixes' Kalman
  covariance), taken as independent.

Where the vehicle is placed in the mission's frame (not relative to a camera-fixed dock) the frame's own
error is added (``frame_cov``: fly sets the frame on the mean of a few seconds of positions and, where
the frame turns by the vehicle's heading, headings; that heading's error turns every position about the
start, 1 cm at a dock 2 m away).

Docked when the 95 % confidence ellipsoid of the relative position lies inside the tolerance sphere,
checked by the sufficient condition ``|r| + k95 sqrt(lambda_max(P)) <= tolerance``, with
``k95 = sqrt(chi2_3(0.95)) = 2.7955`` (:data:`BOUND_95_3D`).  The results record the basis, the
estimated distance and the bound of the verdict.

With a 1 cm position noise alone one reading's margin is 2.8 cm, the mean of five readings' 1.25 cm;
a turned frame's heading error (2 deg over 2 s of headings) adds about 1 cm of std at the tank's dock.  A
vehicle whose estimate is never that certain is not declared docked (the run times out), and the
results record the smallest bound reached (``verdict_bound_m``).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from auvdock.loop.stages import LoopResult, Verdict
from auvdock.vehicle.geometry import rotation_zyx
from auvdock.vehicle.state import LIN, POS

if TYPE_CHECKING:
    from auvdock.estimation.estimate import Estimate
    from auvdock.loop.stages import ControlStage, DockModel, Observation

__all__ = ["BOUND_95_3D", "Verdict", "MarginVerdict", "CaptureVerdict", "DockingRule", "bound_95"]

#: Distinct position readings averaged by the telemetry basis (0.2 s of a 25 Hz stream).
TELEMETRY_MEAN = 5
#: sqrt of the chi-square 95 % quantile with 3 degrees of freedom: the 95 % ellipsoid of a 3-D
#: Gaussian is ``{x: (x - m)^T P^-1 (x - m) <= BOUND_95_3D^2}``.
BOUND_95_3D = 2.7954834829151074


def bound_95(distance_m: float, cov: np.ndarray) -> float:
    """The 95 % bound of a distance: ``distance_m + BOUND_95_3D sqrt(lambda_max(cov))`` (m), ``cov``
    the (3, 3) covariance of the relative position (m^2).  Every point of the 95 % ellipsoid is
    within this distance of the dock."""
    lam = float(np.max(np.linalg.eigvalsh(0.5 * (cov + cov.T))))
    return float(distance_m) + BOUND_95_3D * math.sqrt(max(lam, 0.0))


class MarginVerdict:
    """The docking rule of a flown vehicle (see the module docstring).

    Parameters
    ----------
    tolerance_m : float
        The docking tolerance, m.
    dock : DockModel
        The dock as the vehicle knows it (its charted or tracked position), NED m.
    position_std_m : float
        The noise std per axis of the position in an estimate without a covariance (``estimation:
        truth``: the autopilot's position telemetry), m.
    frame_cov : callable, optional
        ``frame_cov(p)`` (3, 3, m^2): what the mission frame's own error adds at position ``p`` (fly:
        :meth:`auvdock.fly.telemetry.TelemetrySensors.frame_cov`), for the bases that place the vehicle
        in the mission's frame (not a position relative to a camera-fixed dock).
    position_bias_std_m : float
        The std per axis of the position telemetry's slowly varying error, m
        (``sensors.position.bias_std_m``): added whole to the mean of the readings, which does not
        average it.

    Attributes
    ----------
    closest : Verdict or None
        The judgement with the smallest bound so far.
    """

    def __init__(
        self,
        tolerance_m: float,
        dock: DockModel,
        position_std_m: float,
        frame_cov: Callable[[np.ndarray], np.ndarray] | None = None,
        position_bias_std_m: float = 0.0,
    ) -> None:
        self.tolerance_m = float(tolerance_m)
        self.dock = dock
        self.position_std_m = float(position_std_m)
        self.position_bias_std_m = float(position_bias_std_m)
        self.frame_cov = frame_cov
        self.closest: Verdict | None = None
        self._recent: deque[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = deque()

    def reset(self) -> None:
        self.closest = None
        self._recent.clear()

    def judge(self, estimate: Estimate | None) -> Verdict | None:
        """The verdict on the newest estimate (None before one, and for None: the readings averaged so far
        are forgotten)."""
        if estimate is None:
            self._recent.clear()
            return None
        rel = estimate.state[POS] - self.dock_at(estimate)
        if estimate.relative_cov is not None and estimate.dock_fix_t is not None:
            basis, cov = "navigation filter's estimate", np.asarray(estimate.relative_cov, dtype=float)
        elif estimate.state_cov is not None:  # the dock as charted (no fix of it yet): the position's own
            basis, cov = "navigation filter's position", np.asarray(estimate.state_cov, dtype=float)[0:3, 0:3]
        else:
            rel, n = self._telemetry_mean(estimate, rel)
            basis = f"position telemetry, the mean of {n}" if n > 1 else "position telemetry"
            cov = np.eye(3) * (self.position_std_m**2 / n + self.position_bias_std_m**2)
            dock_cov = getattr(self.dock, "offset_covariance", None)
            if dock_cov is not None and getattr(self.dock, "process_noise", None) is not None:
                basis, cov = f"{basis}, and the camera's dock", cov + np.asarray(dock_cov, float)
        if self.frame_cov is not None and basis != "navigation filter's estimate":
            cov = cov + np.asarray(self.frame_cov(estimate.state[POS]), dtype=float)
        distance = float(np.linalg.norm(rel))
        verdict = Verdict(estimate.t, basis, distance, bound_95(distance, cov), self.tolerance_m)
        if self.closest is None or verdict.bound_m < self.closest.bound_m:
            self.closest = verdict
        return verdict

    def dock_at(self, estimate: Estimate) -> np.ndarray:
        """The docking point (3,, NED m) the estimate is relative to, at its instant: where the estimation
        stage placed it (:attr:`Estimate.dock_position_ned`, the dock the filter knows, whose telemetry-
        forecast motion may differ from the chart's by millimetres), else the mission's dock moved by the
        estimate's ``dock_offset_ned``."""
        if estimate.dock_position_ned is not None:
            return np.asarray(estimate.dock_position_ned, dtype=float)
        dock = np.asarray(self.dock.position(estimate.t), dtype=float)
        if estimate.dock_offset_ned is not None:
            dock = dock + estimate.dock_offset_ned
        return dock

    def _telemetry_mean(self, est: Estimate, rel: np.ndarray) -> tuple[np.ndarray, int]:
        """The relative position (3,, m) at ``est.t``: the mean of the last :data:`TELEMETRY_MEAN` distinct
        position readings, each carried to ``est.t`` along the relative velocity it was read with (the
        vehicle's over ground, from its attitude and body velocity, less the dock's); and how many."""
        x = np.asarray(est.state, dtype=float)
        v_rel = rotation_zyx(float(x[3]), float(x[4]), float(x[5])) @ x[LIN] - self.dock.velocity(est.t)
        recent = self._recent
        if recent and np.array_equal(recent[-1][3], x[POS]):  # the same reading again (no new telemetry)
            recent.pop()
        recent.append((float(est.t), rel.copy(), np.asarray(v_rel, dtype=float), x[POS].copy()))
        while len(recent) > TELEMETRY_MEAN:
            recent.popleft()
        carried = [r + v * (est.t - t) for t, r, v, _ in recent]
        return np.mean(carried, axis=0), len(carried)


class CaptureVerdict:
    """The capture rule of a flown vehicle (``docking.criterion: capture``): captured on what it knows.

    The judge of ``sim`` is the truth's contact with the dock's body
    (:func:`auvdock.world.dock_body.classify_contact`: the nose in the cradle, deep enough, aligned, slow
    enough, no hull point in the solid).  A vehicle judges the same on its estimate (the vehicle's state
    and the dock where its estimate places it, as :class:`MarginVerdict`), with a margin: the estimate
    moved back out of the cradle, along the dock's axis, by the 95 % radius of the relative position
    (``BOUND_95_3D sqrt(lambda_max(P))``) must still be captured.  The margin is along the axis only (the
    radial and angular limits are judged on the estimate itself).  A :class:`Verdict` with ``captured``
    set; ``bound_m - distance_m`` is the margin.

    Parameters
    ----------
    margin : MarginVerdict
        The point rule, for the relative position, its covariance and basis (its tolerance unused).
    contact : (DockBody, HullBox, CaptureLimits)
        The dock's body, the vehicle's hull and the capture limits
        (:meth:`auvdock.config.mission.Mission.build_contact`).
    """

    def __init__(self, margin: MarginVerdict, contact: tuple[Any, Any, Any]) -> None:
        self.margin = margin
        self.body, self.hull, self.limits = contact
        self.closest: Verdict | None = None

    @property
    def tolerance_m(self) -> float:
        return self.margin.tolerance_m

    def reset(self) -> None:
        self.closest = None
        self.margin.reset()

    def judge(self, estimate: Estimate | None) -> Verdict | None:
        """The capture verdict on the newest estimate (None before one)."""
        from auvdock.world.dock_body import classify_contact

        point = self.margin.judge(estimate)
        if point is None or estimate is None:
            return None
        dock = self.margin.dock
        p_dock = self.margin.dock_at(estimate)
        r95 = point.bound_m - point.distance_m
        h = float(dock.heading_rad)
        axis = np.array([math.cos(h), math.sin(h), 0.0])  # the cradle's axis x_d, into the dock
        x = np.asarray(estimate.state, dtype=float).copy()
        x[POS] = x[POS] - r95 * axis  # moved back out of the cradle by the 95 % radius
        contact = classify_contact(
            x, p_dock, dock.velocity(estimate.t), self.body, self.hull, self.limits, dock_heading_rad=h
        )
        verdict = Verdict(
            point.t,
            point.basis,
            point.distance_m,
            point.bound_m,
            point.tolerance_m,
            captured=contact.status == "captured",
        )
        best = self.closest
        if best is None or (not best.captured and (verdict.captured or verdict.bound_m < best.bound_m)):
            self.closest = verdict  # the first captured judgement, else the nearest
        return verdict


class DockingRule:
    """The loop's docking rule, judged at every period before the step (a stage of
    :mod:`auvdock.loop.stages`).

    In order: a non-finite state has diverged; the truth's contact with the dock's body (``docking.criterion:
    capture`` in simulation) captured or collided ends the run; then docked: on the state (the truth, in
    simulation) within ``tolerance_m`` of the dock, or with ``verdict`` on the control stage's newest
    estimate (a vehicle: the 95 % bound of :class:`MarginVerdict`, or captured with a margin,
    :class:`CaptureVerdict`), the estimate fresh (made at most two periods ago).

    Parameters
    ----------
    dock : DockModel
        The dock judged against.
    tolerance_m : float or None
        Docked within ``tolerance_m`` (m) of the dock; None: no verdict (a stand-in vehicle: the flight it
        serves decides).
    verdict : MarginVerdict or CaptureVerdict, optional
        A vehicle's rule on its estimate; None: on the state.
    """

    def __init__(
        self,
        dock: DockModel,
        tolerance_m: float | None,
        verdict: MarginVerdict | CaptureVerdict | None = None,
    ) -> None:
        self.dock = dock
        self.tolerance_m = tolerance_m
        self.verdict = verdict

    def judge(self, obs: Observation, stage: ControlStage, seeing: bool) -> tuple[float, LoopResult | None]:
        """(distance from the dock (m; NaN when diverged), the ending or None) at ``obs``; ``seeing``:
        the dock is in sight (the older camera tracker docks only while it sees it)."""
        t, x = obs.t, obs.state
        if not np.all(np.isfinite(x)):
            return math.nan, LoopResult("diverged", f"the state went non-finite at t = {t:.2f} s", t)
        dist = float(np.linalg.norm(x[POS] - self.dock.position(t)))
        touch = obs.contact
        if touch is not None and touch.status != "free":
            said = f"{touch.describe()} at t = {t:.2f} s"
            return dist, LoopResult(touch.status, said, t, touch.status == "captured", x.copy(), touch=touch)
        judged = None
        if self.verdict is not None and self.tolerance_m is not None:
            est, stepped = stage.last_estimate, stage.last_step_t  # the step that made it (not its age)
            fresh = est is not None and stepped is not None and t - stepped <= 2.0 * stage.dt + 1e-9
            judged = self.verdict.judge(est if fresh else None)
            inside = judged is not None and judged.docked
        else:
            inside = self.tolerance_m is not None and dist <= self.tolerance_m
        if not (inside and seeing):
            return dist, None
        said = f"docked at t = {t:.2f} s" + ("" if judged is None else f" ({judged.describe()})")
        return dist, LoopResult("docked", said, t, True, x.copy(), verdict=judged)

    def finish(self, result: LoopResult) -> None:
        """A run that ended otherwise carries the verdict's closest judgement."""
        if self.verdict is not None and result.verdict is None:
            result.verdict = self.verdict.closest
