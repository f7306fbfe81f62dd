"""Count what C code prints to stderr instead of letting it cover the operator's screen.

CasADi's solvers (qrqp, IPOPT, the SQP method) print their warnings with C++ ``std::cerr``
straight to the process's file descriptor 2, beyond Python's ``sys.stderr``; in a ``fly``
session against real ArduSub telemetry that was 1,370 lines in 18 s.  :class:`StderrCapture`
points fd 2 at a temporary file while a block runs (:meth:`StderrCapture.capture`), then
reads the lines back: it counts them, keeps how often each distinct line came, and hands the
first occurrence of each new line to ``on_new`` (a session records it among its events).
Output of other threads during the block is captured too (fd 2 is the process's).
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["StderrCapture", "normalise"]

#: CasADi stamps each warning with the wall-clock time ("CasADi - 2026-11-30 20:34:53 WARNING(...)").
_STAMP = re.compile(r"\b\d{4}-\d{2}-\d{2} \d{2}:\d{2}:\d{2}(\.\d+)? ")


def normalise(line: str) -> str:
    """A line without its time stamp, so that repeats of one warning count as one kind."""
    return _STAMP.sub("", line.strip())


class StderrCapture:
    """Capture fd 2 around blocks; count the lines.

    Parameters
    ----------
    on_new : callable, optional
        ``on_new(line)`` for the first occurrence of each distinct line (at most
        ``max_distinct`` lines are reported; later new ones are only counted).
    max_distinct : int
        Most distinct lines reported and kept.
    """

    def __init__(self, on_new: Callable[[str], None] | None = None, max_distinct: int = 10) -> None:
        self.on_new = on_new
        self.max_distinct = int(max_distinct)
        self.lines = 0
        self.distinct: dict[str, int] = {}
        self._file = tempfile.TemporaryFile(mode="w+b")  # noqa: SIM115 -- closed in close()

    @contextmanager
    def capture(self) -> Iterator[None]:
        """fd 2 goes to the capture while the block runs (restored whatever happens)."""
        try:
            sys.stderr.flush()
        except (AttributeError, ValueError, OSError):
            pass
        saved = os.dup(2)
        os.dup2(self._file.fileno(), 2)
        try:
            yield
        finally:
            try:
                sys.stderr.flush()
            except (AttributeError, ValueError, OSError):
                pass
            os.dup2(saved, 2)
            os.close(saved)
            self._collect()

    def _collect(self) -> None:
        f = self._file
        if f.tell() == 0:
            return
        f.seek(0)
        data = f.read()
        f.seek(0)
        f.truncate()
        for raw in data.decode(errors="replace").splitlines():
            line = normalise(raw)
            if not line:
                continue
            self.lines += 1
            if line in self.distinct:
                self.distinct[line] += 1
            elif len(self.distinct) < self.max_distinct:
                self.distinct[line] = 1
                if self.on_new is not None:
                    self.on_new(line)

    def summary(self) -> str:
        """One line: how many lines, how many distinct."""
        shown = len(self.distinct)
        return f"{self.lines} line(s) on stderr during the controller steps ({shown} distinct shown)"

    def close(self) -> None:
        self._file.close()
