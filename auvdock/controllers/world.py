"""What a controller is told of the world beyond its estimate: :class:`ControllerWorld`.

Built once per run by :func:`auvdock.loop.assemble.build_autopilot` from the mission:

* ``entry`` -- the dock's entry corridor (:mod:`auvdock.controllers.entry`), from the dock's body
  as the mission charts it (every controller may know the dock's drawing);
* ``sea`` -- the realised sea (its components and phases), given only to a controller whose
  definition reads the truth (Oracle), which then predicts the true water over its horizon.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from auvdock.controllers.entry import EntryCorridor
    from auvdock.world.waves import WaveComponents

__all__ = ["ControllerWorld"]


@dataclass(frozen=True)
class ControllerWorld:
    """The dock's entry corridor (None: none in the cost) and the true sea (None: not told)."""

    entry: EntryCorridor | None = None
    sea: WaveComponents | None = None
