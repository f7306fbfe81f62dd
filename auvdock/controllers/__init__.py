"""Docking controllers (paper section V): one MPC, five controllers, registered in one place.

================================  ======================================================
module                            what it holds
================================  ======================================================
:mod:`~.base`                     Estimate, ControlOutput, Plan, the Controller protocol
:mod:`~.status`                   step outcome codes
:mod:`~.settings`                 settings every MPC shares (horizon, weights, bounds, solver)
:mod:`~.mpc`                      the MPC of eq. (10) (DockingMPC), built once per run
:mod:`~.solvers`                  the NLP solvers, registered (ipopt, sqp, rti)
:mod:`~.rti`                      real-time iteration
:mod:`~.baseline`                 Naive, Kinematic, Oracle MPC and their settings
:mod:`~.fse`                      Sequential and Optimized FSE-MPC and their settings
:mod:`~.registry`                 every controller (CONTROLLERS), build_controller
================================  ======================================================

Every controller has ``step(estimate, u_prev) -> ControlOutput`` and is driven by
:class:`auvdock.loop.autopilot.Autopilot`.
"""

from __future__ import annotations

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
from auvdock.controllers.solvers import SOLVERS, solver_names

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
