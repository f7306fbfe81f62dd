"""Ctrl-C (SIGINT) held back over short sections that must not be cut in two.

Python raises KeyboardInterrupt between any two bytecodes of the main thread.  Inside
:class:`SigintDeferred` a SIGINT only sets a flag; leaving the block raises the
KeyboardInterrupt then, so the section (a CasADi solve, creating a results group, writing
a run's outcome) either runs whole or not at all.

It also keeps CasADi's own interrupt check from turning Ctrl-C into a failed solve (IPOPT
returns ``NonIpopt_Exception_Thrown``), which a run loop would take for solver trouble and
go on.  Outside the main thread, where handlers cannot be set, it does nothing.

SIGTERM (what Docker, BlueOS and systemd send to stop a service) is made a Ctrl-C by
:func:`sigterm_interrupts`: its handler raises SIGINT in the process, so every command ends a
SIGTERM exactly as it ends a Ctrl-C (a vehicle set neutral, files closed, the summary printed,
exit 130), and :func:`interrupt_name` says which of the two it was for the messages.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = ["SigintDeferred", "sigint_raises", "sigint_pending", "sigterm_interrupts", "interrupt_name"]

#: What interrupted the process last: "Ctrl-C" (SIGINT) or "SIGTERM".
_interrupted_by = "Ctrl-C"

#: The SigintDeferred blocks open now (innermost last), main thread only.
_open: list[SigintDeferred] = []


class SigintDeferred:
    """Context manager: SIGINT inside the block is raised as KeyboardInterrupt on leaving it."""

    def __enter__(self) -> SigintDeferred:
        self.hit = False
        self._old = None
        if threading.current_thread() is threading.main_thread():
            try:
                self._old = signal.signal(signal.SIGINT, self._handler)
            except ValueError:
                self._old = None
            else:
                _open.append(self)
        return self

    def _handler(self, signum, frame) -> None:
        self.hit = True

    def __exit__(self, *exc: object) -> None:
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
            if _open and _open[-1] is self:
                _open.pop()
        if self.hit:
            raise KeyboardInterrupt


@contextlib.contextmanager
def sigint_raises() -> Iterator[None]:
    """Ctrl-C raises KeyboardInterrupt at once inside this block, even within a
    :class:`SigintDeferred` one: for long waits that are safe to cut (a C compiler running in a
    child process, which the caller then stops)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    try:
        old = signal.signal(signal.SIGINT, signal.default_int_handler)
    except ValueError:  # pragma: no cover - not the main interpreter
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def sigint_pending() -> bool:
    """Whether a Ctrl-C is being held back by an open :class:`SigintDeferred` block (so a long
    piece of work that can be skipped, such as starting a compile, should not start)."""
    return any(d.hit for d in _open)


def _sigterm(signum, frame) -> None:
    global _interrupted_by
    _interrupted_by = "SIGTERM"
    signal.raise_signal(signal.SIGINT)  # handled by whatever handles Ctrl-C now (ignored if it is)


def sigterm_interrupts() -> None:
    """From now on SIGTERM interrupts as Ctrl-C does (main thread only; elsewhere nothing)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _sigterm)


def interrupt_name() -> str:
    """``"SIGTERM"`` if a SIGTERM interrupted the process, else ``"Ctrl-C"`` (for the messages)."""
    return _interrupted_by
