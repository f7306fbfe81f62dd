"""Types shared by every controller: what goes in (:class:`Measurement`), what comes out
(:class:`ControlOutput`) and the :class:`Controller` protocol."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

__all__ = ["Measurement", "ControlOutput", "Plan", "Controller"]


@dataclass
class Measurement:
    """What the vehicle knows at one control instant.

    Attributes
    ----------
    t : float
        Time, s (mission clock: 0 at the start).
    state : ndarray (12,)
        Vehicle state (Assumption 1): NED position (m), ZYX Euler angles (rad), body
        velocity over ground (m/s) and angular rate (rad/s); :mod:`auvdock.vehicle.state`.
    flow_ned : ndarray (3,) or None
        True water velocity at the vehicle, NED (m/s), where an exteroceptive sensor gives
        it (Assumption 3; simulation only).  Used by Kinematic and Oracle MPC only.
    sensors : dict
        Raw readings for the estimators: ``pose`` (6,), ``gyro_rad_s`` (3,),
        ``relative_velocity_m_s`` (3,), ``accel_m_s2`` (3,), ``depth_rate_m_s`` (scalar).
    readings : list
        The sensor suite's readings delivered since the last step
        (:class:`auvdock.estimation.navigation_filter.Reading`), for the navigation filter
        (``estimation: filter``); ``state`` is then not used by the controller.
    """

    t: float
    state: np.ndarray
    flow_ned: np.ndarray | None = None
    sensors: dict[str, np.ndarray] = field(default_factory=dict)
    readings: list[Any] = field(default_factory=list)


@dataclass
class Plan:
    """A predictive controller's plan: states (N+1, 12) and inputs (N, n), over-ground velocities."""

    state: np.ndarray
    thrust: np.ndarray


@dataclass
class ControlOutput:
    """What a controller step returns.

    Attributes
    ----------
    thrust : ndarray (n,)
        Thrust of each thruster to apply now and hold for one period, N.
    status : int
        Step outcome, a code of :mod:`auvdock.controllers.status`.
    solve_time_s : float
        Wall time of the whole step, s (set by :class:`auvdock.loop.autopilot.Autopilot`).
    plan : Plan or None
        The plan the thrust comes from, for controllers that plan (None otherwise).
    series : dict
        Extra per-step values to record (name -> array), as the controller's
        ``extra_series`` declares them.
    time_parts : dict
        Where the step's wall time went, s, by part (:mod:`auvdock.runtime.timing`; set by the
        Autopilot): the rest of ``solve_time_s`` is Python.
    info : dict
        Anything else a controller wants to report about the step (not recorded).
    """

    thrust: np.ndarray
    status: int
    solve_time_s: float = 0.0
    plan: Plan | None = None
    series: dict[str, np.ndarray] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    time_parts: dict[str, float] = field(default_factory=dict)


class Controller(Protocol):
    """What every controller offers.  Registered in :mod:`auvdock.controllers.registry`."""

    name: str
    #: Extra per-step series it records: name -> per-row shape.
    extra_series: dict[str, tuple[int, ...]]

    def step(self, meas: Measurement, u_prev: np.ndarray) -> ControlOutput:
        """One control step from a measurement; ``u_prev`` (n,) the thrust applied last (N)."""
        ...

    def reset(self) -> None:
        """Forget everything from a previous run."""
        ...
