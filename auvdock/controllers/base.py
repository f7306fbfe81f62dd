"""Types shared by every controller: what goes in (:class:`Measurement`) and what comes out."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from .mpc import MPCResult

__all__ = ["Measurement", "ControlOutput", "Controller"]


@dataclass
class Measurement:
    """What the vehicle knows at one control instant.

    Attributes
    ----------
    t : float
        Time, s (mission clock: 0 at the start).
    state : ndarray (12,)
        Vehicle state (Assumption 1): NED position (m), ZYX Euler angles (rad), body
        velocity over ground (m/s) and angular rate (rad/s).
    flow_ned : ndarray (3,) or None
        True water velocity at the vehicle, NED (m/s), where an exteroceptive sensor gives
        it (Assumption 3; simulation only).  Used by Kinematic and Oracle MPC only.
    sensors : dict
        Raw inertial readings for the flow estimator: ``accel_m_s2`` (3,) body-frame
        linear acceleration, ``gyro_rad_s`` (3,), ``depth_rate_m_s`` (1,).
    """

    t: float
    state: np.ndarray
    flow_ned: np.ndarray | None = None
    sensors: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class ControlOutput:
    """What a controller step returns.

    ``thrust`` (8,) N to apply now; ``status`` a solver status code
    (:data:`auvdock.results.STATUS_NAMES`); ``solve_time_s`` wall time of the whole step (s);
    ``mpc`` the MPC's result; ``series`` extra per-step values to record (name -> array).
    """

    thrust: np.ndarray
    status: int
    solve_time_s: float
    mpc: MPCResult
    series: dict[str, np.ndarray] = field(default_factory=dict)


class Controller(Protocol):
    name: str

    def step(self, meas: Measurement, u_prev: np.ndarray) -> ControlOutput:
        """One control step from a measurement; ``u_prev`` (8,) the thrust applied last (N)."""
        ...

    def reset(self) -> None: ...
