"""The ``auvdock`` command line (Typer + rich): one module per command group.

Exit status: 0 success; 1 a run finished but did not dock / a command failed at run
time; 2 bad input (a mission file, an option) -- with ONE line on stderr naming the
file, the field and the problem, and no traceback; 130 interrupted (Ctrl-C).

=================  ==============================================
module             commands
=================  ==============================================
``app``            the Typer app, console, one-line input errors
``validate``       validate
``sim``            sim, plot
``campaign``       compare, report, sweep
``fly``            fly, vehicle-sim
``bench``          bench
``camera``         markers, calibrate
``cache``          cache info, cache clear
=================  ==============================================
"""

from __future__ import annotations

import sys

# the commands are registered in this order (the order of --help)
# isort: off
from . import validate, sim, campaign, fly, bench, camera, cache  # noqa: F401

# isort: on
from .app import app, err_console

__all__ = ["app", "main"]


def main() -> None:
    """Console-script entry point."""
    try:
        app()
    except KeyboardInterrupt:
        err_console.print("interrupted")
        sys.exit(130)


if __name__ == "__main__":  # pragma: no cover
    main()
