"""Types shared by every controller: what goes in (:class:`~auvdock.estimation.estimate.Estimate`,
the estimation stage's), what comes out (:class:`ControlOutput`) and the :class:`Controller` protocol."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from auvdock.estimation.estimate import Estimate

__all__ = ["Estimate", "ControlOutput", "Plan", "Controller"]


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
    channels_us : ndarray (6,) or None
        For a control stage that commands RC channels directly (a pilot over the link of a
        stand-in vehicle), the six channels, us; the loop's actuator path then takes them
        instead of ``thrust``.
    """

    thrust: np.ndarray
    status: int
    solve_time_s: float = 0.0
    plan: Plan | None = None
    series: dict[str, np.ndarray] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    time_parts: dict[str, float] = field(default_factory=dict)
    channels_us: np.ndarray | None = None


class Controller(Protocol):
    """What every controller offers.  Registered in :mod:`auvdock.controllers.registry`."""

    name: str
    #: Extra per-step series it records: name -> per-row shape.
    extra_series: dict[str, tuple[int, ...]]

    def step(self, est: Estimate, u_prev: np.ndarray) -> ControlOutput:
        """One control step from the estimation stage's estimate; ``u_prev`` (n,) the thrust
        commanded last (N)."""
        ...

    def reset(self) -> None:
        """Forget everything from a previous run."""
        ...
