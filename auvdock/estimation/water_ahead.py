"""The water a controller's prediction meets over its horizon: :class:`WaterAhead`.

The MPC's prediction model (:mod:`auvdock.controllers.mpc`) takes, for each of its N steps, the
water's velocity at the vehicle and its acceleration (NED; m/s, m/s^2), held over that step.
How a controller fills them is what it may know:

* :meth:`WaterAhead.held` -- one velocity over the whole horizon, no acceleration: the paper's
  formulation (the flow held constant in {n}), and every controller without a wave estimate;
* :meth:`WaterAhead.from_waves` -- the estimated slow current held, plus the navigation filter's
  wave oscillators (:class:`auvdock.estimation.wave_model.WaveModel`) run forward on their
  own dynamics from their estimated velocity and rate: what a deployable controller knows;
* :meth:`WaterAhead.from_sea` -- the true current plus the true sea's orbital velocity and
  acceleration at the vehicle's position: what Oracle is told (the realised sea, an idealisation it
  says it has).

In all three the vehicle's position is taken as it is now (over a 0.5 s horizon at docking speeds
it moves a few centimetres, against wavelengths of metres).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from auvdock.estimation.wave_model import WaveModel
    from auvdock.world.waves import WaveComponents

__all__ = ["WaterAhead"]


@dataclass(frozen=True)
class WaterAhead:
    """The water over a prediction horizon of N steps.

    Attributes
    ----------
    velocity_ned : ndarray (N, 3)
        The water's velocity at the vehicle during step k (at its start, held over it), NED, m/s.
    accel_ned : ndarray (N, 3)
        Its acceleration, NED, m/s^2: the rate the vehicle's relative velocity sees and the
        Froude-Krylov force's acceleration (equal for a vehicle moving slowly against the waves'
        phase speed).
    """

    velocity_ned: np.ndarray
    accel_ned: np.ndarray

    def __post_init__(self) -> None:
        v, a = np.asarray(self.velocity_ned, dtype=float), np.asarray(self.accel_ned, dtype=float)
        if v.ndim != 2 or v.shape[1] != 3 or a.shape != v.shape:
            raise ValueError(
                f"WaterAhead: velocity and acceleration must both be (N, 3), got {v.shape}, {a.shape}"
            )

    @property
    def steps(self) -> int:
        """N, the number of horizon steps."""
        return int(self.velocity_ned.shape[0])

    @classmethod
    def held(cls, velocity_ned: np.ndarray, steps: int) -> WaterAhead:
        """``velocity_ned`` (3,) over ``steps`` steps, no acceleration (the paper's held flow)."""
        v = np.asarray(velocity_ned, dtype=float).reshape(3)
        return cls(np.tile(v, (steps, 1)), np.zeros((steps, 3)))

    @classmethod
    def from_waves(
        cls,
        current_ned: np.ndarray,
        wave_velocity_ned: np.ndarray,
        wave_accel_ned: np.ndarray,
        model: WaveModel,
        offsets_s: np.ndarray,
    ) -> WaterAhead:
        """The current ``current_ned`` (3,) held plus the wave oscillators' expected motion from
        ``wave_velocity_ned`` and ``wave_accel_ned`` (3, each) now, at the horizon's stages' starts
        ``offsets_s`` (N,) s from now (``k dt`` on a uniform grid;
        :meth:`~auvdock.estimation.wave_model.WaveModel.propagate`)."""
        w, a = model.propagate(wave_velocity_ned, wave_accel_ned, np.asarray(offsets_s, dtype=float))
        return cls(np.asarray(current_ned, dtype=float).reshape(1, 3) + w, a)

    @classmethod
    def from_sea(
        cls,
        current_ned: np.ndarray,
        sea: WaveComponents,
        position_ned: np.ndarray,
        t: float,
        offsets_s: np.ndarray,
    ) -> WaterAhead:
        """The current ``current_ned`` (3,) held plus the sea's orbital velocity and local
        acceleration at ``position_ned`` (3,, m) at ``t`` plus the horizon's stages' starts ``offsets_s``
        (N,) s (``k dt`` on a uniform grid)."""
        times = float(t) + np.asarray(offsets_s, dtype=float)
        p = np.broadcast_to(np.asarray(position_ned, dtype=float).reshape(1, 3), (times.size, 3))
        kin = sea.kinematics(p, times)
        return cls(
            np.asarray(current_ned, dtype=float).reshape(1, 3) + kin.velocity_ned_m_s,
            kin.acceleration_ned_m_s2,
        )
