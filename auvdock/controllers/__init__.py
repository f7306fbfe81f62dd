"""Docking controllers (paper section V): one MPC, five controllers, registered in one place.

================================  ======================================================
module                            what it holds
================================  ======================================================
:mod:`~.base`                     Estimate, ControlOutput, Plan, the Controller protocol
:mod:`~.status`                   step outcome codes
:mod:`~.settings`                 the settings: what every MPC shares, each controller's own (no CasADi)
:mod:`~.mpc`                      the MPC of eq. (10) (DockingMPC), built once per run
:mod:`~.solvers`                  the NLP solvers, registered (ipopt, sqp, rti)
:mod:`~.rti`                      real-time iteration
:mod:`~.baseline`                 Naive, Kinematic, Oracle MPC
:mod:`~.fse`                      Sequential and Optimized FSE-MPC, CE MPC
:mod:`~.registry`                 every controller (CONTROLLERS), build_controller
================================  ======================================================

Every controller has ``step(estimate, u_prev) -> ControlOutput`` and is driven by
:class:`auvdock.loop.autopilot.Autopilot`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from auvdock.controllers.base import Controller, ControlOutput, Estimate, Plan
from auvdock.controllers.registry import (
    CONTROLLERS,
    ControllerEntry,
    build_controller,
    controller_names,
    controller_specs,
    resolve_solver,
    settings_for,
    settings_union,
    split_controller,
)
from auvdock.controllers.settings import solver_names

if TYPE_CHECKING:  # pragma: no cover
    from auvdock.controllers.solvers import SOLVERS

__all__ = [
    "Estimate",
    "ControlOutput",
    "Plan",
    "Controller",
    "CONTROLLERS",
    "ControllerEntry",
    "SOLVERS",
    "build_controller",
    "controller_names",
    "controller_specs",
    "split_controller",
    "resolve_solver",
    "settings_for",
    "settings_union",
    "solver_names",
    "CONTROLLER_NAMES",
]

#: The registered controllers' names (also :func:`controller_names`).
CONTROLLER_NAMES = controller_names()


def __getattr__(name: str) -> Any:
    """``SOLVERS`` (the solvers' builders, CasADi), imported when first asked for."""
    if name == "SOLVERS":
        from auvdock.controllers.solvers import SOLVERS

        globals()[name] = SOLVERS
        return SOLVERS
    raise AttributeError(f"module 'auvdock.controllers' has no attribute {name!r}")
