"""The library entry points a notebook uses: :func:`simulate`, :func:`load_mission`, :func:`load_run`.

>>> import auvdock
>>> run = auvdock.simulate("gyre", docking__timeout_s=20)
>>> run
Run(mission='gyre', controller='oracle', docked at 12.60 s, 253 steps)
>>> run.to_dataframe()["state.z"]          # pandas, one column per component (m)
>>> run.to_xarray().position.sel(ned="down").plot()    # xarray: labelled "position [m]"
>>> run.save("gyre.h5")
>>> auvdock.load_run("gyre.h5")            # the same run, from the file

They are re-exported by :mod:`auvdock` (``auvdock.simulate``, ``auvdock.load_mission``,
``auvdock.load_run``, ``auvdock.Run``, ``auvdock.Mission``, ``auvdock.MissionError``,
``auvdock.RunFileError``).

Overrides
---------
``simulate(mission, **overrides)`` changes fields of the mission first, as
:meth:`auvdock.config.mission.Mission.with_updates` does.  A nested field is named by its
path with ``__`` between the parts, or a section is given a mapping of the fields to
change; these are the same::

    simulate("gyre", docking__timeout_s=20, controller__horizon_steps=15)
    simulate("gyre", docking={"timeout_s": 20}, controller={"horizon_steps": 15})
    simulate("gyre", **{"docking.timeout_s": 20, "controller.horizon_steps": 15})

A mapping for a section changes only the fields it names; any other value (a list, or a
mapping for a free-form field such as ``vehicle.overrides``) replaces the field; a number
as a part indexes a list (``dock__position_ned_m__2=6.0``).  Values are in the units the
field names say (``_s`` seconds, ``_m`` metres, ...).  A field that does not exist or a
value the mission refuses raises one :class:`~auvdock.config.mission.MissionError`, e.g.
``simulate: docking.tolerence_m: no such field (did you mean tolerance_m?)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from auvdock.config.mission import Mission, MissionError, parse_mission
from auvdock.config.mission import load_mission as _load_mission_file
from auvdock.results.run import Run

__all__ = ["simulate", "load_mission", "load_run", "Run", "Mission", "MissionError", "RunFileError"]


class RunFileError(Exception):
    """A results file that cannot be read as a run.  ``str(err)`` is the one line shown to users:
    ``<path>: no such results file``, ``<path>: not an auvdock results file (...)``, ...; ``path``
    is the file as given."""

    def __init__(self, path: str | Path, message: str) -> None:
        self.path = str(path)
        super().__init__(message)


def load_mission(mission: str | Path | Mapping[str, Any] | Mission) -> Mission:
    """A validated mission from a file, a shipped mission's name, or mission data.

    Parameters
    ----------
    mission : str, Path, mapping or Mission
        A mission file; or the name of a mission shipped with auvdock (``"gyre"``,
        ``"tank_0p6hz"``, ...: ``auvdock missions`` lists them; an existing file of that
        name wins); or the content of a mission file as a mapping
        (``{"name": "mine", "flow": {"case": "case2"}}``); or a :class:`Mission`
        (returned as is).

    Returns
    -------
    Mission

    Raises
    ------
    MissionError
        ``<file>: <field.path>: <problem>`` for a missing file or unknown name, a YAML
        error or an invalid field.
    """
    if isinstance(mission, Mission):
        return mission
    if isinstance(mission, Mapping):
        return parse_mission(dict(mission), "<mission data>")
    if isinstance(mission, str | Path):
        return _load_mission_file(mission)
    raise TypeError(
        f"mission must be a Mission, a file path, a shipped mission's name or a mapping, "
        f"not {type(mission).__name__}"
    )


def load_run(path: str | Path, group: str = "/") -> Run:
    """A run from a results file: what ``auvdock sim`` / ``fly`` / ``replay`` write and
    :meth:`Run.save` writes, the same :class:`Run` as :func:`simulate` returns.

    Parameters
    ----------
    path : str or Path
        The HDF5 results file (``run.save("gyre.h5")``, ``auvdock sim ... --out DIR``).
    group : str
        The run group: ``"/"`` for a single-run file, ``"/runs/<case>/<controller>"`` in a
        campaign file (``auvdock.results.store.list_runs(path)`` lists them).

    Returns
    -------
    Run
        Every per-step series in the units of :mod:`auvdock.results.store` (``time_s`` s,
        ``state`` m / rad / m/s / rad/s, ``thrust_N`` N, ...), the outcome, the mission and the
        controller; ``run.source`` is ``"<path>:<group>"``.  An unfinished run (a crash, Ctrl-C)
        reads with ``complete`` False and an empty outcome.

    Raises
    ------
    RunFileError
        One error for every file that cannot be read as a run, its message naming the file:
        ``<path>: no such results file`` for a missing file; ``<path>: not an auvdock results
        file (...)`` for one that is not HDF5, has no such group or is not a run;
        ``<path>: cannot read the results file (...)`` for one the system cannot read.
    """
    try:
        return Run.from_file(path, group)
    except (FileNotFoundError, ValueError) as e:
        raise RunFileError(path, str(e)) from None
    except OSError as e:
        raise RunFileError(path, f"{path}: cannot read the results file ({e})") from None


def simulate(
    mission: str | Path | Mapping[str, Any] | Mission,
    controller: str | Mapping[str, Any] | None = None,
    **overrides: Any,
) -> Run:
    """Run one closed-loop docking simulation and return it in memory.

    Parameters
    ----------
    mission : str, Path, mapping or Mission
        What :func:`load_mission` takes: a :class:`Mission`, a mission file, a shipped
        mission's name (``"gyre"``) or mission data.
    controller : str or mapping, optional
        The controller to fly instead of the mission's: ``NAME`` or ``NAME@VARIANT``
        (``"naive"``, ``"kinematic"``, ``"oracle"``, ``"sequential"``, ``"optimized"``,
        ``"sequential@paper"``); shared settings are kept, its own take their defaults.
        A mapping changes controller settings instead (``{"type": "optimized", "alpha":
        2e-3}``), like ``controller__alpha=2e-3``.
    **overrides
        Changes to mission fields, applied after ``controller``: ``docking__timeout_s=20``,
        ``docking={"timeout_s": 20}`` or ``**{"docking.timeout_s": 20}`` (see the module
        docstring), e.g. ``seed=3``, ``flow__case="case2"``, ``estimation="filter"``.

    Returns
    -------
    Run
        Every per-step series (``time_s`` (T,) s, ``state`` (T, 12), ``thrust_N`` (T, n) N,
        ...), the outcome (``run.outcome["docked"]``, ``["time_to_dock_s"]``, ...), the
        resolved mission (``run.mission_yaml``) and the controller's name.  Nothing is
        written to disk (``run.save(path)`` writes the results file ``auvdock sim`` writes).

    Raises
    ------
    MissionError
        For a mission that does not load, an unknown controller, or an override naming a
        field that does not exist or giving a value the mission refuses:
        ``simulate: <field.path>: <problem>``.
    """
    m = load_mission(mission)
    changes: dict[str, Any] = {}
    if isinstance(controller, Mapping):
        changes["controller"] = dict(controller)
    elif controller is not None:
        changes["controller.type"] = str(controller)
    changes.update(overrides)
    if changes:
        m = m.with_updates(changes, where="simulate")
    return _run(m)


def _run(mission: Mission) -> Run:
    """Fly ``mission`` in the closed loop and return the run: the one place that runs it."""
    from auvdock.loop.simulation import run_simulation as run_loop

    run = run_loop(mission, keep=True).run
    assert run is not None
    return run
