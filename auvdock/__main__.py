"""``auvdock`` (the console script) and ``python -m auvdock``: the command line's entry.

A Ctrl-C or a SIGTERM while the commands load (Typer, rich and the commands' modules: about a
second) exits with status 130 and one line, quietly: nothing has started, nothing is to be kept.
The handler is installed here, by the program, and not on ``import auvdock.cli``: a notebook or script that
imports the package keeps Python's own KeyboardInterrupt.  Then :func:`auvdock.cli.main` runs the
command, with its own Ctrl-C handling.
"""

from __future__ import annotations

import os
import signal
import threading

__all__ = ["main"]


def _interrupted_while_starting(signum, frame) -> None:  # noqa: ANN001  # pragma: no cover - timing
    """Ctrl-C (or SIGTERM) while the command line loads (nothing started, nothing to save): exit 130,
    quietly."""
    os.write(2, b"interrupted (SIGTERM)\n" if signum == signal.SIGTERM else b"interrupted\n")
    os._exit(130)


def main(argv: list[str] | None = None) -> None:
    """Run the ``auvdock`` command line (``argv``: its arguments; default ``sys.argv[1:]``)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, _interrupted_while_starting)
        signal.signal(signal.SIGTERM, _interrupted_while_starting)  # the command's own handler replaces it
    from auvdock.cli import main as run_command  # the commands load here

    run_command(argv)


if __name__ == "__main__":
    main()
