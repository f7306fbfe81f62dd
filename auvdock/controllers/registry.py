"""Every controller, registered in one place (:data:`CONTROLLERS`).

A controller is a module with a settings class (an :class:`~auvdock.controllers.settings.MPCSettings`
with a literal ``type``) and a class that follows :class:`~auvdock.controllers.base.Controller`;
registering it is one :class:`ControllerEntry` line below.  The mission's ``controller``
section is the discriminated union of the registered settings classes (:func:`settings_union`),
the CLI's ``--controller`` choices are :func:`controller_names`, and :func:`build_controller`
makes one from its settings.

==============  =======================================================  ===============  ========
name            what it is                                               reads true flow  auto
==============  =======================================================  ===============  ========
``naive``       MPC, eqs. (1)-(2) with no current                        no               rti
``kinematic``   MPC, current in the kinematics only (eq. 6)              yes (Assump. 3)  rti
``oracle``      MPC, eqs. (1)-(2) with the true current                  yes (Assump. 3)  rti
``sequential``  FSE-MPC: perception law (9) + MPC on the estimated flow  no               rti [#]_
``optimized``   FSE-MPC: cost (10) - alpha F, estimated flow             no               rti
``ce``          the FSE controllers' filter and MPC, no exploration      no               rti
==============  =======================================================  ===============  ========

.. [#] ``sqp`` for ``sequential@paper`` (:func:`resolve_solver` says why).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Any, Union

from pydantic import Field

from auvdock.controllers.settings import (
    SOLVER_NAMES,
    CertaintyEquivalentSettings,
    KinematicSettings,
    MPCSettings,
    NaiveSettings,
    OptimizedSettings,
    OracleSettings,
    SequentialSettings,
)
from auvdock.controllers.world import ControllerWorld
from auvdock.estimation.settings import EstimatorSettings
from auvdock.sensing.settings import SensorSettings

if TYPE_CHECKING:
    from auvdock.controllers.base import Controller
    from auvdock.vehicle import Vehicle
    from auvdock.world.dock import DockMotion

__all__ = [
    "ControllerEntry",
    "CONTROLLERS",
    "controller_names",
    "controller_label",
    "controller_short_label",
    "VARIANTS",
    "split_controller",
    "reads_true_flow",
    "controller_specs",
    "settings_union",
    "settings_for",
    "resolve_solver",
    "build_controller",
]


@dataclass(frozen=True)
class ControllerEntry:
    """One registered controller.

    Attributes
    ----------
    name : str
        Its ``type`` in missions and ``--controller``.
    settings : type
        Its settings class (a pydantic model with ``type: Literal[name]``).
    build : callable
        ``build(settings, vehicle, dock, solver, estimator, sensors, world) -> Controller``.
    auto_solver : str
        What solver ``auto`` means for it (docs/performance.md: how it was chosen).
    auto_solver_paper : str, optional
        What ``auto`` means for its ``paper`` variant, where that differs.
    reads_true_flow : bool
        Whether its definition gives it the true flow (Assumption 3); outputs say so.
    summary : str
        One line for listings.
    estimates_flow : bool
        Whether it learns the current itself from the sensors (the FSE controllers' flow
        filter, paper IV.A): it then needs the water-relative velocity, which only the
        estimation stage (or the paper's simulated sensor, ``estimation: truth`` in sim) gives.
    label : str
        Its display name in tables, findings and figures (``"Oracle MPC"``).
    short_label : str
        The first word of it, as the paper's findings name it (``"Oracle"``).
    colour : str
        Its colour in every figure (hex; colour-blind-safe Okabe-Ito hues); empty: the figures
        pick one from a fallback palette by its name.
    in_paper : bool
        One of the paper's five controllers: the default set of ``compare`` and ``bench`` (the
        paper's study); the others are named explicitly.
    """

    name: str
    settings: type[MPCSettings]
    build: Callable[..., Controller]
    auto_solver: str
    reads_true_flow: bool
    summary: str
    estimates_flow: bool = False
    auto_solver_paper: str | None = None
    label: str = ""
    short_label: str = ""
    colour: str = ""
    in_paper: bool = True


# the controllers' classes (CasADi) are imported when one is built, not when the registry is read
# (reading a mission validates its controller section against the settings alone)
def _baseline(settings, vehicle, dock, solver, estimator, sensors, world) -> Controller:
    from auvdock.controllers.baseline import BaselineMPC

    return BaselineMPC(settings, vehicle, dock, solver, world)


def _fse(settings, vehicle, dock, solver, estimator, sensors, world) -> Controller:
    from auvdock.controllers.fse import FSEMPC

    return FSEMPC(settings, vehicle, dock, solver, estimator, sensors, world)


#: Every controller, in the paper's order: the one place to register a new one.  The order is the
#: order of every listing, table and legend; ``label`` and ``colour`` are how every output shows it.
CONTROLLERS: dict[str, ControllerEntry] = {
    e.name: e
    for e in (
        ControllerEntry(
            "naive", NaiveSettings, _baseline, "rti", False, "MPC, no current in the model",
            label="Naive MPC", short_label="Naive", colour="#D55E00",  # vermillion
        ),
        ControllerEntry(
            "kinematic", KinematicSettings, _baseline, "rti", True, "MPC, true current in the kinematics",
            label="Kinematic MPC", short_label="Kinematic", colour="#E69F00",  # orange
        ),
        ControllerEntry(
            "oracle", OracleSettings, _baseline, "rti", True, "MPC, full model, true current",
            label="Oracle MPC", short_label="Oracle", colour="#009E73",  # bluish green
        ),
        ControllerEntry(
            "sequential", SequentialSettings, _fse, "rti", False, "FSE-MPC: perception law (9), then MPC",
            estimates_flow=True, auto_solver_paper="sqp",
            label="Sequential FSE-MPC", short_label="Sequential", colour="#0072B2",  # blue
        ),
        ControllerEntry(
            "optimized", OptimizedSettings, _fse, "rti", False, "FSE-MPC: cost (10) - alpha F",
            estimates_flow=True,
            label="Optimized FSE-MPC", short_label="Optimized", colour="#CC79A7",  # reddish purple
        ),
        ControllerEntry(
            "ce", CertaintyEquivalentSettings, _fse, "rti", False,
            "MPC on the estimated flow, no exploration (certainty equivalence)",
            estimates_flow=True, in_paper=False,
            label="Certainty-equivalent MPC", short_label="CE", colour="#000000",  # black (Okabe-Ito)
        ),
    )
}  # fmt: skip


def controller_names(paper_only: bool = False) -> tuple[str, ...]:
    """The registered controllers' names, in order (``paper_only``: the paper's five)."""
    return tuple(n for n, e in CONTROLLERS.items() if e.in_paper or not paper_only)


def controller_label(spec: str) -> str:
    """Display name of a registered controller (``"oracle"`` -> ``"Oracle MPC"``); any other name
    (an unregistered one, or a ``NAME@VARIANT`` spec) is returned as it is."""
    entry = CONTROLLERS.get(str(spec))
    return entry.label if entry is not None and entry.label else str(spec)


def controller_short_label(spec: str) -> str:
    """The short display name (``"oracle"`` -> ``"Oracle"``), as the paper's findings name it."""
    entry = CONTROLLERS.get(str(spec))
    return entry.short_label if entry is not None and entry.short_label else controller_label(spec)


#: ``controller.variant`` values: the paper's formulation, or the robust one (the default).
VARIANTS = ("paper", "robust")


def reads_true_flow(spec: str) -> bool:
    """Whether the controller ``NAME`` or ``NAME@VARIANT`` is told the truth by its definition (Kinematic,
    Oracle: :attr:`ControllerEntry.reads_true_flow`); ValueError for an unknown one."""
    return CONTROLLERS[split_controller(spec)[0]].reads_true_flow


def split_controller(spec: str) -> tuple[str, str | None]:
    """A controller spec, ``NAME`` or ``NAME@VARIANT`` (``oracle``, ``sequential@paper``), as
    ``(name, variant or None)``; ValueError naming the bad part."""
    name, _, variant = str(spec).partition("@")
    if name not in CONTROLLERS:
        raise ValueError(f"unknown controller {name!r} (known: {', '.join(CONTROLLERS)})")
    if "@" in str(spec) and variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r} of {name} (known: {', '.join(VARIANTS)})")
    return name, (variant or None)


def controller_specs(variants: bool = False, paper_only: bool = True) -> tuple[str, ...]:
    """The paper's five controllers (``paper_only`` False: every one), and with ``variants`` each
    also as ``NAME@paper``, after the defaults."""
    names = controller_names(paper_only)
    return names + tuple(f"{n}@paper" for n in names) if variants else names


def settings_union() -> Any:
    """The mission's ``controller`` type: the registered settings classes, told apart by ``type``."""
    members = tuple(e.settings for e in CONTROLLERS.values())
    return Annotated[Union[members], Field(discriminator="type")]  # noqa: UP007 (a runtime tuple)


def settings_for(name: str, like: MPCSettings | None = None) -> MPCSettings:
    """Settings of controller ``name``: the fields ``like`` shares with it, defaults for the rest.

    Switching ``oracle`` settings to ``optimized`` keeps horizon, weights, bounds and solver
    and takes the default ``alpha``; switching back drops ``alpha``.
    """
    if name not in CONTROLLERS:
        raise ValueError(f"unknown controller {name!r} (known: {', '.join(CONTROLLERS)})")
    cls = CONTROLLERS[name].settings
    if like is None:
        return cls.model_validate({})  # every settings class has its type as a default
    if like.type == name:
        return like
    shared = {k: v for k, v in like.model_dump().items() if k in cls.model_fields and k != "type"}
    return cls.model_validate({**shared, "type": name})


def resolve_solver(name: str, controller: str, variant: str | None = None) -> str:
    """The solver ``name`` stands for with ``controller``: itself, or for ``auto`` the controller's choice.

    ``controller`` is ``NAME`` or ``NAME@VARIANT``; ``variant`` (``robust`` or ``paper``), when
    given, takes precedence over the spec's.

    ``auto`` was chosen by docking all six paper cases with every controller x solver
    (``auvdock bench --case 1 ... --case 6 --solvers rti,sqp,ipopt``; docs/performance.md):
    ``rti`` docks exactly the cases the iterated solvers dock, at the same times to 0.05 s,
    with every controller in its robust variant, in a third of the time per step or less.
    With Sequential FSE-MPC in the paper's variant it does not: there the MPC does not know
    the perception wrench it is given, which moves the vehicle off the shifted plan every
    step; one QP step per control step does not catch up in case 4 (it times out where SQP
    docks at 41.6 s), so ``auto`` is ``sqp`` for ``sequential@paper``.  The robust variant
    plans with the wrench (the MPC's input offset), and RTI tracks it.
    """
    if name != "auto":
        if name not in SOLVER_NAMES:
            raise ValueError(f"unknown solver {name!r} (known: auto, {', '.join(SOLVER_NAMES)})")
        return name
    name, spec_variant = split_controller(controller)
    entry = CONTROLLERS[name]
    if (variant or spec_variant) == "paper" and entry.auto_solver_paper:
        return entry.auto_solver_paper
    return entry.auto_solver


def build_controller(
    settings: MPCSettings,
    vehicle: Vehicle,
    dock: DockMotion,
    estimator: EstimatorSettings | None = None,
    sensors: SensorSettings | None = None,
    world: ControllerWorld | None = None,
) -> Controller:
    """The controller ``settings.type`` describes, built once for a run.

    Parameters
    ----------
    settings : MPCSettings
        A registered controller's settings (the mission's ``controller`` section).
    vehicle, dock : Vehicle, DockMotion
        The prediction model's vehicle and the dock whose motion is known (Assumption 2).
    estimator, sensors : EstimatorSettings, SensorSettings, optional
        The flow estimator's settings and the sensor noise it accounts for (FSE-MPCs);
        defaults when omitted.
    world : ControllerWorld, optional
        What it knows of the dock's body and (Oracle) the true sea; default: neither.
    """
    entry = CONTROLLERS.get(settings.type)
    if entry is None:
        raise ValueError(f"unknown controller {settings.type!r} (known: {', '.join(CONTROLLERS)})")
    solver = resolve_solver(settings.solver.name, entry.name, settings.variant)
    return entry.build(
        settings, vehicle, dock, solver, estimator or EstimatorSettings(), sensors or SensorSettings(),
        world or ControllerWorld(),
    )
