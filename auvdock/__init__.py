"""auvdock: dock a BlueROV2 Heavy to a heaving wave-energy-converter dock with MPC.

The library in a notebook::

    import auvdock

    run = auvdock.simulate("gyre", controller="optimized", docking__timeout_s=30)
    run.outcome["docked"], run.outcome["time_to_dock_s"]
    ds = run.to_xarray()          # xarray.Dataset, dimension time_s
    df = run.to_dataframe()       # pandas.DataFrame, columns state.x, thrust_N.T1, ...
    run.save("gyre.h5")           # the results file auvdock sim writes

:func:`simulate` and :func:`load_mission` (:mod:`auvdock.api`), :class:`Run`
(:mod:`auvdock.results.run`), :class:`Mission` and :class:`MissionError`
(:mod:`auvdock.config.mission`) are imported on first use, so ``import auvdock`` stays light.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from auvdock._version import __version__

__all__ = ["__version__", "simulate", "load_mission", "Run", "Mission", "MissionError"]

if TYPE_CHECKING:  # pragma: no cover
    from auvdock.api import Mission, MissionError, Run, load_mission, simulate

_LAZY = frozenset({"simulate", "load_mission", "Run", "Mission", "MissionError"})


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        from auvdock import api

        value = getattr(api, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'auvdock' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
