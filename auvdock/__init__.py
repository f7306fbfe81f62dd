"""auvdock: dock a BlueROV2 Heavy to a heaving wave-energy-converter dock with MPC.

The library in a notebook::

    import auvdock

    run = auvdock.simulate("gyre", controller="optimized", docking__timeout_s=30)
    run.outcome["docked"], run.outcome["time_to_dock_s"]
    ds = run.to_xarray()          # xarray.Dataset, dimension time_s; position [m], force [N], ...
    df = run.to_dataframe()       # pandas.DataFrame, columns state.x, thrust_N.T1, ...
    run.save("gyre.h5")           # the results file auvdock sim writes
    run = auvdock.load_run("gyre.h5")     # and back

:func:`simulate`, :func:`load_mission`, :func:`load_run` and :class:`RunFileError`
(:mod:`auvdock.api`), :class:`Run` (:mod:`auvdock.results.run`), :class:`Mission` and
:class:`MissionError` (:mod:`auvdock.config.mission`) are imported on first use, so ``import
auvdock`` stays light.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from auvdock._version import __version__

__all__ = [
    "__version__",
    "simulate",
    "load_mission",
    "load_run",
    "Run",
    "Mission",
    "MissionError",
    "RunFileError",
]

if TYPE_CHECKING:  # pragma: no cover
    from auvdock.api import Mission, MissionError, Run, RunFileError, load_mission, load_run, simulate

_LAZY = frozenset({"simulate", "load_mission", "load_run", "Run", "Mission", "MissionError", "RunFileError"})


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        from auvdock import api

        value = getattr(api, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'auvdock' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
