"""Ctrl-C (SIGINT) held back over short sections that must not be cut in two.

Python raises KeyboardInterrupt between any two bytecodes of the main thread.  Inside
:class:`SigintDeferred` a SIGINT only sets a flag; leaving the block raises the
KeyboardInterrupt then, so the section (a CasADi solve, creating a results group, writing
a run's outcome) either runs whole or not at all.

It also keeps CasADi's own interrupt check from turning Ctrl-C into a failed solve (IPOPT
returns ``NonIpopt_Exception_Thrown``), which a run loop would take for solver trouble and
go on.  Outside the main thread, where handlers cannot be set, it does nothing.
"""

from __future__ import annotations

import signal
import threading

__all__ = ["SigintDeferred"]


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
        return self

    def _handler(self, signum, frame) -> None:
        self.hit = True

    def __exit__(self, *exc: object) -> None:
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
        if self.hit:
            raise KeyboardInterrupt
