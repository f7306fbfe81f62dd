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
``sitl``           sitl-physics
``bench``          bench
``camera``         markers, calibrate
``cache``          cache info, cache clear
=================  ==============================================
"""

from __future__ import annotations

import os
import signal
import sys
import threading


def _interrupted_while_starting(signum, frame) -> None:  # pragma: no cover - timing
    """Ctrl-C while the command line loads (nothing started, nothing to save): exit 130, quietly."""
    os.write(2, b"interrupted\n")
    os._exit(130)


_MAIN_THREAD = threading.current_thread() is threading.main_thread()
if _MAIN_THREAD:
    _previous_sigint = signal.signal(signal.SIGINT, _interrupted_while_starting)

# the commands are registered in this order (the order of --help)
# isort: off
from auvdock.cli import validate, sim, campaign, fly, sitl, bench, camera, cache  # noqa: F401, E402

# isort: on
try:  # typer vendors click since 0.2x; older ones use click itself
    from typer._click import exceptions as _cx  # noqa: E402
except ImportError:  # pragma: no cover
    from click import exceptions as _cx  # noqa: E402

from auvdock.cli.app import app, err_console, interrupt_reported  # noqa: E402

if _MAIN_THREAD:
    signal.signal(signal.SIGINT, _previous_sigint)

__all__ = ["app", "main"]


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: runs a command and exits with its status.

    0 success; 1 a run that did not dock or a command that failed at run time; 2 bad input
    (one line on stderr: ``error: ...``); 130 interrupted (Ctrl-C), with no traceback.
    """
    import typer

    try:
        rc = app(args=argv, standalone_mode=False)
    except _cx.NoArgsIsHelpError as e:
        print(e.ctx.get_help() if e.ctx is not None else str(e))
        rc = 0
    except _cx.UsageError as e:  # a bad option or argument: one line, exit 2
        _one_line(_usage_line(e))
        rc = 2
    except _cx.ClickException as e:
        _one_line(f"error: {e.format_message()}")
        rc = e.exit_code
    except (typer.Abort, KeyboardInterrupt):
        rc = 130
    if rc == 130 and not interrupt_reported():  # Typer turns Ctrl-C into exit 130, silently
        err_console.print("interrupted", markup=False, highlight=False)
    _ignore_late_sigint()
    sys.exit(rc if isinstance(rc, int) else 0)


def _ignore_late_sigint() -> None:
    """The command has ended and said so: a Ctrl-C now (exiting) changes nothing and prints nothing."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _one_line(text: str) -> None:
    err_console.print(" ".join(text.split()), markup=False, highlight=False, soft_wrap=True)


def _usage_line(e: Exception) -> str:
    """``error: auvdock sim: --seed: 'abc' is not a valid integer`` from a usage error."""
    ctx = getattr(e, "ctx", None)
    where = f"{ctx.command_path}: " if ctx is not None else ""
    param = getattr(e, "param", None)
    message = e.format_message() if hasattr(e, "format_message") else str(e)
    if param is not None and getattr(e, "message", None):
        names = getattr(param, "opts", None) or [getattr(param, "name", "")]
        hint = "/".join(n for n in names if n) or str(param.name)
        if param.param_type_name == "argument":
            hint = str(param.name).upper()
        message = f"{hint}: {e.message}"
    return f"error: {where}{message}"


if __name__ == "__main__":  # pragma: no cover
    main()
