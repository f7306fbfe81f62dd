"""Where a control step's time goes: named parts, measured inside the step.

:class:`auvdock.loop.autopilot.Autopilot` opens a step (:func:`begin`), the pieces that cost time
mark themselves with :func:`part` (the estimation stage, the FSE flow filter, the MPC's QP
data and QP for ``rti``, the NLP solver and its function evaluations for ``sqp`` / ``ipopt``),
and the step's parts (s) are handed back (:func:`end`) into ``ControlOutput.time_parts``; the
rest of the step's wall time is Python (``auvdock bench`` prints the medians).  Per thread:
one control loop per thread at most.  A part costs two ``perf_counter`` calls (well under a
microsecond each); outside a step nothing is recorded.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["begin", "end", "part", "add", "PARTS"]

#: The parts in the order ``auvdock bench`` prints them (others follow by name).
PARTS = ("estimation", "flow filter", "perception", "qp data", "qp", "nlp functions", "nlp solver")

_local = threading.local()


def begin() -> None:
    """Start collecting the parts of one step (this thread)."""
    _local.parts = {}


def end() -> dict[str, float]:
    """The parts collected since :func:`begin` (s), and stop collecting."""
    parts = getattr(_local, "parts", None) or {}
    _local.parts = None
    return parts


def add(name: str, seconds: float) -> None:
    """Add ``seconds`` to part ``name`` of the current step (nothing outside a step)."""
    parts = getattr(_local, "parts", None)
    if parts is not None:
        parts[name] = parts.get(name, 0.0) + float(seconds)


@contextmanager
def part(name: str) -> Iterator[None]:
    """Time the block as part ``name`` of the current step."""
    t0 = time.perf_counter()
    try:
        yield
    finally:
        add(name, time.perf_counter() - t0)
