"""A flight's events: what happened, when, in one list (and to whoever shows them as they happen)."""

from __future__ import annotations

from collections.abc import Callable

from auvdock.runtime.clock import Clock

__all__ = ["EventLog"]


class EventLog:
    """The events of one session: ``(t, text)`` with ``t`` in s since the session began, on its clock.

    Parameters
    ----------
    clock : Clock
        The session's clock.
    """

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self.t0 = clock.now()
        self.items: list[tuple[float, str]] = []
        #: Called with each event as it happens: ``on_event(t, text)``.
        self.on_event: Callable[[float, str], None] | None = None

    def add(self, text: str) -> None:
        """An event now."""
        item = (self.clock.now() - self.t0, text)
        self.items.append(item)
        if self.on_event is not None:
            self.on_event(*item)

    def last(self) -> str:
        """The newest event's text ("" before one)."""
        return self.items[-1][1] if self.items else ""

    def vehicle_text_since_arming(self) -> str:
        """The vehicle's latest STATUSTEXT since arming ("" if none)."""
        for _, text in reversed(self.items):
            if text == "armed":
                return ""
            if text.startswith("vehicle: "):
                return text[len("vehicle: ") :]
        return ""
