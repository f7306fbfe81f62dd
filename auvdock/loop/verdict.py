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
  the filter's position covariance;
* ``estimation: truth``: the autopilot's position telemetry with the position source's stated noise
  (isotropic), plus the dock's own covariance where the dock is tracked by the camera
  (``dock.source: camera``: the fixes' Kalman covariance), taken as independent.

Docked when the 95 % confidence ellipsoid of the relative position lies inside the tolerance sphere,
checked by the sufficient condition ``|r| + k95 sqrt(lambda_max(P)) <= tolerance``, with
``k95 = sqrt(chi2_3(0.95)) = 2.7955`` (:data:`BOUND_95_3D`).  The results record the basis, the
estimated distance and the bound of the verdict.

With a 1 cm position noise the estimate's margin is 2.8 cm: the estimate must come within 2.2 cm
of a 5 cm tolerance.  A vehicle whose estimate is never that certain is not declared docked (the
run times out), and the results record the smallest bound reached (``verdict_bound_m``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from auvdock.vehicle.state import POS

if TYPE_CHECKING:
    from auvdock.estimation.estimate import Estimate
    from auvdock.loop.closed_loop import DockModel

__all__ = ["BOUND_95_3D", "Verdict", "MarginVerdict", "bound_95"]

#: sqrt of the chi-square 95 % quantile with 3 degrees of freedom: the 95 % ellipsoid of a 3-D
#: Gaussian is ``{x: (x - m)^T P^-1 (x - m) <= BOUND_95_3D^2}``.
BOUND_95_3D = 2.7954834829151074


def bound_95(distance_m: float, cov: np.ndarray) -> float:
    """The 95 % bound of a distance: ``distance_m + BOUND_95_3D sqrt(lambda_max(cov))`` (m), ``cov``
    the (3, 3) covariance of the relative position (m^2).  Every point of the 95 % ellipsoid is
    within this distance of the dock."""
    lam = float(np.max(np.linalg.eigvalsh(0.5 * (cov + cov.T))))
    return float(distance_m) + BOUND_95_3D * math.sqrt(max(lam, 0.0))


@dataclass(frozen=True)
class Verdict:
    """One judgement of the docking rule.

    Attributes
    ----------
    t : float
        The instant judged, s (mission clock): the estimate's.
    basis : str
        What was judged: ``"navigation filter's estimate"``, ``"navigation filter's position"``,
        ``"position telemetry"`` (``estimation:
        truth``), ``"position telemetry and the camera's dock"`` (see the module docstring).
    distance_m : float
        The estimated distance of the vehicle from the dock, m.
    bound_m : float
        Its 95 % bound, m.
    tolerance_m : float
        The docking tolerance, m.
    """

    t: float
    basis: str
    distance_m: float
    bound_m: float
    tolerance_m: float

    @property
    def docked(self) -> bool:
        """The 95 % bound is inside the tolerance."""
        return self.bound_m <= self.tolerance_m

    def describe(self) -> str:
        """One line: ``"on the estimate: 0.021 m from the dock, 95 % bound 0.049 m <= 0.05 m"``."""
        rel = "<=" if self.docked else ">"
        return (
            f"on the {self.basis}: {self.distance_m:.3f} m from the dock, 95 % bound "
            f"{self.bound_m:.3f} m {rel} {self.tolerance_m:g} m"
        )


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
    ) -> None:
        self.tolerance_m = float(tolerance_m)
        self.dock = dock
        self.position_std_m = float(position_std_m)
        self.closest: Verdict | None = None

    def reset(self) -> None:
        self.closest = None

    def judge(self, estimate: Estimate | None) -> Verdict | None:
        """The verdict on the newest estimate (None before one)."""
        if estimate is None:
            return None
        dock = np.asarray(self.dock.position(estimate.t), dtype=float)
        if estimate.dock_offset_ned is not None:
            dock = dock + estimate.dock_offset_ned
        distance = float(np.linalg.norm(estimate.state[POS] - dock))
        if estimate.relative_cov is not None and estimate.dock_fix_t is not None:
            basis, cov = "navigation filter's estimate", np.asarray(estimate.relative_cov, dtype=float)
        elif estimate.state_cov is not None:  # the dock as charted (no fix of it yet): the position's own
            basis, cov = "navigation filter's position", np.asarray(estimate.state_cov, dtype=float)[0:3, 0:3]
        else:
            basis, cov = "position telemetry", np.eye(3) * self.position_std_m**2
            dock_cov = getattr(self.dock, "offset_covariance", None)
            if dock_cov is not None and getattr(self.dock, "process_noise", None) is not None:
                basis, cov = "position telemetry and the camera's dock", cov + np.asarray(dock_cov, float)
        verdict = Verdict(estimate.t, basis, distance, bound_95(distance, cov), self.tolerance_m)
        if self.closest is None or verdict.bound_m < self.closest.bound_m:
            self.closest = verdict
        return verdict
