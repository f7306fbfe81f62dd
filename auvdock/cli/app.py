"""The ``auvdock`` command line (Typer + rich).

Exit status: 0 success; 1 a run finished but did not dock / a command failed at run
time; 2 bad input (a mission file, an option) -- with ONE line on stderr naming the
file, the field and the problem, and no traceback.
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass
from pathlib import Path

import typer
from rich.console import Console

from auvdock._version import __version__
from auvdock.config.mission import Mission, MissionError, load_mission
from auvdock.runtime.clock import Clock, ScaledClock, wall_clock


def _usage_name(self) -> str:  # noqa: ANN001 -- a method of typer.core.TyperArgument
    """An argument in the usage line as click writes it: ``MISSION``, ``[PATH]``, ``PATH...``."""
    name = str(self.metavar or self.name or "").upper()
    if not self.required:
        name = f"[{name}]"
    return name + ("..." if self.nargs != 1 else "")


# typer 0.29 writes required arguments as ``{mission}`` in the usage line (and, in its rich help,
# flags as taking ``<bool>``): the help is click's plain layout, with click's argument names
if hasattr(typer.core.TyperArgument, "_usage_display_name"):
    typer.core.TyperArgument._usage_display_name = _usage_name  # type: ignore[method-assign]  # typer internal

app = typer.Typer(
    name="auvdock",
    help="Dock a BlueROV2 Heavy to a heaving wave-energy-converter dock in ocean currents.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)

# emoji=False: ``:abc:`` in a port, a path or a mission name is text, never an emoji code (rich would
# print ``--port udp:abc:14550`` with a picture in it); markup stays for our own styles, and every
# piece of user text printed with markup on goes through :func:`rich.markup.escape`
console = Console(emoji=False)
err_console = Console(stderr=True, emoji=False)


@dataclass(frozen=True)
class Runtime:
    """What the commands wait and pace on, handed in by whoever runs them: the wall clock by default; a
    test runs a command in simulated time with ``CliRunner().invoke(app, args, obj=Runtime(sim_clock))``
    (``fly`` beside an in-process vehicle simulator on the same :class:`~auvdock.runtime.clock.SimClock`)."""

    clock: Clock = wall_clock


def runtime(ctx: typer.Context) -> Runtime:
    """The :class:`Runtime` the command line was invoked with (the default one if none)."""
    obj = ctx.find_root().obj
    return obj if isinstance(obj, Runtime) else Runtime()


#: Set once a command has said why it stopped on Ctrl-C (see :func:`exit_interrupted`).
_interrupt_reported = False


def exit_interrupted(message: str = "interrupted") -> None:
    """Say in one line what Ctrl-C left behind (e.g. where the results are), then exit 130."""
    global _interrupt_reported
    err_console.print(message, markup=False, highlight=False, soft_wrap=True)
    _interrupt_reported = True
    raise typer.Exit(code=130)


def interrupt_reported() -> bool:
    """Whether a command already printed its Ctrl-C line."""
    return _interrupt_reported


def fail_input(message: str) -> None:
    """Print one line on stderr and exit with status 2 (bad input)."""
    err_console.print(f"error: {message}", markup=False, highlight=False, soft_wrap=True)
    raise typer.Exit(code=2)


def positive_timeout(value: float | None) -> float | None:
    """``--timeout`` (a callback): None, or a positive, finite number of seconds; else exit 2
    with one line (the same rule in sim, compare, sweep, bench and fly)."""
    if value is not None and not (value > 0 and value < float("inf")):
        fail_input(f"--timeout: must be a positive number of seconds (got {value})")
    return value


def check_estimation(value: str | None) -> str | None:
    """``--estimation``: None or one of :data:`auvdock.estimation.stage.ESTIMATION_MODES`; else exit 2
    with one line (the same rule in sim, compare and fly)."""
    if value is None:
        return None
    from auvdock.estimation.stage import ESTIMATION_MODES

    if value not in ESTIMATION_MODES:
        *first, last = ESTIMATION_MODES
        choices = f"{', '.join(first)} or {last}" if first else last
        fail_input(f"--estimation: must be {choices} (got {value!r})")
    return value


def check_seed(value: int | None) -> int | None:
    """``--seed``: None or a whole number >= 0 (a mission's ``seed``); else exit 2 with one line."""
    if value is not None and value < 0:
        fail_input(f"--seed: must be at least 0 (got {value})")
    return value


def output_dir(path: Path, option: str = "--out") -> Path:
    """``path`` as an output directory, created if need be; or exit 2 with one line naming the
    option, the path and the problem (a file is there, no permission, a read-only place)."""
    if path.exists() and not path.is_dir():
        fail_input(f"{option} {path}: exists and is not a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        fail_input(f"{option} {path}: cannot create the directory ({e.strerror or e})")
    return path


def output_file(path: Path, option: str) -> Path:
    """``path`` as a file to write (its folder created if need be); or exit 2 with one line naming the
    option, the path and the problem (a directory is there, the folder cannot be made)."""
    if path.is_dir():
        fail_input(f"{option} {path}: is a directory")
    output_dir(path.parent if str(path.parent) else Path("."), option)
    return path


def load_or_exit(path: Path) -> Mission:
    """Load a mission file, or a shipped mission by name (``gyre``), or exit 2 with one line."""
    from auvdock.config.catalog import resolve

    try:
        return load_mission(resolve(path))
    except MissionError as e:
        fail_input(str(e))
        raise AssertionError("unreachable") from None


def water_line(m: Mission) -> str:
    """The water of a mission in a few words: the current, and the waves if there is a sea, e.g.
    ``no current; waves JONSWAP Hs 1.75 m, Tp 9.44 s, ...: 560 components, Hm0 1.76 m, depth 70 m``
    (a header that said only ``still water`` hid the sea); without a sea the current alone."""
    flow = m.build_flow().describe()
    sea = m.build_sea()
    if sea is None:
        return flow
    return f"{'no current' if flow == 'still water' else flow}; waves {sea.describe()}"


def _version_callback(value: bool) -> None:
    if value:
        console.print(f"auvdock {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    ctx: typer.Context,
    version: bool = typer.Option(
        False, "--version", callback=_version_callback, is_eager=True, help="Print the version and exit."
    ),
    clock_rate: float = typer.Option(
        1.0,
        "--clock-rate",
        help="Run the command's clock at RATE x the wall clock: a rehearsal slower than real time, every "
        "program at one rate (ArduSub SITL with --speedup RATE). A vehicle runs at 1.",
    ),
) -> None:
    """auvdock: flow-state-estimating MPC docking for underwater vehicles."""
    from auvdock.runtime.codegen import set_reporter

    set_reporter(_compile_notice, _background_notice)
    if clock_rate != 1.0:
        if not (math.isfinite(clock_rate) and 0.01 <= clock_rate <= 1.0):
            fail_input(f"--clock-rate {clock_rate:g}: expected a rate in [0.01, 1] (slower than real time)")
        ctx.obj = Runtime(ScaledClock(runtime(ctx).clock, clock_rate))


def _background_notice(message: str) -> None:
    """Said once per function when its compile starts in the background (first use)."""
    err_console.print(message, markup=False, highlight=False, soft_wrap=True)


def split_list(values: list[str] | None) -> list[str]:
    out: list[str] = []
    for v in values or []:
        out += [x.strip() for x in v.split(",") if x.strip()]
    return out


def controller_list(controllers: list[str] | None, variants: bool = False) -> list[str]:
    """``--controllers`` (comma-separated or repeated; ``NAME`` or ``NAME@VARIANT``; default the
    paper's five, and with ``variants`` each also ``@paper``), or exit 2 naming the bad one."""
    from auvdock.controllers import controller_specs

    ctrls = split_list(controllers) or list(controller_specs(variants))
    for c in ctrls:
        check_controller(c, "--controllers")
    return ctrls


def check_controller(spec: str, option: str = "--controller") -> str:
    """A controller spec (``NAME`` or ``NAME@VARIANT``), or exit 2 with one line naming the problem."""
    from auvdock.controllers import split_controller

    try:
        split_controller(spec)
    except ValueError as e:
        fail_input(f"{option}: {e}")
    return spec


def _compile_notice(message: str):
    """Shown while a solver compiles (first use of a problem): a spinner on a terminal; with
    stderr redirected (a log file, a pipe) one plain line before and one after, with the time
    taken, so that a log never shows a minute of silence."""
    if err_console.is_terminal:
        return err_console.status(f"[bold]{message}[/bold] - about a minute, once", spinner="dots")
    return _plain_notice(message)


@contextlib.contextmanager
def _plain_notice(message: str):
    t0 = time.monotonic()
    err_console.print(f"{message} - about a minute, once", markup=False, highlight=False, soft_wrap=True)
    try:
        yield
    finally:
        err_console.print(
            f"compiled in {time.monotonic() - t0:.0f} s", markup=False, highlight=False, soft_wrap=True
        )
